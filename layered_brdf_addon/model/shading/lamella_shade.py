"""The closures of tilted lamellae in a clear crystal (labradorite's schiller): a film stack (:mod:`..stack`) whose
films lie across the lower normal ``n1`` (the tilted boundary), inside a crystal of the layer's index under its
polished top.

The crystal is millimetres thick: what its top reflects and what the lamellae reflect do not interfere, their
light adds.  Three parts:

* **the top's gloss**: one energy-keeping lobe about ``n0`` (the top's roughness) carrying the top boundary's
  Fresnel reflectance, outside to crystal, at the microfacets' angle to the view;
* **the schiller**: the view refracted into the crystal meets the lamellae at the cosine ``c = -<t_o, n1>`` (eq.
  10), they reflect the stack's ``R(c)`` (every lamella, coherently: :mod:`..stack_optics`, the crystal above and
  below them), and that light leaves through the top along ``l*`` (eq. 11): the tilted boundary's transmitted lobe
  (:func:`.channel_program.channel_lobes`, the lamellae's roughness spreading it), energy-keeping, carrying
  ``(1 - F(v)) R(c) (1 - F(l*))``, ``F`` the top's reflectance;
* **what the lamellae pass**, ``T(c)`` after the top's ``1 - F(v)``, and what they reflect that the top sends back
  inside (its ``F(l*)``, or all of it past the critical angle: it meets the lamellae again at another angle, where
  they pass it), reaches the crystal's body: the diffuse part takes ``kd`` of it (the light scattered there
  crosses the lamellae and the top again on its way out: ``<T>``, what the lamellae pass averaged over the
  hemisphere, and the top's ``1 - F`` at normal incidence), the Base Shader the rest, where the lower medium is
  clear.

:func:`lamella_geometry` is what the view and the lamellae's normal decide (every closure's shape, ``c``, the
top's share), :func:`lamella_shade` the closures from it and the lamellae's optics: ``read(cos)`` their ``(R,
T)`` per channel at the cosine ``cos`` (at the point's thickness), ``leaving`` their ``<T>``.  The shaders read
both from the material's tables (:func:`tabulated_lamellae`, baked by :mod:`..stack_tables`); numpy computes
them.  Reflected, passed and absorbed light add up to what arrives, channel by channel.
"""
from __future__ import annotations

import math
from dataclasses import replace

from ..ops_numpy import vec
from .base_shader import CLEAR_K
from .channel_program import channel_lobes
from .closures import Closure, ShadingResult
from .energy import microfacet_cosine
from .lobes import INV_2PI, closure_for
from .tables import lower_frame, texel_coordinates, view_column
from .thin_film import fresnel_reflectance

LAMELLA_IMAGES = ("reflected", "passed", "leaving")  # the lamellae's optics' tables (RGB), over sqrt(c) and d
# The geometry's tables, over the view's angle from n0 and its azimuth from the lower normal (RGBA each): the
# schiller's closure (its normal's components in the lower frame, roughness, anisotropy), the schiller's weight
# over R(c), the cosine c, what of the schiller's light leaves through the top, what the top lets in (1 - F(v));
# the gloss's closure.
GEOMETRY_IMAGES = (("normal_x", "normal_y", "roughness", "anisotropy"), ("weight", "cosine", "out", "through"),
                   ("gloss_weight", "gloss_roughness", "gloss_anisotropy", ""))
AZIMUTH_ROWS = 33  # the geometry's rows over the view's azimuth from the lower normal (0..pi), at least


def lamella_geometry(ops, plan, P, n0, n1, v) -> dict:
    """What the view and the lamellae's normal ``n1`` decide, not the lamellae's optics: the top's gloss (a
    closure), the schiller's closure (its weight over ``R(c)``: ``weight``), the cosine ``cos`` to the
    lamellae, what of the schiller's light leaves through the top (``out``; the rest it sends back inside) and
    what the top lets in, ``through`` (``1 - F(v)``, the top's reflectance ``F(v)``), under a top of normal
    ``n0``, view ``v``, the inputs ``P`` clamped (:func:`.inputs.clamped_inputs`)."""
    r1, r0, e0, e1, ks = P["r1_g"], P["r0"], P["e0"], P["e1"], P["ks"]
    eta = r0 / r1
    lobes = channel_lobes(ops, r1, e0, e1, r0, n0, n1, v, plan.lobe, interference=False, energy=True)
    top = fresnel_reflectance(ops, microfacet_cosine(ops, e0, lobes["cos_v"]), eta)
    # The light the lamellae return crosses the top on its way out at l*, as the light that leaves along v came in.
    out = ops.select(lobes["through"], (1.0 - fresnel_reflectance(ops, microfacet_cosine(ops, e0, lobes["cos_ls"]),
                                                                  eta)) * lobes["tail"], 0.0)
    weight = (1.0 - top) * out * (ks * (lobes["e_T"] + 2.0) * INV_2PI) * lobes["inv_peak_T"]
    gloss = closure_for(ops, plan.lobe, "reflect", n0, e0, v, (top * ks * (e0 + 2.0) * INV_2PI,) * 3, energy=True)
    schiller = Closure("transmit", lobes["N_T0"], lobes["e_T"], lobes["alpha_T"], (1.0, 1.0, 1.0), lobes["aniso_T"],
                       lobes["U_T0"])
    return dict(gloss=gloss, schiller=schiller, weight=weight, cos=ops.clamp(-lobes["to_lower"], 0.0, 1.0),
                out=out, through=1.0 - top)


def lamella_shade(ops, plan, P, geo, read, leaving) -> ShadingResult:
    """The closures of the lamellae of :func:`lamella_geometry`'s ``geo``, ``read`` and ``leaving`` their optics
    (above), colours (one vector per quantity: the channels are computed together).  ``read(cos)`` may give
    ``T`` as None: lamellae that absorb nothing pass what they do not reflect.  ``extras`` carries
    ``base_weight``, ``transmittance`` and ``reflected`` as :func:`.stack_shade.stack_shade` does."""
    res = ShadingResult()
    R, T = read(geo["cos"])
    R = ops.clamp(R, 0.0, 1.0)
    through, out = geo["through"], geo["out"]
    if plan.specular:
        s = geo["schiller"]
        res.glossy += [geo["gloss"], Closure(s.name, s.normal, s.exponent, s.alpha, R * geo["weight"], s.anisotropy,
                                             s.tangent, s.roughness)]
    # What the lamellae pass, and what they reflect that the top sends back into the crystal (beyond its critical
    # angle, or its Fresnel share): it crosses the lamellae again at another angle, where they pass it.  For clear
    # lamellae T + R (1 - out) is 1 - R out, within [0, 1] as R and out are.
    if T is None:
        inside = 1.0 - R * out
    else:
        inside = ops.clamp(ops.clamp(T, 0.0, 1.0) + R * (1.0 - out), 0.0, 1.0)
    entering = inside * through
    kd = P["kd"]
    if plan.diffuse:
        exit_top = 1.0 - fresnel_reflectance(ops, 1.0, P["r0"] / P["r1_g"])
        body = ops.combine(*(kd * P[f"base_{c}"] * exit_top for c in "rgb"))
        res.diffuse = entering * body * ops.clamp(leaving, 0.0, 1.0)
    if plan.passes:
        clear = ops.combine(*(ops.lt(P[f"k2_{c}"], CLEAR_K) * (1.0 - kd) for c in "rgb"))
        passed = entering * clear
        channels = ops.components(passed)
        weight = ops.minimum(ops.minimum(channels[0], channels[1]), channels[2])
    else:
        weight, passed = 0.0, ops.combine(0.0, 0.0, 0.0)
    res.extras.update(base_weight=weight, transmittance=passed, reflected=(1.0 - through) + R * (through * out))
    return res


def response_optics(response, d):
    """``(read, leaving)`` of :func:`lamella_shade` from a stack's optics computed at thicknesses ``d`` (numpy:
    :class:`..stack_optics.StackResponse`, the crystal above the lamellae)."""
    def read(cos):
        R, T = response.colour(cos, d)
        return vec(R), vec(T)
    return read, vec(response.hemispherical(d)[1])


def geometry_coordinates(ops, layout, n0, v, phi):
    """Where the geometry's tables are read: the view's angle from ``n0`` along x (linearly: near normal view
    the schiller turns with the view), its azimuth ``phi`` from the lower normal (0..pi) along y."""
    w, h = layout.width, layout.height
    along = view_column(ops, ops.clamp(ops.dot(v, n0), 0.0, 1.0), (w - 1.0) / w, 0.5 / w)
    return ops.combine(along, ops.madd(phi, (h - 1.0) / (h * math.pi), 0.5 / h), 0.0)


def tabulated_lamellae(ops, plan, layout, P, n0, v, d, axis) -> ShadingResult:
    """:func:`lamella_shade` reading both the geometry (over the view's angle and azimuth from the lower normal,
    tilt axis ``axis``) and the optics (over the cosine to the lamellae and the thickness) from the material's
    tables: a few reads per point, whatever the number of films or domains."""
    w, b, phi = lower_frame(ops, n0, v, axis)
    gxy = geometry_coordinates(ops, layout, n0, v, phi)
    first = layout.geometry_image
    g = []
    for k in range(len(GEOMETRY_IMAGES)):
        colour, alpha = ops.table(first + k, gxy)
        g.append([*ops.components(colour), alpha])
    (nx, ny, rough, aniso), (weight, cos, out, through), (gw, grough, ganiso, _) = g
    normal = ops.closure_normal(n0 + w * nx + b * ny, n0)
    geo = dict(weight=weight, cos=cos, out=out, through=through,
               gloss=Closure("reflect", n0, None, grough * grough, (gw, gw, gw), ganiso, ops.cross(n0, v), grough),
               schiller=Closure("transmit", normal, None, rough * rough, None, aniso, ops.cross(normal, v), rough))

    optics = layout if plan.thickness != "constant" else replace(layout, height=1)  # every row alike: the middle

    def along_d(root):
        return texel_coordinates(ops, optics, P, root, d)

    def read(c):
        xy = along_d(ops.sqrt(c))  # along x the cosine's root, as a stack's view
        passed = ops.table(layout.optics_image("passed"), xy)[0] if layout.passed else None
        return ops.table(layout.optics_image("reflected"), xy)[0], passed

    # <T> is the same along a row: read where the cosine is 1.
    leaving = ops.table(layout.optics_image("leaving"), along_d(1.0))[0] if plan.diffuse else 1.0
    return lamella_shade(ops, plan, P, geo, read, leaving)
