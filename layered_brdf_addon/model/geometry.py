"""Vector helpers on arrays of shape (..., 3): guarded normalise, reflect, refract, tilt."""
from __future__ import annotations

import numpy as np

Z_AXIS = np.array([0.0, 0.0, 1.0])
X_AXIS = np.array([1.0, 0.0, 0.0])


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot product over the last axis (no trailing axis kept)."""
    return np.einsum("...k,...k->...", a, b)


def safe_normalize(v: np.ndarray, fallback=Z_AXIS) -> np.ndarray:
    """Unit vectors; zero-length or non-finite vectors become ``fallback`` (broadcast)."""
    v = np.asarray(v, dtype=float)
    n2 = dot(v, v)
    ok = np.isfinite(n2) & (n2 > 1e-24)
    with np.errstate(invalid="ignore", divide="ignore"):
        out = v / np.sqrt(np.where(ok, n2, 1.0))[..., None]
    fb = np.broadcast_to(np.asarray(fallback, dtype=float), out.shape)
    if np.all(ok):
        return out
    fb = safe_normalize(fb) if fb is not Z_AXIS else fb
    return np.where(ok[..., None], out, fb)


def reflect(v: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Mirror ``v`` about the plane of normal ``n``: ``v - 2 <v, n> n``."""
    return v - 2.0 * dot(v, n)[..., None] * n


def refract(v: np.ndarray, n: np.ndarray, eta) -> tuple[np.ndarray, np.ndarray]:
    """Refract ``v`` (pointing towards the boundary) through the boundary of normal ``n``.

    ``n`` points to the side ``v`` comes from (``<v, n> < 0``); ``eta`` is the ratio of
    indices ``n_from / n_to``.  Returns ``(t, valid)``: ``valid`` is False where ``v``
    does not reach the boundary from ``n``'s side or where total internal reflection
    happens; ``t`` is then zero.
    """
    eta = np.asarray(eta, dtype=float)
    cosi = -dot(v, n)
    k = 1.0 - eta * eta * (1.0 - cosi * cosi)
    valid = (cosi > 0.0) & (k >= 0.0)
    sq = np.sqrt(np.maximum(k, 0.0))
    t = eta[..., None] * v + (eta * cosi - sq)[..., None] * n
    return np.where(valid[..., None], t, 0.0), valid


def tangent_axis(n0: np.ndarray, up=Z_AXIS, fallback=X_AXIS) -> np.ndarray:
    """Tilt axis ``normalize(cross(up, n0))``; ``fallback`` where ``|cross| < 1e-4`` (SPEC)."""
    c = np.cross(np.broadcast_to(up, np.shape(n0)), n0)
    length = np.sqrt(dot(c, c))
    ok = length >= 1e-4
    t = c / np.where(ok, length, 1.0)[..., None]
    return np.where(ok[..., None], t, np.broadcast_to(fallback, np.shape(t)))


def rotate_about(v: np.ndarray, axis: np.ndarray, angle) -> np.ndarray:
    """Rotate ``v`` about the unit ``axis`` by ``angle`` radians (Rodrigues)."""
    c = np.cos(angle)
    s = np.sin(angle)
    c = np.asarray(c)[..., None] if np.ndim(c) else c
    s = np.asarray(s)[..., None] if np.ndim(s) else s
    return v * c + np.cross(axis, v) * s + axis * dot(axis, v)[..., None] * (1.0 - c)


def tilted_normal(n0: np.ndarray, tilt_deg, azimuth_deg=0.0, up=Z_AXIS, fallback=X_AXIS) -> np.ndarray:
    """Lower normal ``n1``: ``n0`` rotated by ``tilt`` about the tilt axis (SPEC conventions).

    The axis is ``normalize(cross(up, n0))`` (``fallback`` where the cross product
    vanishes), turned about ``n0`` by ``azimuth``.
    """
    t = tangent_axis(n0, up, fallback)
    t = rotate_about(t, n0, np.radians(azimuth_deg))
    return safe_normalize(rotate_about(n0, t, np.radians(tilt_deg)), n0)


def correlated_normal(n0: np.ndarray, grad_d: np.ndarray, strength) -> np.ndarray:
    """Lower normal from the thickness gradient: ``normalize(n0 + s * grad_t(d))``.

    ``grad_d`` is in nm per object unit; only its tangential part is used.
    """
    g = grad_d - dot(grad_d, n0)[..., None] * n0
    return safe_normalize(n0 + np.asarray(strength)[..., None] * g if np.ndim(strength) else n0 + strength * g, n0)


def finite_difference_gradient(f, p: np.ndarray, step: float) -> np.ndarray:
    """Forward-difference gradient of the scalar field ``f`` at ``p`` (the shaders' scheme)."""
    f0 = f(p)
    g = np.empty(np.shape(p), dtype=float)
    for k in range(3):
        dp = np.zeros(3)
        dp[k] = step
        g[..., k] = (f(p + dp) - f0) / step
    return g
