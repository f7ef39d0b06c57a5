"""Vector helpers on arrays of shape (..., 3): guarded normalise, reflect, refract, tilt."""
from __future__ import annotations

import numpy as np

from . import ops_numpy
from .shading import surface_prelude

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


def tilted_normal(n0: np.ndarray, tilt_deg, azimuth_deg=0.0, up=Z_AXIS, fallback=X_AXIS) -> np.ndarray:
    """Lower normal ``n1`` of a constant tilt: the shading program's step (SPEC conventions).

    ``n0`` rotated by ``tilt`` about the tilt axis ``normalize(cross(up, n0))`` (``fallback``
    where the cross product vanishes), the axis turned about ``n0`` by ``azimuth``.
    """
    n0 = ops_numpy.vec(n0)
    t = surface_prelude.tilt_axis_about(ops_numpy, n0, np.asarray(azimuth_deg, dtype=float),
                                        tuple(map(float, up)), tuple(map(float, fallback)))
    return np.asarray(surface_prelude.tilted_normal(ops_numpy, n0, t, np.asarray(tilt_deg, dtype=float)))


def correlated_normal(n0: np.ndarray, grad_d: np.ndarray, strength) -> np.ndarray:
    """Lower normal from the thickness gradient, ``normalize(n0 + s grad_t(d))``: the shading
    program's step.  ``grad_d`` is in nm per unit length; only its tangential part is used."""
    return np.asarray(surface_prelude.correlated_normal(ops_numpy, ops_numpy.vec(n0), ops_numpy.vec(grad_d),
                                                        np.asarray(strength, dtype=float)))
