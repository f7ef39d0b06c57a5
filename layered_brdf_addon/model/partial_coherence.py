"""A disordered stack as partially coherent: the films near the top interfere, deeper ones add their light as
power.

Light reflected by two boundaries interferes with a phase of ``4 pi (optical path between them) / lambda``.
Where the films' thicknesses are spread (:attr:`.stack.FilmStack.disorder`), so is that path; once its spread
passes about a wave (:data:`.stack_optics.COHERENCE_SPREAD_NM`: the round trip's phase spread by pi at 380
nm), the interference averages out over the stack's draws and what the boundaries reflect adds as
intensities, as in a pile of plates (Stokes; Born & Wolf §7.6; Katsidis & Siapkas, Appl. Opt. 41, 3978
(2002): coherent and incoherent layers in one stack, which tmm's ``inc_tmm`` computes).  So:

* the **top**, the films above where the spread of their optical thickness from the top passes coherence
  (:func:`deep_start`), is summed coherently (:func:`.stack_amplitudes.reflect_transmit`, or star products where
  it absorbs) for each of the stack's draws (:func:`.stack_optics.disorder_draws`);
* the **deep** part below is a pile of slabs whose light adds as power, per wavelength and per polarisation
  (s and p piled apart): **gap** films, each an incoherent slab that passes ``|e^{i beta}|^2`` each way (its
  absorption, averaged over the draws), and between two gap films a **unit**, its films summed coherently
  between the gap films' media and averaged over the draws.  The gap films (``mode``): the film of largest
  optical thickness once a period (``periods``: each deeper period a coherent unit), once every as many
  periods as the top holds (``blocks``: units one coherence length deep), or every film (``films``: each
  film incoherent, its boundaries piled: the limit of a spread of many waves).  The deep units are alike,
  so the pile is one cell raised to their number by doubling (:func:`.incoherent.repeated`).

The top and the pile combine as two slabs (:func:`.incoherent.over_sides`: what each reflects from above and
from below).  The deep part is summed once on a grid of the colour's step, each draw's wavelengths (moved by
its share of a step) read from it linearly.

What it holds (docs/stacks.md, ``benchmarks/stack_table.py --tables draws``): against tmm's ``inc_tmm`` with
the same films incoherent, within 0.02 CIEDE2000; against the average of many draws of the whole stack summed
coherently, worse than 8 coherent draws for every stack measured (films a coherence length apart still
interfere with their neighbours: the deep part is not a pile), so :func:`.stack_optics.stack_colour` sums
every film coherently unless asked for this sum.  numpy; no bpy.
"""
from __future__ import annotations

import numpy as np

from .incoherent import over_sides, repeated
from .stack import FilmStack
from .stack_amplitudes import _interface, _media, _phase, _power_ratio, _star, _through, reflect_transmit
from .stack_optics import (channel_weights, coherent_films, colour_step, disorder_draws, film_index, film_optical,
                           lower_index, stack_colour)


DEEP_MODES = ("blocks", "periods", "films")  # where the deep part's gap films lie (this module's docs)


def _gaps(stack: FilmStack, mode: str):
    """``(is_gap, period)``: whether layer ``j`` is a gap film (incoherent) and the deep part's repeat in layers.
    The gap is the period's film of largest optical thickness, once a period (``periods``) or once every
    block of as many periods as the coherent top holds (``blocks``); ``films``: every film."""
    if mode == "films":
        return (lambda j: True), len(stack.films)
    widest = int(np.argmax([film_optical(f) for f in stack.films]))
    every = len(stack.films) * (max(1, coherent_films(stack) // len(stack.films)) if mode == "blocks" else 1)
    return (lambda j: j % every == widest % every), every


def deep_start(stack: FilmStack, mode: str = "blocks") -> int:
    """The first deep layer (``stack.count``: none): the first gap film at or below the film where the spread
    of the optical thickness from the top passes coherence (:func:`.stack_optics.coherent_films`); a stack
    without disorder or of one period keeps every film coherent."""
    if not stack.disorder or stack.periods == 1:
        return stack.count
    gap = _gaps(stack, mode)[0]
    return next((k for k in range(coherent_films(stack), stack.count) if gap(k)), stack.count)


def _boundary(media, qs, a, b):
    """The boundary from medium ``a`` into ``b``, s and p on a first axis, as ``(r, t, r', t')``."""
    s_, p_ = _interface(media[a], qs[a], media[b], qs[b])
    return tuple(np.stack(np.broadcast_arrays(x, y)) for x, y in zip(s_, p_))


def _slab(media, qs, thicknesses, k):
    """``(R, T, R', T')`` per polarisation (s, p on a first axis, double precision) of the films between
    ``media[0]`` and ``media[-1]`` (``thicknesses``: one per film, broadcasting), summed coherently by
    Redheffer star products (:func:`.stack_amplitudes._star`: both sides at once)."""
    cell = _boundary(media, qs, 0, 1)
    for j in range(1, len(media) - 1):
        d = np.asarray(thicknesses[j - 1], dtype=np.float32)[..., None]
        cell = _star(_through(cell, _phase(qs[j], d, k)), _boundary(media, qs, j, j + 1))
    r, t, rb, tb = cell
    R, Rb = (np.abs(x).astype(np.float64) ** 2 for x in (r, rb))
    if not any(np.any(m.imag) for m in media):  # nothing absorbs: what is not reflected passes
        return R, 1.0 - R, Rb, 1.0 - Rb
    return (R, _power_ratio(t[0], t[1], media[0], qs[0], media[-1], qs[-1], True), Rb,
            _power_ratio(tb[0], tb[1], media[-1], qs[-1], media[0], qs[0], True))


def _deep(stack: FilmStack, start: int, n0, lower, cos0, scale, lams, mode: str):
    """``(R, T, R', T')`` per polarisation of the layers from ``start`` (a gap film) down, over the lower
    medium ``lower`` (at ``lams``), seen from inside the gap film: a pile of the gap films and the units
    between them (this module's docs)."""
    index = {f: film_index(f, lams) for f in stack.films}
    layers = stack.layers
    media, qs = _media(n0, [index[f] for f in layers], lower, cos0, lams)  # media[j + 1]: layer j's
    k = (2.0 * np.pi / lams).astype(np.float32)
    draws = disorder_draws(stack)
    gap, period = _gaps(stack, mode)

    def gap_slab(j):
        if not np.any(media[j + 1].imag):
            return 0.0, 1.0, 0.0, 1.0
        passes = np.mean([np.abs(_phase(qs[j + 1], np.asarray(scale * layers[j].thickness_nm * x, dtype=np.float32)
                                        [..., None], k)).astype(np.float64) ** 2 for x in draws[:, j]], axis=0)
        return 0.0, passes, 0.0, passes

    def unit(a, b):  # the films between gap a and gap b (or the lower medium, b = count)
        between = media[a + 1:b + 2]
        if b == a + 1:
            return _slab(between, qs[a + 1:b + 2], [], k)
        slabs = [_slab(between, qs[a + 1:b + 2], [scale * layers[j].thickness_nm * x[j] for j in range(a + 1, b)], k)
                 for x in draws]
        return tuple(np.mean([s[i] for s in slabs], axis=0) for i in range(4))

    def segment(first, stop):  # the pile of layers first..stop - 1, from inside gap film first
        out, j = None, first
        while j < stop:
            after = next((g for g in range(j + 1, stop) if gap(g)), stop)
            part = over_sides(gap_slab(j), unit(j, after))
            out, j = part if out is None else over_sides(out, part), after
        return out

    cells = (stack.count - start - 1) // period  # whole periods above the last one
    last = segment(start + cells * period, stack.count)
    return last if not cells else over_sides(repeated(segment(start, start + period), cells), last)


def _read(values, grid, lams):
    """``values`` (on the last axis, at the evenly spaced ``grid``) at ``lams``, linearly."""
    step = grid[1] - grid[0]
    i = np.clip(((lams - grid[0]) // step).astype(int), 0, len(grid) - 2)
    w = (lams - grid[i]) / step
    return tuple(np.asarray(v)[..., i] * (1.0 - w) + np.asarray(v)[..., i + 1] * w if np.ndim(v) else v
                 for v in values)


def partial_colour(stack: FilmStack, n0: float, lower_rgb: tuple, cos0, scale, accuracy: str, lower_medium: str,
                   step: float, mode: str = "blocks"):
    """``(R, T)`` per channel (..., 3) of a disordered ``stack`` whose spread passes coherence above its lowest
    film (:func:`deep_start` below ``stack.count``), as :func:`.stack_optics.stack_colour` takes it (out of gamut
    kept): the coherent top over each draw, over the deep pile (this module's docs)."""
    start = deep_start(stack, mode)
    cos0, scale = np.asarray(cos0, dtype=float), np.asarray(scale, dtype=float)
    draws = disorder_draws(stack)
    if accuracy == "rgb":
        grid = channel_weights("rgb")[0]
    else:
        grid = 380.0 + np.arange(int(round(400.0 / step)) + 1) * step
    deep = _deep(stack, start, n0, lower_index(lower_rgb[0], lower_rgb[1], grid, lower_medium), cos0, scale, grid,
                 mode)
    R = T = 0.0
    for j, draw in enumerate(draws):
        shift = (j + 0.5) / len(draws) - 0.5 if accuracy != "rgb" else 0.0
        lams, weights = channel_weights(accuracy, step, shift)
        index = {f: film_index(f, lams) for f in stack.films}
        top = [index[f] for f in stack.layers[:start]]
        below = index[stack.layers[start]]
        thicknesses = [scale * f.thickness_nm * x for f, x in zip(stack.layers[:start], draw)]
        if any(np.any(n.imag) for n in top + [below]):
            media, qs = _media(n0, top, below, cos0, lams)
            upper = _slab(media, qs, thicknesses, (2.0 * np.pi / lams).astype(np.float32))
        else:  # nothing absorbs: the same from both sides, and what is not reflected passes
            r = reflect_transmit(n0, top, thicknesses, below, cos0, lams, polarised=True)[0].astype(np.float64)
            upper = r, 1.0 - r, r, 1.0 - r
        whole = over_sides(upper, deep if accuracy == "rgb" else _read(deep, grid, lams))
        R, T = R + 0.5 * (whole[0][0] + whole[0][1]) @ weights, T + 0.5 * (whole[1][0] + whole[1][1]) @ weights
    return R / len(draws), T / len(draws)


def stack_colour_partial(stack: FilmStack, n0: float, lower_rgb: tuple, cos0, scale, mode: str,
                         accuracy: str = "analytic", lower_medium: str = "custom"):
    """``(R, T)`` per channel as the optics give them (no gamut) of ``stack`` with its films from
    :func:`deep_start` down adding their light as power (``mode``); the coherent sum
    (:func:`.stack_optics.stack_colour`) where no film is that deep, or the stack has domains."""
    if stack.domains > 1 or deep_start(stack, mode) >= stack.count:
        return stack_colour(stack, n0, lower_rgb, cos0, scale, accuracy, lower_medium, gamut=False)
    accuracy = "rgb" if accuracy == "rgb" else "analytic"
    step = colour_step(stack, float(np.max(scale)))
    return partial_colour(stack, n0, lower_rgb, cos0, scale, accuracy, lower_medium, step, mode)
