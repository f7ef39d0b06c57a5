"""The layer's index as Blender's glTF materials give it: an IOR and a Dispersion (20 / V_d, V_d the
Abbe number, KHR_materials_dispersion), beside the paper's three channel indices."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from layered_brdf_addon.model import preset
from layered_brdf_addon.model.dispersion import (C_LINE_NM, D_LINE_NM, F_LINE_NM, abbe_index, abbe_indices,
                                                 ior_and_dispersion)
from layered_brdf_addon.model.media import FILM_MEDIA, medium
from layered_brdf_addon.model.params import LayeredParams
from layered_brdf_addon.model.policy import plan_effects
from layered_brdf_addon.model.presets import ARTIST_PRESETS
from layered_brdf_addon.model.spectral_tables import SAMPLE_COUNTS, tables

from constants import MAX_FAILING, REL_TOL


@given(st.floats(1.0, 3.0), st.floats(0.0, 4.0))
@settings(max_examples=60, deadline=None)
def test_ior_is_the_d_line_index_and_dispersion_the_abbe_number(ior, dispersion):
    assert abbe_index(ior, dispersion, D_LINE_NM) == pytest.approx(ior, abs=2e-5)
    if ior > 1.0 + 1e-6:
        spread = abbe_index(ior, dispersion, F_LINE_NM) - abbe_index(ior, dispersion, C_LINE_NM)  # n_F - n_C
        assert 20.0 * spread / (ior - 1.0) == pytest.approx(dispersion, rel=1e-3, abs=1e-9)
        assert ior_and_dispersion(abbe_indices(ior, dispersion)) == pytest.approx((ior, dispersion), abs=2e-4)


@pytest.mark.parametrize("n", SAMPLE_COUNTS)
def test_the_spectral_modes_cauchy_fit_recovers_the_abbe_law(n):
    t = tables(n)
    rgb = np.array(abbe_indices(1.6, 1.2))
    fitted = np.asarray(t["cauchy"]) @ rgb
    assert fitted == pytest.approx([abbe_index(1.6, 1.2, lam) for lam in t["wavelengths"]], abs=1e-4)


def test_ior_mode_derives_the_three_indices_and_plans_from_them():
    p = LayeredParams.from_dict(dict(layer_index="ior", layer_ior=1.5, layer_dispersion=0.6, r1_r=3.0))
    assert p.r1 == pytest.approx(abbe_indices(1.5, 0.6))  # the channel values follow the IOR, not the socket
    assert plan_effects(p).dispersion and plan_effects(p).index == "ior"
    assert not plan_effects(p.replace(layer_dispersion=0.0)).dispersion
    assert plan_effects(p.replace(layer_dispersion=0.0), animated={"layer_dispersion"}).dispersion
    with pytest.raises(Exception, match="layer_ior"):
        LayeredParams.from_dict(dict(layer_ior=0.5))


def test_the_media_as_ior_and_dispersion_are_within_a_third_of_a_percent_of_their_measured_indices():
    for name in FILM_MEDIA:
        n = medium(name).n[:3]
        assert abbe_indices(*ior_and_dispersion(n)) == pytest.approx(n, rel=3.3e-3), name  # anatase: 0.30%
    for name, overrides in ARTIST_PRESETS.items():
        assert overrides["layer_index"] == "ior", name


@pytest.mark.slow
@pytest.mark.parametrize("backend", ["nodes", "osl"])
def test_ior_and_dispersion_render_as_the_indices_they_give(backend):
    from layered_brdf_reference.compare import agreement
    from render_helpers import render_row

    ior = preset("beetle_shell").replace(layer_dispersion=1.5, d_min=250.0, d_max=420.0)
    channels = ior.replace(layer_index="channels", **dict(zip(("r1_r", "r1_g", "r1_b"), ior.r1)))
    row = render_row([ior, channels], backend=backend, height=72, samples=4)
    half = row.passes.beauty.shape[1] // 2
    a, b = row.passes.beauty[:, :half, :3], row.passes.beauty[:, half:2 * half, :3]
    mask = np.any(b > 0.0, axis=-1)
    ag = agreement(a, b, mask, rel_tol=REL_TOL)
    assert ag.failing_fraction <= MAX_FAILING, ag
