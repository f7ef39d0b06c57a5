"""The interference terms: eq. 3's optical path difference and the cosine of its phase, at one
wavelength or integrated over each RGB channel's band in closed form (:func:`band_cosine`,
from the fit baked in ``model/data/band_fit.json``), and the harmonics of thin-film optics.
"""
from __future__ import annotations

import math

from ..spectral_band import MIN_PATH_COS, band_fit
from .step import shader_function


@shader_function
def interference_path(ops, r1, d, s_i, s_o):
    """Eq. 3's optical path difference ``D = r1 d (s_i + s_o)`` (``s``: the refracted
    cosines) and its slope ``dD/dr1 = d (1/s_i + 1/s_o)`` (``r1 s = sqrt(r1^2 - r0^2
    sin^2)``), the cosines floored at ``MIN_PATH_COS`` there: the slope only moves the path
    to first order with the dispersed index (:func:`band_cosine`)."""
    opd = r1 * d * (s_i + s_o)
    slope = d * (1.0 / ops.maximum(s_i, MIN_PATH_COS) + 1.0 / ops.maximum(s_o, MIN_PATH_COS))
    return opd, slope


@shader_function
def band_cosine(ops, opd, slope, r1, offset=0.0, *, dispersion, footprint=False, shifted=False):
    """The interference cosine ``cos(2 pi D / lambda)`` of a path difference ``D`` (nm; a
    triple, one per RGB channel, at the channel's index) integrated over each channel's
    band of the spectral ground truth, in closed form (docs/spectral.md, "Analytic mode"):
    a sum of damped cosines ``a exp(-b D^2) cos(2 pi nu D)``, the Fourier transform of a
    fit of the channel's weight by Gaussians in wavenumber (model/spectral_band.py).

    With ``dispersion`` each Gaussian sees the index about its own wavenumber, to second
    order: the path moves by ``slope (r1(nu) - r1_c)`` (``slope = dD/dr1``), the damping takes
    the group path ``g = D + slope nu dr1/dnu``, and the phase's curvature is a chirp ``c``
    (a Gaussian with a quadratic phase: ``a (1 + c^2)^(-1/4) exp(-b g^2 / (1 + c^2))
    cos(2 pi nu D + atan(c) / 2 - c b g^2 / (1 + c^2))``); the three are constant rows times
    the indices ``r1``, times ``slope``.  A zero path gives 1, the paper's RGB value.

    With ``footprint``, where the backend knows how much the path changes across the pixel
    (OSL's derivatives: ``w = filterwidth(D)``), each term is also averaged over a box of
    that width, to second order ``exp(-pi^2 nu^2 w^2 / 6)``: a thickness that varies within
    a pixel (noise seen from far away) averages out instead of turning into noise.

    With ``shifted``, ``cos(2 pi D / lambda + offset)``: a reflection phase, constant over
    the band, added to every term."""
    def rows(name):
        return ops.combine(*(ops.dot(r1, tuple(row)) for row in slot[name]))

    w = ops.footprint(opd) if footprint else None
    total = None
    for slot in band_fit()["slots"]:
        neg_b = tuple(-b for b in slot["damping"])
        two_pi_nu = tuple(2.0 * math.pi * nu for nu in slot["wavenumber"])
        if dispersion:
            x = ops.madd(slope, rows("index_shift"), opd)
            g = ops.madd(slope, rows("index_slope"), x)
            c = slope * rows("index_chirp")
            den = ops.madd(c, c, 1.0)
            arg = g * g * neg_b / den  # -b g^2 / (1 + c^2)
            atan_c = ops.combine(*(ops.atan2(ck, 1.0) for ck in ops.components(c)))
            phase = ops.madd(atan_c, 0.5, ops.madd(x, two_pi_nu, arg * c))
            amplitude = ops.power(den, -0.25) * tuple(slot["amplitude"])
        else:
            arg = opd * opd * neg_b
            phase = opd * two_pi_nu
            amplitude = tuple(slot["amplitude"])
        if w is not None:
            arg = ops.madd(w * w, tuple(-(math.pi * nu) ** 2 / 6.0 for nu in slot["wavenumber"]), arg)
        if shifted:
            phase = phase + offset
        wave = ops.exp(arg) * ops.cos(phase)
        total = wave * amplitude if total is None else ops.madd(wave, amplitude, total)
    return total


def interference_cosine(ops, lam, opd, slope, r1, phase, *, band, dispersion, footprint):
    """``cos(2 pi D / lambda + phase)`` at the wavelength ``lam``, or with ``band`` integrated
    over each RGB channel's band (:func:`band_cosine`)."""
    if band:
        return band_cosine(ops, opd, slope, r1, phase, dispersion=dispersion, footprint=footprint, shifted=True)
    return ops.cos((2.0 * math.pi / lam) * opd + phase)


def harmonics(ops, f, lam, opd, slope, r1, orders, *, band, dispersion, footprint):
    """``sum_m g_m cos(2 pi m D / lambda + phi_m)`` over the ``orders`` harmonics of
    :func:`film_beams` (the m-th travels the path ``m D``), each integrated over the band
    with ``band``."""
    wave = None
    for m in range(1, orders + 1):
        c = interference_cosine(ops, lam, opd * float(m), slope * float(m), r1, f[f"phi{m}"], band=band,
                                dispersion=dispersion, footprint=footprint)
        wave = f[f"g{m}"] * c if wave is None else wave + f[f"g{m}"] * c
    return wave
