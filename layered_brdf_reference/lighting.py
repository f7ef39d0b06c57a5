"""Monte Carlo integration of the exact model under lights other than a sun.

Used to check renders lit by a uniform environment or an area light: the pixel is
``int f(l, v) L(l) <n0, l> dl`` over the hemisphere (or over the light's area).
"""
from __future__ import annotations

import numpy as np

from layered_brdf_addon.model.geometry import dot, reflect, safe_normalize
from layered_brdf_addon.model.params import WAVELENGTHS_NM, LayeredParams

from .exact_model import layered_brdf


def _frame(n):
    """Orthonormal tangents (t, b) for unit normals n (..., 3)."""
    a = np.where(np.abs(n[..., :1]) > 0.9, np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]))
    t = safe_normalize(np.cross(a, n))
    return t, np.cross(n, t)


def _phong_dirs(axis, k, u1, u2):
    cos_t = u1 ** (1.0 / (k + 1.0))
    sin_t = np.sqrt(np.maximum(1.0 - cos_t ** 2, 0.0))
    phi = 2.0 * np.pi * u2
    t, b = _frame(axis)
    return (t * (sin_t * np.cos(phi))[..., None] + b * (sin_t * np.sin(phi))[..., None]
            + axis * cos_t[..., None])


def _phong_pdf(axis, k, l):
    c = np.maximum(dot(axis, l), 0.0)
    return (k + 1.0) / (2.0 * np.pi) * c ** k


def brdf_times_cos(params: LayeredParams, n0, n1, d, v, l, wavelengths=WAVELENGTHS_NM):
    """``f(l, v) <n0, l>`` per channel for arrays of light directions ``l``."""
    cos_l = np.maximum(dot(n0, l), 0.0)
    f = layered_brdf(-l, np.broadcast_to(v, l.shape), n0, n1, d, params, ng=n0, wavelengths=wavelengths)
    return cos_l[..., None] * f


def environment_shading(params: LayeredParams, n0, n1, d, v, radiance: float = 1.0, samples: int = 2048,
                        seed: int = 0, wavelengths=WAVELENGTHS_NM, shading=None, environment=None):
    """Pixels (P, 3) under a uniform environment of ``radiance``, by Monte Carlo.

    Directions come from a mixture of cosine sampling (1/3) and a Phong lobe about the
    mirror direction (2/3, exponent half the narrower of ``e0`` and ``e1 / r1^2``, a stack's ``e0``); for
    tilted lamellae (a stack with a tilted lower normal) a third, about their schiller's direction
    (:func:`_schiller_directions`, exponent half of ``e1 / r1^2``), a third each; the estimator divides by
    the mixture density, so it is unbiased for any parameters.
    ``shading(params, n0, n1, d, l, v)`` (pixel per unit irradiance from ``l``) replaces
    the exact model, e.g. :func:`layered_brdf_reference.closures.closure_shading` for a white-furnace prediction.
    ``environment(l)``: the radiance (..., 3) arriving from the directions ``l`` (an HDRI), times
    ``radiance``; None: uniform.
    """
    rng = np.random.default_rng(seed)
    n0 = np.asarray(n0, dtype=float)
    P = n0.shape[0]
    v = np.broadcast_to(np.asarray(v, dtype=float), n0.shape)
    r_v = reflect(-v, n0)
    # A film stack has one lobe, of the top boundary (no transmitted lobe of its own exponent); tilted lamellae
    # have the top's and their schiller's, sampled each about its own direction.
    stack = getattr(params, "stack", None) is not None
    lamellae = stack and params.normal_mode == "tilted"
    narrowest = params.e0 if stack else min(params.e0, params.e1 / max(params.r1) ** 2)
    k = max(0.5 * narrowest, 1.0)
    if lamellae:
        k_s = max(0.5 * params.e1 / params.r1[1] ** 2, 1.0)
        schiller = _schiller_directions(params, n0, np.asarray(n1, dtype=float), v, r_v)
    out = np.zeros((P, 3))
    batch = max(1, min(samples, 65536 // max(P, 1)))
    done = 0
    while done < samples:
        b = min(batch, samples - done)
        rep = lambda a: np.repeat(a[None], b, axis=0).reshape((b * P,) + np.shape(a)[1:])  # noqa: E731
        N0, RV, V = rep(n0), rep(r_v), rep(np.ascontiguousarray(v))
        N1, D = rep(np.asarray(n1, dtype=float)), rep(np.broadcast_to(np.asarray(d, dtype=float), (P,)))
        u1, u2, u3 = rng.random(b * P), rng.random(b * P), rng.random(b * P)
        cos_dir = _phong_dirs(N0, 1.0, u1, u2)  # cos^1 about n0 = cosine sampling
        lobe_dir = _phong_dirs(RV, k, u1, u2)
        l = np.where((u3 < 1.0 / 3.0)[..., None], cos_dir, lobe_dir)
        pdf = _phong_pdf(N0, 1.0, l) / 3.0 + 2.0 / 3.0 * _phong_pdf(RV, k, l)
        if lamellae:
            S = rep(schiller)
            l = np.where((u3 > 2.0 / 3.0)[..., None], _phong_dirs(S, k_s, u1, u2), l)
            pdf = (_phong_pdf(N0, 1.0, l) + _phong_pdf(RV, k, l) + _phong_pdf(S, k_s, l)) / 3.0
        if shading is None:
            val = brdf_times_cos(params, N0, N1, D, V, l, wavelengths)
        else:
            val = shading(params, N0, N1, D, l, V)
        if environment is not None:
            val = val * environment(l)
        est = np.where(pdf[..., None] > 0, val / np.where(pdf > 0, pdf, 1.0)[..., None], 0.0)
        out += est.reshape(b, P, 3).sum(axis=0)
        done += b
    return radiance * out / samples


def _schiller_directions(params, n0, n1, v, r_v):
    """Where tilted lamellae send the view's light (eqs. 10, 11): ``-v`` refracted into the crystal (the
    layer's index, green's), mirrored on the lamellae (normal ``n1``) and refracted out; the top's mirror
    direction ``r_v`` where it cannot leave."""
    eta = params.r0 / params.r1[1]
    cos_v = np.clip(dot(v, n0), 0.0, 1.0)
    t = -v * eta + n0 * (eta * cos_v - np.sqrt(np.maximum(1.0 - eta * eta * (1.0 - cos_v ** 2), 0.0)))[..., None]
    r = t - 2.0 * dot(t, n1)[..., None] * n1
    cos_r = dot(r, n0)
    k = 1.0 - (1.0 - cos_r ** 2) / (eta * eta)
    out = r / eta + n0 * (np.sqrt(np.maximum(k, 0.0)) - cos_r / eta)[..., None]
    return np.where(((k > 0.0) & (cos_r > 0.0))[..., None], safe_normalize(out), r_v)


def area_light_shading(params: LayeredParams, n0, n1, d, v, points, light_matrix, size: float, power: float,
                       samples: int = 1024, seed: int = 0, wavelengths=WAVELENGTHS_NM):
    """Pixels (P, 3) lit by a square area light (Blender's: radiance ``power / (pi A)``,
    emitting along its local -Z), by stratified sampling of the light's surface."""
    rng = np.random.default_rng(seed)
    m = np.asarray(light_matrix, dtype=float)
    centre, ax, ay, az = m[:3, 3], m[:3, 0], m[:3, 1], m[:3, 2]
    area = size * size
    radiance = power / (np.pi * area)
    n0 = np.asarray(n0, dtype=float)
    P = n0.shape[0]
    v = np.broadcast_to(np.asarray(v, dtype=float), n0.shape)
    side = int(np.ceil(np.sqrt(samples)))
    out = np.zeros((P, 3))
    count = 0
    for i in range(side):
        for j in range(side):
            jit = rng.random((P, 2))
            x = ((i + jit[:, 0]) / side - 0.5) * size
            y = ((j + jit[:, 1]) / side - 0.5) * size
            q = centre + x[:, None] * ax + y[:, None] * ay
            w = q - points
            r2 = dot(w, w)
            l = w / np.sqrt(r2)[..., None]
            cos_light = np.maximum(dot(-l, -az), 0.0)  # the light emits along -Z
            val = brdf_times_cos(params, n0, n1, d, v, l, wavelengths)
            out += val * (cos_light / r2)[..., None]
            count += 1
    return radiance * area * out / count
