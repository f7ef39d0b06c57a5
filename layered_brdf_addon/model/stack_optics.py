"""The optics of a film stack: reflectance and transmittance per wavelength and per channel, exact for any
number of films (the amplitudes' sums: :mod:`.stack_amplitudes`), a disordered stack averaged over draws, and
a material's stack as its shading reads it (:class:`StackResponse`).

A stack's ``disorder`` (:class:`.stack.FilmStack`) is averaged over :data:`DISORDER_DRAWS` stacks whose films'
thicknesses are drawn with that relative spread, each film on its own (stratified, a fixed seed: the same
stack bakes the same tables).  8 draws hold the average of many for spreads of a few percent, not tens; the
deeper films' light added as power (:mod:`.partial_coherence`) was measured against them and held less.

Colour: :func:`channel_weights` turns a spectrum sampled over 380-780 nm (every 5 nm, finer where the
films that interfere call for it, :func:`spectral_step`) into linear Rec.709 per channel (the CIE 1931
observer under D65, :mod:`.spectral_tables`), each channel's weights summing to 1 (a flat spectrum of 0.3
reads 0.3 in every channel): the analytic mode's colour, integrated over each channel's band, brought
within the gamut by :func:`within_gamut`.  numpy; no bpy.
"""
from __future__ import annotations

import functools
import math
import os
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, replace
from statistics import NormalDist

import numpy as np

from .dispersion import abbe_index
from .colour_gamut import within_gamut
from .incoherent import pile
from .media import medium as named_medium, spectrum
from .spectral_tables import observer, tables
from .stack_amplitudes import _mean, periodic_reflect_transmit, reflect_transmit
from .stack import FilmStack

SPECTRUM_NM = np.arange(380.0, 781.0, 5.0)  # the band every 5 nm (where a film's highest index is looked up)
DISORDER_DRAWS = 8  # stacks drawn to average a stack's disorder
DISORDER_SEED = 20031  # their seed (the same stack, the same draws)
CHANNEL_NM = (645.0, 525.0, 445.0)  # the paper's three wavelengths (the 'rgb' accuracy)

SAMPLES_PER_SPECTRAL_FRINGE = 8  # wavelengths per fringe of the whole stack at the bluest (no aliasing)
DISORDERED_SAMPLES = 4  # per fringe for each draw of a disordered stack (the draws' wavelengths interleave)
FINEST_STEP_NM = 0.5


@functools.lru_cache(maxsize=None)
def _channel_weights(step_nm: float, shift: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Wavelengths every ``step_nm`` at the middles of 380-780 nm's steps, moved by ``shift`` steps (in
    [-0.5, 0.5]: every wavelength stays in the band), and their weights."""
    o = observer()
    count = int(round(400.0 / step_nm))
    lams = 380.0 + (np.arange(count) + 0.5 + shift) * step_nm
    cmf = np.stack([np.interp(lams, o["cmf_nm"], o["cmf"][:, i]) for i in range(3)], axis=-1)
    d65 = np.interp(lams, o["d65_nm"], o["d65"])
    xyz = d65[:, None] * cmf  # (wavelengths, XYZ), each wavelength the width of one step
    rgb = xyz @ np.linalg.inv(o["rec709_to_xyz"]).T  # each wavelength's linear Rec.709
    rgb = rgb / rgb.sum(axis=0)  # a flat spectrum of 1 is (1, 1, 1)
    for a in (lams, rgb):
        a.setflags(write=False)
    return lams, rgb


def spectral_step(optical_nm: float, samples: int = SAMPLES_PER_SPECTRAL_FRINGE) -> float:
    """The wavelength step (nm) that samples the fringes of a stack of optical thickness ``optical_nm``
    (its largest ``n d``) ``samples`` times at 380 nm (a fringe is ``lambda^2 / (2 n d)`` wide): 5 nm for thin
    stacks, down to :data:`FINEST_STEP_NM`."""
    fringe = 380.0 ** 2 / (2.0 * max(optical_nm, 1e-9))
    for step in (5.0, 2.5, 1.25, 1.0, 0.5):
        if step <= fringe / samples or step == FINEST_STEP_NM:
            return step
    return FINEST_STEP_NM


def colour_step(stack: FilmStack, largest_scale: float) -> float:
    """The wavelength step of ``stack``'s colour at scales up to ``largest_scale``: :func:`spectral_step` of the
    films that interfere (:func:`coherent_optical`), :data:`DISORDERED_SAMPLES` a fringe for each draw of a
    disordered stack (each draw's wavelengths moved by its share of a step: 8 draws sample a fringe 32 times)."""
    samples = DISORDERED_SAMPLES if stack.disorder else SAMPLES_PER_SPECTRAL_FRINGE
    return spectral_step(largest_scale * coherent_optical(stack), samples)


def channel_weights(accuracy: str = "analytic", step_nm: float = 5.0, shift: float = 0.0):
    """``(wavelengths, M)``: the wavelengths a colour mode samples and the (wavelengths, 3) matrix that
    turns a spectrum there into linear Rec.709: the analytic mode sums 380-780 nm every ``step_nm`` (each
    channel's band, :func:`spectral_step`; ``shift``: the wavelengths moved by that share of a step),
    ``spectralN`` its N wavelengths (:func:`.spectral_tables.tables`), ``rgb`` the paper's three
    wavelengths, one per channel."""
    if accuracy == "rgb":
        return np.asarray(CHANNEL_NM), np.eye(3)
    if accuracy.startswith("spectral"):
        t = tables(int(accuracy[len("spectral"):]))
        return np.asarray(t["wavelengths"], dtype=float), np.asarray(t["rgb"], dtype=float)
    return _channel_weights(float(step_nm), float(shift))


def _cauchy(values_rgb, wavelengths) -> np.ndarray:
    """A quadratic in ``1 / lambda^2`` through three values at the channels' wavelengths (n or k of a
    medium given per channel), at ``wavelengths``."""
    x = 1.0 / np.asarray(CHANNEL_NM) ** 2
    coefficients = np.linalg.solve(np.stack([np.ones(3), x, x * x], axis=-1), np.asarray(values_rgb, dtype=float))
    w = 1.0 / np.asarray(wavelengths, dtype=float) ** 2
    return coefficients[0] + coefficients[1] * w + coefficients[2] * w * w


def _measured(name: str, wavelengths) -> np.ndarray:
    """A named medium's ``n + i k`` at ``wavelengths``: :func:`.media.spectrum`'s linear reading of its samples
    (and its error outside them), numpy's for the thousands of wavelengths a band summed finely takes."""
    lams = np.asarray(wavelengths, dtype=float)
    spectrum(name, [float(lams.min()), float(lams.max())] if lams.size else [])
    m = named_medium(name)
    return np.interp(lams, m.wavelengths, m.n_spectrum) + 1j * np.interp(lams, m.wavelengths, m.k_spectrum)


def film_index(film, wavelengths) -> np.ndarray:
    """A film's complex index ``n + i k`` at ``wavelengths`` (nm)."""
    if film.medium:
        return _measured(film.medium, wavelengths)
    lams = np.asarray(wavelengths, dtype=float)
    return abbe_index(film.ior, film.dispersion, lams) + 1j * film.k


def lower_index(r2, k2, wavelengths, medium: str = "custom") -> np.ndarray:
    """The lower medium's complex index at ``wavelengths``: a named medium's measured spectrum, or the
    three per-channel values ``r2``, ``k2`` joined by a Cauchy law (n at least 0.01, k at least 0)."""
    if medium and medium != "custom":
        return _measured(medium, wavelengths)
    n = np.maximum(_cauchy(r2, wavelengths), 0.01)
    k = np.maximum(_cauchy(k2, wavelengths), 0.0)
    return n + 1j * k


def disorder_draws(stack: FilmStack) -> np.ndarray:
    """Each draw's thickness factor per film, (draws, films): 1 for a stack without disorder (one
    draw); else :data:`DISORDER_DRAWS` draws of ``1 + disorder g``, ``g`` standard normal, kept above
    0.05 (the same draws for the same stack).  Stratified (a Latin hypercube): each film takes every one
    of the normal's :data:`DISORDER_DRAWS` quantiles once, in an order of its own, so that 8 draws average
    a stack as a few dozen independent ones would (measured: benchmarks/stack_table.py --tables draws)."""
    if not stack.disorder:
        return np.ones((1, stack.count))
    rng = np.random.default_rng(DISORDER_SEED)
    quantiles = np.array([NormalDist().inv_cdf((k + 0.5) / DISORDER_DRAWS) for k in range(DISORDER_DRAWS)])
    g = np.stack([quantiles[rng.permutation(DISORDER_DRAWS)] for _ in range(stack.count)], axis=1)
    return np.maximum(1.0 + stack.disorder * g, 0.05)


COHERENCE_SPREAD_NM = 95.0  # optical thickness spread past which a disordered stack's films no longer interfere
# (a spread of ``n d`` of 95 nm spreads the round trip's phase by pi at 380 nm)


@functools.lru_cache(maxsize=1024)
def film_optical(film) -> float:
    """A film's optical thickness (nm, ``n d`` at its highest index over the band)."""
    return film.thickness_nm * float(np.max(film_index(film, SPECTRUM_NM).real))


def coherent_films(stack: FilmStack) -> int:
    """How many films from the top interfere: all without disorder; with it, those above the film where the
    spread of their optical thickness passes :data:`COHERENCE_SPREAD_NM`, at least one period."""
    spread = 0.0
    for k, f in enumerate(stack.layers):
        spread += (film_optical(f) * stack.disorder) ** 2
        if k >= len(stack.films) and spread > COHERENCE_SPREAD_NM ** 2:
            return k
    return stack.count


def coherent_optical(stack: FilmStack) -> float:
    """The optical thickness (nm, ``sum n d`` at scale 1) of the films that interfere (:func:`coherent_films`;
    deeper films add their light as incoherent films do, :mod:`.partial_coherence`).  It sets how finely the
    stack's colour is sampled in wavelength and thickness."""
    return sum(film_optical(f) for f in stack.layers[:coherent_films(stack)])


def films_absorb(stack: FilmStack, wavelengths=SPECTRUM_NM) -> bool:
    """Whether a film of ``stack`` absorbs at any of ``wavelengths`` (else the stack passes into the medium under
    it exactly what it does not reflect)."""
    return any(bool(np.any(film_index(f, wavelengths).imag > 0.0)) for f in stack.films)


def stack_spectra(stack: FilmStack, n0: float, lower, cos0, scale, wavelengths, draw=None, polarised=False):
    """``(R, T)`` of ``stack`` scaled by ``scale`` (broadcasting with ``cos0``) at ``wavelengths``: arrays of
    shape ``broadcast(cos0, scale) + (L,)``; ``draw``: the films' thickness factors of one draw of its
    disorder (:func:`disorder_draws`), or None (none); ``polarised``: s and p on a first axis.  Domains
    (:mod:`.incoherent`): one in the medium above on both sides, one on the lower medium, piled per polarisation."""
    lams = np.asarray(wavelengths, dtype=float)
    if stack.domains > 1:
        one, around = replace(stack, domains=1), np.full(lams.shape, n0 + 0j)
        clear = not films_absorb(stack, lams)  # then what is not reflected passes
        domain = stack_spectra(one, n0, around, cos0, scale, lams, draw, True)
        last = domain if np.allclose(lower, around) else stack_spectra(one, n0, lower, cos0, scale, lams, draw, True)
        R, T = pile(domain, last, stack.domains, (clear, clear and not np.any(np.imag(lower))))
        return _mean(R, polarised), _mean(T, polarised)
    cos0, scale = np.asarray(cos0, dtype=float), np.asarray(scale, dtype=float)  # broadcast as the phases are
    if draw is None and stack.periods > 1:
        return periodic_reflect_transmit(n0, [film_index(f, lams) for f in stack.films], [scale * f.thickness_nm for f
                                         in stack.films], stack.periods, lower, cos0, lams, polarised)
    factors = np.ones(stack.count) if draw is None else draw
    index = {f: film_index(f, lams) for f in stack.films}  # one array per film of the period: shared work
    return reflect_transmit(n0, [index[f] for f in stack.layers],
                            [scale * f.thickness_nm * x for f, x in zip(stack.layers, factors)], lower, cos0, lams,
                            polarised)


SCALE_FREE_SAMPLES = 32  # values of s / lambda a fringe (linear between them: 0.5% of a fringe), and wavelengths
# as finely in the phase the media's dispersion moves
LEAST_WAVELENGTH_NODES = 5  # wavelengths a stack whose media disperse is computed at, at least (every 100 nm)
LOWER_SPREAD_A_NODE = 0.1  # how far the lower medium's n + k moves between two wavelengths computed, at most
CALL_POINTS = 4096  # points whose sums cost what a sum's numpy calls cost (each wavelength computed is a sum)


def _spread(index) -> float:
    return float(np.ptp(np.real(index)) + np.ptp(np.imag(index)))


def grid_colour(stack: FilmStack, n0: float, lower_at, cos0, scale, accuracy: str, step: float, draws):
    """``(R, T)`` per channel of :func:`stack_colour` on a grid of cosines ``(C, 1)`` and scales ``(1, M)``, averaged
    over ``draws`` (:func:`disorder_draws`, or ``[None]``), from the stack computed along ``u = s / lambda``; None
    where computing every pair costs less (a few scales, films that disperse strongly) or the grid is not one.

    A film's phase is ``2 pi u`` times its ``n d cos``, and every boundary's amplitudes depend on the media's indices
    only: where no film disperses, the films summed at one wavelength along :data:`SCALE_FREE_SAMPLES` values of
    ``u`` a fringe of the whole stack hold every scale and wavelength, read linearly between them (labradorite's
    tables: 881 values of ``u`` where its 102 rows and 400 wavelengths make 40,800 pairs); a lower medium that
    disperses takes that sum as a map of its boundary's amplitude (:func:`.stack_amplitudes.reflect_transmit`),
    applied at wavelengths where its index moves by :data:`LOWER_SPREAD_A_NODE` at most between two (a metal's
    steep spectrum).  Where films disperse, the stack is computed so at a few wavelengths
    (:data:`LEAST_WAVELENGTH_NODES`, more where their indices move their phase by more than a
    :data:`SCALE_FREE_SAMPLES`-th of a fringe between two).  Between the wavelengths computed, linearly too: each
    computed for the values of ``u`` its neighbours' band reads only.  The draws share the values of ``u``: their
    mean is read once, at every draw's wavelengths (each draw's moved by its share of a step, :func:`stack_colour`:
    together a step ``len(draws)`` times finer).  The readings and the band's weights are one matrix per
    wavelength computed (``u`` to each scale's channels).  ``lower_at``: the lower medium's index at given
    wavelengths."""
    cos0, scale = np.asarray(cos0, dtype=float), np.asarray(scale, dtype=float)
    if not (cos0.ndim == 2 and scale.ndim == 2 and cos0.shape[1] == 1 and scale.shape[0] == 1):
        return None
    lams, weights = channel_weights(accuracy, step / len(draws) if accuracy == "analytic" else step)
    pairs = cos0.shape[0] * scale.size * lams.size  # every draw's pairs (its wavelengths a share of these)
    plan = _along_u(stack, lower_at(lams), cos0.shape[0], scale, lams, draws, pairs) if lams.size > 1 else None
    if plan is None:
        return None
    u, coarse, mapped = plan
    below = lower_at(coarse)
    rows = scale.shape[1]
    at = (scale[0][:, None] / lams[None, :] - u[0]) / (u[1] - u[0])  # (M, L): where each pair's s / lambda lies
    i = np.clip(at.astype(int), 0, len(u) - 2)
    w = np.clip(at - i, 0.0, 1.0)

    def summed(lam, lower, band):  # the draws' mean along u[band], at ``lam`` over ``lower``
        R = T = 0.0
        for draw in draws:
            r, t = stack_spectra(stack, n0, lower, cos0, (u[band] * lam)[None, :], np.array([lam]), draw)
            R, T = R + r, T + t
        return R / len(draws), T / len(draws)

    whole = summed(coarse[0], below, slice(None)) if mapped else None  # (C, U, nodes)
    out = [np.zeros(cos0.shape[:1] + (rows, 3)), np.zeros(cos0.shape[:1] + (rows, 3))]
    for node, lam in enumerate(coarse):
        share = np.interp(lams, coarse, np.eye(len(coarse))[node])  # (L,): this wavelength's part (1 for one)
        ls = np.flatnonzero(share)
        if not ls.size:
            continue
        first, last = int(i[:, ls].min()), int(i[:, ls].max()) + 2  # the values of u this band reads
        band = slice(first, last)
        R, T = ([x[..., band, node] for x in whole] if mapped else
                [x[..., 0] for x in summed(lam, below[node:node + 1], band)])
        matrix = _reading(i[:, ls] - first, w[:, ls], share[ls, None] * weights[ls], last - first)  # (U, M * 3)
        for o, x in zip(out, (R, T)):
            o += np.einsum("cu,uk->ck", x, matrix).reshape(o.shape)  # no BLAS threads beside the pool's
    return out[0], out[1]


def _along_u(stack: FilmStack, lower, cosines: int, scale, lams, draws, pairs: int):
    """``(u, wavelengths, mapped)``: the values of ``u = s / lambda`` (every draw's fringes sampled) and the
    wavelengths :func:`grid_colour` computes the stack at, and whether the films are summed once for all of them (no
    film disperses); or None where computing the ``pairs`` costs less."""
    index = {f: film_index(f, lams) for f in stack.films}
    factors = [np.ones(stack.count) if draw is None else np.asarray(draw) for draw in draws]
    optical = max(sum(f.thickness_nm * x * float(np.max(np.abs(index[f]))) for f, x in zip(stack.layers, factor))
                  for factor in factors)
    moved = max(sum(f.thickness_nm * x * _spread(index[f]) for f, x in zip(stack.layers, factor))  # nm of n d
                for factor in factors)
    lo, hi = float(np.min(scale)) / lams.max(), float(np.max(scale)) / lams.min()
    count = max(math.ceil((hi - lo) * 2.0 * optical * SCALE_FREE_SAMPLES) + 2, 2)
    mapped = moved == 0.0 and _spread(lower) > 0.0
    if mapped:
        nodes = max(math.ceil(_spread(lower) / LOWER_SPREAD_A_NODE) + 1, LEAST_WAVELENGTH_NODES)
        sums = 2 * len(draws)  # a map's sum costs two
    else:
        nodes = 1 if moved == 0.0 else max(math.ceil(2.0 * hi * moved * SCALE_FREE_SAMPLES) + 1,
                                           LEAST_WAVELENGTH_NODES)
        sums = len(draws) * nodes
    if 2 * sums * (cosines * count + CALL_POINTS) >= pairs:  # half the cost, at most
        return None
    if nodes > 1 and np.any(np.diff(lams) <= 0.0):  # read between wavelengths in order only (not 'rgb''s three)
        return None
    if not hi > lo:  # every scale 0 (no films' thickness): nothing to read along
        return None
    return (np.linspace(lo, hi, count), (np.linspace(lams.min(), lams.max(), nodes) if nodes > 1 else lams[:1]),
            mapped)


def _reading(i, w, weights, count: int) -> np.ndarray:
    """The (U, M * 3) matrix that takes a spectrum along ``count`` values of ``u`` to each scale's channels: pair
    ``(m, l)`` reads ``u`` values ``i`` and ``i + 1`` (weights ``1 - w`` and ``w``), wavelength ``l`` weighs
    ``weights[l]``."""
    rows = i.shape[0]
    matrix = np.zeros((count * rows, 3))
    for at, part in ((i, 1.0 - w), (i + 1, w)):
        where = (at * rows + np.arange(rows)[:, None]).ravel()  # (u, m) flattened
        for c in range(3):
            matrix[:, c] += np.bincount(where, (part * weights[None, :, c]).ravel(), minlength=count * rows)
    return matrix.reshape(count, rows * 3)


def stack_colour(stack: FilmStack, n0: float, lower_rgb: tuple, cos0, scale, accuracy: str = "analytic",
                 lower_medium: str = "custom", gamut: bool = True, step_nm: float | None = None):
    """``(R, T)`` per channel, linear Rec.709 (..., 3), of ``stack`` at outside cosines ``cos0`` and
    scales ``scale`` (broadcasting), over a lower medium given per channel (``lower_rgb``: ``(r2, k2)``)
    or named; the colour as ``accuracy`` sees it (:func:`channel_weights`: 'rgb' the paper's three
    wavelengths, every other mode the band summed finely).

    A disordered stack is averaged over its draws (:func:`disorder_draws`), each summed on wavelengths
    moved by its share of a step: what a draw's fine fringes alias to, the draws average out (the analytic
    mode's step follows the fringes of the films that interfere, :func:`coherent_optical`); on a grid read
    along ``s / lambda`` (:func:`grid_colour`) every draw is read at all the draws' wavelengths.  A colour outside
    Rec.709's gamut (a saturated Bragg peak) is held within it channel by channel, ``R`` in [0, 1] and ``T``
    in [0, 1 - R] (``gamut=False``: as the optics give it).  ``step_nm``: the wavelength step, where the caller
    chose it for more points than these (:func:`spectral_step` of the largest scale otherwise).  Every film is
    summed coherently in each draw (:mod:`.partial_coherence` adds the deeper films' light as power instead:
    measured farther from the average of many draws)."""
    # Baked into tables, a stack's colour costs nothing per sample: every banded mode (analytic, spectralN)
    # sums the whole band finely; 'rgb' keeps the paper's three wavelengths.
    accuracy = "rgb" if accuracy == "rgb" else "analytic"
    step = colour_step(stack, float(np.max(scale))) if step_nm is None else step_nm
    draws = [None] if not stack.disorder else list(disorder_draws(stack))

    def lower_at(lams):
        return lower_index(*lower_rgb, lams, lower_medium)

    read = grid_colour(stack, n0, lower_at, cos0, scale, accuracy, step, draws)
    if read is not None:
        R, T = read
    else:
        R = T = 0.0
        for k, draw in enumerate(draws):
            shift = (k + 0.5) / len(draws) - 0.5 if accuracy == "analytic" and len(draws) > 1 else 0.0
            lams, weights = channel_weights(accuracy, step, shift)
            r, t = stack_spectra(stack, n0, lower_at(lams), cos0, scale, lams, draw)
            R, T = R + r @ weights, T + t @ weights
        R, T = R / len(draws), T / len(draws)
    # A saturated stack's colour can lie outside Rec.709 (a negative channel), which a closure's weight
    # cannot hold: each channel within [0, 1] (within_gamut), what the films absorb kept, and what passes
    # within what is not reflected.
    if not gamut:  # the optics' own colour (compared with thin-film optics)
        return R, T
    absorbed = 1.0 - R - T
    R = within_gamut(R)
    return R, np.clip(1.0 - R - absorbed, 0.0, 1.0 - R)


PAIRS_PER_THREAD = 256  # points a thread takes at least
HEMISPHERE_NODES = 8  # Gauss-Legendre nodes in cos^2 for a stack's mean reflectance over the hemisphere


@dataclass(frozen=True)
class StackResponse:
    """A material's stack as its shading reads it: ``(R, T)`` per channel at outside cosines and layer
    thicknesses (nm, the stack's total: each film scaled by ``d / total``), with the material's outside
    index, lower medium and colour mode (:meth:`of`)."""

    stack: FilmStack
    n0: float
    lower_rgb: tuple
    lower_medium: str = "custom"
    accuracy: str = "analytic"

    @classmethod
    def of(cls, params) -> "StackResponse":
        """The response of ``params``'s stack (a :class:`~.params.LayeredParams` with one): under the outside, or
        tilted lamellae in a crystal of the layer's index (:mod:`.shading.lamella_shade`)."""
        above = params.r1[1] if params.normal_mode == "tilted" else params.r0
        return cls(params.stack, float(above), (tuple(params.r2), tuple(params.k2)), params.lower_medium,
                   params.accuracy)

    def scale(self, d):
        return np.asarray(d, dtype=float) / self.stack.total_nm

    def colour(self, cos0, d):
        """``(R, T)`` per channel (..., 3) at outside cosines ``cos0`` and thicknesses ``d`` (broadcasting),
        each distinct pair computed once.  Where the points are a grid (a table's texels: every cosine at
        every thickness), the boundaries' amplitudes are computed once per cosine, not per texel
        (:func:`stack_spectra` broadcasts the cosines against the scales)."""
        cos0, d = np.broadcast_arrays(np.asarray(cos0, dtype=float), np.asarray(d, dtype=float))
        cosines, at_cos = np.unique(cos0.ravel(), return_inverse=True)
        rows, at_row = np.unique(d.ravel(), return_inverse=True)
        if len(cosines) * len(rows) <= 2 * cos0.size:  # a grid
            R, T = self._computed(cosines[:, None], self.scale(rows)[None, :])
            at = (np.asarray(at_cos).ravel(), np.asarray(at_row).ravel())
        else:
            pairs, where = np.unique(np.stack([cos0.ravel(), d.ravel()], axis=-1), axis=0, return_inverse=True)
            R, T = self._computed(pairs[:, 0], self.scale(pairs[:, 1]))
            at = (np.asarray(where).ravel(),)
        return R[at].reshape(cos0.shape + (3,)), T[at].reshape(cos0.shape + (3,))

    def _computed(self, cosines, scales):
        """:func:`stack_colour` at ``cosines`` and ``scales``, both (N, 1) and (1, M) (a grid) or (P,) (pairs),
        the first axis split between the machine's cores (numpy lets go of Python's lock in its array loops)."""
        step = colour_step(self.stack, float(np.max(scales)))
        grid = cosines.ndim == 2
        points = np.broadcast_shapes(cosines.shape, scales.shape)
        workers = max(1, min(os.cpu_count() or 1, int(np.prod(points)) // PAIRS_PER_THREAD, len(cosines)))
        parts = np.array_split(np.arange(len(cosines)), workers)

        def part(index):
            return stack_colour(self.stack, self.n0, self.lower_rgb, cosines[index], scales if grid else scales[index],
                                self.accuracy, self.lower_medium, step_nm=step)

        with ThreadPoolExecutor(workers) as pool:
            done = list(pool.map(part, parts))
        return tuple(np.concatenate([np.broadcast_to(d[k], (len(i),) + points[1:] + (3,)) for d, i in zip(done, parts)])
                     for k in (0, 1))

    def hemispherical(self, d):
        """``(R, T)`` averaged over the hemisphere, cosine-weighted (what light scattered under the stack
        meets on its way out), per channel (..., 3) at thicknesses ``d``."""
        return hemispherical_mean(self.colour, d)


def hemispherical_mean(colour, d):
    """``colour(cos0, d)``'s ``(R, T)`` averaged over the hemisphere, cosine-weighted, at thicknesses ``d``:
    Gauss-Legendre in ``cos^2`` (:data:`HEMISPHERE_NODES` cosines)."""
    x, w = np.polynomial.legendre.leggauss(HEMISPHERE_NODES)
    cos2 = 0.5 * (x + 1.0)  # uniform in cos^2: the cosine weight
    d = np.asarray(d, dtype=float)
    R, T = colour(np.sqrt(cos2).reshape((-1,) + (1,) * d.ndim), d[None])
    return np.tensordot(0.5 * w, R, axes=(0, 0)), np.tensordot(0.5 * w, T, axes=(0, 0))
