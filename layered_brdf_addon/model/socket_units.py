"""What a parameter's socket holds when it is not the parameter itself: Blender's vocabulary on
the node, the paper's in the model.

* ``"roughness"``: the specular exponents ``e0`` and ``e1`` are Phong exponents in the paper and in
  :class:`~.params.LayeredParams`; their sockets hold a Roughness (0-1) as Blender's Principled
  and Glossy BSDFs define it, ``alpha = Roughness^2``.  The program's lobes are Beckmann lobes of
  ``alpha = sqrt(2 / (4 e + 2))`` at normal incidence (:func:`~.shading.lobes.lobe_alphas`), so
  ``Roughness = (2 e + 1)^(-1/4)`` and ``e = (Roughness^-4 - 1) / 2``: the upper boundary's
  highlight is as wide as a Glossy BSDF's of the same Roughness.  Roughness 1 is ``e = 0``;
  Roughness 0 is the sharpest exponent the parameter allows (1e5, Roughness 0.047).
* ``"radians"``: an angle socket (subtype ANGLE) holds radians and shows degrees; the node group's
  Tilt and Tilt Azimuth are angle sockets, the parameters (and the OSL shader's sockets, which have
  no angle subtype) are in degrees.

:func:`to_socket` is plain Python (writing a value into a socket); :func:`from_socket` is a step of
the shading program (``ops``), which every backend runs on the socket's value.
"""
from __future__ import annotations

import math

ROUGHNESS = "roughness"
RADIANS = "radians"
UNITS = ("", ROUGHNESS, RADIANS)
SMALLEST_ROUGHNESS4 = 1.0e-30  # Roughness^4 below this reads as this (e stays finite; clamped after)


def to_socket(units: str, value):
    """The socket's value for a parameter's ``value`` (a number, or a numpy array of them; a
    parameter's value is within its range: an exponent is not negative)."""
    if units == ROUGHNESS:
        return (2.0 * value + 1.0) ** -0.25
    if units == RADIANS:
        return value * (math.pi / 180.0)
    return value


def socket_units_of(spec, backend: str) -> str:
    """What ``backend``'s socket of ``spec`` holds: the node group's angle sockets hold radians (the
    OSL shader's degrees); a Roughness socket a roughness in both."""
    if backend == "nodes" and spec.subtype == "ANGLE":
        return RADIANS
    return spec.socket_units


def from_socket(ops, units: str, x):
    """The parameter's value for the socket's value ``x`` (a program value of ``ops``)."""
    if units == ROUGHNESS:  # x within [0, 1]: the shader clamps its inputs first
        r2 = x * x
        return 0.5 * (1.0 / ops.maximum(r2 * r2, SMALLEST_ROUGHNESS4) - 1.0)
    if units == RADIANS:
        return x * (180.0 / math.pi)
    return x


def socket_range(units: str, lo: float, hi: float) -> tuple[float, float]:
    """The range of the socket's values for a parameter range ``[lo, hi]``."""
    if units == ROUGHNESS:
        return 0.0, 1.0
    return to_socket(units, lo), to_socket(units, hi)
