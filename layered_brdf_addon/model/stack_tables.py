"""A film stack's tables: its closures (:func:`.shading.stack_shade.stack_shade`) baked over the view's
cosine and the layer's thickness, in the layout every material's tables have (:mod:`.shading.tables`), so
the node group and the OSL shader read a stack of 64 films as they read one film: one image for the
reflected lobe, one for the diffuse part and the Base Shader's factor, one for the lobe's anisotropy, and
one for what passes to the base where the plan has a diffuse part.

Rows along the thickness: :data:`.table_grid.SAMPLES_PER_FRINGE` per fringe of the films that interfere
(the finest the stack's reflectance shows as the thickness scales), within
:data:`.table_grid.MAX_TABLE_BYTES`.  numpy; no bpy.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from . import ops_numpy, table_grid
from .angle_nodes import ANGLE_NODES, NodeResponse
from .ops_numpy import ShadingPoint
from .params import LayeredParams
from .plan import EffectPlan
from .shading.inputs import clamped_inputs
from .shading.lamella_shade import AZIMUTH_ROWS, GEOMETRY_IMAGES, LAMELLA_IMAGES, lamella_geometry
from .shading.surface_prelude import tilted_normal
from .shading.stack_shade import stack_shade
from .shading.tables import COS_SAMPLES, MIN_NORMAL_COS, TableLayout
from .stack_optics import (DISORDERED_SAMPLES, SPECTRUM_NM, StackResponse, coherent_optical, films_absorb,
                           lower_index)



def _place(plan: EffectPlan) -> str:
    if not plan.passes:
        return "none"
    return "own" if plan.diffuse else "shared"


def stack_rows(params: LayeredParams, plan: EffectPlan, row: TableLayout) -> int:
    """Texels along the thickness: 1 for a constant one, else :data:`.table_grid.SAMPLES_PER_FRINGE` per
    fringe of the films that interfere (the whole stack without disorder, :func:`.stack_optics.coherent_optical`:
    a fringe at the shortest wavelength per ``lambda / 2`` of their optical thickness as the scale runs over the
    layer's range), at least :data:`.table_grid.MIN_THICKNESS_SAMPLES`, within the bytes and rows a material's tables
    may have (``row``: a layout of one row)."""
    if plan.thickness == "constant":
        return 1
    scales = abs(params.d_max - params.d_min) / params.stack.total_nm
    fringes = 2.0 * coherent_optical(params.stack) * scales / table_grid.SHORTEST_NM
    wanted = max(math.ceil(table_grid.SAMPLES_PER_FRINGE * fringes) + 1, table_grid.MIN_THICKNESS_SAMPLES)
    most = min(table_grid.MAX_TABLE_BYTES // (row.images * row.image_width * 16), table_grid.MAX_THICKNESS_SAMPLES)
    return int(min(wanted, most))


# Texels along the square root of the cosine to tilted lamellae: their Bragg peak moves through a channel's band
# as that cosine changes by a few hundredths (labradorite: 64 texels left 7% of its schiller's highlights off by
# more than 2%, 128 none; docs/stacks.md).
LAMELLA_COS_SAMPLES = 128


@dataclass(frozen=True)
class LamellaLayout(TableLayout):
    """The tables of tilted lamellae (:mod:`.shading.lamella_shade`).  First their optics, one image each of
    :attr:`optics` (RGB; alpha unused) over the square root of the cosine to the lamellae and the thickness:
    what they reflect; what they pass (``passed``: where they absorb, for clear lamellae pass what they do not
    reflect, a read less); what they pass averaged over the hemisphere (``leaving``, where the plan has a
    diffuse part; every column of a row alike); then the geometry,
    :data:`.shading.lamella_shade.GEOMETRY_IMAGES`, over the view's angle from ``n0`` (linearly) and its
    azimuth from the lower normal (0..pi, the rows), the schiller's normal in the lower frame as a tilted
    boundary's tables hold it (:func:`.shading.tables.lower_frame`)."""

    leaving: bool = False
    passed: bool = True

    @property
    def optics(self) -> tuple[str, ...]:
        """The optics' images, in order (of :data:`.shading.lamella_shade.LAMELLA_IMAGES`)."""
        return tuple(name for name, kept in zip(LAMELLA_IMAGES, (True, self.passed, self.leaving)) if kept)

    def optics_image(self, name: str) -> int:
        return self.optics.index(name)

    @property
    def geometry_image(self) -> int:
        return len(self.optics)

    @property
    def images(self) -> int:
        return self.geometry_image + len(GEOMETRY_IMAGES)


def stack_layout(params: LayeredParams, plan: EffectPlan) -> TableLayout:
    """The layout of a stack's tables: the reflected lobe (every channel) where the plan is specular; tilted
    lamellae's optics (:class:`LamellaLayout`)."""
    if plan.normals == "tilted":  # the rows hold the geometry's azimuths too
        row = LamellaLayout((), LAMELLA_COS_SAMPLES, 1, leaving=plan.diffuse, passed=absorbing(params))
        return replace(row, height=max(stack_rows(params, plan, row), AZIMUTH_ROWS))
    closures = (("reflect", (0, 1, 2)),) if plan.specular else ()
    row = TableLayout(closures, COS_SAMPLES, 1, 1, (), _place(plan))
    return replace(row, height=stack_rows(params, plan, row))


def _texel_points(params: LayeredParams, plan: EffectPlan, layout: TableLayout):
    """The shading points of the texels of ``layout`` (n0 = +z), their inputs, views and thicknesses, and the
    stack's response there (a disordered stack's draws cost their films each: the optics at fewer angles,
    joined by cubics)."""
    values = table_grid.held_values(params, ShadingPoint.SOCKETS)
    n0 = np.zeros((1, layout.height, layout.width, 3))
    n0[..., 2] = 1.0
    pt = ShadingPoint(values, n0, n0, np.zeros_like(n0))
    P = clamped_inputs(pt, replace(plan, tables=False))
    v, d, _ = table_grid.texel_grid(layout.width, layout.height, float(P["d_min"]), float(P["d_max"]))
    response = StackResponse.of(params)
    if params.stack.disorder:
        response = NodeResponse(response, d[0, :, 0], ANGLE_NODES)
    return pt, P, n0, v, d, response


def stack_grid(params: LayeredParams, plan: EffectPlan, layout: TableLayout):
    """The stack's closures at the texels of ``layout`` (as :func:`.table_bake._shade_grid` gives a film's),
    what passes to the base, and no frame (the closures lie about ``n0``)."""
    pt, P, n0, v, d, response = _texel_points(params, plan, layout)
    res = stack_shade(pt, replace(plan, tables=False), P, ops_numpy.vec(n0), ops_numpy.vec(v), d, response)
    return res, (res.extras["base_weight"], res.extras["transmittance"]), None


def lamella_texels(params: LayeredParams, plan: EffectPlan, layout: LamellaLayout) -> np.ndarray:
    """Tilted lamellae's tables (float32, images x H x W x RGBA): what they reflect and pass at the texels'
    cosines to their normal (the crystal above them), and with ``layout.leaving`` their hemispherical mean."""
    pt, P, _, v, d, response = _texel_points(params, plan, layout)
    out = np.zeros((layout.images, layout.height, layout.width, 4), dtype=np.float32)
    R, T = response.colour(v[0, ..., 2], d[0])
    out[0, ..., :3] = R
    if layout.passed:
        out[layout.optics_image("passed"), ..., :3] = T
    if layout.leaving:
        out[layout.optics_image("leaving"), ..., :3] = response.hemispherical(d[0, :, 0])[1][:, None, :]
    out[layout.geometry_image:] = _lamella_geometry(pt, P, plan, layout)
    return out


def _lamella_geometry(pt, P, plan: EffectPlan, layout: LamellaLayout) -> np.ndarray:
    """The geometry's images (:data:`.shading.lamella_shade.GEOMETRY_IMAGES`) at the texels: the view at the
    angle ``pi/2 (1 - i / (W - 1))`` from ``n0 = +z`` in the xz plane, the lamellae tilted towards the azimuth
    ``phi = pi j / (H - 1)`` about ``t = (-sin phi, cos phi, 0)``, so that the lower frame is ``w = (cos phi,
    sin phi, 0)`` and ``b = -t`` (as :func:`.table_bake._shade_grid` bakes a tilted film's)."""
    v, _, phi = table_grid.texel_grid(layout.width, 1, 0.0, 0.0, layout.height)
    v, phi = v[:, 0], phi[:, 0]  # (H, W): rows the azimuths
    n0 = np.zeros_like(v)
    n0[..., 2] = 1.0
    axis, w = table_grid.azimuth_frame(phi)
    n1 = tilted_normal(pt, ops_numpy.vec(n0), ops_numpy.vec(axis), float(P["tilt"]))
    geo = lamella_geometry(pt, replace(plan, tables=False), P, ops_numpy.vec(n0), n1, ops_numpy.vec(v))
    normal = np.broadcast_to(np.asarray(geo["schiller"].normal, dtype=float), v.shape)
    z = np.maximum(normal[..., 2], MIN_NORMAL_COS)
    gloss, schiller = geo["gloss"], geo["schiller"]

    def root(alpha):
        return np.sqrt(np.clip(alpha, 0.0, 1.0))

    planes = [np.sum(normal * w, -1) / z, np.sum(normal * -axis, -1) / z, root(schiller.alpha), schiller.anisotropy,
              geo["weight"], geo["cos"], geo["out"], geo["through"],
              gloss.weight[0], root(gloss.alpha), gloss.anisotropy, 0.0]
    values = np.stack([np.broadcast_to(np.asarray(x, dtype=float), phi.shape) for x in planes], axis=-1)
    return values.reshape(layout.height, layout.width, len(GEOMETRY_IMAGES), 4).transpose(2, 0, 1, 3)


def absorbing(params: LayeredParams) -> bool:
    """Whether a film of ``params``'s stack, or its lower medium, absorbs anywhere in the visible: else the
    stack passes exactly what it does not reflect."""
    lower = lower_index(params.r2, params.k2, SPECTRUM_NM, params.lower_medium)
    return films_absorb(params.stack) or bool(np.any(np.imag(lower) > 0.0))


def stack_record(params: LayeredParams) -> dict:
    """What a stack's tables depend on besides the sockets: the stack, the lower medium by name (a named one is
    read at every wavelength, not only at the channels'), and for a disordered stack how finely each draw
    samples the band (tables baked with another sampling are baked again)."""
    record = {"stack": params.stack.to_dict(), "lower_medium": params.lower_medium}
    if params.stack.disorder:
        record["disordered_samples"] = DISORDERED_SAMPLES
    return record
