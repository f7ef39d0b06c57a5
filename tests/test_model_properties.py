"""Physical and qualitative properties of the numpy reference."""
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from layered_brdf_addon.model.geometry import dot, tilted_normal
from layered_brdf_reference.exact_model import diffuse_rho, fresnel_f0, schlick, specular_terms

unit = arrays(np.float64, 3, elements=st.floats(-1.0, 1.0, allow_nan=False))
index = st.floats(0.2, 4.0)
exponent = st.one_of(st.just(0.0), st.floats(0.0, 1.0e5))
thickness = st.floats(0.0, 1.0e6)


@given(i=unit, o=unit, n0=unit, n1=unit, r1=st.tuples(index, index, index), d=thickness, e0=exponent, e1=exponent)
def test_specular_is_finite_and_non_negative(i, o, n0, n1, r1, d, e0, e1):
    t = specular_terms(i, o, n0, n1, r1, d, e0, e1)
    for arr in t:
        assert np.all(np.isfinite(arr))
    assert np.all(t.rho >= 0.0) and np.all(t.R >= 0.0) and np.all(t.T >= 0.0)
    # Eq. 5 is bounded by (sqrt R -+ sqrt T)^2.
    lo = (np.sqrt(t.R) - np.sqrt(t.T)) ** 2
    hi = (np.sqrt(t.R) + np.sqrt(t.T)) ** 2
    assert np.all(t.rho >= lo * (1 - 1e-9) - 1e-300) and np.all(t.rho <= hi * (1 + 1e-9) + 1e-300)


@given(r1=st.tuples(index, index, index), d=thickness)
def test_diffuse_is_finite_and_non_negative(r1, d):
    rho = diffuse_rho(r1, d)
    assert np.all(np.isfinite(rho)) and np.all(rho >= 0.0)


def test_thin_layers_are_red_and_thicker_bring_green_and_blue():
    d = np.linspace(1.0, 30.0, 200)
    thin = diffuse_rho([1.5, 1.5, 1.5], d).mean(axis=0)
    assert thin[0] > thin[1] > thin[2]
    thick = diffuse_rho([1.5, 1.5, 1.5], np.linspace(30.0, 400.0, 2000))
    dominant = set(np.argmax(thick, axis=1))
    assert {1, 2} <= dominant  # green and blue each dominate somewhere as d grows
    first_not_red = np.argmax(np.argmax(thick, axis=1) != 0)
    assert 30.0 < np.linspace(30.0, 400.0, 2000)[first_not_red] < 200.0


def test_dispersion_blue_lobe_peaks_furthest_from_mirror():
    n0 = np.array([0.0, 0.0, 1.0])
    n1 = tilted_normal(n0[None], 10.0, 90.0, up=np.array([0.0, 1.0, 0.0]))[0]  # tilt within the x-z plane
    theta_i = np.radians(30.0)
    i = np.array([np.sin(theta_i), 0.0, -np.cos(theta_i)])
    r_i = i * [1, 1, -1]
    ang = np.radians(np.linspace(-89.0, 89.0, 35601))
    o = np.stack([np.sin(ang), np.zeros_like(ang), np.cos(ang)], axis=-1)
    t = specular_terms(np.broadcast_to(i, o.shape), o, n0, n1, [1.5, 1.6, 1.8], 0.0, 90.0, 170.0)
    peaks = o[np.argmax(t.T, axis=0)]
    dev = np.degrees(np.arccos(np.clip(dot(peaks, r_i), -1, 1)))
    assert dev[2] > dev[1] > dev[0] > 1.0


def _phong_samples(k, n, rng):
    """Directions about +z with pdf (k + 1)/(2 pi) cos^k."""
    u1, u2 = rng.random(n), rng.random(n)
    cos_t = u1 ** (1.0 / (k + 1.0))
    sin_t = np.sqrt(1.0 - cos_t ** 2)
    phi = 2 * np.pi * u2
    v = np.stack([sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t], axis=-1)
    return v, (k + 1.0) / (2 * np.pi) * cos_t ** k


@pytest.mark.parametrize("r1", [1.2, 1.5, 2.0])
@pytest.mark.parametrize("e1", [30.0, 120.0, 500.0])
def test_transmitted_lobe_albedo_at_normal_incidence(r1, e1):
    """Monte Carlo over exterior directions: T's albedo is (1 - F)(1 - f) within 3%."""
    rng = np.random.default_rng(7)
    k = 0.5 * e1 / r1 ** 2  # importance density wider than the lobe (about e1 / r1^2)
    o, pdf = _phong_samples(k, 400_000, rng)
    i = np.array([0.0, 0.0, -1.0])
    n = np.array([0.0, 0.0, 1.0])
    t = specular_terms(np.broadcast_to(i, o.shape), o, n, n, [r1], 0.0, 0.0, e1)
    albedo = np.mean(t.T[:, 0] * o[:, 2] / pdf)
    f = fresnel_f0(r1)
    assert albedo == pytest.approx((1 - f) * (1 - f), rel=0.03)


@pytest.mark.parametrize("r1", [1.2, 1.5, 2.0])
@pytest.mark.parametrize("e0", [30.0, 120.0, 500.0])
def test_reflected_lobe_albedo_at_normal_incidence(r1, e0):
    rng = np.random.default_rng(8)
    o, pdf = _phong_samples(0.5 * e0, 400_000, rng)
    i = np.array([0.0, 0.0, -1.0])
    n = np.array([0.0, 0.0, 1.0])
    t = specular_terms(np.broadcast_to(i, o.shape), o, n, n, [r1], 0.0, e0, 0.0)
    albedo = np.mean(t.R[:, 0] * o[:, 2] / pdf)
    assert albedo == pytest.approx(schlick(1.0, fresnel_f0(r1)), rel=0.03)
