"""Hard cases of the numpy reference: exact expected values, not only 'no NaN'."""
import math

import numpy as np
import pytest

from layered_brdf_reference.exact_model import diffuse_rho, fresnel_f0, phong_norm, schlick, specular_terms

N = np.array([0.0, 0.0, 1.0])
R1 = [1.4, 1.45, 1.6]


def dirs(theta_deg, phi_deg=0.0):
    """Light-incident ``i`` at polar angle theta (travelling along +x) and its mirror ``o``."""
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    i = np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), -np.cos(t)])
    return i, i * [1, 1, -1]


def terms(i, o, n0=N, n1=N, r1=R1, d=70.0, e0=90.0, e1=170.0, **kw):
    t = specular_terms(i, o, n0, n1, r1, d, e0, e1, **kw)
    for a in t:
        assert np.all(np.isfinite(a))
    assert np.all(t.rho >= 0)
    return t


def reflected_expected(i, o, r1, e0, r0=1.0):
    f = fresnel_f0(np.asarray(r1), r0)
    c = np.dot(i * [1, 1, -1], o)
    lobe = c ** e0 if c > 0 else 0.0
    return schlick(-i[2], f) * (e0 + 2) / (2 * np.pi) * lobe


@pytest.mark.parametrize("theta", [89.0, 89.9, 89.999])
def test_grazing_light_at_mirror(theta):
    i, o = dirs(theta)
    t = terms(i, o)
    assert np.allclose(t.R, reflected_expected(i, o, R1, 90.0))
    assert np.all(t.rho > 0)


@pytest.mark.parametrize("which", ["light", "view"])
@pytest.mark.parametrize("theta", [90.0, 91.0, 135.0, 180.0])
def test_at_or_below_horizon_gives_zero(which, theta):
    i, o = dirs(30.0)
    t_rad = np.radians(theta)
    s, c = np.sin(t_rad), (0.0 if theta == 90.0 else np.cos(t_rad))  # exactly on the horizon at 90
    if which == "light":
        i = np.array([s, 0.0, -c])
    else:
        o = np.array([-s, 0.0, c])
    t = terms(i, o)
    assert np.all(t.rho == 0.0) and np.all(t.R == 0.0) and np.all(t.T == 0.0)


def test_index_matched_layer():
    # r1 = r0: f = 0, no refraction; T = (1 - F)^2 N1, interference with phase 2 pi d / lam cos.
    i, o = dirs(30.0)
    t = terms(i, o, r1=[1.0, 1.0, 1.0], d=100.0)
    F = (1 - np.cos(np.radians(30))) ** 5
    R = F * phong_norm(90.0)
    T = (1 - F) ** 2 * phong_norm(170.0)
    phase = np.pi * 100.0 / np.array([645.0, 525.0, 445.0]) * 2 * np.cos(np.radians(30))
    assert np.allclose(t.R, R) and np.allclose(t.T, T)
    assert np.allclose(t.rho, R + T + 2 * np.cos(2 * phase) * np.sqrt(R * T))


def test_total_internal_reflection_leaves_only_the_reflected_lobe():
    r1 = [0.8, 0.8, 0.8]  # the layer is optically thinner: no refraction beyond asin(0.8)
    i, o = dirs(60.0)
    t = terms(i, o, r1=r1)
    assert np.all(t.T == 0.0)
    assert np.allclose(t.rho, reflected_expected(i, o, r1, 90.0))
    i, o = dirs(30.0)  # below the critical angle light does cross
    assert np.all(terms(i, o, r1=r1).T > 0.0)


def test_zero_thickness_is_fully_constructive():
    i, o = dirs(20.0)
    t = terms(i, o, d=0.0)
    assert np.allclose(t.rho, (np.sqrt(t.R) + np.sqrt(t.T)) ** 2)
    # The diffuse part: rho_d(0) = 1 + 2 sqrt(Td (1 - Td)), 1.56 at r1 = 1.5.
    assert np.allclose(diffuse_rho([1.5] * 3, 0.0), 1.5598833, atol=1e-6)


def test_huge_thickness_stays_bounded():
    i, o = dirs(20.0)
    t = terms(i, o, d=1.0e6)
    assert np.all(t.rho >= (np.sqrt(t.R) - np.sqrt(t.T)) ** 2 - 1e-12)
    assert np.all(t.rho <= (np.sqrt(t.R) + np.sqrt(t.T)) ** 2 + 1e-12)
    rd = diffuse_rho(R1, 1.0e6)
    assert np.all(np.isfinite(rd)) and np.all((rd >= 0) & (rd <= 2))


def test_exponent_zero_lobe_is_zero_where_cosine_not_positive():
    i, _ = dirs(30.0)
    # o orthogonal to the mirror direction: <r_i, o> = 0 -> lobe 0, not 0^0 = 1.
    r_i = i * [1, 1, -1]
    o = np.cross(r_i, [0.0, 1.0, 0.0])
    o = o if o[2] > 0 else -o
    assert abs(np.dot(r_i, o)) < 1e-12 and o[2] > 0
    t = terms(i, o, e0=0.0, e1=1.0e5)
    assert np.all(t.R == 0.0)
    # Inside the lobe, e0 = 0 gives the constant F / pi.
    i, o = dirs(30.0)
    o2 = np.array([0.3, 0.2, 0.9])
    o2 /= np.linalg.norm(o2)
    t = terms(i, o2, e0=0.0)
    assert np.allclose(t.R, schlick(np.cos(np.radians(30)), fresnel_f0(np.array(R1))) / np.pi)


def test_huge_exponent_at_and_off_mirror():
    i, o = dirs(30.0)
    t = terms(i, o, e0=1.0e5, e1=1.0e5)
    assert np.allclose(t.R, reflected_expected(i, o, R1, 1.0e5))
    assert np.all(t.R > 100.0)  # F ~ 0.03 times (e + 2) / (2 pi) ~ 1.6e4
    _, o_off = dirs(35.0)  # 5 degrees off: cos^1e5 underflows far below the peak
    assert np.all(terms(i, o_off, e0=1.0e5, e1=1.0e5).rho < 1e-20)


def test_lower_normal_opposite_blocks_the_path():
    i, o = dirs(30.0)
    t = terms(i, o, n1=-N)  # 180 degrees: <t_i, n1> > 0
    assert np.all(t.T == 0.0)
    assert np.allclose(t.rho, reflected_expected(i, o, R1, 90.0))


def test_lower_normal_at_90_degrees_in_plane_of_incidence_normal():
    i, o = dirs(30.0)
    t = terms(i, o, n1=np.array([0.0, 1.0, 0.0]))  # <t_i, n1> = 0: no path
    assert np.all(t.T == 0.0)
    assert np.allclose(t.rho, reflected_expected(i, o, R1, 90.0))


def test_lower_normal_at_89_degrees():
    n1 = np.array([0.0, np.sin(np.radians(89.0)), np.cos(np.radians(89.0))])
    i, o = dirs(30.0, 90.0)  # light travels along +y: t_i leans on n1's side
    t = terms(i, o, n1=n1, e1=0.0)
    assert np.allclose(t.R, reflected_expected(i, o, R1, 90.0))
    assert np.all(t.T == 0.0)  # t_i . n1 > 0: the lower boundary faces away
    i, o = dirs(30.0, -90.0)
    t = terms(i, o, n1=n1, e1=0.0)
    # t_i . n1 < 0 but t_o . n1 > 0 for the mirror view: no exit path either.
    assert np.all(t.T == 0.0)


@pytest.mark.parametrize("bad", [np.zeros(3), np.full(3, np.nan), np.array([np.inf, 0, 0])])
def test_degenerate_upper_normal_falls_back_to_geometric(bad):
    i, o = dirs(25.0)
    t = terms(i, o, n0=bad, n1=bad, ng=N)
    ref = terms(i, o, n0=N, n1=N)
    assert np.allclose(t.rho, ref.rho)


@pytest.mark.parametrize("bad", [np.zeros(3), np.full(3, np.nan)])
def test_degenerate_lower_normal_falls_back_to_upper(bad):
    i, o = dirs(25.0)
    assert np.allclose(terms(i, o, n1=bad).rho, terms(i, o).rho)


def test_degenerate_directions_give_zero():
    _, o = dirs(25.0)
    assert np.all(terms(np.zeros(3), o).rho == 0.0)
    assert np.all(terms(np.full(3, np.nan), o).rho == 0.0)


def test_vectorised_matches_scalar(rng):
    i = -np.abs(rng.normal(size=(50, 3))) * [1, 1, 1]
    o = np.abs(rng.normal(size=(50, 3)))
    n0 = np.array([0.1, -0.2, 1.0]) + 0.1 * rng.normal(size=(50, 3))
    n1 = n0 + 0.2 * rng.normal(size=(50, 3))
    d = rng.uniform(0, 500, 50)
    v = specular_terms(i, o, n0, n1, R1, d, 90.0, 170.0).rho
    for k in range(50):
        s = specular_terms(i[k], o[k], n0[k], n1[k], R1, d[k], 90.0, 170.0).rho
        assert np.allclose(v[k], s, rtol=1e-12, atol=0)
    assert math.isfinite(float(v.sum()))
