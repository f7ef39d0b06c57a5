"""A film stack's amplitudes summed: reflectance and transmittance, exact for any number of films.

Thin-film optics (Born & Wolf §1.6) for a stack between the outside medium (real index ``n0``)
and the lower medium (complex ``n2 + i k2``), every film with its complex index ``n + i k`` per
wavelength.  The reflection amplitude is summed from the bottom up (Rouard's method, the
transfer-matrix product written as a recursion): with ``r_{j,j+1}`` and ``t_{j,j+1}`` the
Fresnel amplitudes of the boundary under film ``j`` and ``beta_j = 2 pi n~_j d_j cos~_j / lambda``
its phase thickness, ``r_j = (r_{j-1,j} + r_{j+1}' e^{2 i beta_j}) / (1 + r_{j-1,j} r_{j+1}' e^{2 i beta_j})``,
and likewise the transmission amplitude.  ``Im beta_j >= 0`` (the root that decays into an
absorbing film), so ``e^{2 i beta}`` never grows: films of ``k`` up to 10 and microns of thickness
stay finite, where the product of transfer matrices overflows (:func:`reflect_transmit`, in single
precision, carries ``r_j`` as a numerator and a denominator, products and sums only, and divides them
every few films: :func:`_renormalised`).  A periodic stack without disorder is its period combined with
itself by Redheffer star products, ``log2(periods)`` of them (:func:`periodic_reflect_transmit`).
Reflectance and transmittance are the means of the s and p polarisations (unpolarised light); ``T`` is
the power that enters the lower medium (absorbed there where it absorbs), ``1 - R - T`` what the films
absorb.  numpy; no bpy.
"""
from __future__ import annotations

import math

import numpy as np

from .incoherent import repeated

MIN_COS = 1.0e-6  # the most grazing outside cosine the optics take


def _cos_inside(n, n0_sin):
    """``n cos theta`` inside a medium of complex index ``n`` for the invariant ``n0 sin theta0``:
    the root with a non-negative imaginary part (the wave that decays, or leaves, downwards)."""
    q = np.sqrt(n * n - n0_sin * n0_sin + 0j)
    return np.where(q.imag < 0.0, -q, q)


def _star(a, b):
    """The scattering amplitudes ``(r, t, r', t')`` of sub-stack ``a`` over sub-stack ``b`` (Redheffer's
    star product: the bounces between them summed), ``r``/``t`` for light from above, ``r'``/``t'`` from
    below; stable where the amplitudes are at most 1 in size."""
    ra, ta, rb_a, tb_a = a
    rb, tb, rb_b, tb_b = b
    inv = 1.0 / (1.0 - rb_a * rb)
    return ra + ta * rb * tb_a * inv, ta * tb * inv, rb_b + tb_b * rb_a * tb * inv, tb_b * tb_a * inv


def _power(cell, count: int):
    """``cell`` star ``cell`` ... ``count`` times, by squaring (``log2 count`` products)."""
    return repeated(cell, count, _star)


def _interface(na, qa, nb, qb):
    """Per polarisation (s, p), the amplitudes ``(r, t, r', t')`` of the boundary from a medium of index
    ``na`` (``qa = na cos``) into one of ``nb``: Fresnel's, one division each.  ``r' = -r``, ``t = 1 + r``
    and ``t' = 1 - r`` (s), ``t = (na / nb)(1 + r)`` and ``t' = (nb / na)(1 - r)`` (p, with
    ``r = (nb^2 qa - na^2 qb) / (nb^2 qa + na^2 qb)``)."""
    rs = (qa - qb) / (qa + qb)
    a, b = nb * nb * qa, na * na * qb
    rp = (a - b) / (a + b)
    ratio = na / nb
    s_ = (rs, 1.0 + rs, -rs, 1.0 - rs)
    p_ = (rp, ratio * (1.0 + rp), -rp, (1.0 - rp) / ratio)
    return [s_, p_]


def _phase(q, d, k):
    """``e^{i q d k}`` (a film's crossing: ``q = n cos`` complex, ``d`` its thickness, ``k = 2 pi / lambda``),
    single precision.  Thicknesses evenly spaced along their second last axis where ``q`` does not change
    along it (a table's rows): each row a product of two crossings computed for a few rows (:func:`_rows_phase`)."""
    d = np.asarray(d)
    return _rows_phase(q, d, k) if _even_rows(q, d) else _crossing(q, d, k)


def _crossing(q, d, k):
    """:func:`_phase` from real functions (``e^{-Im} (cos + i sin)``: numpy's complex exponential is several
    times slower)."""
    s = d.astype(np.float32) * k
    out = np.empty(np.broadcast_shapes(np.shape(q), np.shape(s)), dtype=np.complex64)
    angle = q.real * s
    out.real, out.imag = np.cos(angle), np.sin(angle)
    if np.any(q.imag):  # a film that absorbs (e^{-0} is 1: a clear film's crossing skips it, the same values)
        fade = np.exp(-(q.imag * s))
        out.real *= fade
        out.imag *= fade
    return out


def _even_rows(q, d) -> bool:
    """Whether ``d`` (..., M, 1) steps evenly along its rows (M of at least 9) where ``q`` does not change."""
    if d.ndim < 2 or d.shape[-1] != 1 or d.shape[-2] < 9 or (np.ndim(q) >= 2 and np.shape(q)[-2] != 1):
        return False
    steps = np.diff(d, axis=-2)
    first = steps[..., :1, :]  # allclose's test, without its overhead (it runs for every film of every sum)
    return bool(np.all(np.abs(steps - first) <= 1e-12 * float(np.max(np.abs(d))) + 1e-9 * np.abs(first)))


def _rows_phase(q, d, k):
    """:func:`_phase` along M evenly spaced rows ``d_0 + m h``: with ``m = a B + b`` (B about ``sqrt M``),
    ``e^{i q k (d_0 + a B h)} e^{i q k b h}``, the crossings computed for 2 ``sqrt M`` rows and one product a
    texel."""
    rows = d.shape[-2]
    block = math.isqrt(rows - 1) + 1
    h = d[..., 1:2, :] - d[..., :1, :]
    starts = _crossing(q, d[..., ::block, :], k)  # (..., A, L)
    within = _crossing(q, h * np.arange(block)[:, None], k)  # (..., B, L)
    out = starts[..., :, None, :] * within[..., None, :, :]
    return out.reshape(out.shape[:-3] + (-1, out.shape[-1]))[..., :rows, :]


def _through(cell, phase):
    """``cell`` over a film's crossing (phase ``e^{i beta}`` each way, no bounce): ``cell`` star the film,
    in a product's worth of multiplications."""
    r, t, rb, tb = cell
    phase2 = phase * phase
    return r, t * phase, rb * phase2, tb * phase


RENORMALISE_FILMS = 16  # films summed at most between divisions by the bounces' denominator (2^16 its growth)
SMALLEST_DENOMINATOR = 1e-20  # how far it may shrink before a division (single precision's least normal 1e-38)


def _renormalised(bounds) -> set:
    """The films (their boundaries' indices in ``bounds``) after whose step the sum divides by its denominator:
    it grows at most 2x a film (``|r| <= 1``) and shrinks at most by ``1 - |r_b|`` (``1 + r_b r e^{2 i beta}``),
    which light near grazing in a film of about the outside's index brings to a millionth: a division once
    :data:`RENORMALISE_FILMS` films or a shrinking to :data:`SMALLEST_DENOMINATOR`, whichever comes first."""
    out, films, shrink = set(), 0, 1.0
    for j in range(len(bounds) - 1, 0, -1):
        films += 1
        shrink *= max(1.0 - float(np.max(np.abs(bounds[j - 1][0]))), 0.0)
        if films == RENORMALISE_FILMS or shrink < SMALLEST_DENOMINATOR or j == 1:
            out.add(j)
            films, shrink = 0, 1.0
    return out


def _power_ratio(ts, tp, n0, q0, n2, q2, polarised=False):
    """Unpolarised transmittance (the power into the lower medium) from the amplitudes (``polarised``: s, p)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        Ts = np.abs(ts) ** 2 * np.real(q2) / np.real(q0)
        # p: the power ratio with the cosines conjugated (the amplitudes are of the electric field)
        Tp = np.abs(tp) ** 2 * np.real(n2 * np.conj(q2 / n2)) / np.real(n0 * np.conj(q0 / n0))
    return np.clip(np.nan_to_num(np.where(np.real(q0) > 0.0, _mean(np.stack([Ts, Tp]), polarised), 0.0)), 0.0, 1.0)


def _mean(sp, polarised: bool):
    """The mean of the s and p values on the first axis (unpolarised light), or both where ``polarised``."""
    return sp if polarised else 0.5 * (sp[0] + sp[1])


def _media(n0, indices, lower, cos0, lams):
    # At exactly grazing light every boundary reflects all (|r| = 1) and the bounces' sum is 0 / 0: a
    # millionth off grazing, the stack reflects all but a millionth.
    c0 = np.clip(np.asarray(cos0, dtype=float), MIN_COS, 1.0)[..., None]
    n0_sin = n0 * np.sqrt(1.0 - c0 * c0)
    single = {}  # one single-precision array per index array (the films of a period share theirs)
    media = [np.full(lams.shape, n0 + 0j, dtype=np.complex64)] + \
        [single.setdefault(id(n), np.asarray(n, dtype=np.complex64)) for n in list(indices) + [lower]]
    cosines = {}  # a medium's cosines, once for the films that share its index array
    for n in media:
        if id(n) not in cosines:
            cosines[id(n)] = _cos_inside(n.astype(complex), n0_sin).astype(np.complex64)  # grazing kept off 0
    return media, [cosines[id(n)] for n in media]


def reflect_transmit(n0: float, indices, thicknesses, lower, cos0, wavelengths, polarised=False):
    """Unpolarised ``(R, T)`` of a stack, broadcast over ``cos0`` (the outside cosines, any shape ``S``)
    and ``wavelengths`` (shape ``(L,)``): arrays of shape ``S + (L,)``.

    ``indices``: one complex array (L,) per film, top first; ``thicknesses``: one thickness (nm) per
    film, each a number or an array broadcasting with ``S`` (a stack scaled point by point);
    ``lower``: the lower medium's complex index (L,); ``polarised``: s and p on a first axis.

    ``lower`` may instead hold N indices where ``wavelengths`` holds one (the films' indices and phases those
    at that wavelength: a stack computed along ``s / lambda``, over a lower medium that disperses): the films
    are summed once, as the map of the lowest boundary's amplitude ``r_b`` to the stack's (each film's step is
    linear in the sum's numerator and denominator), and the arrays are of shape ``S + (N,)``, one per lower
    index.  The map is carried as two sums: from the middle index's amplitude ``r_m`` (a stack's own sum) and
    from a unit step of it, ``((r_b - r_m) A + B) / ((r_b - r_m) C + D)``: where the index moves little, a small
    correction to one sum, as precise as it near grazing (from ``r_b = 1`` and ``0``, in single precision, the
    two nearly cancelled: R up to 0.15 off a chitin-air mirror's at 89.9 degrees)."""
    lams = np.asarray(wavelengths, dtype=float)
    media, qs = _media(n0, indices, lower, cos0, lams)
    # The sum runs in single precision (the films' many steps at half the cost; R within 1e-4 of double), both
    # polarisations at once (s and p on a first axis: each film's phase computed once for both)
    bounds, seen = [], {}
    for j in range(len(media) - 1):  # each pair's boundary once (a period's films repeat)
        pair = (id(media[j]), id(media[j + 1]))
        if pair not in seen:
            (rs, ts, _, _), (rp, tp, _, _) = _interface(media[j], qs[j], media[j + 1], qs[j + 1])
            seen[pair] = (np.stack(np.broadcast_arrays(rs, rp)), np.stack(np.broadcast_arrays(ts, tp)))
        bounds.append(seen[pair])
    # Where no film absorbs, what is not reflected enters the lower medium (R + T = 1, whether or not it absorbs
    # there): the transmitted amplitude is not summed
    lossless = not any(np.any(m.imag) for m in media[:-1])
    k = (2.0 * np.pi / lams).astype(np.float32)
    thick = [np.asarray(x, dtype=float)[..., None] for x in thicknesses]
    mapped = np.size(lower) > lams.size  # the sum as a map of the lowest boundary's amplitude
    ends = [b[0].shape[1:] for b in (bounds[:-1] if mapped else bounds[-1:])]
    shape = (2,) + np.broadcast_shapes(*ends, *(q.shape for q in qs[1:len(qs) - 1 if mapped else 2]),
                                       *(x.shape for x in thick))
    # r = num / den (and t = tn / den): each film's step is products and sums, in place, no division; mapped,
    # the columns (num, den) carried from a unit step of r_b and from the middle index's r_m
    r_last = bounds[-1][0]
    middle = r_last[..., r_last.shape[-1] // 2, None]  # r_m
    starts = ((1.0, 0.0), (middle, 1.0)) if mapped else ((r_last, 1.0),)
    columns = [tuple(np.full(shape, x, dtype=np.complex64) for x in c) for c in starts]  # C order (a copy of a
    # broadcast view keeps its strides' order: every later step then runs across memory)
    tmp = np.empty(shape, dtype=np.complex64)
    tn = None if lossless else np.full(shape, 1.0 if mapped else bounds[-1][1], dtype=np.complex64)
    divisions = _renormalised(bounds)
    for j in range(len(media) - 2, 0, -1):  # film j (media[j]), from the bottom up
        rb, tb = bounds[j - 1]
        if lossless:
            phase2 = _phase(qs[j], 2.0 * thick[j - 1], k)  # e^{2 i beta}, |.| <= 1
        else:
            phase = _phase(qs[j], thick[j - 1], k)  # e^{i beta}
            phase2 = phase * phase
            tn *= phase
            tn *= tb  # t_j = tb t e^{i beta} / (1 + rb r e^{2 i beta})
        for num, den in columns:
            np.multiply(num, phase2, out=tmp)
            np.multiply(den, rb, out=num)
            num += tmp  # r_j = (rb + r e^{2 i beta}) / (1 + rb r e^{2 i beta})
            tmp *= rb
            den += tmp
        if j in divisions:  # by the last column's denominator (a stack's own: mapped, over r_m)
            den = columns[-1][1]
            for x in [x for c in columns for x in c if x is not den] + ([] if tn is None else [tn]):
                x /= den
            den[...] = 1.0
    if mapped:  # the stack over each lower index
        (a, c), (b, d) = columns
        r_b, t_b = bounds[-1]
        delta = r_b - middle
        den = delta * c + d
        r, t = (delta * a + b) / den, (None if lossless else t_b * tn / den)
    else:
        r, t = columns[0][0], tn
    R = np.clip(_mean(np.abs(r) ** 2, polarised), 0.0, 1.0)
    if lossless:
        return R, 1.0 - R
    return R, _power_ratio(t[0], t[1], media[0], qs[0], media[-1], qs[-1], polarised)


def periodic_reflect_transmit(n0: float, indices, thicknesses, periods: int, lower, cos0, wavelengths,
                              polarised=False):
    """:func:`reflect_transmit` of a period of films (``indices``, ``thicknesses``) repeated ``periods``
    times, at the cost of ``log2 periods`` star products: the period as a cell in the first film's medium
    (through each film and across each boundary, back into the first film), raised to the power of the
    periods; the stack is the outside's boundary into the first film, the cells, and the first film's
    boundary into the lower medium (a film of no thickness changes nothing)."""
    lams = np.asarray(wavelengths, dtype=float)
    media, qs = _media(n0, indices, lower, cos0, lams)
    films = len(indices)
    # In single precision, as reflect_transmit: each boundary once, for both polarisations
    single = [q.astype(np.complex64) for q in qs]
    index = [m.astype(np.complex64) for m in media]
    k = (2.0 * np.pi / lams).astype(np.float32)

    def boundary(a, b):
        return _interface(index[a], single[a], index[b], single[b])

    crossings = [_phase(single[j], np.asarray(thicknesses[j - 1], dtype=float)[..., None], k)
                 for j in range(1, films + 1)]
    inner = [boundary(j, j + 1 if j < films else 1) for j in range(1, films + 1)]  # the last into the next period
    top, bottom = boundary(0, 1), boundary(1, len(media) - 1)
    out = []
    for pol in (0, 1):  # s, p
        cell = None
        for j in range(1, films + 1):
            phase = crossings[j - 1]
            cell = (np.zeros_like(phase), phase, np.zeros_like(phase), phase) if cell is None else \
                _through(cell, phase)
            if films > 1 or j != 1:  # a period of one film has no boundary within it
                cell = _star(cell, inner[j - 1][pol])
        stack = _star(_star(top[pol], _power(cell, periods)), bottom[pol])
        out.append(stack)
    (rs, ts, _, _), (rp, tp, _, _) = out
    R = _mean(np.stack([np.abs(rs) ** 2, np.abs(rp) ** 2]), polarised)
    return np.clip(R, 0.0, 1.0), _power_ratio(ts, tp, media[0], qs[0], media[-1], qs[-1], polarised)
