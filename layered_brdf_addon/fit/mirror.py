"""A smooth film's mirror reflectance per RGB channel, from the shading program's amplitudes.

The reflected, transmitted and interference lobes coincide at the mirror direction of a
parallel film; with lobes normalised to 1 (``(e + 2) / (2 pi) = 1``) and ``ks = 1`` their
amplitudes integrated about that direction read as the film's reflectance:
``(AR + r1^2 AT + r1 AI) / cos_v`` with the paper's optics (``AT`` carries the in-layer lobe's
``1 / r1^2``, ``AI`` the square root of both), ``AR + AT + AI`` with thin-film optics, whose
energy-keeping lobes carry the reflectance itself; a film stack's one lobe carries the stack's.  What a spectrophotometer or thin-film
optics measures.
"""
from __future__ import annotations

import math

import numpy as np

from ..model import ops_numpy, program
from ..model.params import WAVELENGTHS_NM, LayeredParams
from ..model.policy import plan_effects
from ..model.stack_optics import StackResponse, stack_colour

UNIT_LOBE_EXPONENT = 2.0 * math.pi - 2.0  # (e + 2) / (2 pi) = 1
SMOOTH_FACETS = 1.0e12  # the exponent of a smooth boundary's microfacets: they face the view's normal


def smooth_film(params: LayeredParams) -> LayeredParams:
    """``params`` as a smooth parallel film of unit lobes and ``ks = 1`` (its indices, optics,
    lower medium and accuracy kept)."""
    return params.replace(ks=1.0, e0=UNIT_LOBE_EXPONENT, e1=UNIT_LOBE_EXPONENT, normal_mode="parallel")


def mirror_reflectance(params: LayeredParams, theta_deg: float, thickness_nm=None) -> np.ndarray:
    """Reflectance (linear Rec.709, last axis R, G, B) of the smooth film of ``params`` at
    ``theta_deg`` from the normal, one row per thickness (default: ``d_min``, a uniform film)."""
    p = smooth_film(params)
    plan = plan_effects(p)
    d = np.atleast_1d(np.asarray(p.d_min if thickness_nm is None else thickness_nm, dtype=float))
    cos_v = np.full(d.shape, math.cos(math.radians(theta_deg)))
    if p.stack is not None:  # a stack's one lobe carries its reflectance, as the optics give it (out of gamut too)
        s = StackResponse.of(p)
        R, _ = stack_colour(s.stack, s.n0, s.lower_rgb, cos_v, s.scale(d), s.accuracy, s.lower_medium, gamut=False)
        return R[0] if thickness_nm is None else R
    one = np.ones(d.shape)
    r1 = ops_numpy.triple(*p.r1)
    e = UNIT_LOBE_EXPONENT
    lobes = (cos_v, cos_v, one, one, one)  # cos_ls, cos_ci, tail, through, atten: the mirror direction
    modes = dict(interference=plan.interference, band=plan.analytic, dispersion=plan.dispersion, footprint=False)
    lam = ops_numpy.triple(*WAVELENGTHS_NM)
    if p.optics == "physical":
        AR, AT, AI = program.film_amplitudes(ops_numpy, r1, lam, e, e, SMOOTH_FACETS, p.ks, p.r0,
                                             ops_numpy.triple(*p.r2),
                                             ops_numpy.triple(*p.k2), d, cos_v, *lobes,
                                             orders=program.harmonic_count(plan), **modes)
        R = AR + AT + AI
    else:
        AR, AT, AI = program.lobe_amplitudes(ops_numpy, r1, lam, e, e, p.ks, p.r0, d, cos_v, *lobes, **modes)
        R = (AR + r1 * r1 * AT + r1 * AI) / cos_v
    out = np.broadcast_to(np.asarray(R, dtype=float), d.shape + (3,)).copy()
    return out[0] if thickness_nm is None else out
