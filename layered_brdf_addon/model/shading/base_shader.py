"""What reaches the artist's Base Shader under the layer: ``1 - F(v)`` with the paper's
optics; with thin-film optics, what the film neither reflects nor gives to the diffuse part.
"""
from __future__ import annotations

from .fresnel import fresnel_f0, schlick
from .step import shader_function
from .thin_film import film_beams, harmonic_count


def base_weight(ops, r1, r0, cos_v):
    """What the top boundary transmits to the artist's base shader, ``1 - F(v)``: the mean
    over the channels (a Mix Shader takes one factor)."""
    F = schlick(ops, cos_v, fresnel_f0(ops, ops.combine(*r1), r0))
    return 1.0 - ops.dot(F, (1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0))


CLEAR_K = 1e-3  # a lower medium of smaller extinction is clear: it passes on what enters it


@shader_function
def film_transmittance(ops, r1, r0, n2, k2, kd, cos_v, *, orders=1):
    """What reaches the Base Shader with thin-film optics: the light that the film neither
    reflects nor gives to the diffuse part (``kd``), where the lower medium is clear; a medium
    that absorbs (``k2`` above :data:`CLEAR_K`, a metal) keeps it.  A Mix Shader takes one
    factor for every channel, and the film's reflectance at a point lies anywhere between the
    troughs and crests of its interference: the factor is what passes where the film reflects
    most, ``1 - max(DC + 2 sqrt(R01 T) sum g_m)`` over the channels, so that reflected and
    passed light never add up to more than arrives."""
    eta = r0 / r1
    cos1 = ops.sqrt(ops.maximum((1.0 - eta * eta) + eta * eta * (cos_v * cos_v), 0.0))
    f = film_beams(ops, cos_v, cos1, r1, r0, n2, k2, orders=orders)
    swing = f["g1"]
    for m in range(2, orders + 1):
        swing = swing + f[f"g{m}"]
    crest = f["R01"] + f["T"] + 2.0 * ops.sqrt(f["R01"] * f["T"]) * swing
    passed = ops.clamp(1.0 - crest, 0.0, 1.0) * ops.lt(k2, CLEAR_K)
    r, g, b = ops.components(passed)
    return ops.minimum(ops.minimum(r, g), b) * (1.0 - kd)


def base_receives_light(plan) -> bool:
    """Whether the Base Shader gets any light under ``plan``: not under an absorbing lower medium (a
    metal keeps what enters it) with thin-film optics."""
    return plan.optics != "physical" or plan.passes


def passed_to_base(ops, plan, inputs, v, n0):
    """The Base Shader's factor for ``plan``: ``1 - F(v)`` with the paper's optics, the film's
    :func:`film_transmittance` with thin-film optics, 0 where the lower medium absorbs (a metal
    keeps what enters it).  ``inputs``: the program's inputs (:func:`.inputs.program_inputs`)."""
    if not base_receives_light(plan):
        return 0.0
    with ops.stage("What reaches the Base Shader: " + ("what the film neither reflects nor absorbs"
                                                        if plan.optics == "physical" else "1 - F(v)")):
        cos_v = ops.named("cos_v", ops.clamp(ops.dot(v, n0), 0.0, 1.0))
        if plan.optics == "physical":
            passed = film_transmittance(ops, ops.combine(*inputs["r1"]), inputs["r0"], ops.combine(*inputs["r2"]),
                                        ops.combine(*inputs["k2"]), inputs["kd"], cos_v,
                                        orders=harmonic_count(plan))
        else:
            passed = base_weight(ops, inputs["r1"], inputs["r0"], cos_v)
        return ops.named("transmitted", passed)
