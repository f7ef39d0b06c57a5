"""numpy backend of the shading program: scalars (...), vectors (..., 3)."""
from __future__ import annotations

import contextlib
import sys

import numpy as np


def _s(x):
    return np.asarray(x, dtype=float)


def is_vector(x) -> bool:
    """A 3-vector: a direction, or a channel triple (one component per RGB channel)."""
    return isinstance(x, _Vec) or (isinstance(x, (tuple, list)) and len(x) == 3)


def _align(*xs):
    """Plain arrays that broadcast together, and whether a vector was among them: a per-point
    scalar (...) meeting a vector (..., 3) gets a trailing axis."""
    if not any(is_vector(x) for x in xs):
        return [x if isinstance(x, (int, float)) else np.asarray(x, dtype=float) for x in xs], False
    out = []
    for x in xs:
        if isinstance(x, (int, float)):
            out.append(x)
        elif is_vector(x):
            out.append(_plain(x))
        else:
            a = np.asarray(x, dtype=float)
            out.append(a[..., None] if a.ndim else a)
    return out, True


def _elementwise(fn):
    """``fn`` on aligned arguments; the result is a vector when an argument was one."""
    def apply(*xs):
        args, vector = _align(*xs)
        r = fn(*args)
        return vec(r) if vector else r

    apply.__name__ = fn.__name__
    return apply


@_elementwise
def clamp(x, lo, hi):
    return np.clip(x, lo, hi)


@_elementwise
def sqrt(x):
    return np.sqrt(np.maximum(x, 0.0))  # guarded, like Blender's Math node


@_elementwise
def exp(x):
    with np.errstate(over="ignore", under="ignore"):
        return np.exp(np.minimum(x, 80.0))


@_elementwise
def cos(x):
    return np.cos(x)


@_elementwise
def sin(x):
    return np.sin(x)


def cross(a, b):
    return vec(np.cross(_plain(a), _plain(b)))


def atan2(y, x):
    return np.arctan2(y, x)


def acos(x):
    """The angle of the cosine ``x`` clamped to [-1, 1] (guarded, like Blender's Math node)."""
    return np.arccos(np.clip(x, -1.0, 1.0))


@_elementwise
def maximum(a, b):
    return np.maximum(a, b)


@_elementwise
def minimum(a, b):
    return np.minimum(a, b)


@_elementwise
def lt(a, b):
    return (np.asarray(a) < b).astype(float)


@_elementwise
def gt(a, b):
    return (np.asarray(a) > b).astype(float)


@_elementwise
def select(c, a, b):
    return np.where(np.asarray(c) > 0.5, a, b)


def mix(a, b, t):
    """``a + (b - a) t``."""
    return a + (b - a) * t


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


def unit(v):
    """``v`` over its length, the zero vector (and a non-finite one) zero, as Blender's Normalize gives it: for a
    vector its caller knows is not degenerate, or guards itself."""
    v = _plain(v)
    n2 = dot(v, v)
    ok = np.isfinite(n2) & (n2 > 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = v / np.sqrt(np.where(ok, n2, 1.0))[..., None]
    return vec(np.where(ok[..., None], u, 0.0))


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

    def __rtruediv__(self, other):
        return vec(self._operand(other) / self._base())

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


def function(fn, values, settings):
    """Run a named step of the program (the OSL backend emits it as a function)."""
    return fn(sys.modules[__name__], *values, **settings)


def after(state, x):
    """``x`` (a backend that schedules by dependency waits for ``state``; numpy need not)."""
    return x


class NoiseUnavailable(ValueError):
    """numpy does not evaluate Blender's noise: the thickness must come from the render."""


class ShadingPoint:
    """numpy ops that also know a shading point: the material's inputs and the geometry.

    ``inputs``: parameter values by socket name (scalars or per-point arrays); ``normal``,
    ``incoming`` (towards the camera) and ``p_object``: (..., 3) arrays; ``matrix``: the
    object's 3x3 linear part (object to world), identity by default; ``normal_input``: the Normal
    socket's vector (None: unconnected, the shading normal).
    """

    SOCKETS = "osl"  # the inputs are socket values as the OSL shader's (params.socket_units)

    def __init__(self, inputs, normal, incoming, p_object, matrix=None, normal_input=None,
                 height_gradient=None, tables=None):
        self.inputs = dict(inputs)
        self.tables = tables
        self.height_gradient = height_gradient
        self.normal = vec(normal)
        self.view = vec(np.broadcast_to(np.asarray(incoming, dtype=float), np.shape(normal)))
        self.p_object = vec(p_object)
        self.matrix = np.eye(3) if matrix is None else np.asarray(matrix, dtype=float)[:3, :3]
        self.normal_input = normal_input

    def __getattr__(self, name):  # the arithmetic of the module
        return getattr(sys.modules[__name__], name)

    def function(self, fn, values, settings):
        return fn(self, *values, **settings)

    def call(self, name, fn, inputs, **static):
        args = {k: vec(v) if isinstance(v, tuple) and len(v) == 3 else v for k, v in inputs.items()}
        return fn(self, **args, **static)

    # the shading point ---------------------------------------------------------
    def stage(self, title):
        """A stage of the program (the node backend frames its nodes): nothing to do here."""
        return contextlib.nullcontext()

    def input(self, name):
        if name == "Normal":  # unconnected (None): the shading normal, where the shaders' zero vector falls back
            given = self.normal if self.normal_input is None else self.normal_input
            return vec(np.broadcast_to(np.asarray(given, dtype=float), np.shape(self.normal)))
        if name == "Thickness" and name not in self.inputs:
            return np.asarray(-1.0)  # not linked
        return np.asarray(self.inputs[name], dtype=float)

    def shading_normal(self):
        return self.normal

    def incoming(self):
        return self.view

    def object_position(self):
        return self.p_object

    def object_to_world(self, v):
        return vec(_plain(v) @ self.matrix.T)

    def world_to_object(self, v):
        return vec(_plain(v) @ np.linalg.inv(self.matrix).T)

    def noise_fbm(self, p, w, scale, detail, roughness):
        raise NoiseUnavailable("numpy does not evaluate Blender's noise: pass the render's thickness "
                               "(and lower normal) passes")

    def table(self, k, xy):
        """Image ``k`` of the material's baked tables (``tables``: images, H, W, RGBA) at image coordinates
        ``xy``: its colour and alpha (:func:`table_lookup`)."""
        x, y, _ = components(xy)
        texel = table_lookup(self.tables, k, x, y)
        return vec(texel[..., :3]), texel[..., 3]

    def bump_normal(self, n, height, distance):
        """``normalize(n + distance grad_t(height))``, the tangential part of the height's gradient:
        what Blender's Bump node (inverted) gives; the gradient is ``height_gradient`` (world space),
        given with the points, for numpy differentiates nothing."""
        if self.height_gradient is None:
            raise NoiseUnavailable("numpy needs the gradient of a linked thickness (height_gradient)")
        g = vec(np.broadcast_to(np.asarray(self.height_gradient, dtype=float), np.shape(n)))
        g = g - n * dot(g, n)
        return normalize(n + g * distance, n)


def _bspline_weights(t):
    """The four cubic B-spline weights of offset ``t`` (0..1) from the texel before, as Cycles and EEVEE
    weigh texels ``i - 1 .. i + 2`` for Cubic interpolation."""
    t2, t3 = t * t, t * t * t
    return ((-t3 + 3.0 * t2 - 3.0 * t + 1.0) / 6.0, (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
            (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0, t3 / 6.0)


def table_lookup(tables: np.ndarray, k: int, x, y):
    """Image ``k`` of ``tables`` at image coordinates ``x``, ``y`` (0..1), as Cycles' Image Texture (and
    EEVEE's) reads it with Cubic interpolation and extended edges: a cubic B-spline over the texels,
    texel centres at ``(i + 0.5) / W``, indices clamped to the image.  The tables hold the spline's
    coefficients (:func:`..table_bake.spline_coefficients`), so the lookup returns the baked values at
    texel centres."""
    _, h, w, _ = tables.shape
    img = tables[k].astype(float)

    def axis(u, n):
        p = np.asarray(u, dtype=float) * n - 0.5
        i0 = np.floor(p)
        weights = _bspline_weights(p - i0)
        i0 = i0.astype(int)
        return [(np.clip(i0 + o, 0, n - 1), wt) for o, wt in zip((-1, 0, 1, 2), weights)]

    xs, ys = axis(x, w), axis(y, h)
    out = 0.0
    for yi, wy in ys:
        row = 0.0
        for xi, wx in xs:
            row = row + img[yi, xi] * np.asarray(wx)[..., None]
        out = out + row * np.asarray(wy)[..., None]
    return out


def named(hint, x):
    """``x`` (the OSL backend names its temporary ``hint``)."""
    return x


def madd(a, b, c):
    """``a * b + c`` (a node backend makes it one Multiply Add node)."""
    return a * b + c


@_elementwise
def power(x, p):
    """``x ** p`` for ``x > 0``."""
    return np.power(x, p)


def footprint(x):
    """How much ``x`` changes across the pixel: unknown here (no derivatives), ``None``."""
    return None


@_elementwise
def clamp_input(x, lo, hi):
    """An input clamped to its parameter's range; NaN gives ``lo``."""
    return np.where(np.isnan(x), lo, np.clip(x, lo, hi))


@_elementwise
def nan_to_zero(x):
    return np.where(np.isnan(x), 0.0, x)



def closure_normal(v, fallback):
    """A closure's normal, unit (the renderer's BSDFs normalise theirs)."""
    return normalize(v, fallback)


def components(v):
    v = _plain(v)
    return v[..., 0], v[..., 1], v[..., 2]


@_elementwise
def abs(x):  # noqa: A001 - the ops interface's name
    return np.abs(x)


@_elementwise
def floor(x):
    return np.floor(x)


@_elementwise
def sign(x):
    return np.sign(x)


def triple(x, y, z):
    """A constant channel triple."""
    return vec(np.array([x, y, z], dtype=float))
