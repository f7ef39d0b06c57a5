"""Cycles' own closures on numpy: the Beckmann (Glossy BSDF) and Phong (OSL ``phong_ramp``) lobes as
Blender's kernel evaluates them, and :func:`evaluate_closures`, what a shader's closures return for a
light (weights clamped at 0, closures Cycles drops left out, bump shadowing).  The numpy twin of the
render that the fit, the tables' self-check and the tests judge the closures by.
"""
from __future__ import annotations

import numpy as np

from .geometry import dot, safe_normalize
from .shading.energy import INV_2PI

# Lobe conversions and Cycles' own closure evaluations (Blender 5.0 kernel).
def beckmann_lambda(alpha2, cos_n):
    """Smith Lambda of Beckmann, Cycles' rational approximation."""
    cos2 = np.maximum(cos_n * cos_n, 1e-30)
    t = alpha2 * np.maximum(1.0 / cos2 - 1.0, 0.0)
    a = 1.0 / np.sqrt(np.maximum(t, 1e-30))
    lam = ((0.396 * a - 1.259) * a + 1.0) / ((2.181 * a + 3.535) * a)
    return np.where(t < 0.39, 0.0, lam)


def glossy_alphas(alpha, aniso):
    """Cycles' Glossy BSDF: ``alpha_x`` (along the tangent) and ``alpha_y`` from alpha =
    Roughness^2 and Anisotropy (clamped to +-0.99; isotropic within 1e-4 of 0), each
    saturated to [0, 1] by the closure's setup."""
    alpha = np.asarray(alpha, dtype=float)
    a = np.clip(np.asarray(aniso, dtype=float), -0.99, 0.99)
    ax = np.where(a < 0.0, alpha / (1.0 + a), alpha * (1.0 - a))
    ay = np.where(a < 0.0, alpha * (1.0 + a), alpha / (1.0 - a))
    iso = np.abs(a) <= 1e-4
    ax = np.where(iso, alpha, ax)
    ay = np.where(iso, alpha, ay)
    return np.clip(ax, 0.0, 1.0), np.clip(ay, 0.0, 1.0)


def _lambda_from(t):
    a = 1.0 / np.sqrt(np.maximum(t, 1e-30))
    lam = ((0.396 * a - 1.259) * a + 1.0) / ((2.181 * a + 3.535) * a)
    return np.where(t < 0.39, 0.0, lam)


def beckmann_eval(N, v, l, alpha, aniso=0.0, T=None):
    """Cycles' Beckmann closure (no Fresnel): ``D / (4 cosNV (1 + Lambda_V + Lambda_L))``, cosine
    included; anisotropic about the tangent ``T`` (frame as Cycles' make_orthonormals_tangent)."""
    ax, ay = glossy_alphas(alpha, aniso)
    # Isotropic closures (|anisotropy| <= 1e-4) ignore the tangent, which may be zero.
    iso = np.broadcast_to(np.abs(np.clip(np.asarray(aniso, dtype=float), -0.99, 0.99)) <= 1e-4, np.shape(N)[:-1])
    if T is None:
        T = np.broadcast_to(np.array([1.0, 0.0, 0.0]), np.shape(N))
    Y = safe_normalize(np.cross(N, np.broadcast_to(T, np.shape(N))), N)
    X = np.cross(Y, N)
    cos_nv = dot(N, v)
    cos_nl = dot(N, l)
    h = safe_normalize(v + l, N)
    hz, hx, hy = dot(h, N), dot(h, X), dot(h, Y)
    with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
        e_aniso = (hx * hx / (ax * ax) + hy * hy / (ay * ay)) / np.maximum(hz * hz, 1e-300)
        e_iso = np.maximum(1.0 - hz * hz, 0.0) / np.maximum(hz * hz * ax * ax, 1e-300)
        D = np.exp(-np.where(iso, e_iso, e_aniso)) / (np.pi * ax * ay * hz ** 4)

        def lam(w):
            wz, wx, wy = dot(w, N), dot(w, X), dot(w, Y)
            t_aniso = ((ax * wx) ** 2 + (ay * wy) ** 2) / np.maximum(wz * wz, 1e-30)
            t_iso = ax * ax * np.maximum(1.0 / np.maximum(wz * wz, 1e-30) - 1.0, 0.0)
            return _lambda_from(np.where(iso, t_iso, t_aniso))

        val = D / (4.0 * np.maximum(cos_nv, 1e-30) * (1.0 + lam(v) + lam(l)))
    val = np.where(np.isfinite(val) & (hz > 0.0), val, 0.0)
    return np.where((cos_nv > 0.0) & (cos_nl >= 0.0), val, 0.0)


def phong_ramp_eval(N, v, l, e):
    """Cycles' ``phong_ramp`` with eight equal colours: ``cosNL (e + 2)/(2 pi) cos^e(R, l)``."""
    cos_nv = dot(N, v)
    cos_nl = dot(N, l)
    r = 2.0 * cos_nv[..., None] * N - v
    c = dot(r, l)
    with np.errstate(under="ignore"):
        val = cos_nl * (e + 2.0) * INV_2PI * np.power(np.maximum(c, 0.0), e)
    return np.where((cos_nv > 0) & (cos_nl > 0) & (c > 0), val, 0.0)


def phong_peak(cos_nv, e):
    return np.maximum(cos_nv, 0.0) * (e + 2.0) * INV_2PI


def ensure_valid_specular_reflection(Ng, v, N):
    """Cycles bends a glossy closure's normal so the mirrored view stays above ``Ng``."""
    R = 2.0 * dot(N, v)[..., None] * N - v
    iz = dot(v, Ng)
    threshold = np.minimum(0.9 * iz, 0.01)
    ok = dot(Ng, R) >= threshold
    X = safe_normalize(N - dot(N, Ng)[..., None] * Ng, N)
    ix = dot(v, X)
    a = ix * ix + iz * iz
    b = 2.0 * (a + iz * threshold)
    c = (threshold + iz) ** 2
    disc = np.sqrt(np.maximum(b * b - 4.0 * a * c, 0.0))
    a_safe = np.where(a > 0, a, 1.0)
    nz2 = np.where(ix < 0, 0.25 * (b + disc) / a_safe, 0.25 * (b - disc) / a_safe)
    bent = np.sqrt(np.maximum(1.0 - nz2, 0.0))[..., None] * X + np.sqrt(np.maximum(nz2, 0.0))[..., None] * Ng
    return np.where(ok[..., None], N, bent)


CLOSURE_WEIGHT_CUTOFF = 1e-5  # Cycles drops a closure whose mean weight is below this


def _colour(value, shape) -> np.ndarray:
    """A closure's colour as an array of ``shape`` (..., 3): three channels, or a colour of the program
    (a baked table's)."""
    if isinstance(value, tuple):
        return np.stack([np.broadcast_to(x, shape[:-1]) for x in value], axis=-1)
    return np.broadcast_to(np.asarray(value, dtype=float), shape)


def evaluate_closures(result, n0, v, l, lobe_kind="beckmann", ng=None, bump_correction=True):
    """Cycles' evaluation of the closures for light ``l``: pixel per unit irradiance.

    Mirrors the kernel: weights clamped at 0, closures with a mean weight below 1e-5
    dropped, glossy normals bent by ``ensure_valid_specular_reflection`` (when
    ``bump_correction`` and ``ng`` is given), and the bump shadowing term.
    """
    n0 = np.asarray(n0, dtype=float)
    v = np.broadcast_to(np.asarray(v, dtype=float), n0.shape)
    l = np.broadcast_to(np.asarray(l, dtype=float), n0.shape)
    out = np.zeros(n0.shape[:-1] + (3,))
    for cl in result.glossy:
        w = np.maximum(_colour(cl.weight, n0.shape), 0.0)
        w = np.where((w.mean(axis=-1) >= CLOSURE_WEIGHT_CUTOFF)[..., None], w, 0.0)
        N = safe_normalize(np.asarray(cl.normal, dtype=float), n0)
        if bump_correction and ng is not None:
            N = np.where(np.all(N == ng, axis=-1, keepdims=True), N, ensure_valid_specular_reflection(ng, v, N))
        if lobe_kind == "phong":
            val = phong_ramp_eval(N, v, l, np.asarray(cl.exponent))
        else:
            T = None if cl.tangent is None else np.asarray(cl.tangent, dtype=float)
            val = beckmann_eval(N, v, l, np.asarray(cl.alpha), np.asarray(cl.anisotropy), T)
        # Bump shadowing: a closure normal on the other side of the light than n0 sees nothing.
        shadow = dot(n0, l) * dot(n0, N) * dot(N, l) < 0.0
        out += w * np.where(shadow, 0.0, val)[..., None]
    if result.diffuse is not None:
        col = _colour(result.diffuse, n0.shape)
        col = np.where((np.maximum(col, 0).mean(axis=-1) >= CLOSURE_WEIGHT_CUTOFF)[..., None], np.maximum(col, 0), 0)
        out += col * (np.maximum(dot(n0, l), 0.0) / np.pi)[..., None]
    return out
