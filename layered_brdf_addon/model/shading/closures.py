"""What the shading program returns at a shading point: its glossy closures
(:class:`Closure`), the diffuse closure's colour and the shader's other outputs
(:class:`ShadingResult`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any


@dataclass
class Closure:
    """A glossy closure: normal, Phong exponent, Beckmann alpha, per-channel weights."""

    name: str
    normal: Any
    exponent: Any
    alpha: Any  # geometric mean of the two alphas (the Glossy BSDF's Roughness^2)
    weight: tuple  # (r, g, b) scalars
    anisotropy: Any = 0.0  # the Glossy BSDF's Anisotropy: the lobe's stretch along ``tangent``
    tangent: Any = None


@dataclass
class ShadingResult:
    glossy: list = field(default_factory=list)
    diffuse: tuple | None = None  # (r, g, b) colour of the diffuse closure (normal n0)
    extras: dict = field(default_factory=dict)
