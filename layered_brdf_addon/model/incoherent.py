"""Coherent domains whose light adds as power: a stack of films repeated one under the other, each copy apart
from the next by more than light's coherence (labradorite's lamellae keep their order over domains of a
stone; :attr:`.stack.FilmStack.domains`).

Between domains no phase survives, so what they reflect and pass combines as the intensities of a pile of
plates (Stokes): a slab reflecting ``Ra`` and passing ``Ta`` over one reflecting ``Rb`` and passing ``Tb``
reflects ``Ra + Ta^2 Rb / (1 - Ra Rb)`` and passes ``Ta Tb / (1 - Ra Rb)``, the light bouncing between them
summed.  A domain here reflects the same from above and below (exact for films that absorb nothing, by
reciprocity and R + T = 1; for absorbing films, an approximation), so a pile of equal domains is symmetric
too, and ``count`` domains take ``log2 count`` combinations (doubling).  numpy; per wavelength, before the
colour is summed over a band (a narrow Bragg peak adds up per wavelength, not per channel).
"""
from __future__ import annotations

import numpy as np

FLOOR = 1.0e-9  # 1 - Ra Rb, at least (two perfect mirrors facing each other)


def over_sides(upper, lower):
    """``(R, T, R', T')`` of the slab ``upper`` over ``lower``, each given as ``(R, T, R', T')``: what it reflects
    and passes of the light from above, then from below (an absorbing slab reflects differently from each
    side).  From above, ``Ra + Ta T'a Rb / (1 - R'a Rb)`` and ``Ta Tb / (1 - R'a Rb)``; from below, ``R'b + T'b
    Tb R'a / (1 - R'a Rb)`` and ``T'b T'a / (1 - R'a Rb)``: the light bouncing between them summed."""
    Ra, Ta, Ra_below, Ta_below = upper
    Rb, Tb, Rb_below, Tb_below = lower
    inv = 1.0 / np.maximum(1.0 - Ra_below * Rb, FLOOR)
    return (Ra + Ta * Ta_below * Rb * inv, Ta * Tb * inv, Rb_below + Tb_below * Tb * Ra_below * inv,
            Tb_below * Ta_below * inv)


def over(upper, lower):
    """``(R, T)`` of the slab ``upper`` (symmetric) over ``lower``, their light added as power
    (:func:`over_sides` with each slab the same from both sides)."""
    (Ra, Ta), (Rb, Tb) = upper, lower
    inv = 1.0 / np.maximum(1.0 - Ra * Rb, FLOOR)
    return Ra + Ta * Ta * Rb * inv, Ta * Tb * inv


def repeated(cell, count: int, combine=over_sides):
    """``count`` (at least 1) copies of the slab ``cell`` one under the other (``combine``: :func:`over_sides`
    or :func:`over`), by doubling: ``log2 count`` combinations."""
    above, power, n = None, cell, count
    while n:
        if n & 1:
            above = power if above is None else combine(above, power)
        n >>= 1
        if n:
            power = combine(power, power)
    return above


def _in_double(slab, clear: bool):
    R, T = (np.asarray(x, dtype=np.float64) for x in slab)
    return R, (1.0 - R if clear else T)


def pile(domain, last, count: int, clear=(False, False)):
    """``(R, T)`` of ``count`` domains: ``count - 1`` of ``domain`` (its ``(R, T)`` between the medium around
    it on both sides) over ``last`` (the same domain on the lower medium), by doubling, in double precision.
    ``clear``: whether ``domain`` and ``last`` absorb nothing, so that what they pass is exactly what they do
    not reflect (a single-precision ``T`` off by 1e-5 would add up over many domains)."""
    domain, last = _in_double(domain, clear[0]), _in_double(last, clear[1])
    return last if count == 1 else over(repeated(domain, count - 1, over), last)
