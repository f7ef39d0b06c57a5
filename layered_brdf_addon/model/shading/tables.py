"""The closures read from tables baked for a material's values, instead of computed per point.

Where the lower boundary is parallel to the upper one, every closure of the program lies about
``n0`` with its tangent across the plane of ``n0`` and the view, and its weights, width and
anisotropy depend on the material's values (constants) and on two per-point scalars only: the
view's cosine to ``n0`` and the thickness ``d``.  A material whose values are constants can
therefore have them baked (:mod:`..table_bake`, by this same program run on numpy) into small
float images over ``(cos_v, d)``, which the shader reads with one Image Texture node each
(cubic B-spline interpolation of prefiltered coefficients, extended at the edges), whatever the
accuracy mode or optics.

The images (:class:`TableLayout`): one per glossy closure (colour: its weight per channel;
alpha: the Glossy BSDF's Roughness, ``sqrt(alpha)``), one for the diffuse colour and the Base
Shader's factor, and the closures' anisotropies four to an image.  Texel ``(i, j)`` holds the
values at ``cos_v = (i / (W - 1))^2`` (denser towards grazing views) and ``d = d_min + (d_max -
d_min) j / (H - 1)``; a lookup puts ``cos_v = 0`` and ``1`` on the first and last texels' centres.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..plan import EffectPlan
from .base_shader import base_receives_light
from .closures import Closure, ShadingResult

TABLE_FORMAT = 2  # what a texel holds (this module's layout; 2: cubic B-spline coefficients in the node group's
# images); baked tables of another format are rebaked
COS_SAMPLES = 64  # texels along the square root of the view's cosine (measured: docs/tables.md)
PARALLEL_TOLERANCE = 1.0e-5  # a baked closure's normal may differ from n0 by this (rounding)


#: Values a tabulable plan reads before or besides its tables, never in them: the pattern's (they decide
#: where the thickness falls within [d_min, d_max], the tables' axis) and the lower boundary's direction
#: (parallel to the upper one).  Animating them (a noise phase that makes a film flow) keeps the tables,
#: and changing them bakes nothing.
UNREAD_BY_TABLES = frozenset({"noise_scale", "noise_detail", "noise_roughness", "noise_phase", "tilt",
                              "tilt_azimuth", "bump_strength"})


class NotTabulable(ValueError):
    """The plan's closures depend on more than the view's cosine and the thickness."""


def tabulable(plan: EffectPlan) -> bool:
    """Whether the closures of ``plan`` can be baked: parallel boundaries (every closure about ``n0``),
    a thickness from the material's pattern or a constant (a linked thickness has no known range),
    Beckmann lobes (the node group's)."""
    return plan.normals == "parallel" and plan.thickness in ("noise", "height", "constant") and \
        plan.lobe == "beckmann"


@dataclass(frozen=True)
class TableLayout:
    """Which images a plan's tables have and what each texel holds.

    ``closures``: the glossy closures' names, in the program's order, each with the channels
    its weight has (a dispersive plan's per-channel closures weigh one channel);
    ``width``, ``height``: texels along ``cos_v`` and ``d`` (1 for a constant thickness)."""

    closures: tuple[tuple[str, tuple[int, ...]], ...]
    width: int
    height: int

    @property
    def closure_images(self) -> int:
        return len(self.closures)

    @property
    def anisotropy_images(self) -> int:
        return (len(self.closures) + 3) // 4

    @property
    def images(self) -> int:
        """Images in all: the closures', the diffuse colour's (with the Base Shader's factor), the anisotropies'."""
        return self.closure_images + 1 + self.anisotropy_images

    @property
    def diffuse_image(self) -> int:
        return self.closure_images

    def anisotropy_slot(self, k: int) -> tuple[int, int]:
        """(image, channel) of closure ``k``'s anisotropy."""
        return self.closure_images + 1 + k // 4, k % 4


def table_coordinates(ops, layout: TableLayout, P, n0, v, d):
    """The lookup's image coordinates at the shading point: ``cos_v`` along x, the thickness's place
    in ``[d_min, d_max]`` along y (the sockets' range, so a link's thickness is read where it lies),
    each mapped onto the texels' centres."""
    w, h = layout.width, layout.height
    cos_v = ops.clamp(ops.dot(v, n0), 0.0, 1.0)
    x = ops.madd(ops.sqrt(cos_v), (w - 1.0) / w, 0.5 / w)
    if h == 1:
        return ops.combine(x, 0.5, 0.0)
    t = (d - P["d_min"]) / (P["d_max"] - P["d_min"])
    return ops.combine(x, ops.madd(t, (h - 1.0) / h, 0.5 / h), 0.0)


def tabulated_shade(ops, plan: EffectPlan, layout: TableLayout, P, n0, v, d) -> ShadingResult:
    """The closures of :func:`..program.shade` read from the baked tables (``ops.table(k, xy)``:
    image ``k``'s colour and alpha at ``xy``), with the Base Shader's factor in ``extras``."""
    xy = table_coordinates(ops, layout, P, n0, v, d)
    res = ShadingResult()
    anisotropies = {}  # image -> its four channels
    tangent = ops.cross(n0, v)
    for k, (name, _) in enumerate(layout.closures):
        image, channel = layout.anisotropy_slot(k)
        if image not in anisotropies:
            colour, alpha = ops.table(image, xy)
            anisotropies[image] = [*ops.components(colour), alpha]
        colour, roughness = ops.table(k, xy)
        res.glossy.append(Closure(name, n0, None, roughness * roughness, colour, anisotropies[image][channel],
                                  tangent, roughness))
    colour, base = ops.table(layout.diffuse_image, xy)
    if plan.diffuse:
        res.diffuse = colour
    res.extras["base_weight"] = base if base_receives_light(plan) else 0.0
    return res
