"""The spectral modes: integration against colour-science, white normalisation, Cauchy fit,
convergence of N = 32 to the 1 nm ground truth, and the interference cut-off."""
import colour
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from layered_brdf_addon.model.geometry import tilted_normal
from layered_brdf_addon.model.params import WAVELENGTHS_NM, LayeredParams
from layered_brdf_addon.model.presets import PRESETS
from layered_brdf_reference import spectral
from layered_brdf_reference.exact_model import diffuse_rho, diffuse_td, specular_brdf

Z = np.array([0.0, 0.0, 1.0])


def preset_triples():
    out = []
    for overrides in PRESETS.values():
        t = LayeredParams.from_dict(overrides).r1
        if t not in out:
            out.append(t)
    return out


def in_plane(theta_deg):
    """Unit vectors in the x-z plane at ``theta`` from +z, towards +x."""
    t = np.radians(np.asarray(theta_deg, dtype=float))
    return np.stack([np.sin(t), np.zeros_like(t), np.cos(t)], axis=-1)


def colour_rgb(values: np.ndarray) -> np.ndarray:
    """colour's rectangle-rule XYZ of a 380-780 nm, 1 nm spectrum, then the module's normalisation
    (Y = 1 for a unit reflectance, colour's Rec.709 matrix, the white correction)."""
    cmfs, illuminant = spectral.reference_cmfs_and_illuminant()
    sd = colour.SpectralDistribution(dict(zip(cmfs.wavelengths, values)))
    xyz = colour.sd_to_XYZ(sd, cmfs, illuminant, method="Integration") / 100.0
    return (xyz @ spectral.xyz_to_rec709_matrix().T) * spectral.ground_truth_sampling().white_correction, xyz


def model_spectra() -> dict[str, np.ndarray]:
    """Spectra at the 401 ground-truth wavelengths: the model at a few configurations and two
    smooth reflectances."""
    lam = spectral.ground_truth_sampling().wavelengths
    out = {}
    for r1, d in (((1.5, 1.5, 1.5), 20.0), ((1.3, 1.3, 1.3), 150.0), ((1.5, 1.6, 1.8), 90.0),
                  ((2.2, 2.3, 2.45), 50.0)):
        out[f"diffuse {r1} {d}"] = spectral.spectral_diffuse_spectrum(r1, d, wavelengths=lam)
    n1 = tilted_normal(Z[None], 14.0, 90.0, up=np.array([0.0, 1.0, 0.0]))[0]
    for r1, d, view, n1_ in (((1.4, 1.45, 1.6), 70.0, 30.0, Z), ((1.5, 1.6, 1.8), 180.0, 20.0, n1),
                             ((1.33, 1.33, 1.33), 400.0, 60.0, Z)):
        o = in_plane(view)
        i = -(o * [-1.0, 1.0, 1.0])  # light at the mirror direction
        out[f"specular {r1} {d} {view}"] = spectral.spectral_specular_spectrum(i, o, Z, n1_, r1, d, 130.0, 130.0,
                                                                               wavelengths=lam)
    out["gaussian"] = 0.1 + 0.7 * np.exp(-0.5 * ((lam - 540.0) / 45.0) ** 2)
    out["sigmoid"] = 0.05 + 0.85 / (1.0 + np.exp(-(lam - 600.0) / 20.0))
    return out


# ----------------------------------------------------------------------------
def test_ground_truth_matches_colour_integration():
    gt = spectral.ground_truth_sampling()
    for name, values in model_spectra().items():
        assert values.shape == (401,) and np.all(values >= 0.0), name
        rgb_colour, xyz_colour = colour_rgb(values)
        np.testing.assert_allclose(gt.to_xyz(values), xyz_colour, rtol=1e-6, atol=0, err_msg=name)
        scale = np.abs(rgb_colour).max()
        np.testing.assert_allclose(gt.to_rgb(values), rgb_colour, rtol=0, atol=1e-6 * scale, err_msg=name)


def test_reference_tables_come_from_colour():
    cmfs, illuminant = spectral.reference_cmfs_and_illuminant()
    full = colour.MSDS_CMFS[spectral.CMFS_NAME]
    assert cmfs.shape == colour.SpectralShape(380, 780, 1)
    np.testing.assert_array_equal(cmfs.values, full.values[20:421])
    d65 = colour.SDS_ILLUMINANTS["D65"]
    for lam in (380.0, 560.0, 780.0):  # the 5 nm table's own samples are kept
        assert illuminant[lam] == pytest.approx(d65[lam], rel=1e-12)


@pytest.mark.parametrize("sampling", [spectral.spectral_sampling(n) for n in (1, 4, 7, 8, 16, 32, 64)]
                         + [spectral.ground_truth_sampling(), spectral.ground_truth_sampling("wyman"),
                            spectral.spectral_sampling(32, "wyman"), spectral.spectral_sampling(16, "wyman", "point"),
                            spectral.spectral_sampling(32, "cie1931", "point")], ids=lambda s: s.label)
def test_white_maps_to_one(sampling):
    white = sampling.to_rgb(np.ones(sampling.n))
    np.testing.assert_allclose(white, 1.0, rtol=0, atol=1e-14)
    assert sampling.to_xyz(np.ones(sampling.n))[1] == pytest.approx(1.0, abs=1e-14)
    assert sampling.matrix.shape == (sampling.n, 3)


def test_white_correction_is_small_and_shared_by_all_bin_counts():
    c = spectral.ground_truth_sampling().white_correction
    assert np.max(np.abs(c - 1.0)) < 1e-3  # 380-780 nm D65 is within 1e-3 of Rec.709's white
    for n in (4, 8, 16, 32):
        np.testing.assert_allclose(spectral.spectral_sampling(n).white_correction, c, rtol=1e-12)


def test_bins_partition_the_ground_truth():
    gt = spectral.ground_truth_sampling()
    for n in (1, 4, 8, 16, 32, 7):
        part = spectral.bin_partition(n)
        np.testing.assert_allclose(part.sum(axis=0), 1.0, atol=1e-12)
        cells = np.diff(spectral.bin_edges(n))
        cells[0] += 0.5  # the outer half-cells of 380 and 780 nm
        cells[-1] += 0.5
        np.testing.assert_allclose(part.sum(axis=1), cells, atol=1e-12)
        s = spectral.spectral_sampling(n)
        np.testing.assert_allclose(s.xyz, part @ gt.xyz, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(s.wavelengths, 380.0 + (np.arange(n) + 0.5) * 400.0 / n)


def test_cauchy_fit_passes_through_the_three_indices():
    triples = preset_triples() + [(1.0, 2.0, 1.5), (0.5, 0.4, 0.3), (3.0, 2.0, 4.0)]
    for t in triples:
        c = spectral.cauchy_fit(t)
        np.testing.assert_allclose(spectral.index_at(c, WAVELENGTHS_NM), t, rtol=1e-12, atol=0)
    batch = np.array(triples)
    np.testing.assert_allclose(spectral.index_at(spectral.cauchy_fit(batch), WAVELENGTHS_NM), batch, rtol=1e-12)
    c = spectral.cauchy_fit((1.3, 1.3, 1.3))
    np.testing.assert_array_equal(c, [1.3, 0.0, 0.0])
    np.testing.assert_array_equal(spectral.index_at(c, np.linspace(380, 780, 9)), 1.3)
    # Indices that follow a Cauchy law (BK7-like: A = 1.5046, B = 4200 nm^2) give back its coefficients.
    lam = np.asarray(WAVELENGTHS_NM)
    law = (1.5046, 4200.0, 1.0e8)
    np.testing.assert_allclose(spectral.cauchy_fit(spectral.index_at(law, lam)), law, rtol=1e-8)


def test_preset_indices_stay_inside_the_parameter_range():
    lam = spectral.ground_truth_sampling().wavelengths
    for t in preset_triples():
        r = spectral.index_at(spectral.cauchy_fit(t), lam)
        assert np.all(r >= spectral.INDEX_MIN) and np.all(r <= spectral.INDEX_MAX)
        np.testing.assert_array_equal(spectral.dispersed_index(t, lam), r)


def test_spectral_model_is_the_exact_model_per_wavelength():
    s = spectral.spectral_sampling(8)
    o = in_plane([10.0, 40.0, 70.0])
    i = -(o * [-1.0, 1.0, 1.0])
    r1 = (1.4, 1.5, 1.7)
    r1_lam = spectral.index_at(spectral.cauchy_fit(r1), s.wavelengths)
    d = np.array([50.0, 300.0, 900.0])
    want = specular_brdf(i, o, Z, Z, r1_lam, d, 90.0, 170.0, 1.0, s.wavelengths) @ s.matrix
    np.testing.assert_allclose(spectral.spectral_specular(i, o, Z, Z, r1, d, 90.0, 170.0, sampling=s), want, rtol=1e-13)
    want_d = diffuse_rho(r1_lam, d, 1.0, s.wavelengths) @ s.matrix
    np.testing.assert_allclose(spectral.spectral_diffuse(r1, d, sampling=8), want_d, rtol=1e-13)
    # At d = 0 the phase vanishes at every wavelength: a constant index gives a flat spectrum, a grey.
    grey = spectral.spectral_diffuse((1.5, 1.5, 1.5), 0.0, sampling=32)
    np.testing.assert_allclose(grey, diffuse_rho((1.5,), 0.0)[0], rtol=1e-12)


def test_chunked_evaluation_matches_one_call(monkeypatch):
    rng = np.random.default_rng(3)
    o = in_plane(rng.uniform(0, 85, 500))
    i = -(o * [-1.0, 1.0, 1.0])
    d = rng.uniform(0, 1000, 500)
    whole = spectral.spectral_specular_spectrum(i, o, Z, Z, (1.5, 1.6, 1.8), d, 130.0, 130.0,
                                                wavelengths=np.arange(380, 781.0))
    monkeypatch.setattr(spectral, "_CHUNK_ELEMENTS", 4096)
    parts = spectral.spectral_specular_spectrum(i, o, Z, Z, (1.5, 1.6, 1.8), d, 130.0, 130.0,
                                                wavelengths=np.arange(380, 781.0))
    np.testing.assert_array_equal(parts, whole)


# ----------------------------------------------------------------------------
# Convergence: N = 32 against the 1 nm ground truth.  Bound (this sweep and the benchmark's):
# CIEDE2000 <= 0.6 everywhere, mean <= 0.1, and |RGB difference| <= 0.015 per channel.
N32_MAX_DE = 0.6
N32_MEAN_DE = 0.1
N32_MAX_RGB = 0.015


def convergence_sweep():
    d = np.linspace(0.0, 1000.0, 21)
    views = np.linspace(0.0, 85.0, 6)
    vv, dd = np.meshgrid(views, d, indexing="ij")
    o = in_plane(vv.ravel())
    i = -(o * [-1.0, 1.0, 1.0])
    n1 = in_plane(np.full(o.shape[0], 14.0))
    return i, o, dd.ravel(), n1, d


def test_n32_converges_to_the_ground_truth():
    gt = spectral.ground_truth_sampling()
    s32, s16, s8 = (spectral.spectral_sampling(n) for n in (32, 16, 8))
    i, o, dd, n1_tilt, d = convergence_sweep()
    norm = 132.0 / (2.0 * np.pi)
    de = {8: [], 16: [], 32: []}
    rgb_diff = []
    for r1 in preset_triples():
        for n1 in (Z, n1_tilt):
            ref = spectral.spectral_specular(i, o, Z, n1, r1, dd, 130.0, 130.0, sampling=gt) / norm
            for n, s in ((8, s8), (16, s16), (32, s32)):
                val = spectral.spectral_specular(i, o, Z, n1, r1, dd, 130.0, 130.0, sampling=s) / norm
                de[n].append(spectral.delta_e_2000(val, ref))
                if n == 32:
                    rgb_diff.append(np.abs(val - ref).max())
        ref_d = spectral.spectral_diffuse(r1, d, sampling=gt)
        for n, s in ((8, s8), (16, s16), (32, s32)):
            val = spectral.spectral_diffuse(r1, d, sampling=s)
            de[n].append(spectral.delta_e_2000(val, ref_d))
            if n == 32:
                rgb_diff.append(np.abs(val - ref_d).max())
    de = {n: np.concatenate(v) for n, v in de.items()}
    assert de[32].max() <= N32_MAX_DE
    assert de[32].mean() <= N32_MEAN_DE
    assert max(rgb_diff) <= N32_MAX_RGB
    assert de[32].mean() < de[16].mean() < de[8].mean()


# ----------------------------------------------------------------------------
index = st.floats(0.2, 4.0)
angle = st.floats(0.0, 89.0)


@settings(deadline=None, derandomize=True, max_examples=60)
@given(r1=st.tuples(index, index, index), d=st.floats(0.0, 1.0e5), view=angle, light=angle,
       tilt=st.floats(0.0, 40.0), e0=st.floats(0.0, 2000.0), e1=st.floats(0.0, 2000.0),
       n=st.sampled_from([4, 8, 16, 32]))
def test_spectral_colour_is_finite_and_physical(r1, d, view, light, tilt, e0, e1, n):
    o = in_plane(view)
    i = -in_plane(-light)
    n1 = in_plane(tilt)
    s = spectral.spectral_sampling(n)
    spectrum = spectral.spectral_specular_spectrum(i, o, Z, n1, r1, d, e0, e1, wavelengths=s.wavelengths)
    diffuse = spectral.spectral_diffuse_spectrum(r1, d, wavelengths=s.wavelengths)
    for spec in (spectrum, diffuse):
        assert np.all(np.isfinite(spec)) and np.all(spec >= 0.0)
        rgb = s.to_rgb(spec)
        assert np.all(np.isfinite(rgb))
        # Non-negative spectra and CMFs: XYZ >= 0.  RGB may be negative (outside Rec.709's gamut).
        assert np.all(s.to_xyz(spec) >= -1e-12 * max(1.0, float(spec.max())))
    rgb = spectral.spectral_specular(i, o, Z, n1, r1, d, e0, e1, sampling=s)
    assert np.all(np.isfinite(rgb))


def test_spectral_colour_can_leave_the_rec709_gamut():
    """A saturated interference colour has a negative Rec.709 channel; the RGB mode never has."""
    d = np.linspace(0.0, 400.0, 401)
    gt = spectral.spectral_diffuse((2.2, 2.3, 2.45), d, sampling=spectral.ground_truth_sampling())
    assert gt.min() < -0.1
    assert np.all(spectral.ground_truth_sampling().to_xyz(
        spectral.spectral_diffuse_spectrum((2.2, 2.3, 2.45), d, wavelengths=spectral.ground_truth_sampling().wavelengths))
        >= 0.0)
    assert diffuse_rho((2.2, 2.3, 2.45), d).min() >= 0.0


# ----------------------------------------------------------------------------
def test_wyman_cmfs_are_close_to_the_table():
    lam = spectral.ground_truth_sampling().wavelengths
    table = spectral.cmf_cie1931(lam)
    fit = spectral.cmf_wyman(lam)
    err = np.abs(fit - table).max(axis=0)
    assert np.all(err < 0.025)
    assert np.all(err / table.max(axis=0) < 0.015)
    np.testing.assert_allclose(fit.max(axis=0), table.max(axis=0), rtol=0.02)
    e = spectral.wyman_table_error()
    assert e["max_abs_z"] == pytest.approx(err[2])


def test_interference_cutoff():
    d15 = spectral.interference_cutoff_nm(1.5)
    d30 = spectral.interference_cutoff_nm(3.0)
    assert d15 == pytest.approx(2.0 * d30)  # only the optical thickness r1 d matters
    assert spectral.interference_cutoff_nm((1.5, 1.6, 1.8)) == d15  # a triple uses its smallest index
    assert spectral.interference_cutoff_nm(1.5, 2.0) < d15 < spectral.interference_cutoff_nm(1.5, 0.5)
    assert spectral.interference_cutoff_nm(1.5, modulation=0.5) < d15
    # Definition: the worst case reaches the tolerance just below D*, never beyond it.
    D = spectral.interference_cutoff_optical_nm(1.0)
    beyond = np.arange(D, spectral.CUTOFF_SEARCH_MAX_OPTICAL_NM, 1.0)
    assert spectral.interference_delta_e(D - 1.0) >= 1.0 and np.all(spectral.interference_delta_e(beyond) < 1.0)
    # Many periods of phase across the visible band at the cut-off.
    assert spectral.phase_spread(1.5, d15) / (2.0 * np.pi) > 5.0
    # The full diffuse model beyond its cut-off is within tolerance of the mean colour.
    r1 = 1.5
    td = float(diffuse_td(r1))
    m = 2.0 * np.sqrt(td * (1.0 - td))
    d_star = spectral.interference_cutoff_nm(r1, 1.0, modulation=m)
    d = np.arange(d_star, d_star + 3000.0, 2.0)
    rgb = spectral.spectral_diffuse((r1, r1, r1), d, sampling=spectral.ground_truth_sampling())
    assert np.all(spectral.delta_e_2000(rgb, np.ones(3)) < 1.0)
    assert d_star < d15
