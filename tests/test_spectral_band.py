"""The analytic mode's closed form: the interference cosine integrated over each channel's band,
against numerical integration of the same spectra, and the mode against the 1 nm ground truth."""
import json

import numpy as np
import pytest

from layered_brdf_addon.model import spectral_band
from layered_brdf_addon.model.params import LayeredParams
from layered_brdf_addon.model.policy import plan_effects
from layered_brdf_addon.model.presets import PRESETS
from layered_brdf_reference import band_fitting, spectral
from layered_brdf_reference.exact_model import channel_cosine, diffuse_rho, specular_brdf

# Bounds on |closed form - numerical integral| of the channel cosine (measured: 0.017, 0.004,
# 0.0017 without dispersion; up to 0.039 in red with the presets' strongest dispersion).
FIT_BOUND = (0.02, 0.005, 0.003)
DISPERSED_BOUND = (0.045, 0.012, 0.012)
DISPERSIVE_TRIPLES = ((1.4, 1.45, 1.6), (1.5, 1.6, 1.8), (2.2, 2.3, 2.45), (1.45, 1.47, 1.5))


def test_closed_form_matches_numerical_integration():
    err = band_fitting.fit_error()
    for c, bound in enumerate(FIT_BOUND):
        assert err[f"max_abs_{'rgb'[c]}"] <= bound, err


def test_zero_path_gives_one_and_thick_layers_average_out():
    """A zero path is the RGB mode's value (1); far beyond the band's coherence length the
    channels' cosines vanish, as the numerical integral does (no aliasing)."""
    assert np.allclose(channel_cosine(0.0), 1.0, atol=1e-12)
    far = np.linspace(12000.0, 60000.0, 97)
    assert np.abs(channel_cosine(far)).max() < 1e-3
    assert np.abs(band_fitting.channel_cosine_numeric(far)).max() < 0.01
    # The paper's RGB point samples do not fade.
    assert np.abs(np.cos(2.0 * np.pi * far[:, None] / np.array([645.0, 525.0, 445.0]))).max() > 0.9


@pytest.mark.parametrize("r1", DISPERSIVE_TRIPLES)
def test_dispersion_to_second_order_matches_numerical_integration(r1):
    """Eq. 18's path 2 r1(lambda) d is exactly linear in the index: the closed form's expansion
    about each Gaussian is the only error."""
    d = np.linspace(0.0, 2000.0, 401)[:, None]
    r = np.asarray(r1)
    D, S = 2.0 * d * r, 2.0 * d * np.ones(3)
    diff = np.abs(channel_cosine(D, r, S) - band_fitting.channel_cosine_numeric(D, r, S)).max(axis=0)
    assert np.all(diff <= DISPERSED_BOUND), diff


def test_equal_indices_need_no_dispersion_terms():
    d = np.linspace(0.0, 1500.0, 61)[:, None]
    r = np.array([1.5, 1.5, 1.5])
    assert np.allclose(channel_cosine(2.0 * d * r, r, 2.0 * d), channel_cosine(2.0 * d * r), atol=1e-12)


def test_baked_rows_are_current():
    for slot in json.loads(spectral_band.PATH.read_text())["slots"]:
        shift, slope, chirp = spectral_band.derived_rows(slot["wavenumber"], slot["damping"])
        assert np.allclose(slot["index_shift"], shift, atol=1e-12)
        assert np.allclose(slot["index_slope"], slope, atol=1e-12)
        assert np.allclose(slot["index_chirp"], chirp, atol=1e-12)
        assert len(slot["amplitude"]) == 3 and all(b > 0.0 for b in slot["damping"])
    amplitudes = np.array([s["amplitude"] for s in spectral_band.band_fit()["slots"]])
    assert np.allclose(amplitudes.sum(axis=0), 1.0, atol=1e-12)
    assert np.abs(amplitudes).max() <= band_fitting.FIT_AMPLITUDE_BOUND + 1e-9


def test_analytic_mode_is_close_to_the_ground_truth():
    """The exact model in the analytic mode against the 1 nm spectral ground truth (eq. 18,
    and eq. 5 at the mirror highlight of parallel boundaries, where interference is
    strongest), with the preset index triples: far closer than the paper's RGB samples."""
    gt = spectral.ground_truth_sampling()
    d = np.linspace(0.0, 1000.0, 41)
    theta = np.radians(np.linspace(0.0, 80.0, 5))
    o = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], axis=-1)[:, None, :]
    i = -(o * np.array([-1.0, 1.0, 1.0]))
    z = np.array([0.0, 0.0, 1.0])
    triples = sorted({LayeredParams.from_dict(v).r1 for v in PRESETS.values()})
    de_an, de_rgb, de_diff = [], [], []
    for r1 in triples:
        ref = spectral.spectral_specular(i, o, z, z, r1, d, 130.0, 130.0, sampling=gt)
        an = specular_brdf(i, o, z, z, r1, d, 130.0, 130.0, band=True)
        rgb = specular_brdf(i, o, z, z, r1, d, 130.0, 130.0)
        scale = 2.0 * np.pi / 132.0  # read as reflectances
        de_an.append(spectral.delta_e_2000(an * scale, ref * scale).ravel())
        de_rgb.append(spectral.delta_e_2000(rgb * scale, ref * scale).ravel())
        de_diff.append(spectral.delta_e_2000(diffuse_rho(r1, d, band=True), spectral.spectral_diffuse(r1, d, sampling=gt)))
    an, rgb, diff = (np.concatenate(x) for x in (de_an, de_rgb, de_diff))
    assert an.mean() < 1.0 and np.percentile(an, 95) < 2.5, (an.mean(), np.percentile(an, 95))
    assert diff.mean() < 1.0 and np.percentile(diff, 95) < 2.5, (diff.mean(), np.percentile(diff, 95))
    assert an.mean() < 0.25 * rgb.mean()


def test_planner_keeps_the_analytic_mode_and_drops_interference_that_averages_out():
    p = LayeredParams.from_dict(PRESETS["fig6_medium"]).replace(accuracy="analytic")
    plan = plan_effects(p)
    assert plan.analytic and plan.spectral == 0 and plan.interference and "A" in plan.key
    thick = p.replace(d_min=20000.0, d_max=20000.0)
    assert not plan_effects(thick).interference
    assert plan_effects(thick, animated={"d_min"}).interference
    assert not plan_effects(p.replace(accuracy="rgb")).analytic


def test_only_the_osl_analytic_shader_filters_over_the_pixel_footprint():
    """OSL has derivatives: the analytic shader averages the interference over filterwidth of the
    path; the planner can switch that off, and the RGB shader never has it."""
    from dataclasses import replace

    from layered_brdf_addon.backends.osl_shader import shader_source

    p = LayeredParams.from_dict(PRESETS["fig6_medium"]).replace(accuracy="analytic")
    plan = plan_effects(p)
    assert "filterwidth(opd)" in shader_source(plan)
    assert "filterwidth(opd)" not in shader_source(replace(plan, footprint=False))
    assert "filterwidth(opd)" not in shader_source(plan_effects(p.replace(accuracy="rgb")))
    assert replace(plan, footprint=False).key != plan.key
