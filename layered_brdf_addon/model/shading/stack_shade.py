"""The closures of a stack of films (:mod:`..stack`): one energy-keeping lobe that carries the stack's
reflectance, the diffuse part under the stack, and what the stack passes to the base.

A stack's films are parallel to the top boundary, so everything they reflect leaves about the mirror
direction, coherently summed over every film (:mod:`..stack_optics`): the reflected lobe about ``n0``
(the top boundary's roughness) carries the stack's reflectance ``R`` at the microfacets' angle to the
view (:func:`.energy.microfacet_cosine`), its albedo that reflectance at every angle (energy-keeping,
:func:`.lobes.closure_for`).  What the stack passes into the lower medium, ``T`` at the same angle
(``1 - R`` for films that do not absorb), reaches the base: the diffuse part takes ``kd`` of it
(scattered light crosses the stack again on its way out: ``<T>``, what the stack passes averaged over
the hemisphere) and the Base Shader the rest, where the lower medium is clear.  Reflected and
passed light add up to what arrives, channel by channel.

``response`` gives ``(R, T)`` per channel at cosines and thicknesses (:class:`..stack_optics.StackResponse`,
numpy): the shaders read these closures from tables baked by this step (:mod:`..table_bake`), whatever
the number of films.
"""
from __future__ import annotations

from .closures import ShadingResult
from .energy import microfacet_cosine
from .lobes import INV_2PI, closure_for
from .base_shader import CLEAR_K


def stack_shade(ops, plan, P, n0, v, d, response) -> ShadingResult:
    """The closures of ``response``'s stack at points of upper normal ``n0``, view ``v`` and thickness
    ``d`` (nm, the stack's total), the inputs ``P`` clamped (:func:`.inputs.clamped_inputs`); ``extras``
    carries ``base_weight`` and ``transmittance`` as :func:`..program.layered_surface` does."""
    res = ShadingResult()
    cos_v = ops.clamp(ops.dot(v, n0), 0.0, 1.0)
    cos_f = microfacet_cosine(ops, P["e0"], cos_v)
    R, T = response.colour(cos_f, d)
    reflected = tuple(R[..., c] for c in range(3))
    if plan.specular:
        peak = P["ks"] * (P["e0"] + 2.0) * INV_2PI
        res.glossy.append(closure_for(ops, plan.lobe, "reflect", n0, P["e0"], v, tuple(r * peak for r in reflected),
                                      energy=True))
    clear = [ops.lt(P[f"k2_{c}"], CLEAR_K) for c in "rgb"]
    kd = P["kd"]
    if plan.diffuse:
        entering = response.colour(1.0, d)[1]
        leaving = response.hemispherical(d)[1]
        res.diffuse = tuple(kd * P[f"base_{c}"] * ops.clamp(entering[..., i], 0.0, 1.0) *
                            ops.clamp(leaving[..., i], 0.0, 1.0) for i, c in enumerate("rgb"))
    passed = tuple(ops.clamp(T[..., i], 0.0, 1.0) * clear[i] * (1.0 - kd) for i in range(3))
    if plan.passes:
        weight = ops.minimum(ops.minimum(passed[0], passed[1]), passed[2])
    else:
        weight, passed = 0.0, (0.0, 0.0, 0.0)
    res.extras.update(base_weight=weight, transmittance=ops.combine(*passed), reflected=ops.combine(*reflected))
    return res
