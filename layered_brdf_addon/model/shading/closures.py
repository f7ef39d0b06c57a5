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
    weight: Any  # (r, g, b) scalars, or a colour of the backend
    anisotropy: Any = 0.0  # the Glossy BSDF's Anisotropy: the lobe's stretch along ``tangent``
    tangent: Any = None
    roughness: Any = None  # the Glossy BSDF's Roughness, sqrt(alpha), where the program has it as such


@dataclass
class ShadingResult:
    glossy: list = field(default_factory=list)
    diffuse: Any = None  # colour of the diffuse closure (normal n0): (r, g, b) scalars or a colour of the backend
    extras: dict = field(default_factory=dict)
