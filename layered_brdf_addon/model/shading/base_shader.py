"""What reaches the artist's Base Shader under the layer: ``1 - F(v)`` with the paper's
optics; with thin-film optics, what the film neither reflects nor gives to the diffuse part.
"""
from __future__ import annotations

from .fresnel import fresnel_f0, schlick
from .step import shader_function


def top_transmittance(ops, r1, r0, cos_v):
    """What the top boundary transmits with the paper's optics, ``1 - F(v)``, per channel."""
    return 1.0 - schlick(ops, cos_v, fresnel_f0(ops, ops.combine(*r1), r0))


def base_weight(ops, r1, r0, cos_v):
    """What the top boundary transmits to the artist's base shader, ``1 - F(v)``: the mean
    over the channels (a Mix Shader takes one factor)."""
    return _channel_mean(ops, top_transmittance(ops, r1, r0, cos_v))


def _channel_mean(ops, x):
    return ops.dot(x, (1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0))


CLEAR_K = 1e-3  # a lower medium of smaller extinction is clear: it passes on what enters it


def base_receives_light(plan) -> bool:
    """Whether the Base Shader gets any light under ``plan``: not under an absorbing lower medium (a
    metal keeps what enters it) with thin-film optics."""
    return plan.optics != "physical" or plan.passes


def passed_to_base(ops, plan, inputs, v, n0, reflected=None):
    """What reaches the base for ``plan``: ``(factor, transmittance)``, the Base Shader's factor (one
    value: a Mix Shader's) and what passes per channel (the colour of a clear base's Transparent BSDF),
    :func:`passed_at`, in the shader's stage of that name."""
    if not base_receives_light(plan):
        return 0.0, ops.combine(0.0, 0.0, 0.0)
    with ops.stage("What reaches the Base Shader: " + ("what the film neither reflects nor absorbs"
                                                        if plan.optics == "physical" else "1 - F(v)")):
        cos_v = ops.named("cos_v", ops.clamp(ops.dot(v, n0), 0.0, 1.0))
        weight, passed = passed_at(ops, plan, inputs, cos_v, reflected)
        return ops.named("transmitted", weight), ops.named("transmittance", passed)


def passed_at(ops, plan, inputs, cos_v, reflected=None):
    """:func:`passed_to_base` at the view's cosine ``cos_v`` to ``n0``.

    The paper's optics: ``1 - F(v)`` per channel, their mean the factor.  Thin-film optics: what the
    film neither reflects at this incidence (``reflected``, the program's lobes' reflectance per
    channel, :func:`.channel_program.channel_block`) nor gives to the diffuse part, ``(1 - R)(1 - kd)``,
    where the lower medium is clear (a metal keeps what enters it): reflected and passed light then add
    up to what arrives, channel by channel; the factor is the least of the channels, so that an
    artist's shader of any colour under the film never receives more than passes.
    ``inputs``: the program's inputs (:func:`.inputs.program_inputs`)."""
    if not base_receives_light(plan):
        return 0.0, ops.combine(0.0, 0.0, 0.0)
    if plan.optics == "physical":
        passed = base_transmittance(ops, 0.0 if reflected is None else reflected, ops.combine(*inputs["k2"]),
                                    inputs["kd"])
        r, g, b = ops.components(passed)
        return ops.minimum(ops.minimum(r, g), b), passed
    passed = top_transmittance(ops, inputs["r1"], inputs["r0"], cos_v)
    return _channel_mean(ops, passed), passed


@shader_function
def base_transmittance(ops, reflected, k2, kd):
    """Thin-film optics' light under the film per channel: ``(1 - R)(1 - kd)`` where the lower medium is
    clear (``k2`` below :data:`CLEAR_K`), else 0; ``R`` the film's reflectance at this incidence."""
    return ops.clamp(1.0 - reflected, 0.0, 1.0) * ops.lt(k2, CLEAR_K) * (1.0 - kd)
