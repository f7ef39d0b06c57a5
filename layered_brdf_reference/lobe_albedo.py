"""Directional albedos of the lobes, by quadrature: what a lobe returns of the light that arrives
from one direction, integrated over the hemisphere it reflects into.

* :func:`beckmann_albedo`: Cycles' Beckmann closure at unit weight (its numpy twin,
  :func:`layered_brdf_addon.fit.cycles_closures.beckmann_eval`), anisotropic as the shading program
  sets it (``alpha_x`` across the plane of the view and the closure normal, ``alpha_y`` within it).
  The physical mode divides each closure's weight by it, so that the closure returns its weight
  (:mod:`layered_brdf_addon.model.shading.energy`); :func:`fit_closure_albedo` fits the closed form
  the shaders evaluate and writes ``layered_brdf_addon/model/data/closure_albedo.json``
  (``make albedo-fit``).
* :func:`phong_albedo`: the paper's lobe ``(e + 2)/(2 pi) cos^e`` about a direction at cosine ``mu``
  to the normal, clipped at the horizon: about ``mu`` for a sharp lobe, more where it crosses the
  horizon.  The exact model's reflected lobe is divided by it in the physical mode.
* :func:`layer_lobe_albedo`: the same for the transmitted lobe, a lobe ``cos^e1`` inside the layer
  about an upward direction at cosine ``c`` to the normal, leaving through the top boundary (the
  critical cone) into the outside, crossing it with the unpolarised Fresnel transmittance.

An offline tool: the fit needs scipy.
"""
from __future__ import annotations

import functools
import json
import math

import numpy as np

from layered_brdf_addon.fit.cycles_closures import _lambda_from
from layered_brdf_addon.model import ops_numpy
from layered_brdf_addon.model.shading.energy import ALBEDO_PATH, closure_albedo_numpy
from layered_brdf_addon.model.shading.thin_film import fresnel_reflectance

QUADRATURE = 64  # Gauss-Legendre nodes per axis


@functools.lru_cache(maxsize=None)
def _legendre01(n: int):
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


@functools.lru_cache(maxsize=None)
def _gaussian_slopes(n: int):
    """Gauss-Legendre nodes of a unit-variance-over-two Gaussian slope (``ndtri(u) / sqrt 2``) on each of two
    axes and the product weights: Beckmann's microfacet slopes over ``alpha``, sampling ``D cos theta_h``."""
    from scipy.special import ndtri

    u, w = _legendre01(n)
    return ndtri(u) / math.sqrt(2.0), np.outer(w, w)


def _facet_normals(a_x, a_y, n: int):
    """The microfacet normals ``(h_x, h_y, h_z)`` of the slope nodes for alphas ``a_x`` (along x, across the
    view's plane) and ``a_y`` (along y, within it), and their weights (:func:`_gaussian_slopes`)."""
    q, ww = _gaussian_slopes(n)
    sx, sy = q[:, None] * a_x, q[None, :] * a_y
    hz = 1.0 / np.sqrt(1.0 + sx * sx + sy * sy)
    return -sx * hz, -sy * hz, hz, ww


def beckmann_albedo(ax, ay, mu, n: int = QUADRATURE) -> np.ndarray:
    """Directional albedo of Cycles' Beckmann closure (no Fresnel, unit weight) seen at cosine
    ``mu``, alphas ``ax`` across the plane of the view and the normal, ``ay`` within it.

    Integrated over the microfacet normals, whose slopes are Gaussian (``D cos theta_h`` is their
    density): ``E = < G2 (v.h) / (mu cos theta_h) >`` over the normals whose mirror of the view
    lies above the horizon, ``G2 = 1 / (1 + Lambda_v + Lambda_l)`` as Cycles evaluates it."""
    ax, ay, mu = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (ax, ay, mu)))
    out = np.empty(ax.shape)
    for idx in np.ndindex(ax.shape):
        a_x, a_y, m = max(ax[idx], 1e-4), max(ay[idx], 1e-4), min(max(mu[idx], 1e-4), 1.0)
        hx, hy, hz, ww = _facet_normals(a_x, a_y, n)
        vy, vz = math.sqrt(max(1.0 - m * m, 0.0)), m
        vh = hy * vy + hz * vz
        lx, ly, lz = 2.0 * vh * hx, 2.0 * vh * hy - vy, 2.0 * vh * hz - vz

        def lam(x, y, z):
            return _lambda_from(((a_x * x) ** 2 + (a_y * y) ** 2) / np.maximum(z * z, 1e-30))

        g2 = 1.0 / (1.0 + lam(0.0, vy, vz) + lam(lx, ly, lz))
        val = np.where((lz > 0.0) & (vh > 0.0), g2 * vh / (m * hz), 0.0)
        out[idx] = float((ww * val).sum())
    return out


def _clipped_ring(a, b):
    """``integral over phi of max(a + b cos phi, 0)``, ``b >= 0``."""
    ratio = np.clip(-a / np.maximum(b, 1e-300), -1.0, 1.0)
    phi1 = np.arccos(ratio)
    return np.where(a >= b, 2.0 * np.pi * a, np.where(a <= -b, 0.0, 2.0 * (a * phi1 + b * np.sin(phi1))))


def phong_albedo(e, mu, n: int = 256) -> np.ndarray:
    """``(e + 2)/(2 pi) int max(cos alpha, 0)^e max(cos theta_o, 0) d omega_o``: the paper's lobe of
    exponent ``e`` about a direction at cosine ``mu`` to the normal (``mu`` may be negative: a
    centre below the horizon), clipped at the horizon.  ``cos alpha = t`` is integrated with
    ``t = s^(1/(e+1))`` (``t^e dt = ds / (e + 1)``), the azimuth about the centre in closed form."""
    e, mu = np.broadcast_arrays(np.asarray(e, dtype=float), np.asarray(mu, dtype=float))
    s, w = _legendre01(n)
    t = s ** (1.0 / (e[..., None] + 1.0))
    m = np.clip(mu[..., None], -1.0, 1.0)
    ring = _clipped_ring(m * t, np.sqrt(1.0 - m * m) * np.sqrt(np.maximum(1.0 - t * t, 0.0)))
    return (e + 2.0) / (2.0 * np.pi * (e + 1.0)) * np.einsum("...k,k->...", ring, w)


def _leaving(cos1, eta):
    """``(1 - R01) cos theta_1`` for in-layer directions at cosine ``cos1`` to the normal that leave through
    the top boundary (inside the critical cone), else 0: the top boundary's Fresnel reflectance of the
    shading program, from outside at the cosine the direction leaves at (``eta = r0 / r1``)."""
    k = 1.0 - (1.0 - cos1 * cos1) / (eta * eta)  # cos^2 of the outside direction
    cos0 = np.sqrt(np.maximum(k, 0.0))
    trans = 1.0 - np.asarray(fresnel_reflectance(ops_numpy, cos0, eta))
    return np.where((k > 0.0) & (cos1 > 0.0), trans * cos1, 0.0)


def layer_lobe_albedo(e1, eta, c, n: int = 128, m_phi: int = 64) -> np.ndarray:
    """What the transmitted lobe returns outside per unit of its coefficient, before the
    ``1 / (1 - R01(l))`` of its light's entry: ``(e1 + 2)/(2 pi r1^2) int cos^e1(alpha) (1 - R01(o))
    cos theta_o d omega_o`` over the outside directions ``o`` whose path into the layer makes the
    angle ``alpha`` with the lobe's centre, an upward in-layer direction at cosine ``c`` to the normal
    (``eta = r0 / r1``).  In the layer's solid angle (``cos theta_o d omega_o = cos theta_1 d omega_1 /
    eta^2``, which cancels the ``1 / r1^2`` but for ``1 / r0^2``, here 1): ``(e1 + 2)/(2 pi) int
    cos^e1(alpha) (1 - R01) cos theta_1 d omega_1`` inside the critical cone."""
    e1, eta, c = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (e1, eta, c)))
    s, w = _legendre01(n)
    phi = (np.arange(m_phi) + 0.5) * (np.pi / m_phi)  # the half turn; the lobe is symmetric
    t = s ** (1.0 / (e1[..., None, None] + 1.0))
    cc = np.clip(c[..., None, None], -1.0, 1.0)
    cos1 = cc * t + np.sqrt(1.0 - cc * cc) * np.sqrt(np.maximum(1.0 - t * t, 0.0)) * np.cos(phi)[:, None]
    ring = _leaving(cos1, eta[..., None, None]).mean(axis=-2) * (2.0 * np.pi)
    return (e1 + 2.0) / (2.0 * np.pi * (e1 + 1.0)) * np.einsum("...k,k->...", ring, w)


def visible_cosine(alpha, mu, n: int = QUADRATURE) -> np.ndarray:
    """The mean cosine between a view at cosine ``mu`` to the normal and the normals of the microfacets it
    sees on an isotropic Beckmann surface of ``alpha``: the average of ``v.h`` weighted by ``max(v.h, 0) D(h)``
    (the visible normals' density, over ``D cos theta_h``, which the slopes sample)."""
    alpha, mu = np.broadcast_arrays(np.asarray(alpha, dtype=float), np.asarray(mu, dtype=float))
    out = np.empty(alpha.shape)
    for idx in np.ndindex(alpha.shape):
        a, m = max(alpha[idx], 1e-5), min(max(mu[idx], 0.0), 1.0)
        _, hy, hz, ww = _facet_normals(a, a, n)
        vh = hy * math.sqrt(1.0 - m * m) + hz * m
        seen = ww * np.maximum(vh, 0.0) / hz
        out[idx] = float((seen * vh).sum() / seen.sum())
    return out


def fit_microfacet_cosine() -> tuple[np.ndarray, float]:
    """Least-squares fit of :func:`layered_brdf_addon.model.shading.energy.microfacet_cosine`'s three
    coefficients to :func:`visible_cosine` over alphas 0.003-1 and cosines 0.01-1: the coefficients and the
    largest error."""
    from scipy.optimize import least_squares

    alpha = np.array([0.003, 0.01, 0.03, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.7, 1.0])[:, None]
    mu = np.array([1.0, 0.9, 0.7, 0.5, 0.4, 0.3, 0.2, 0.15, 0.1, 0.07, 0.05, 0.03, 0.02, 0.01])[None, :]
    want = visible_cosine(alpha, mu)

    def form(c):
        return np.sqrt(mu * mu + (c[0] * alpha) ** 2 * np.maximum(1.0 - mu * mu, 1e-12) ** c[2]) / \
            np.sqrt(1.0 + c[1] * alpha * alpha)

    sol = least_squares(lambda c: (form(c) - want).ravel(), [0.9, 0.9, 1.0])
    return sol.x, float(np.abs(form(sol.x) - want).max())


# --------------------------------------------------------------------------
# The closed form of Cycles' Beckmann albedo that the shaders evaluate.
FIT_SAMPLES = 3000


def _fit_points(seed: int = 1):
    """Alphas and view cosines over the range the shading program gives its closures, denser
    where they are small (most lobes): ``alpha`` in [0.003, 1], ``mu`` in [0.01, 1]."""
    rng = np.random.default_rng(seed)
    ax = np.maximum(rng.uniform(0.0, 1.0, FIT_SAMPLES) ** 1.5, 0.003)
    ay = np.maximum(rng.uniform(0.0, 1.0, FIT_SAMPLES) ** 1.5, 0.003)
    mu = np.maximum(rng.uniform(0.0, 1.0, FIT_SAMPLES) ** 1.5, 0.01)
    return ax, ay, mu, beckmann_albedo(ax, ay, mu)


def fit_closure_albedo() -> dict:
    """Least-squares fit of :func:`closure_albedo_numpy`'s twelve coefficients to
    :func:`beckmann_albedo`; returns the table, with the fit's largest and rms errors."""
    from scipy.optimize import least_squares

    ax, ay, mu, e = _fit_points()
    start = np.array([0.3, 3.0, 1.0, 1.0, 0.1, 2.0, 1.0, 2.5, 0.5, 3.0, 1.0, 1.0])

    def residual(c):
        return closure_albedo_numpy(ax, ay, mu, c) - e

    sol = least_squares(residual, start, bounds=(0.0, np.inf))
    err = np.abs(residual(sol.x))
    return {"coefficients": [float(x) for x in sol.x], "max_error": float(err.max()),
            "rms_error": float(np.sqrt(np.mean(err * err))), "samples": FIT_SAMPLES}


def main() -> None:
    table = fit_closure_albedo()
    ALBEDO_PATH.write_text(json.dumps(table, indent=1) + "\n")
    print(f"wrote {ALBEDO_PATH}: largest error {table['max_error']:.4f}, rms {table['rms_error']:.4f}")


if __name__ == "__main__":
    main()


# --------------------------------------------------------------------------
# Tables of the two lobes' albedos for the exact model (interpolated; the quadrature per point
# would multiply its cost by thousands).
_E_NODES = 72  # over log(1 + e), exponents 0 to 1e6
_E_MAX = 1e6
_C_NODES = 385  # over sqrt(cosine): fine near the horizon, where sharp lobes change fastest


def _grid():
    u = np.linspace(0.0, math.log1p(_E_MAX), _E_NODES)
    s = np.linspace(0.0, 1.0, _C_NODES)
    return u, s


def _bilinear(table, e, c):
    """``table`` (exponent, sqrt(cosine)) read at ``e``, ``c`` (arrays of one shape), bilinearly."""
    u = np.log1p(np.clip(e, 0.0, _E_MAX)) * ((_E_NODES - 1) / math.log1p(_E_MAX))
    s = np.sqrt(np.clip(c, 0.0, 1.0)) * (_C_NODES - 1)
    i = np.minimum(u.astype(int), _E_NODES - 2)
    j = np.minimum(s.astype(int), _C_NODES - 2)
    fu, fs = u - i, s - j
    return ((1.0 - fu) * ((1.0 - fs) * table[i, j] + fs * table[i, j + 1]) +
            fu * ((1.0 - fs) * table[i + 1, j] + fs * table[i + 1, j + 1]))


@functools.lru_cache(maxsize=None)
def _phong_table():
    u, s = _grid()
    return phong_albedo(np.expm1(u)[:, None], (s * s)[None, :])


# The transmitted lobe's table: its ring integrals over the azimuth about the centre, once per cosine
# ``c`` of the centre and ``t`` of the angle from it, then weighted by ``t^e1`` for every exponent.
# ``t = 1 - x^2``, ``x`` by Gauss-Legendre panels down to 1e-4 (lobes up to e1 = 1e6).
_X_PANELS = (0.0, 1e-4, 1e-3, 1e-2, 0.1, 1.0)
_PHI_NODES = 64


@functools.lru_cache(maxsize=None)
def _x_nodes():
    g, w = _legendre01(48)
    xs, ws = [], []
    for lo, hi in zip(_X_PANELS[:-1], _X_PANELS[1:]):
        xs.append(lo + (hi - lo) * g)
        ws.append((hi - lo) * w)
    return np.concatenate(xs), np.concatenate(ws)


@functools.lru_cache(maxsize=128)
def _layer_table(eta: float):
    u, s = _grid()
    x, wx = _x_nodes()
    t = 1.0 - x * x
    c = (s * s)[:, None, None]
    phi = (np.arange(_PHI_NODES) + 0.5) * (np.pi / _PHI_NODES)
    cos1 = c * t[None, :, None] + np.sqrt(1.0 - c * c) * np.sqrt(np.maximum(1.0 - t * t, 0.0))[None, :, None] * \
        np.cos(phi)[None, None, :]
    ring = _leaving(cos1, eta).mean(axis=-1) * (2.0 * np.pi)  # (c, t)
    e = np.expm1(u)
    # int t^e ring dt with dt = 2 x dx, in logs so that huge exponents underflow cleanly.
    with np.errstate(under="ignore"):
        weights = np.exp(e[:, None] * np.log(t)[None, :]) * (2.0 * x * wx)[None, :]
    return (e + 2.0)[:, None] / (2.0 * np.pi) * (weights @ ring.T)


ETA_STEP = 0.005  # the transmitted lobe's tables are built at multiples of this eta, and interpolated between


def reflected_albedo(e, mu) -> np.ndarray:
    """:func:`phong_albedo` interpolated in a table (cosines below 0 give the horizon's value)."""
    e, mu = np.broadcast_arrays(np.asarray(e, dtype=float), np.asarray(mu, dtype=float))
    return _bilinear(_phong_table(), e, mu)


def layer_albedo(e1, eta, c) -> np.ndarray:
    """:func:`layer_lobe_albedo` interpolated in tables built at multiples of :data:`ETA_STEP` of
    ``eta`` (``e1``, ``eta``, ``c`` broadcast together)."""
    e1, eta, c = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (e1, eta, c)))
    k = np.maximum(eta, ETA_STEP) / ETA_STEP
    k0 = k.astype(int)
    fk = k - k0
    out = np.zeros(e1.shape)
    for index in np.unique(np.concatenate([np.unique(k0), np.unique(k0) + 1])):
        sel0, sel1 = k0 == index, k0 + 1 == index
        if not (sel0.any() or sel1.any()):
            continue
        table = _layer_table(round(index * ETA_STEP, 6))
        if sel0.any():
            out[sel0] += (1.0 - fk[sel0]) * _bilinear(table, e1[sel0], c[sel0])
        if sel1.any():
            out[sel1] += fk[sel1] * _bilinear(table, e1[sel1], c[sel1])
    return out
