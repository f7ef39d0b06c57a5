"""The closures read from tables baked for a material's values, instead of computed per point.

Where the lower boundary is parallel to the upper one, every closure of the program lies about
``n0`` with its tangent across the plane of ``n0`` and the view, and its weights, width and
anisotropy depend on the material's values (constants) and on two per-point scalars only: the
view's cosine to ``n0`` and the thickness ``d``.  A material whose values are constants can
therefore have them baked (:mod:`..table_bake`, by this same program run on numpy) into small
float images over ``(cos_v, d)``, which the shader reads with one Image Texture node each
(cubic B-spline interpolation of prefiltered coefficients, extended at the edges), whatever the
accuracy mode or optics.

The images (:class:`TableLayout`): one per glossy closure that weighs more than one channel
(colour: its weight per channel; alpha: the Glossy BSDF's Roughness, ``sqrt(alpha)``), one for the
diffuse colour and the Base Shader's factor, and the closures' other values four to an image (the
anisotropies, and a dispersive plan's one-channel closures' weights and roughnesses: a read less
for each four values).  Texel ``(i, j)`` holds the
values at ``cos_v = (i / (W - 1))^2`` (denser towards grazing views) and ``d = d_min + (d_max -
d_min) j / (H - 1)``; a lookup puts ``cos_v = 0`` and ``1`` on the first and last texels' centres.

A tilted lower boundary (a constant tilt ``tau``) adds a third per-point scalar: the azimuth ``phi`` of
the view about ``n0``, from the lower normal.  Its transmitted closures no longer lie about ``n0``, so
their normals are baked too, in the lower normal's frame (``w = t x n0``, the lower normal's direction
along the surface, ``t`` the tilt axis, and ``n0``): the shader has ``t`` from the tilt itself, so the
frame costs no normalisation.  A normal is held as its components along ``w`` and ``t`` over its component
along ``n0`` (where the tangent plane meets it), two values, and ``n0 + x w + y t`` is left to the BSDF to
normalise.  The plane of ``n0`` and ``w`` is a mirror of the geometry, so ``phi`` runs
over ``[0, pi]`` (:data:`AZIMUTH_SAMPLES` slices), and a view on the other side reads its slice with
``t``'s component turned over.  Near normal view these closures turn with the view about ``n0``, so a
slice's texels run along the view's angle ``theta_v`` (texel ``i`` at ``theta_v = pi/2 (1 - i / (W - 1))``),
not its cosine.  The slices lie side by side in each image, each a block of the ``W`` columns with one
column repeated at either edge (so that Cubic interpolation, which reads a texel beyond its position,
stays within the slice); the shader reads the two slices about ``phi`` and mixes them linearly.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ..plan import EffectPlan
from .base_shader import base_receives_light, top_transmittance
from .closures import Closure, ShadingResult
from .inputs import program_inputs

TABLE_FORMAT = 6  # what a texel holds (this module's layout; 2: cubic B-spline coefficients in the node group's
# images; 3: one-channel closures' values packed; 4: a tilted boundary's closure normals in the lower normal's
# frame; 5: energy-keeping lobes, and what passes to the base per channel; 6: clear lamellae without an image of
# what they pass); baked tables of another format are rebaked
COS_SAMPLES = 64  # texels along the square root of the view's cosine (measured: docs/tables.md)
# A tilted boundary's tables (measured: docs/tables.md#a-tilted-boundary): slices over the view's azimuth
# about n0 from the lower normal (0..pi), and texels along the view's angle in each.
AZIMUTH_SAMPLES = 25
ANGLE_SAMPLES = 32
PARALLEL_TOLERANCE = 1.0e-5  # a baked closure's normal may differ from n0 by this (rounding)
MIN_NORMAL_COS = 1.0e-3  # a baked closure normal's component along n0, at least (its others are over it)


#: Values a tabulable plan reads before or besides its tables, never in them: the pattern's (they decide
#: where the thickness falls within [d_min, d_max], the tables' axis) and the lower boundary's direction
#: (parallel to the upper one).  Animating them (a noise phase that makes a film flow) keeps the tables,
#: and changing them bakes nothing.
UNREAD_BY_TABLES = frozenset({"noise_scale", "noise_detail", "noise_roughness", "noise_phase", "tilt",
                              "tilt_azimuth", "bump_strength"})


def unread_by_tables(normals: str) -> frozenset:
    """:data:`UNREAD_BY_TABLES` for a lower boundary of mode ``normals``: a tilted boundary's tables hold
    its tilt (not the tilt's azimuth, which turns the lower normal about ``n0`` point by point)."""
    return UNREAD_BY_TABLES - {"tilt"} if normals == "tilted" else UNREAD_BY_TABLES


class NotTabulable(ValueError):
    """The plan's closures depend on more than the view's cosine and the thickness."""


def tabulable(plan: EffectPlan, backend: str = "nodes") -> bool:
    """Whether the closures of ``plan`` can be baked: a lower boundary parallel (every closure about
    ``n0``) or, in the node group, tilted by a constant angle (the closures' normals baked too); a
    thickness from the material's pattern or a constant (a linked thickness has no known range);
    Beckmann lobes (the node group's).  The OSL shader reads tables of parallel boundaries only, and a
    stack's tilted lamellae (their tables are not sliced: :mod:`.lamella_shade`)."""
    normals = ("parallel", "tilted") if backend == "nodes" or plan.stack else ("parallel",)
    return plan.normals in normals and plan.thickness in ("noise", "height", "constant") and \
        plan.lobe == "beckmann"


@dataclass(frozen=True)
class TableLayout:
    """Which images a plan's tables have and what each texel holds.

    ``closures``: the glossy closures' names, in the program's order, each with the channels
    its weight has (a dispersive plan's per-channel closures weigh one channel);
    ``width``, ``height``: texels along ``cos_v`` and ``d`` (1 for a constant thickness);
    ``azimuths``: slices over the lower normal's azimuth (1: parallel boundaries, no slices);
    ``oriented``: the closures whose normals are baked (those that do not lie about ``n0``).

    A closure that weighs two or three channels has an image of its own (colour: the weight, alpha:
    the roughness); every other value of the closures (a one-channel closure's weight and roughness,
    each closure's anisotropy, an oriented closure's normal) is packed, closure after closure, four to
    an image, in the images after the diffuse one (:meth:`slot`)."""

    closures: tuple[tuple[str, tuple[int, ...]], ...]
    width: int
    height: int
    azimuths: int = 1
    oriented: tuple[int, ...] = ()
    transmittance: str = "none"  # what passes to the base per channel: "none", "computed" (per point, the
    # paper's 1 - F(v)), "shared" (in the diffuse image's colour, where the plan has no diffuse part) or "own"
    # (an image of its own, the last)

    def has_image(self, k: int) -> bool:
        """Whether closure ``k`` has an image of its own (it weighs more than one channel)."""
        return len(self.closures[k][1]) > 1

    @property
    def closure_images(self) -> int:
        return sum(1 for k in range(len(self.closures)) if self.has_image(k))

    @property
    def packed_values(self) -> tuple[tuple[int, str], ...]:
        """The values packed four to an image, in order: ``(closure, what)``, ``what`` one of "weight",
        "roughness" (one-channel closures), "anisotropy", "normal_x", "normal_y" (oriented: the normal's
        components along ``w`` and ``b`` over its component along ``n0``, :func:`lower_frame`)."""
        out = []
        for k in range(len(self.closures)):
            if not self.has_image(k):
                out += [(k, "weight"), (k, "roughness")]
            out.append((k, "anisotropy"))
            if k in self.oriented:
                out += [(k, "normal_x"), (k, "normal_y")]
        return tuple(out)

    @property
    def packed_images(self) -> int:
        return (len(self.packed_values) + 3) // 4

    @property
    def images(self) -> int:
        """Images in all: the closures' own, the diffuse colour's (with the Base Shader's factor), the
        packed values', and the transmittance's where it has one of its own."""
        return self.closure_images + 1 + self.packed_images + (self.transmittance == "own")

    @property
    def transmittance_image(self) -> int:
        """The image whose colour is what passes to the base per channel."""
        return self.images - 1 if self.transmittance == "own" else self.diffuse_image

    @property
    def diffuse_image(self) -> int:
        return self.closure_images

    def closure_image(self, k: int) -> int:
        """The image of closure ``k``'s weight (colour) and roughness (alpha); it must have one."""
        if not self.has_image(k):
            raise ValueError(f"closure {k} weighs one channel: its values are packed (slot)")
        return sum(1 for i in range(k) if self.has_image(i))

    def slot(self, k: int, what: str) -> tuple[int, int]:
        """(image, channel) of closure ``k``'s packed value ``what`` (:attr:`packed_values`)."""
        i = self.packed_values.index((k, what))
        return self.closure_images + 1 + i // 4, i % 4

    @property
    def sliced(self) -> bool:
        return self.azimuths > 1

    @property
    def block_width(self) -> int:
        """Columns of one azimuth slice in an image: the ``W`` texels, and one repeated at each edge when sliced."""
        return self.width + 2 if self.sliced else self.width

    @property
    def image_width(self) -> int:
        """Columns of each image."""
        return self.azimuths * self.block_width


def table_coordinates(ops, layout: TableLayout, P, n0, v, d):
    """The lookup's image coordinates at the shading point: the view's angle along x (``sqrt(cos_v)``, or
    ``theta_v`` when sliced, in the first slice), the thickness's place in ``[d_min, d_max]`` along y (the
    sockets' range, so a link's thickness is read where it lies), each mapped onto the texels' centres."""
    w = layout.width
    cos_v = ops.clamp(ops.dot(v, n0), 0.0, 1.0)
    if layout.sliced:
        x = view_column(ops, cos_v, (w - 1.0) / layout.image_width, 1.5 / layout.image_width)
        return _with_thickness(ops, layout, P, x, d)
    return texel_coordinates(ops, layout, P, ops.sqrt(cos_v), d)


def view_column(ops, cos_v, scale, offset):
    """``scale a + offset``, ``a`` the view's angle from ``n0`` as a table's columns hold it, linearly: 1 along
    ``n0``, 0 at grazing (a tilted boundary's closures turn with the view about ``n0``, so near normal view they
    vary with the angle, not its cosine); ``cos_v``: the view's cosine to ``n0``, clamped.  One node: the
    angle's arc cosine, and the map onto the columns folded into one multiply-add (in single precision the
    arc cosine of a cosine near 1 is off by 5e-4 radians at most: 0.04 of a column of 128)."""
    return ops.madd(ops.acos(cos_v), -scale * 2.0 / math.pi, scale + offset)


def texel_coordinates(ops, layout: TableLayout, P, root, d):
    """The image coordinates of an unsliced table at ``root`` (the square root of the cosine its columns run
    along: the view's, or a tilted stack's cosine to its lamellae) and thickness ``d``, on the texels' centres."""
    w = layout.width
    x = (w - 1.0) / w * root + 0.5 / w if isinstance(root, float) else ops.madd(root, (w - 1.0) / w, 0.5 / w)
    return _with_thickness(ops, layout, P, x, d)


def _with_thickness(ops, layout: TableLayout, P, x, d):
    """``x`` and the thickness's row coordinate: ``d``'s place in ``[d_min, d_max]`` on the rows' centres, as one
    multiply-add of ``d`` (its factor and offset are the material's values only: Cycles folds them)."""
    h = layout.height
    if h == 1:
        return ops.combine(x, 0.5, 0.0)
    k = ((h - 1.0) / h) / (P["d_max"] - P["d_min"])
    return ops.combine(x, ops.madd(d, k, 0.5 / h - P["d_min"] * k), 0.0)


def lower_frame(ops, n0, v, t):
    """The frame the tables of a tilted boundary are baked in, from the tilt axis ``t`` (unit, across
    ``n0``): ``w = t x n0`` (the lower normal's direction along the surface), ``b``, and the view's azimuth
    from ``w``, ``|phi|`` in ``[0, pi]``.  ``b`` is ``t`` turned towards the view's side (``t sign(v.t)``),
    so that a closure normal baked at ``|phi|`` lies along ``n0 + x w + y b`` on either side of the mirror."""
    w = ops.cross(t, n0)
    across = ops.dot(v, t)
    phi = ops.atan2(ops.abs(across), ops.dot(v, w))
    return w, t * ops.sign(across), phi


def _slice_reader(ops, layout: TableLayout, xy, phi):
    """``read(k)``: image ``k`` at ``xy`` (in the first slice) interpolated linearly between the two
    slices about ``phi``; without slices, image ``k`` at ``xy``."""
    if not layout.sliced:
        return lambda k: ops.table(k, xy)
    u = ops.clamp(phi * ((layout.azimuths - 1.0) / math.pi), 0.0, layout.azimuths - 1.0)
    i0 = ops.minimum(ops.floor(u), layout.azimuths - 2.0)
    f = u - i0
    step = 1.0 / layout.azimuths  # a slice's width in image coordinates
    xy0 = xy + ops.combine(i0 * step, 0.0, 0.0)
    xy1 = xy0 + ops.combine(step, 0.0, 0.0)

    def read(k):
        c0, a0 = ops.table(k, xy0)
        c1, a1 = ops.table(k, xy1)
        return ops.mix(c0, c1, f), ops.mix(a0, a1, f)
    return read


def tabulated_shade(ops, plan: EffectPlan, layout: TableLayout, P, n0, v, d, axis=None) -> ShadingResult:
    """The closures of :func:`..program.shade` read from the baked tables (``ops.table(k, xy)``:
    image ``k``'s colour and alpha at ``xy``), with the Base Shader's factor in ``extras``; ``axis``:
    a tilted boundary's tilt axis (:func:`.surface_prelude.tilt_axis`, read where the layout is sliced)."""
    xy = table_coordinates(ops, layout, P, n0, v, d)
    phi = frame = None
    if layout.sliced:
        *frame, phi = lower_frame(ops, n0, v, axis)
    read = _slice_reader(ops, layout, xy, phi)
    res = ShadingResult()
    packed = {}  # image -> its four channels

    def value(k, what):
        image, channel = layout.slot(k, what)
        if image not in packed:
            colour, alpha = read(image)
            packed[image] = [*ops.components(colour), alpha]
        return packed[image][channel]

    tangent = ops.cross(n0, v)
    for k, (name, channels) in enumerate(layout.closures):
        normal, u = n0, tangent
        if k in layout.oriented:
            # The normal's components over its component along n0: two values, and no normalisation here
            # (the BSDF normalises its Normal).
            x, y = (value(k, what) for what in ("normal_x", "normal_y"))
            normal = ops.closure_normal(n0 + frame[0] * x + frame[1] * y, n0)
            u = ops.cross(normal, v)
        if layout.has_image(k):
            colour, roughness = read(layout.closure_image(k))
        else:  # one channel: its weight placed in that channel
            w, roughness = value(k, "weight"), value(k, "roughness")
            colour = ops.combine(*(w if c in channels else 0.0 for c in range(3)))
        res.glossy.append(Closure(name, normal, None, roughness * roughness, colour, value(k, "anisotropy"),
                                  u, roughness))
    # The diffuse colour and the Base Shader's factor do not depend on the lower normal: every slice holds
    # them, and the first is read.
    colour, base = ops.table(layout.diffuse_image, xy)
    if plan.diffuse:
        res.diffuse = colour
    res.extras["base_weight"] = base if base_receives_light(plan) else 0.0
    if layout.transmittance == "none":
        res.extras["transmittance"] = ops.combine(0.0, 0.0, 0.0)
    elif layout.transmittance == "computed":
        res.extras["transmittance"] = top_transmittance(ops, program_inputs(P)["r1"], P["r0"],
                                                        ops.clamp(ops.dot(v, n0), 0.0, 1.0))
    else:
        res.extras["transmittance"] = colour if layout.transmittance == "shared" else \
            read(layout.transmittance_image)[0]
    return res
