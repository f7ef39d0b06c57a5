"""numpy backend of the shading program: scalars (...), vectors (..., 3)."""
from __future__ import annotations

import sys

import numpy as np


def _s(x):
    return np.asarray(x, dtype=float)


def clamp(x, lo, hi):
    return np.clip(x, lo, hi)


def sqrt(x):
    return np.sqrt(np.maximum(x, 0.0))  # guarded, like Blender's Math node


def exp(x):
    with np.errstate(over="ignore", under="ignore"):
        return np.exp(np.minimum(x, 80.0))


def cos(x):
    return np.cos(x)


def sin(x):
    return np.sin(x)


def cross(a, b):
    return vec(np.cross(_plain(a), _plain(b)))


def atan2(y, x):
    return np.arctan2(y, x)


def maximum(a, b):
    return np.maximum(a, b)


def minimum(a, b):
    return np.minimum(a, b)


def lt(a, b):
    return (_s(a) < b).astype(float)


def gt(a, b):
    return (_s(a) > b).astype(float)


def select(c, a, b):
    return np.where(_s(c) > 0.5, a, b)


def select_vec(c, a, b):
    return vec(np.where((_s(c) > 0.5)[..., None], _plain(a), _plain(b)))


def _plain(a):
    return a.view(np.ndarray) if isinstance(a, np.ndarray) else np.asarray(a, dtype=float)


def dot(a, b):
    return np.einsum("...k,...k->...", _plain(a), _plain(b))


def length(a):
    return np.sqrt(dot(a, a))


def normalize(v, fallback):
    v = _plain(v)
    n2 = dot(v, v)
    ok = np.isfinite(n2) & (n2 > 1e-20)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = v / np.sqrt(np.where(ok, n2, 1.0))[..., None]
    return vec(np.where(ok[..., None], u, np.broadcast_to(_plain(fallback), np.shape(u))))


class _Vec(np.ndarray):
    """(..., 3) array whose products with per-point scalars (...) broadcast over the last axis."""

    __array_ufunc__ = None  # ndarray op _Vec defers to _Vec's reflected operators

    def _base(self):
        return self.view(np.ndarray)

    def _operand(self, other):
        if isinstance(other, _Vec):
            return other.view(np.ndarray)
        if isinstance(other, (tuple, list)):
            return np.asarray(other, dtype=float)  # a constant vector
        other = np.asarray(other, dtype=float)
        return other[..., None] if other.ndim else other  # a per-point scalar

    def __mul__(self, other):
        return vec(self._base() * self._operand(other))

    __rmul__ = __mul__

    def __truediv__(self, other):
        return vec(self._base() / self._operand(other))

    def __add__(self, other):
        return vec(self._base() + self._operand(other))

    __radd__ = __add__

    def __sub__(self, other):
        return vec(self._base() - self._operand(other))

    def __rsub__(self, other):
        return vec(self._operand(other) - self._base())

    def __neg__(self):
        return vec(-self._base())


def vec(a):
    """Wrap a (..., 3) array so ``vec * per_point_scalar`` broadcasts per point."""
    return np.asarray(a, dtype=float).view(_Vec)


def call(name, fn, inputs, **static):
    """Run a sub-program (a node backend turns it into a sub-group)."""
    args = {k: vec(v) if isinstance(v, tuple) and len(v) == 3 else v for k, v in inputs.items()}
    return fn(sys.modules[__name__], **args, **static)


def combine(x, y, z):
    """A vector from three scalars."""
    x, y, z = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float), np.asarray(z, dtype=float))
    return vec(np.stack([x, y, z], axis=-1))
