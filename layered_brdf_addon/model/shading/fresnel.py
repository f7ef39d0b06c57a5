"""The paper's Fresnel terms: Schlick's approximation (eq. 7), the coefficient at normal
incidence (eq. 8) and the transmission into the layer (eq. 9).
"""
from __future__ import annotations

from .step import shader_function


@shader_function
def schlick(ops, cos_t, f):
    """Eq. 7 for a direction pointing away from the surface; a grazing or below-horizon
    direction gives F = 1 (the cosine is clamped)."""
    x = 1.0 - ops.clamp(cos_t, 0.0, 1.0)
    x2 = x * x
    return f + (1.0 - f) * (x2 * x2 * x)


@shader_function
def fresnel_f0(ops, r1, r0):
    """Eq. 8: Fresnel coefficient at normal incidence."""
    q = (r0 - r1) / (r0 + r1)
    return q * q


@shader_function
def transmission_factor(ops, s, f):
    """Eq. 9 with ``s = <v, -n0>`` of the in-layer direction: ``(1 - f)(1 - (1 - s)^5)``."""
    x = ops.clamp(1.0 - s, 0.0, 1.0)
    x2 = x * x
    return (1.0 - f) * (1.0 - x2 * x2 * x)
