"""The lobes' amplitudes at their centres: the reflected, transmitted and interference lobes of
eqs. 3-9 with the paper's optics or thin-film optics, and the diffuse part's factor (eqs. 15
and 18).
"""
from __future__ import annotations

import math

from .energy import microfacet_cosine
from .fresnel import fresnel_f0, schlick, transmission_factor
from .interference import band_cosine, harmonics, interference_path
from .lobes import INV_2PI
from .step import shader_function
from .thin_film import film_beams, fresnel_reflectance


@shader_function
def lobe_amplitudes(ops, r1, lam, e0, e1, ks, r0, d, cos_v, cos_ls, cos_ci, tail, through, atten, *,
                    interference=True, band=False, dispersion=True, footprint=False):
    """Values at their centres of the reflected, transmitted and interference lobes (eqs.
    3-9) of one wavelength ``lam`` (or three: a triple), on lobes placed by
    :func:`lobe_geometry` (``cos_ls``: cosine of the transmitted centre ``l*``, ``cos_ci``:
    of the interference centre, ``atten``: the interference lobe's attenuation).  ``band``:
    the three RGB channels (a triple) with the interference integrated over each channel's
    band (:func:`band_cosine`) instead of taken at ``lam``, and with ``footprint`` over the
    pixel's footprint too."""
    f = fresnel_f0(ops, r1, r0)
    F = schlick(ops, cos_v, f)
    # Eq. 6 with the modified-Phong normalisation (e0 + 2)/(2 pi), at the lobe's centre.
    # Products written with the material's constants together, so that a shader compiler
    # folds them once per material.
    AR_amp = F * (ks * (e0 + 2.0) * INV_2PI)
    eta = r0 / r1
    eta2 = eta * eta
    s_o = ops.sqrt((1.0 - eta2) + eta2 * (cos_v * cos_v))  # <t_o, -n0>
    Tc = transmission_factor(ops, s_o, f)
    F_l = schlick(ops, cos_ls, f)
    AT_amp = (1.0 - F_l) * Tc * tail * (ks * (e1 + 2.0) * INV_2PI / (r1 * r1))
    AT = ops.select(through, AT_amp * cos_ls, 0.0)
    if interference:
        s_i = ops.sqrt((1.0 - eta2) + eta2 * (cos_ci * cos_ci))
        if band:
            opd, slope = interference_path(ops, r1, d, s_i, s_o)
            cos2phi = band_cosine(ops, opd, slope, r1, dispersion=dispersion, footprint=footprint)
        else:
            cos2phi = ops.cos((2.0 * math.pi / lam) * r1 * d * (s_i + s_o))  # twice the phase of eq. 3
        AI = ops.select(through, cos2phi * ops.sqrt(AR_amp * AT_amp) * (atten * cos_ci) * 2.0, 0.0)
    else:
        AI = 0.0  # averaged over the band: cos(2 Phi) has mean 0
    return AR_amp * cos_v, AT, AI


@shader_function
def film_amplitudes(ops, r1, lam, e0, eT, e_facets, ks, r0, n2, k2, d, cos_v, cos_ls, cos_ci, tail, through, atten, *,
                    interference=True, band=False, dispersion=True, footprint=False, orders=1):
    """:func:`lobe_amplitudes` with thin-film optics (the physical mode): the reflected lobe
    carries the top boundary's exact reflectance, the transmitted lobe what the lower
    boundary reflects back through the top one (all its bounces), the interference lobe the
    harmonics of :func:`film_beams` with their reflection phases.  The film's optics are taken
    at the microfacets' angle to the view (:func:`.energy.microfacet_cosine` of the top boundary's
    exponent ``e_facets``: a rough film reflects through microfacets less grazing than the view);
    the transmitted lobe's light side crosses the top boundary at its own angle (``cos_ls``).

    Energy-keeping lobes (:mod:`.energy`): each amplitude is the reflectance its lobe carries
    times the lobe's normalised peak ``(e + 2)/(2 pi)`` (``eT``: the transmitted lobe's exponent
    seen from outside), with no light cosine: the closures then return, integrated over the
    hemisphere, the film's reflectance at every angle.  The interference lobe, the geometric mean
    of the two (eq. 5), is ``2 cos sqrt(A_R A_T)`` attenuated by their distance."""
    eta = r0 / r1
    eta2 = eta * eta
    cos_f = microfacet_cosine(ops, e_facets, cos_v)
    s_o = ops.sqrt(ops.maximum((1.0 - eta2) + eta2 * (cos_f * cos_f), 0.0))  # <t_o, -m>, m a microfacet's normal
    f = film_beams(ops, cos_f, s_o, r1, r0, n2, k2, orders=orders)
    AR = f["R01"] * (ks * (e0 + 2.0) * INV_2PI)
    # The transmitted beams cross the top boundary at l*, not at the view: (1 - R01(l*)) / (1 - R01(v)).
    cross = (1.0 - fresnel_reflectance(ops, microfacet_cosine(ops, e_facets, cos_ls), eta)) / \
        ops.maximum(1.0 - f["R01"], 1e-6)
    AT_amp = f["T"] * cross * tail * (ks * (eT + 2.0) * INV_2PI)
    AT = ops.select(through, AT_amp, 0.0)
    if not interference:
        return AR, AT, 0.0  # averaged over the band: the cosines have mean 0
    cos_fi = microfacet_cosine(ops, e_facets, cos_ci)
    s_i = ops.sqrt((1.0 - eta2) + eta2 * (cos_fi * cos_fi))
    opd, slope = interference_path(ops, r1, d, s_i, s_o)
    wave = harmonics(ops, f, lam, opd, slope, r1, orders, band=band, dispersion=dispersion, footprint=footprint)
    AI = ops.select(through, wave * ops.sqrt(AR * AT_amp) * (atten * 2.0), 0.0)
    return AR, AT, AI


@shader_function
def diffuse_rho(ops, r1, r0, lam, d, *, band=False, dispersion=True, footprint=False):
    """Eqs. 15 and 18: ``1 + 2 cos(4 pi r1 d / lambda) sqrt(Td (1 - Td))``; ``band``: the
    cosine integrated over each RGB channel's band (:func:`band_cosine`, the path
    ``D = 2 r1 d`` with slope ``dD/dr1 = 2 d``)."""
    td = 80.0 * r0 * r1 / (21.0 * (r1 + r0) * (r1 + r0))
    if band:
        c = band_cosine(ops, r1 * (2.0 * d), 2.0 * d, r1, dispersion=dispersion, footprint=footprint)
    else:
        c = ops.cos((4.0 * math.pi / lam) * r1 * d)
    return ops.maximum(1.0 + c * (2.0 * ops.sqrt(td * (1.0 - td))), 0.0)


@shader_function
def film_diffuse_rho(ops, r1, r0, n2, k2, lam, d, *, band=False, dispersion=True, footprint=False, orders=1,
                     interference=True):
    """The diffuse part's factor with thin-film optics: light scattered under the layer
    crosses the film twice, ``(1 - R_f)(1 - <R_f>)``, ``R_f`` the film's reflectance at
    normal incidence (its interference integrated over the band with ``band``) and
    ``<R_f>`` its mean over thickness; at most 1 - R_f, so the diffuse and the specular
    light together never exceed what arrives."""
    f = film_beams(ops, 1.0, 1.0, r1, r0, n2, k2, orders=orders)
    mean = f["R01"] + f["T"]
    rf = mean
    if interference:
        wave = harmonics(ops, f, lam, r1 * (2.0 * d), 2.0 * d, r1, orders, band=band, dispersion=dispersion,
                         footprint=footprint)
        rf = rf + wave * (2.0 * ops.sqrt(f["R01"] * f["T"]))
    return ops.clamp(1.0 - rf, 0.0, 1.0) * ops.clamp(1.0 - mean, 0.0, 1.0)
