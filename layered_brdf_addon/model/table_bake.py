"""Baking a material's tables (:mod:`.shading.tables`): the shading program run on numpy over a grid of
view cosines and thicknesses, its closures written texel by texel.

``bake(params, plan)`` returns the layout and the images as one float32 array (images, H, W, RGBA);
``table_digest`` names what a bake depends on, so that a table is rebaked exactly when it would change.
"""
from __future__ import annotations

import hashlib
import json
import math
from dataclasses import replace
from functools import lru_cache

import numpy as np

from . import ops_numpy, stack_tables
from .table_grid import (MAX_TABLE_BYTES, MAX_THICKNESS_SAMPLES, MIN_THICKNESS_SAMPLES, SAMPLES_PER_FRINGE,
                         SAMPLES_PER_HARMONIC_FRINGE, SHORTEST_NM, azimuth_frame, held_values, texel_grid as _grid)
from .ops_numpy import ShadingPoint
from .params import WAVELENGTHS_NM, LayeredParams
from .plan import EffectPlan
from .program import shade, tabulated_lamellae, tabulated_shade
from .shading.base_shader import base_receives_light, passed_to_base
from .shading.inputs import clamped_inputs, program_inputs
from .shading.surface_prelude import tilted_normal
from .shading.tables import (ANGLE_SAMPLES, AZIMUTH_SAMPLES, COS_SAMPLES, MIN_NORMAL_COS, PARALLEL_TOLERANCE,
                             TABLE_FORMAT, NotTabulable, TableLayout, tabulable, unread_by_tables)
from .shading.thin_film import harmonic_count

def _fringe_samples(params: LayeredParams, plan: EffectPlan) -> int:
    """Texels along the thickness that its interference needs: :data:`SAMPLES_PER_FRINGE` per fringe (a
    fringe is ``lambda / (2 r1)`` of thickness at normal incidence, the shortest), and
    :data:`SAMPLES_PER_HARMONIC_FRINGE` per fringe of the highest harmonic of the beams that bounce inside
    the layer, at least :data:`MIN_THICKNESS_SAMPLES`."""
    if not plan.interference:
        return MIN_THICKNESS_SAMPLES
    fringes = 2.0 * max(params.r1) * abs(params.d_max - params.d_min) / SHORTEST_NM
    per_fringe = max(SAMPLES_PER_FRINGE, SAMPLES_PER_HARMONIC_FRINGE * harmonic_count(plan))
    return max(math.ceil(per_fringe * fringes) + 1, MIN_THICKNESS_SAMPLES)


def thickness_samples(params: LayeredParams, plan: EffectPlan, row: TableLayout) -> int:
    """Texels along the thickness: 1 for a constant one, else what its interference needs
    (:func:`_fringe_samples`), at most what keeps the images of ``row`` (a layout of one row) within
    :data:`MAX_TABLE_BYTES` (and :data:`MAX_THICKNESS_SAMPLES`)."""
    if plan.thickness == "constant":
        return 1
    most = min(MAX_TABLE_BYTES // (row.images * row.image_width * 16), MAX_THICKNESS_SAMPLES)
    return int(min(_fringe_samples(params, plan), most))


def _arithmetic(plan: EffectPlan) -> EffectPlan:
    return replace(plan, tables=False)


def _shade_grid(params: LayeredParams, plan: EffectPlan, width: int, height: int, azimuths: int = 1):
    """The program's closures at the texels (:func:`_grid`, shape (A, H, W)), the Base Shader's factor, and
    the frame a tilted boundary's closure normals are baked in (:func:`.shading.tables.lower_frame`: ``w``,
    ``b``, ``n0``); its lower normal is ``n0`` tilted by the material's tilt towards each texel's azimuth,
    about the axis ``t = (-sin phi, cos phi, 0)``, so that ``w = t x n0 = (cos phi, sin phi, 0)`` and, the
    view lying on the side of ``-t``, ``b = -t``."""
    plan = _arithmetic(plan)
    values = held_values(params, ShadingPoint.SOCKETS)
    n0 = np.zeros((azimuths, height, width, 3))
    n0[..., 2] = 1.0
    pt = ShadingPoint(values, n0, n0, np.zeros_like(n0))
    P = clamped_inputs(pt, plan)
    v, d, phi = _grid(width, height, float(P["d_min"]), float(P["d_max"]), azimuths)
    inputs = program_inputs(P)
    n0v, vv = ops_numpy.vec(n0), ops_numpy.vec(v)
    n1v = n0v
    axis, w = azimuth_frame(phi)
    frame = (w, -axis, n0)
    if plan.normals == "tilted":
        n1v = tilted_normal(pt, n0v, ops_numpy.vec(axis), float(P["tilt"]))
    res = shade(pt, inputs, n0v, n1v, d, vv, plan, WAVELENGTHS_NM)
    return res, passed_to_base(pt, plan, inputs, vv, n0v, res.extras.get("reflected")), frame


def _is_zero(x) -> bool:
    return isinstance(x, float) and x == 0.0


PROBE_TILT = 10.0  # degrees: the tilt at which a plan's closures are probed for normals off n0


@lru_cache(maxsize=64)
def _closures(plan: EffectPlan) -> tuple:
    """The plan's glossy closures: names and the channels each weighs, and which of them do not lie about
    the upper normal (the program's structure, the same for every value of the parameters)."""
    probe = LayeredParams(tilt=PROBE_TILT) if plan.normals == "tilted" else LayeredParams()
    res, _, _ = _shade_grid(probe, plan, 4, 1, AZIMUTH_SAMPLES if plan.normals == "tilted" else 1)
    closures = tuple((cl.name, tuple(c for c in range(3) if not _is_zero(cl.weight[c]))) for cl in res.glossy)
    oriented = tuple(k for k, cl in enumerate(res.glossy) if _off_normal(cl.normal) > PARALLEL_TOLERANCE)
    return closures, oriented


def _off_normal(normal) -> float:
    """How far a baked closure normal lies from ``n0 = +z``, at most."""
    return max(float(np.max(np.abs(np.asarray(a, dtype=float) - b)))
               for a, b in zip(ops_numpy.components(normal), (0.0, 0.0, 1.0)))


def table_layout(params: LayeredParams, plan: EffectPlan) -> TableLayout:
    """The layout of ``params``'s tables for ``plan`` (NotTabulable where the plan's closures depend on more,
    or a tilted boundary's slices would need more than :data:`MAX_TABLE_BYTES`)."""
    if plan.stack:
        return stack_tables.stack_layout(params, plan)
    if not tabulable(plan):
        raise NotTabulable(f"plan {plan.key}: the closures depend on more than the view and the thickness")
    closures, oriented = _closures(replace(plan, tables=False))
    azimuths = AZIMUTH_SAMPLES if plan.normals == "tilted" else 1
    width = ANGLE_SAMPLES if azimuths > 1 else COS_SAMPLES
    place = _transmittance_place(plan)
    height = thickness_samples(params, plan, TableLayout(closures, width, 1, azimuths, oriented, place))
    needed = 1 if plan.thickness == "constant" else _fringe_samples(params, plan)
    if azimuths > 1 and needed > height:
        raise NotTabulable(f"plan {plan.key}: a tilted boundary's tables for {needed} thickness rows would exceed "
                           f"{MAX_TABLE_BYTES} bytes")
    return TableLayout(closures, width, height, azimuths, oriented, place)


def _transmittance_place(plan: EffectPlan) -> str:
    """Where the tables hold what passes to the base per channel (:class:`TableLayout`)."""
    if not base_receives_light(plan):
        return "none"
    if plan.optics != "physical":
        return "computed"  # 1 - F(v) per channel, cheaper than a read
    return "own" if plan.diffuse else "shared"


def fits(params: LayeredParams, plan: EffectPlan) -> bool:
    """Whether ``params``'s tables for ``plan`` can be baked (:func:`table_layout` does not refuse them)."""
    try:
        table_layout(params, plan)
    except NotTabulable:
        return False
    return True


def _plane(x, shape) -> np.ndarray:
    return np.broadcast_to(np.asarray(x, dtype=float), shape)


def bake(params: LayeredParams, plan: EffectPlan) -> tuple[TableLayout, np.ndarray]:
    """``params``'s tables for ``plan``: the layout, and the texels as float32 (images, H, image_width, 4),
    a tilted boundary's azimuth slices side by side, each with its edge columns repeated."""
    layout = table_layout(params, plan)
    if plan.stack and plan.normals == "tilted":
        return layout, stack_tables.lamella_texels(params, plan, layout)
    if plan.stack:
        res, (base, transmittance), frame = stack_tables.stack_grid(params, plan, layout)
    else:
        res, (base, transmittance), frame = _shade_grid(params, plan, layout.width, layout.height, layout.azimuths)
    shape = (layout.azimuths, layout.height, layout.width)
    out = np.zeros((layout.images, *shape, 4), dtype=np.float32)

    def put(k, what, x):
        image, channel = layout.slot(k, what)
        out[image, ..., channel] = _plane(x, shape)

    for k, cl in enumerate(res.glossy):
        if k in layout.oriented:
            normal = np.stack([_plane(a, shape) for a in ops_numpy.components(cl.normal)], axis=-1)
            w, b, z = (np.einsum("...k,...k->...", normal, axis) for axis in frame)
            z = np.maximum(z, MIN_NORMAL_COS)
            put(k, "normal_x", w / z)
            put(k, "normal_y", b / z)
        elif _off_normal(cl.normal) > PARALLEL_TOLERANCE:
            raise NotTabulable(f"closure {cl.name} does not lie about the upper normal")
        roughness = np.sqrt(np.clip(_plane(cl.alpha, shape), 0.0, 1.0))
        if layout.has_image(k):
            image = layout.closure_image(k)
            for c in range(3):
                out[image, ..., c] = _plane(cl.weight[c], shape)
            out[image, ..., 3] = roughness
        else:
            for channel in layout.closures[k][1]:  # its one channel (none: a weight of zero)
                put(k, "weight", cl.weight[channel])
            put(k, "roughness", roughness)
        put(k, "anisotropy", cl.anisotropy)
    if res.diffuse is not None:
        for c in range(3):
            out[layout.diffuse_image, ..., c] = _plane(res.diffuse[c], shape)
    out[layout.diffuse_image, ..., 3] = _plane(base, shape)
    if layout.transmittance in ("shared", "own"):
        for c, x in enumerate(ops_numpy.components(transmittance)):
            out[layout.transmittance_image, ..., c] = _plane(x, shape)
    return layout, _stack_slices(out, layout)


def _stack_slices(texels: np.ndarray, layout: TableLayout) -> np.ndarray:
    """(images, A, H, W, 4) as the images hold them: (images, H, W, 4), or with slices side by side, each
    slice's columns with the first and last repeated, (images, H, A (W + 2), 4)."""
    if layout.sliced:
        texels = np.concatenate([texels[..., :1, :], texels, texels[..., -1:, :]], axis=3)
    n = texels.shape[0]
    return np.ascontiguousarray(np.moveaxis(texels, 1, 2).reshape(n, layout.height, layout.image_width, 4))


def _unstack_slices(texels: np.ndarray, layout: TableLayout) -> np.ndarray:
    """The slices of images (images, H, A (W + 2), 4) without their repeated columns: (images, A, H, W, 4)."""
    n = texels.shape[0]
    blocks = texels.reshape(n, layout.height, layout.azimuths, layout.block_width, 4)[..., 1:-1, :]
    return np.moveaxis(blocks, 2, 1)


def _prefilter(values: np.ndarray, axis: int) -> np.ndarray:
    """Cubic B-spline coefficients along ``axis`` whose spline passes through ``values`` at the texel
    centres, with the edges extended (clamped indices): ``(c[i-1] + 4 c[i] + c[i+1]) / 6 = values[i]``,
    ``c[-1] = c[0]`` and ``c[n] = c[n-1]``; a tridiagonal system, solved by elimination (Thomas)."""
    a = np.moveaxis(np.asarray(values, dtype=np.float64), axis, 0).copy()
    n = a.shape[0]
    if n == 1:
        return np.moveaxis(a, 0, axis)
    diag = np.full(n, 4.0 / 6.0)
    diag[0] = diag[-1] = 5.0 / 6.0
    off = 1.0 / 6.0
    d = diag.copy()
    for i in range(1, n):  # forward elimination
        m = off / d[i - 1]
        d[i] -= m * off
        a[i] -= m * a[i - 1]
    a[-1] /= d[-1]
    for i in range(n - 2, -1, -1):  # back substitution
        a[i] = (a[i] - off * a[i + 1]) / d[i]
    return np.moveaxis(a, 0, axis)


def spline_coefficients(texels: np.ndarray, layout: TableLayout | None = None) -> np.ndarray:
    """What the node group's images hold: for each image (images, H, W, RGBA), the cubic B-spline
    coefficients that Cubic interpolation (Cycles' and EEVEE's Image Texture) turns back into the baked
    values at the texel centres, smooth in between (float32).  Cubic rather than Linear interpolation:
    EEVEE reads Linear images through mipmaps chosen from screen-space derivatives, which a thickness
    noise makes erratic (a dotted pattern), and Cubic reads level 0 only.  With a sliced ``layout``
    (:class:`TableLayout`), each slice is a spline of its own, its repeated edge columns the coefficients at
    its edges (what a clamped index reads)."""
    if layout is None or not layout.sliced:
        return _prefilter(_prefilter(texels, 1), 2).astype(np.float32)
    coefficients = _prefilter(_prefilter(_unstack_slices(texels, layout), 2), 3)
    return _stack_slices(coefficients, layout).astype(np.float32)


def table_digest(params: LayeredParams, plan: EffectPlan) -> str:
    """What the tables of ``params`` for ``plan`` depend on, as a short digest: the table format, the
    plan, and every value the tables hold (not the pattern's, :func:`.shading.tables.unread_by_tables`)."""
    unread = unread_by_tables(plan.normals)
    values = {k: v for k, v in held_values(params, "nodes", plan).items() if k not in unread}
    samples = [COS_SAMPLES, SAMPLES_PER_FRINGE] + \
        ([AZIMUTH_SAMPLES, ANGLE_SAMPLES] if plan.normals == "tilted" else [])
    record = {"format": TABLE_FORMAT, "plan": plan.key, "samples": samples, "values": values}
    if plan.stack:
        record.update(stack_tables.stack_record(params))
    record = json.dumps(record, sort_keys=True)
    return hashlib.sha1(record.encode()).hexdigest()[:16]



def tabulated_result(params: LayeredParams, plan: EffectPlan, layout: TableLayout, texels: np.ndarray, n0, v, d,
                     axis=None):
    """What the group reading these tables returns at points of upper normal ``n0``, view ``v``, thickness
    ``d`` and tilt axis ``axis`` (numpy arrays; ``axis`` where the layout is sliced or the plan's lamellae are
    tilted: unit, across ``n0``,
    :func:`.shading.surface_prelude.tilt_axis`): the program's tabulated
    step on numpy, reading ``texels`` (a bake's) as Cycles' Image Texture reads the images the group holds
    (:func:`spline_coefficients`, :func:`.ops_numpy.table_lookup`)."""
    n0 = np.asarray(n0, dtype=float)
    pt = ShadingPoint(held_values(params, ShadingPoint.SOCKETS), n0, v, np.zeros_like(n0),
                      tables=spline_coefficients(texels, layout))
    P = clamped_inputs(pt, plan)
    t = None if axis is None else ops_numpy.vec(np.asarray(axis, dtype=float))
    if plan.stack and plan.normals == "tilted":
        return tabulated_lamellae(pt, replace(plan, tables=True), layout, P, pt.shading_normal(), pt.incoming(),
                                  np.asarray(d, dtype=float), t)
    return tabulated_shade(pt, replace(plan, tables=True), layout, P, pt.shading_normal(), pt.incoming(),
                           np.asarray(d, dtype=float), t)
