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
  they pass it), reaches the crystal's body: the diffuse part
  takes ``kd`` of it (the light scattered there crosses the lamellae and the top again on its way out: ``<T>``,
  what the lamellae pass averaged over the hemisphere, and the top's ``1 - F`` at normal incidence), the Base
  Shader the rest, where the lower medium is clear.

``read(cos)`` gives the lamellae's ``(R, T)`` per channel at the cosine ``cos`` to their normal (at the point's
thickness), ``leaving`` their ``<T>``: from the material's tables in the shaders (:func:`tabulated_lamellae`,
baked by :mod:`..stack_tables`), from the optics on numpy.  Reflected, passed and absorbed light add up to what
arrives, channel by channel.
"""
from __future__ import annotations

from .base_shader import CLEAR_K
from .channel_program import channel_lobes
from .closures import Closure, ShadingResult
from .energy import microfacet_cosine
from .lobes import INV_2PI, closure_for
from .tables import texel_coordinates
from .thin_film import fresnel_reflectance

LAMELLA_IMAGES = ("reflected", "passed", "leaving")  # what each of the lamellae's tables holds (RGB)


def lamella_shade(ops, plan, P, n0, n1, v, d, read, leaving) -> ShadingResult:
    """The closures of lamellae of normal ``n1`` in a crystal of the layer's index (green's) under a top of
    normal ``n0``, view ``v``, the inputs ``P`` clamped (:func:`.inputs.clamped_inputs`); ``read``,
    ``leaving``: the lamellae's optics (above).  ``extras`` carries ``base_weight``, ``transmittance`` and
    ``reflected`` as :func:`.stack_shade.stack_shade` does."""
    res = ShadingResult()
    r1, r0, e0, e1 = P["r1_g"], P["r0"], P["e0"], P["e1"]
    eta = r0 / r1
    lobes = channel_lobes(ops, r1, e0, e1, r0, n0, n1, v, plan.lobe, interference=False, energy=True)
    cos_v = lobes["cos_v"]
    top = fresnel_reflectance(ops, microfacet_cosine(ops, e0, cos_v), eta)
    cos_lamellae = ops.clamp(-lobes["to_lower"], 0.0, 1.0)
    R, T = read(cos_lamellae)
    R, T = ops.components(R), ops.components(T)
    ks = P["ks"]
    # The light the lamellae return crosses the top on its way out at l*, as the light that leaves along v came in.
    out = ops.select(lobes["through"], (1.0 - fresnel_reflectance(ops, microfacet_cosine(ops, e0, lobes["cos_ls"]),
                                                                  eta)) * lobes["tail"], 0.0)
    schiller = (1.0 - top) * out
    if plan.specular:
        res.glossy.append(closure_for(ops, plan.lobe, "reflect", n0, e0, v, (top * ks * (e0 + 2.0) * INV_2PI,) * 3,
                                      energy=True))
        peak = schiller * (ks * (lobes["e_T"] + 2.0) * INV_2PI) * lobes["inv_peak_T"]
        res.glossy.append(Closure("transmit", lobes["N_T0"], lobes["e_T"], lobes["alpha_T"],
                                  tuple(r * peak for r in R), lobes["aniso_T"], lobes["U_T0"]))
    # What the lamellae pass, and what they reflect that the top sends back into the crystal (beyond its critical
    # angle, or its Fresnel share): it crosses the lamellae again at another angle, where they pass it.
    entering = [(1.0 - top) * ops.clamp(t + r * (1.0 - out), 0.0, 1.0) for t, r in zip(T, R)]
    kd = P["kd"]
    if plan.diffuse:
        exit_top = 1.0 - fresnel_reflectance(ops, 1.0, eta)
        res.diffuse = tuple(kd * P[f"base_{c}"] * entering[i] * ops.clamp(leaving[i], 0.0, 1.0) * exit_top
                            for i, c in enumerate("rgb"))
    clear = [ops.lt(P[f"k2_{c}"], CLEAR_K) for c in "rgb"]
    passed = tuple(entering[i] * clear[i] * (1.0 - kd) for i in range(3))
    if plan.passes:
        weight = ops.minimum(ops.minimum(passed[0], passed[1]), passed[2])
    else:
        weight, passed = 0.0, (0.0, 0.0, 0.0)
    reflected = tuple(top + schiller * r for r in R)
    res.extras.update(base_weight=weight, transmittance=ops.combine(*passed), reflected=ops.combine(*reflected))
    return res


def response_optics(response, d):
    """``(read, leaving)`` of :func:`lamella_shade` from a stack's optics computed at thicknesses ``d`` (numpy:
    :class:`..stack_optics.StackResponse`, the crystal above the lamellae)."""
    leaving = response.hemispherical(d)[1]
    return (lambda cos: response.colour(cos, d)), tuple(leaving[..., c] for c in range(3))


def tabulated_lamellae(ops, plan, layout, P, n0, n1, v, d) -> ShadingResult:
    """:func:`lamella_shade` reading the lamellae's optics from the material's tables (:data:`LAMELLA_IMAGES`):
    the geometry per point, the optics of every lamella in two reads (three with a diffuse part)."""
    def read(cos):
        xy = texel_coordinates(ops, layout, P, ops.sqrt(cos), d)  # along x the cosine's root, as a stack's view
        return ops.table(0, xy)[0], ops.table(1, xy)[0]

    # <T> is the same along a row: read where the cosine is 1.
    leaving = ops.components(ops.table(2, texel_coordinates(ops, layout, P, 1.0, d))[0]) if plan.diffuse \
        else (1.0, 1.0, 1.0)
    return lamella_shade(ops, plan, P, n0, n1, v, d, read, leaving)
