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

from . import ops_numpy
from .ops_numpy import ShadingPoint
from .params import WAVELENGTHS_NM, LayeredParams, iter_sockets, socket_values
from .plan import EffectPlan
from .program import shade, tabulated_shade
from .shading.base_shader import passed_to_base
from .shading.inputs import clamped_inputs, program_inputs
from .shading.tables import (COS_SAMPLES, PARALLEL_TOLERANCE, TABLE_FORMAT, UNREAD_BY_TABLES, NotTabulable,
                             TableLayout, tabulable)
from .shading.thin_film import harmonic_count

SAMPLES_PER_FRINGE = 24  # texels along d per interference fringe of the bluest channel (measured: docs/tables.md)
MIN_THICKNESS_SAMPLES = 8
MAX_TABLE_BYTES = 1 << 20  # a material's tables, at most (float32 RGBA texels)
MAX_THICKNESS_SAMPLES = 1024
SHORTEST_NM = 400.0  # the bluest wavelength a plan evaluates (spectral modes reach below the RGB channels' 465 nm)


def thickness_samples(params: LayeredParams, plan: EffectPlan, images: int = 1) -> int:
    """Texels along the thickness: 1 for a constant one, else enough for :data:`SAMPLES_PER_FRINGE` per fringe
    (a fringe is ``lambda / (2 r1)`` of thickness at normal incidence, the shortest; the beams that bounce
    inside the layer add harmonics), at least :data:`MIN_THICKNESS_SAMPLES`, at most what keeps ``images``
    images of :data:`COS_SAMPLES` texels a row within :data:`MAX_TABLE_BYTES` (and
    :data:`MAX_THICKNESS_SAMPLES`)."""
    if plan.thickness == "constant":
        return 1
    if not plan.interference:
        return MIN_THICKNESS_SAMPLES
    fringes = 2.0 * max(params.r1) * abs(params.d_max - params.d_min) / SHORTEST_NM * harmonic_count(plan)
    most = min(MAX_TABLE_BYTES // (images * COS_SAMPLES * 16), MAX_THICKNESS_SAMPLES)
    return int(min(max(math.ceil(SAMPLES_PER_FRINGE * fringes) + 1, MIN_THICKNESS_SAMPLES), most))


def _grid(width: int, height: int, d_min, d_max):
    """View directions and thicknesses of the texels, (H, W): n0 = +z, the view in the xz plane."""
    c = np.linspace(0.0, 1.0, width) ** 2
    t = np.linspace(0.0, 1.0, height) if height > 1 else np.zeros(1)
    C, T = np.meshgrid(c, t)
    v = np.stack([np.sqrt(np.maximum(1.0 - C * C, 0.0)), np.zeros_like(C), C], axis=-1)
    return v, d_min + (d_max - d_min) * T


def held_values(params: LayeredParams, backend: str, plan: EffectPlan | None = None) -> dict:
    """The shader's input values as the sockets of ``backend`` hold them (float32): what the shader reads,
    and what reading a material's sockets back gives again.  With ``plan``, only those it reads: a layer
    given by its IOR and Dispersion does not read the three indices (derived from them, they may differ in
    their last bit once read back), one given by its three indices not the IOR and Dispersion."""
    values = socket_values({spec.name: getattr(params, spec.name) for spec in iter_sockets()}, backend)
    unread = () if plan is None else ("layer_ior", "layer_dispersion") if plan.index == "channels" else \
        ("r1_r", "r1_g", "r1_b")
    return {k: float(np.float32(v)) for k, v in values.items() if k not in unread}


def _arithmetic(plan: EffectPlan) -> EffectPlan:
    return replace(plan, tables=False)


def _shade_grid(params: LayeredParams, plan: EffectPlan, width: int, height: int):
    """The program's closures at the texels (:func:`_grid`), and the Base Shader's factor."""
    plan = _arithmetic(plan)
    values = held_values(params, ShadingPoint.SOCKETS)
    n0 = np.zeros((height, width, 3))
    n0[..., 2] = 1.0
    pt = ShadingPoint(values, n0, n0, np.zeros_like(n0))
    P = clamped_inputs(pt, plan)
    v, d = _grid(width, height, float(P["d_min"]), float(P["d_max"]))
    inputs = program_inputs(P)
    n0v, vv = ops_numpy.vec(n0), ops_numpy.vec(v)
    res = shade(pt, inputs, n0v, n0v, d, vv, plan, WAVELENGTHS_NM)
    return res, passed_to_base(pt, plan, inputs, vv, n0v), n0


def _is_zero(x) -> bool:
    return isinstance(x, float) and x == 0.0


@lru_cache(maxsize=64)
def _closures(plan: EffectPlan) -> tuple:
    """The plan's glossy closures: names and the channels each weighs (the program's structure,
    the same for every value of the parameters)."""
    res, _, _ = _shade_grid(LayeredParams(), plan, 2, 1)
    return tuple((cl.name, tuple(c for c in range(3) if not _is_zero(cl.weight[c]))) for cl in res.glossy)


def table_layout(params: LayeredParams, plan: EffectPlan) -> TableLayout:
    """The layout of ``params``'s tables for ``plan`` (NotTabulable where the plan's closures depend on more)."""
    if not tabulable(plan):
        raise NotTabulable(f"plan {plan.key}: the closures depend on more than the view and the thickness")
    closures = _closures(replace(plan, tables=False))
    images = TableLayout(closures, COS_SAMPLES, 1).images
    return TableLayout(closures, COS_SAMPLES, thickness_samples(params, plan, images))


def _plane(x, shape) -> np.ndarray:
    return np.broadcast_to(np.asarray(x, dtype=float), shape)


def bake(params: LayeredParams, plan: EffectPlan) -> tuple[TableLayout, np.ndarray]:
    """``params``'s tables for ``plan``: the layout, and the texels as float32 (images, H, W, 4)."""
    layout = table_layout(params, plan)
    res, base, n0 = _shade_grid(params, plan, layout.width, layout.height)
    shape = (layout.height, layout.width)
    out = np.zeros((layout.images, *shape, 4), dtype=np.float32)
    for k, cl in enumerate(res.glossy):
        normal = ops_numpy.components(cl.normal)
        if max(float(np.max(np.abs(_plane(a, shape) - b))) for a, b in zip(normal, (0.0, 0.0, 1.0))) > \
                PARALLEL_TOLERANCE:
            raise NotTabulable(f"closure {cl.name} does not lie about the upper normal")
        for c in range(3):
            out[k, ..., c] = _plane(cl.weight[c], shape)
        out[k, ..., 3] = np.sqrt(np.clip(_plane(cl.alpha, shape), 0.0, 1.0))
        image, channel = layout.anisotropy_slot(k)
        out[image, ..., channel] = _plane(cl.anisotropy, shape)
    if res.diffuse is not None:
        for c in range(3):
            out[layout.diffuse_image, ..., c] = _plane(res.diffuse[c], shape)
    out[layout.diffuse_image, ..., 3] = _plane(base, shape)
    return layout, out


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


def spline_coefficients(texels: np.ndarray) -> np.ndarray:
    """What the node group's images hold: for each image (images, H, W, RGBA), the cubic B-spline
    coefficients that Cubic interpolation (Cycles' and EEVEE's Image Texture) turns back into the baked
    values at the texel centres, smooth in between (float32).  Cubic rather than Linear interpolation:
    EEVEE reads Linear images through mipmaps chosen from screen-space derivatives, which a thickness
    noise makes erratic (a dotted pattern), and Cubic reads level 0 only."""
    return _prefilter(_prefilter(texels, 1), 2).astype(np.float32)


def table_digest(params: LayeredParams, plan: EffectPlan) -> str:
    """What the tables of ``params`` for ``plan`` depend on, as a short digest: the table format, the
    plan, and every value the tables hold (not the pattern's, :data:`.shading.tables.UNREAD_BY_TABLES`)."""
    values = {k: v for k, v in held_values(params, "nodes", plan).items() if k not in UNREAD_BY_TABLES}
    record = json.dumps({"format": TABLE_FORMAT, "plan": plan.key, "samples": [COS_SAMPLES, SAMPLES_PER_FRINGE],
                         "values": values}, sort_keys=True)
    return hashlib.sha1(record.encode()).hexdigest()[:16]



def tabulated_result(params: LayeredParams, plan: EffectPlan, layout: TableLayout, texels: np.ndarray, n0, v, d):
    """What the group reading these tables returns at points of upper normal ``n0``, view ``v`` and
    thickness ``d`` (numpy arrays): the program's tabulated step on numpy, reading ``texels`` (a bake's)
    as Cycles' Image Texture reads the images the group holds (:func:`spline_coefficients`,
    :func:`.ops_numpy.table_lookup`)."""
    n0 = np.asarray(n0, dtype=float)
    pt = ShadingPoint(held_values(params, ShadingPoint.SOCKETS), n0, v, np.zeros_like(n0),
                      tables=spline_coefficients(texels))
    P = clamped_inputs(pt, plan)
    return tabulated_shade(pt, replace(plan, tables=True), layout, P, pt.shading_normal(), pt.incoming(),
                           np.asarray(d, dtype=float))
