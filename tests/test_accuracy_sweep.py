"""The accuracy sweep at coarse resolution: finite metrics, regression bounds, and the
instrument itself (metrics that react as they must to deliberately wrong closures)."""
from __future__ import annotations

import math
from functools import partial

import numpy as np
import pytest

from layered_brdf_addon.model.params import LayeredParams
from layered_brdf_reference import sweep
from layered_brdf_reference.closures import closure_shading
from layered_brdf_reference.exact_model import specular_brdf
from layered_brdf_reference.exact_spheres import exact_shading

RESOLUTION = 32
RGB_CONFIGURATIONS = 60
SPECTRAL_BASE = 3  # x every accuracy mode

# Measured on the coarse sweep below (32 px, 60 RGB configurations, seed 2003; 3 spectral
# configurations x 5 modes, seed 2004) with the closure form of this commit (anisotropic
# lobes, transmitted tails through the critical cone, merged spectral groups, the
# interference lobe always folded):
#   RGB: L1 p50 15.4%, p95 60.2%, max 95.7%; 24 configurations over 20%; 30 holes, 144 ghosts
#   (before those changes: p50 17.7%, p95 80.9%, 30 over 20%, 316 holes, 213 ghosts).
#   Spectral design, per mode: L1 p95 35.6-43.5% (worst: rgb); 3 holes per mode.
# The bounds allow a small margin; lower them when the closure form improves.
MAX_RGB_L1_P50 = 0.154 + 0.03
MAX_RGB_L1_P95 = 0.602 + 0.05
MAX_RGB_OVER_20 = 24 + 3
MAX_RGB_HOLES = 30 + 10
MAX_RGB_GHOSTS = 144 + 30
MAX_SPECTRAL_L1_P95 = 0.435 + 0.05
MAX_SPECTRAL_HOLES = 3 + 3  # per mode
# Presets under the standard sun at 32 px: the paper's figures 0-4.0%; the artist presets, physical
# films with conformal boundaries (e1 = e0 r1^2), 0-2.9% (titanium 26.8%, old metal 21.1%, glaze 15.5%,
# beetle 11.5% with the paper's optics and e1 = e0), but the soap bubble, 9.0%: its lobes (e0 3000) are
# a few pixels wide at 32 px (6.1% at e0 800).
MAX_PRESET_L1 = {"soap_bubble": 0.090 + 0.02, "anodised_titanium": 0.021 + 0.02, "old_metal": 0.016 + 0.02,
                 "beetle_shell": 0.029 + 0.02}
MAX_PRESET_L1_DEFAULT = 0.060 + 0.02

FINITE_KEYS = ("l1", "l1_sphere", "energy", "de_lit", "de_highlight")


@pytest.fixture(scope="module")
def rgb_configs():
    return sweep.design(RGB_CONFIGURATIONS)


@pytest.fixture(scope="module")
def rgb_rows(rgb_configs):
    return sweep.run(rgb_configs, RESOLUTION)


@pytest.fixture(scope="module")
def spectral_rows():
    return sweep.run(sweep.spectral_design(SPECTRAL_BASE), RESOLUTION)


def _finite(m: dict) -> bool:
    return all(math.isfinite(m[k]) for k in FINITE_KEYS) and all(math.isfinite(x) for x in m["energy_rgb"])


def test_design_spans_the_ranges(rgb_configs):
    cs = rgb_configs
    el = [c.elevation for c in cs]
    assert min(el) < 7.0 and max(el) > 85.0
    for key in ("e0", "e1"):
        v = [getattr(c, key) for c in cs]
        assert min(v) < 15.0 and max(v) > 700.0
    r1 = [x for c in cs for x in c.r1]
    assert min(r1) >= sweep.INDEX[0] and max(r1) <= sweep.INDEX[1]
    assert {c.dispersive for c in cs} == {True, False}
    assert {c.normal_mode for c in cs} == {"parallel", "tilted", "correlated"}
    tilts = [c.tilt for c in cs if c.normal_mode == "tilted"]
    assert min(tilts) < 3.0 and max(tilts) > 27.0
    d = [x for c in cs for x in (c.d_min, c.d_max)]
    assert min(d) < 30.0 and max(d) > 950.0
    assert sweep.design(RGB_CONFIGURATIONS) == cs  # seeded
    modes = {c.accuracy for c in sweep.spectral_design(SPECTRAL_BASE)}
    assert modes == set(sweep.ACCURACY_MODES)


def test_every_metric_is_finite(rgb_rows, spectral_rows):
    for r in rgb_rows + spectral_rows:
        m = r["metrics"]
        assert _finite(m), (sweep.describe(r["config"]), m)
        assert m["highlight_pixels"] > 0 and 0 <= m["holes"] <= m["highlight_pixels"]


def test_rgb_accuracy_no_worse_than_measured(rgb_rows):
    s = sweep.summarise(rgb_rows)
    print(f"RGB: L1 p50 {s.l1_p50:.3f} p95 {s.l1_p95:.3f} max {s.l1_max:.3f}; over 20% {s.over_20}; "
          f"holes {s.holes}, ghosts {s.ghosts}")
    assert s.l1_p50 <= MAX_RGB_L1_P50
    assert s.l1_p95 <= MAX_RGB_L1_P95
    assert s.over_20 <= MAX_RGB_OVER_20
    assert s.holes <= MAX_RGB_HOLES
    assert s.ghosts <= MAX_RGB_GHOSTS


def test_spectral_accuracy_no_worse_than_measured(spectral_rows):
    for mode, s in sweep.groups(spectral_rows, lambda c: c["accuracy"]).items():
        print(f"{mode}: L1 p95 {s.l1_p95:.3f}, holes {s.holes}")
        assert s.l1_p95 <= MAX_SPECTRAL_L1_P95, mode
        assert s.holes <= MAX_SPECTRAL_HOLES, mode


def test_presets_no_worse_than_measured():
    for r in sweep.preset_rows(RESOLUTION):
        m = r["metrics"]
        assert _finite(m) and _finite(r["specular_only"]), r["name"]
        assert m["l1"] <= MAX_PRESET_L1.get(r["name"], MAX_PRESET_L1_DEFAULT), (r["name"], m["l1"])


# --------------------------------------------------------------------------
# The instrument.
def _scaled(shading, k):
    def f(*args, **kwargs):
        return k * shading(*args, **kwargs)
    return f


def _exact_with_light(transform):
    """The exact model lit from a transformed sun: a highlight in the wrong place."""
    def f(params, n0, n1, d, l, v, **kwargs):
        return exact_shading(params, n0, n1, d, transform(np.asarray(l, dtype=float)), v)
    return f


@pytest.fixture(scope="module")
def probe(rgb_configs):
    """A few configurations (parallel and tilted, dispersive and not), with their rows."""
    picked = [c for c in rgb_configs if c.normal_mode != "correlated"][:8]
    return picked, sweep.run(picked, RESOLUTION)


def test_exact_against_itself_is_perfect(probe):
    configs, _ = probe
    for c in configs:
        m = sweep.evaluate(c, RESOLUTION, closure=exact_shading)
        assert m["l1"] == 0.0 and m["energy"] == pytest.approx(1.0, abs=1e-12) and m["holes"] == 0
        assert m["de_lit"] == pytest.approx(0.0, abs=1e-9)


def test_half_of_exact_reads_half(probe):
    configs, _ = probe
    for c in configs:
        m = sweep.evaluate(c, RESOLUTION, closure=_scaled(exact_shading, 0.5))
        assert m["l1"] == pytest.approx(0.5, abs=1e-9)
        assert m["energy"] == pytest.approx(0.5, abs=1e-9)
        np.testing.assert_allclose(m["energy_rgb"], 0.5, atol=1e-9)
        assert m["holes"] == 0  # 50% is not a hole
        assert m["de_highlight"] > 5.0  # half the luminance is a visible difference
        tenth = sweep.evaluate(c, RESOLUTION, closure=_scaled(exact_shading, 0.1))
        assert tenth["holes"] == tenth["highlight_pixels"] and tenth["l1"] == pytest.approx(0.9, abs=1e-9)


def test_half_of_the_closure_form_reads_about_half(probe):
    """``|0.5 c - e| = |0.5 (c - e) - 0.5 e|``: the L1 of half the closure form is within half
    its own L1 of 50%, and its energy ratio is exactly half."""
    configs, rows = probe
    for c, r in zip(configs, rows):
        a = r["metrics"]
        m = sweep.evaluate(c, RESOLUTION, closure=_scaled(closure_shading, 0.5))
        assert abs(m["l1"] - 0.5) <= 0.5 * a["l1"] + 1e-9, sweep.describe(r["config"])
        assert m["energy"] == pytest.approx(0.5 * a["energy"], rel=1e-9)
        assert m["holes"] >= a["holes"]
    accurate = [(c, r) for c, r in zip(configs, rows) if r["metrics"]["l1"] < 0.1]
    assert accurate, "the probe should hold a configuration the closure form gets right"
    for c, r in accurate:
        m = sweep.evaluate(c, RESOLUTION, closure=_scaled(closure_shading, 0.5))
        assert m["l1"] == pytest.approx(0.5, abs=0.05) and m["energy"] == pytest.approx(0.5, abs=0.06)


def test_a_misplaced_highlight_is_holes_not_energy():
    """The sun mirrored across the view axis moves the highlight to the other side of the sphere:
    the energy is unchanged (a parallel layer of constant thickness is symmetric), but the
    highlight is empty (holes, L1 near 100%), the light is elsewhere (ghosts) and the L1 over the
    sphere near 200%."""
    c = sweep.SweepConfig(elevation=45.0, sun_azimuth=0.0, e0=200.0, e1=200.0, r1=(1.5, 1.5, 1.5),
                          normal_mode="parallel", tilt=0.0, d_min=300.0, d_max=300.0)
    mirror = partial(np.multiply, np.array([-1.0, 1.0, 1.0]))  # sun at azimuth 0 is on +x
    m = sweep.evaluate(c, RESOLUTION, closure=_exact_with_light(mirror))
    assert m["energy"] == pytest.approx(1.0, abs=0.02)
    assert m["holes"] == m["highlight_pixels"] > 0
    assert m["l1"] > 0.95 and m["l1_sphere"] > 1.8
    assert m["ghosts"] == pytest.approx(m["highlight_pixels"], rel=0.2)
    assert m["de_highlight"] > 20.0


# --------------------------------------------------------------------------
# The closure form at the mirror direction.
@pytest.mark.parametrize("view_deg", [0.0, 20.0, 40.0, 60.0, 70.0])
def test_closure_form_has_the_exact_value_at_the_mirror_direction(view_deg):
    """With parallel boundaries and no phase (d = 0) the three lobes share their centre, and
    the closure form is built to give the exact value there: within 7% out to 70 degrees.
    At a normal view the closures' tangents vanish and the lobes must fall back to
    isotropic, not to zero."""
    p = LayeredParams.from_dict(dict(r1_r=1.5, r1_g=1.5, r1_b=1.5, e0=130.0, e1=130.0, ks=1.0, kd=0.0,
                                     d_min=0.0, d_max=0.0, thickness_mode="height", normal_mode="parallel"))
    t = math.radians(view_deg)
    v = np.array([[math.sin(t), 0.0, math.cos(t)]])
    n0 = np.array([[0.0, 0.0, 1.0]])
    l = np.array([-math.sin(t), 0.0, math.cos(t)])
    d = np.zeros(1)
    closure = closure_shading(p, n0, n0, d, l, v[0], ng=n0)
    exact = specular_brdf(-l[None], v, n0, n0, p.r1, d, p.e0, p.e1, p.r0, ng=n0) * math.cos(t)
    np.testing.assert_allclose(closure, exact, rtol=0.07)
