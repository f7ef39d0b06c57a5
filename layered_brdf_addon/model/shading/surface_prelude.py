"""The surface prelude: the layer's thickness at the shading point (Blender's noise or a
height pattern) and the lower boundary's normal (parallel, tilted, or following the
thickness).
"""
from __future__ import annotations

import math

from ..params import THICKNESS_SOCKET
from ..plan import EffectPlan
from .step import shader_function

DEG = math.pi / 180.0
GRADIENT_STEP = 1.0e-3  # forward-difference step (world units) of the thickness gradient
D_LIMIT = 1.0e6  # largest thickness (nm): the range of d_min and d_max
UNLINKED_THICKNESS = -1.0  # the Thickness input's own value: nothing is linked (a link's -1 reads the same)
UNLINKED_TOLERANCE = 1.0e-4


@shader_function
def tangent_axis(ops, n0, up, fallback):
    """Tilt axis ``normalize(cross(up, n0))``; at the poles, where n0 is along ``up`` and the
    cross product vanishes (length below 1e-4), ``fallback``."""
    c = ops.cross(up, n0)
    return ops.select_vec(ops.lt(ops.length(c), 1e-4), fallback, ops.unit(c))


@shader_function
def tilt_axis_about(ops, n0, azimuth_deg, up, fallback):
    """The axis a constant tilt turns ``n0`` about: :func:`tangent_axis` turned about ``n0`` by
    ``azimuth_deg`` (Rodrigues, for an axis across ``n0``: ``t cos a + (n0 x t) sin a``).  A unit
    vector across ``n0``; ``cross(t, n0)`` is the lower normal's direction along the surface."""
    t = tangent_axis(ops, n0, up, fallback)
    a = azimuth_deg * DEG
    return t * ops.cos(a) + ops.cross(n0, t) * ops.sin(a)


@shader_function
def tilted_normal(ops, n0, t, tilt_deg):
    """Lower normal of a constant tilt: ``n0`` rotated by ``tilt_deg`` about the axis ``t``
    (:func:`tilt_axis_about`, across ``n0``): ``n0 cos(tilt) + (t x n0) sin(tilt)``.  Any tilt up to
    180 degrees is valid: at 90 or 180 degrees no path crosses the layer (eq. 11).  Unit as ``t`` is: ``n0`` and
    ``t x n0`` are orthonormal."""
    a = tilt_deg * DEG
    return n0 * ops.cos(a) + ops.cross(t, n0) * ops.sin(a)


@shader_function
def correlated_normal(ops, n0, grad_d, strength):
    """Lower normal from the thickness gradient: ``normalize(n0 + s grad_t(d))``, the
    tangential part of the gradient only; a degenerate sum falls back to ``n0``."""
    g = grad_d - n0 * ops.dot(grad_d, n0)
    return ops.normalize(n0 + g * strength, n0)


@shader_function
def thickness_factor(ops, p, scale, detail, roughness, phase, *, pattern):
    """The thickness pattern's factor at the object-space position ``p``: Blender's Noise
    Texture (4D fBm, W = phase, lacunarity 2, normalised), or ``clamp(0.5 - 0.5 z, 0, 1)``,
    a film that thickens downwards like a draining soap film."""
    if pattern == "noise":
        return ops.noise_fbm(p, phase, scale, detail, roughness)
    return ops.clamp(0.5 - 0.5 * ops.dot(p, (0.0, 0.0, 1.0)), 0.0, 1.0)


@shader_function
def thickness_at(ops, p, d_min, d_max, scale, detail, roughness, phase, *, pattern):
    """``d = d_min + (d_max - d_min) clamp(n, 0, 1)`` in nm, within [0, D_LIMIT].  With
    ``d_min > d_max`` (sockets fed by textures) the same formula holds: the pattern runs
    from ``d_min`` where the factor is 0 down to ``d_max`` where it is 1."""
    n = thickness_factor(ops, p, scale, detail, roughness, phase, pattern=pattern)
    return ops.clamp(d_min + (d_max - d_min) * ops.clamp(n, 0.0, 1.0), 0.0, D_LIMIT)


@shader_function
def thickness_gradient(ops, p, d, d_min, d_max, scale, detail, roughness, phase, *, pattern):
    """World-space gradient of the thickness ``d`` at ``p`` (nm per world unit), by forward
    differences along the world axes, each step taken into object space: component k is
    ``(d(p + M^-1 h e_k) - d(p)) / h``, which is ``(M^-T grad_obj d)_k``, the inverse
    transpose that a gradient (a covector) needs under rotation and non-uniform scale."""
    h = GRADIENT_STEP
    args = (d_min, d_max, scale, detail, roughness, phase)
    dx = thickness_at(ops, p + ops.world_to_object((h, 0.0, 0.0)), *args, pattern=pattern) - d
    dy = thickness_at(ops, p + ops.world_to_object((0.0, h, 0.0)), *args, pattern=pattern) - d
    dz = thickness_at(ops, p + ops.world_to_object((0.0, 0.0, h)), *args, pattern=pattern) - d
    return ops.combine(dx, dy, dz) * (1.0 / h)


def pattern_inputs(P):
    """The inputs of :func:`thickness_at` after the position."""
    return (P["d_min"], P["d_max"], P["noise_scale"], P["noise_detail"], P["noise_roughness"], P["noise_phase"])


@shader_function
def linked_thickness(ops, t, otherwise):
    """The Thickness input's ``t`` (nm) within [0, D_LIMIT], a NaN (a link's ``inf - inf``) and a negative
    value 0 nm, so that a texture crossing zero thins the film continuously; ``otherwise`` where ``t`` is
    the socket's own value, :data:`UNLINKED_THICKNESS`, that is where nothing is linked (a constant there,
    so Cycles folds the choice away and only ``otherwise`` is evaluated)."""
    t = ops.nan_to_zero(t)
    unlinked = ops.lt(ops.abs(t - UNLINKED_THICKNESS), UNLINKED_TOLERANCE)
    return ops.select(unlinked, otherwise, ops.clamp_input(t, 0.0, D_LIMIT))


def pattern_thickness(ops, P, p_obj, plan: EffectPlan):
    """The plan's thickness pattern (nm) at ``p_obj``, or None for a plan without one (a constant
    thickness, or a link's)."""
    if plan.thickness in ("constant", "input"):
        return None
    return thickness_at(ops, p_obj, *pattern_inputs(P), pattern=plan.thickness)


def layer_thickness(ops, P, p_obj, plan: EffectPlan, pattern=None):
    """Thickness ``d`` (nm) at the object-space position ``p_obj``: the Thickness input where it is
    linked, else the plan's pattern (``pattern``: :func:`pattern_thickness`, computed when not given).
    A plan made for a link evaluates no pattern (a group made for a link that lost it, without the
    add-on to rebuild it, renders Thickness Min); a pattern's plan still takes a link made without the
    add-on (its lower normal keeps the pattern's gradient)."""
    if plan.thickness == "constant":
        return P["d_min"]
    if plan.thickness == "input":
        return linked_thickness(ops, ops.input(THICKNESS_SOCKET), P["d_min"])
    if pattern is None:
        pattern = pattern_thickness(ops, P, p_obj, plan)
    return linked_thickness(ops, ops.input(THICKNESS_SOCKET), pattern)


def tilt_axis(ops, P, n0):
    """The axis a tilted lower boundary turns ``n0`` about at this point (:func:`tilt_axis_about`), from
    the object's axes in world space: the tilt sticks to the object.  An object flattened along its z axis (up
    zero) takes its x axis: its faces' normals lie along z, where the x axis is across them."""
    up = ops.unit(ops.object_to_world((0.0, 0.0, 1.0)))
    x_axis = ops.unit(ops.object_to_world((1.0, 0.0, 0.0)))
    return tilt_axis_about(ops, n0, P["tilt_azimuth"], up, x_axis)


def lower_normal(ops, P, n0, p_obj, d, plan: EffectPlan, pattern=None, axis=None):
    """Lower boundary normal ``n1`` (world space) at a point of upper normal ``n0``; ``d`` the
    thickness, ``pattern`` the plan's pattern there (its gradient is the pattern's own: ``d`` where
    not given); ``axis``: a tilted boundary's :func:`tilt_axis` (computed where not given)."""
    if plan.normals == "tilted":
        return tilted_normal(ops, n0, tilt_axis(ops, P, n0) if axis is None else axis, P["tilt"])
    if plan.normals == "correlated" and plan.thickness == "input":
        # The gradient of a linked thickness is the renderer's: Blender's Bump node on it.
        return ops.bump_normal(n0, d, P["bump_strength"])
    if plan.normals == "correlated" and plan.thickness != "constant":
        base = d if pattern is None else pattern
        grad = thickness_gradient(ops, p_obj, base, *pattern_inputs(P), pattern=plan.thickness)
        return correlated_normal(ops, n0, grad, P["bump_strength"])
    return n0
