"""The fit's colour maths in numpy alone (fit/colour_space.py) against colour-science: CIELAB,
CIEDE2000 (including the hue-wrap and achromatic cases of Sharma, Wu and Dalal's test set),
spectra to RGB, and the baked observer tables being colour-science's."""
import json

import colour
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from layered_brdf_addon.fit import colour_space
from layered_brdf_addon.model.spectral_tables import OBSERVER_PATH
from layered_brdf_reference.spectral import observer_tables, rec709_to_xyz_matrix, white_xy

# Sharma, Wu and Dalal (2005), Table 1: Lab pairs and their CIEDE2000 (rounded to 4 decimals).
SHARMA = [
    ((50.0000, 2.6772, -79.7751), (50.0000, 0.0000, -82.7485), 2.0425),
    ((50.0000, 3.1571, -77.2803), (50.0000, 0.0000, -82.7485), 2.8615),
    ((50.0000, 2.8361, -74.0200), (50.0000, 0.0000, -82.7485), 3.4412),
    ((50.0000, -1.3802, -84.2814), (50.0000, 0.0000, -82.7485), 1.0000),
    ((50.0000, 0.0000, 0.0000), (50.0000, -1.0000, 2.0000), 2.3669),
    ((50.0000, -1.0000, 2.0000), (50.0000, 0.0000, 0.0000), 2.3669),
    ((50.0000, 2.4900, -0.0010), (50.0000, -2.4900, 0.0009), 7.1792),
    ((50.0000, 2.4900, -0.0010), (50.0000, -2.4900, 0.0011), 7.2195),
    ((50.0000, 2.5000, 0.0000), (50.0000, 0.0000, -2.5000), 4.3065),
    ((50.0000, 2.5000, 0.0000), (73.0000, 25.0000, -18.0000), 27.1492),
    ((50.0000, 2.5000, 0.0000), (56.0000, -27.0000, -3.0000), 31.9030),
    ((60.2574, -34.0099, 36.2677), (60.4626, -34.1751, 39.4387), 1.2644),
    ((22.7233, 20.0904, -46.6940), (23.0331, 14.9730, -42.5619), 2.0373),
    ((90.8027, -2.0831, 1.4410), (91.1528, -1.6435, 0.0447), 1.4441),
    ((2.0776, 0.0795, -1.1350), (0.9033, -0.0636, -0.5514), 0.9082),
]


def test_the_observer_tables_are_colour_science_s():
    data = json.loads(OBSERVER_PATH.read_text())
    want = observer_tables()
    assert data.keys() == want.keys()
    for key in want:
        assert np.allclose(data[key], want[key], rtol=0, atol=1e-12), key
    assert np.allclose(colour_space._matrix(), rec709_to_xyz_matrix(), atol=1e-12)
    assert np.allclose(data["white_xy"], white_xy())


def test_ciede2000_reproduces_sharma_s_test_pairs():
    lab1 = np.array([p[0] for p in SHARMA])
    lab2 = np.array([p[1] for p in SHARMA])
    want = np.array([p[2] for p in SHARMA])
    assert np.allclose(colour_space.delta_e_2000(lab1, lab2), want, atol=5e-5)
    assert np.allclose(colour_space.delta_e_2000(lab2, lab1), want, atol=5e-5)


LAB = st.tuples(st.floats(0, 100), st.floats(-128, 128), st.floats(-128, 128))


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(LAB, LAB), min_size=1, max_size=20))
def test_ciede2000_agrees_with_colour_science(pairs):
    lab1 = np.array([p[0] for p in pairs])
    lab2 = np.array([p[1] for p in pairs])
    want = colour.delta_E(lab1, lab2, method="CIE 2000")
    assert np.allclose(colour_space.delta_e_2000(lab1, lab2), want, rtol=1e-9, atol=1e-9)


@settings(max_examples=200, deadline=None)
@given(arrays(float, (7, 3), elements=st.floats(0.0, 20.0)), st.floats(1e-3, 50.0))
def test_lab_agrees_with_colour_science(rgb, white_y):
    xyz = rgb @ rec709_to_xyz_matrix().T / white_y
    want = colour.XYZ_to_Lab(xyz, white_xy())
    assert np.allclose(colour_space.lab(rgb, white_y), want, rtol=1e-9, atol=1e-9)


def test_a_white_per_colour_is_each_colour_s_own():
    rng = np.random.default_rng(5)
    rgb, whites = rng.uniform(0.0, 4.0, (2, 9, 3)), rng.uniform(0.1, 5.0, 9)
    each = np.stack([[colour_space.lab(rgb[i, j], whites[j]) for j in range(9)] for i in range(2)])
    assert np.allclose(colour_space.lab(rgb, whites), each, rtol=1e-12, atol=1e-12)


def test_a_spectrum_gives_colour_science_s_colour():
    rng = np.random.default_rng(3)
    lams = np.arange(360.0, 831.0, 5.0)
    spectra = rng.uniform(0.0, 1.0, (6, lams.size))
    got = colour_space.spectrum_to_rgb(lams, spectra)
    # The same rule with colour-science's own tables (CMFs at 1 nm, D65 at 5 nm).
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    d65 = colour.SDS_ILLUMINANTS["D65"]
    bar = np.stack([np.interp(lams, cmfs.domain, v) for v in np.asarray(cmfs.values).T], axis=-1)
    weights = (np.interp(lams, d65.domain, np.asarray(d65.values)) * np.gradient(lams))[:, None] * bar
    want = colour.XYZ_to_RGB(spectra @ weights / weights[:, 1].sum(), "ITU-R BT.709")
    assert np.allclose(got, want, atol=1e-9)
    assert np.allclose(colour_space.spectrum_to_rgb(lams, np.ones(lams.size)), 1.0, atol=1e-3)
