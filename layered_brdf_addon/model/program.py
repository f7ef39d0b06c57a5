"""The shading program, written once for every backend that runs it.

``shade(ops, inputs, plan)`` computes, from the view direction and the local layer
configuration, the closures that stand for the layered BRDF (the decomposition of
docs/closure-decomposition.md).  ``ops`` supplies arithmetic: numpy arrays
(:mod:`.ops_numpy`, the closure form used to predict renders) or Blender shader
nodes (``node_groups``, the node group).  Python control flow depends only on the
:class:`~.plan.EffectPlan`, never on parameter values, so every parameter stays a
live shader input.  ``osl/layered_brdf.osl`` is the same program written by hand.

Values: scalars and 3-vectors of the backend; Python floats are constants.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from .params import WAVELENGTHS_NM
from .plan import EffectPlan

INV_2PI = 0.5 / math.pi
MIN_COS = 0.05  # lower bound of the view cosine used to widen Beckmann lobes


@dataclass
class Closure:
    """A glossy closure: normal, Phong exponent, Beckmann alpha, per-channel weights."""

    name: str
    normal: Any
    exponent: Any
    alpha: Any
    weight: tuple  # (r, g, b) scalars


@dataclass
class ShadingResult:
    glossy: list = field(default_factory=list)
    diffuse: tuple | None = None  # (r, g, b) colour of the diffuse closure (normal n0)
    extras: dict = field(default_factory=dict)


# ---------------------------------------------------------------- helpers
def schlick(ops, cos_t, f):
    """Eq. 7 for a direction pointing away from the surface."""
    x = 1.0 - ops.clamp(cos_t, 0.0, 1.0)
    x2 = x * x
    return f + (1.0 - f) * (x2 * x2 * x)


def fresnel_f0(r1, r0):
    """Eq. 8."""
    q = (r0 - r1) / (r0 + r1)
    return q * q


def transmission_factor(ops, s, f):
    """Eq. 9 with ``s = <v, -n0>`` of the in-layer direction: ``(1 - f)(1 - (1 - s)^5)``."""
    x = ops.clamp(1.0 - s, 0.0, 1.0)
    x2 = x * x
    return (1.0 - f) * (1.0 - x2 * x2 * x)


def angle2(ops, a, b):
    """Squared angle between unit vectors, accurate for small angles."""
    t = 2.0 * ops.atan2(ops.length(a - b), ops.length(a + b))
    return t * t


def gauss_overlap(ops, p, q, delta2):
    """Integral over the tangent plane of exp(-p|x-a|^2/2) exp(-q|x-b|^2/2), |a-b|^2 = delta2."""
    s = ops.maximum(p + q, 1e-6)
    return (2.0 * math.pi) / s * ops.exp(-(p * q) / (2.0 * s) * delta2)


def beckmann_lambda(ops, alpha2, mu):
    """Cycles' rational approximation of Beckmann's Smith Lambda."""
    mu2 = ops.maximum(mu * mu, 1e-12)
    t = alpha2 * ops.maximum(1.0 / mu2 - 1.0, 0.0)
    a = 1.0 / ops.sqrt(ops.maximum(t, 1e-12))
    lam = ((0.396 * a - 1.259) * a + 1.0) / ((2.181 * a + 3.535) * a)
    return ops.select(ops.lt(t, 0.39), 0.0, lam)


def lobe_alpha(ops, e, mu):
    """Beckmann alpha of a Phong exponent, widened by 1/sqrt(cos) to keep the lobe's energy."""
    return ops.minimum(ops.sqrt(2.0 / ((4.0 * ops.maximum(e, 0.0) + 2.0) * ops.clamp(mu, MIN_COS, 1.0))), 1.0)


def lobe_peak(ops, lobe, e, alpha, mu):
    """The closure's value (cosine included) at its own mirror direction."""
    mu = ops.maximum(mu, 1e-4)
    if lobe == "phong":
        return mu * (e + 2.0) * INV_2PI
    alpha2 = alpha * alpha
    return 1.0 / (math.pi * alpha2 * 4.0 * mu * (1.0 + 2.0 * beckmann_lambda(ops, alpha2, mu)))


def closure_for(ops, lobe, name, normal, e, v, amplitudes):
    """A closure about ``normal`` whose value at its centre equals ``amplitudes``."""
    mu = ops.dot(normal, v)
    alpha = lobe_alpha(ops, e, mu)
    peak = lobe_peak(ops, lobe, e, alpha, mu)
    inv = 1.0 / peak
    return Closure(name, normal, e, alpha, tuple(a * inv for a in amplitudes))


def fold_interference(ops, AR, AT, AI, eR, eT, eI, cR, cT, cI):
    """Non-negative least-squares fit of ``AR gR + AT gT + AI gI`` (``AI < 0``) by
    ``wR gR + wT gT`` (Gaussian lobes in the tangent plane); unchanged where ``AI >= 0``."""
    gRR = gauss_overlap(ops, eR, eR, 0.0)
    gTT = gauss_overlap(ops, eT, eT, 0.0)
    gRT = gauss_overlap(ops, eR, eT, angle2(ops, cR, cT))
    gRI = gauss_overlap(ops, eR, eI, angle2(ops, cR, cI))
    gTI = gauss_overlap(ops, eT, eI, angle2(ops, cT, cI))
    bR = AR * gRR + AT * gRT + AI * gRI
    bT = AR * gRT + AT * gTT + AI * gTI
    m11 = gRR + 1e-6 * (gRR + gTT)  # a small ridge: equal lobes make the system singular
    m22 = gTT + 1e-6 * (gRR + gTT)
    det = m11 * m22 - gRT * gRT
    wR2 = (m22 * bR - gRT * bT) / det
    wT2 = (m11 * bT - gRT * bR) / det
    both = ops.ge(wR2, 0.0) * ops.ge(wT2, 0.0)
    wR1 = ops.maximum(bR, 0.0) / gRR
    wT1 = ops.maximum(bT, 0.0) / gTT
    r_better = ops.ge(bR * wR1, bT * wT1)
    wR = ops.select(both, wR2, ops.select(r_better, wR1, 0.0))
    wT = ops.select(both, wT2, ops.select(r_better, 0.0, wT1))
    neg = ops.lt(AI, 0.0)
    return ops.select(neg, wR, AR), ops.select(neg, wT, AT), ops.select(neg, 0.0, AI)


# ---------------------------------------------------------------- the program
def channel_terms(ops, P, r1, lam, n0, n1, v, d, cos_v, r_v):
    """Amplitudes, centres and exponents of one channel's three lobes."""
    e0, e1, ks, r0 = P["e0"], P["e1"], P["ks"], P["r0"]
    f = fresnel_f0(r1, r0)
    F = schlick(ops, cos_v, f)
    AR_amp = ks * F * (e0 + 2.0) * INV_2PI
    AR = AR_amp * cos_v
    # The light path leaving along v: refract -v into the layer (t_o), mirror it on the
    # lower boundary (r) and refract it out (l*): the transmitted lobe's centre.
    eta = r0 / r1
    inv_eta = r1 / r0
    k_o = 1.0 - eta * eta * (1.0 - cos_v * cos_v)
    s_o = ops.sqrt(k_o)  # <t_o, -n0>
    t_o = v * (-eta) + n0 * (eta * cos_v - s_o)
    to_n1 = ops.dot(t_o, n1)
    r = t_o - n1 * (2.0 * to_n1)
    cos_r = ops.dot(r, n0)
    k_l = 1.0 - inv_eta * inv_eta * (1.0 - cos_r * cos_r)
    l_raw = r * inv_eta - n0 * (inv_eta * cos_r - ops.sqrt(k_l))
    # Eq. 11 and total internal reflection on either crossing: no path, T = 0.
    through = ops.ge(k_o, 0.0) * ops.ge(k_l, 0.0) * ops.lt(to_n1, 0.0) * ops.gt(cos_r, 0.0) * ops.gt(cos_v, 0.0)
    l_star = ops.normalize(ops.select_vec(through, l_raw, r_v), r_v)
    cos_ls = ops.clamp(ops.dot(l_star, n0), 0.0, 1.0)
    through = through * ops.gt(cos_ls, 0.0)
    # The in-layer lobe seen from outside: exponent e1 / r1^2, times cos(l*)/cos(t) for the
    # stretch within the plane of incidence (geometric mean of the two directions).
    s_ls = ops.sqrt(ops.maximum(1.0 - eta * eta * (1.0 - cos_ls * cos_ls), 1e-12))
    e1p = e1 / (r1 * r1) * ops.select(through, cos_ls / s_ls, 1.0)
    Tc = transmission_factor(ops, s_o, f)
    F_l = schlick(ops, cos_ls, f)
    AT_amp = ks * (1.0 - F_l) * Tc * (e1 + 2.0) * INV_2PI / (r1 * r1)
    AT = ops.select(through, AT_amp * cos_ls, 0.0)
    # Interference, eq. 5: sqrt(R T) of two Phong lobes is a lobe of exponent
    # (e0 + e1')/2 about their weighted centre; phase from eq. 3 at that centre.
    w_sum = ops.maximum(e0 + e1p, 1e-6)
    c_I = ops.normalize(r_v * e0 + l_star * e1p, r_v)
    atten = ops.exp(-(e0 * e1p) / (4.0 * w_sum) * angle2(ops, r_v, l_star))
    cos_ci = ops.clamp(ops.dot(c_I, n0), 0.0, 1.0)
    s_i = ops.sqrt(1.0 - eta * eta * (1.0 - cos_ci * cos_ci))
    phase = (math.pi / lam) * r1 * d * (s_i + s_o)
    AI = ops.select(through, 2.0 * ops.cos(2.0 * phase) * ops.sqrt(AR_amp * AT_amp) * atten * cos_ci, 0.0)
    return dict(AR=AR, AT=AT, AI=AI, eT=e1p, eI=0.5 * (e0 + e1p), l_star=l_star, c_I=c_I)


def diffuse_colour(ops, P, d, wavelengths=WAVELENGTHS_NM):
    """``kd base rho_d`` per channel, eqs. 15 and 18."""
    out = []
    r0 = P["r0"]
    for r1, lam, base in zip(P["r1"], wavelengths, P["base"]):
        td = 80.0 * r0 * r1 / (21.0 * (r1 + r0) * (r1 + r0))
        rho = 1.0 + ops.cos((4.0 * math.pi / lam) * r1 * d) * (2.0 * ops.sqrt(td * (1.0 - td)))
        out.append(P["kd"] * base * ops.maximum(rho, 0.0))
    return tuple(out)


def shade(ops, P, n0, n1, d, v, plan: EffectPlan, wavelengths=WAVELENGTHS_NM) -> ShadingResult:
    """Closures of the layered BRDF at one shading point.

    ``P``: dict with ``r1`` (3 values), ``r0``, ``e0``, ``e1``, ``ks``, ``kd``, ``base``
    (3 values); ``n0``, ``n1``: unit normals; ``d``: thickness (nm); ``v``: unit view
    direction (towards the camera).
    """
    res = ShadingResult()
    if plan.diffuse:
        res.diffuse = diffuse_colour(ops, P, d, wavelengths)
    if not plan.specular:
        return res
    cos_v = ops.clamp(ops.dot(v, n0), 0.0, 1.0)
    r_v = n0 * (2.0 * ops.dot(v, n0)) - v
    e0 = P["e0"]
    terms = [channel_terms(ops, P, r1, lam, n0, n1, v, d, cos_v, r_v) for r1, lam in zip(P["r1"], wavelengths)]
    AR, AT, AI = [], [], []
    for t in terms:
        ar, at, ai = fold_interference(ops, t["AR"], t["AT"], t["AI"], e0, t["eT"], t["eI"], r_v, t["l_star"], t["c_I"])
        AR.append(ar)
        AT.append(at)
        AI.append(ai)
    res.glossy.append(closure_for(ops, plan.lobe, "reflect", n0, e0, v, AR))
    if plan.dispersion:
        for c, t in enumerate(terms):
            zero = [0.0, 0.0, 0.0]
            wt, wi = list(zero), list(zero)
            wt[c], wi[c] = AT[c], AI[c]
            res.glossy.append(closure_for(ops, plan.lobe, f"transmit_{'rgb'[c]}", ops.normalize(v + t["l_star"], n0),
                                          t["eT"], v, wt))
            res.glossy.append(closure_for(ops, plan.lobe, f"interfere_{'rgb'[c]}", ops.normalize(v + t["c_I"], n0),
                                          t["eI"], v, wi))
    else:
        # Equal indices: every channel's lobes share centre and exponent (green's are used).
        t = terms[1]
        res.glossy.append(closure_for(ops, plan.lobe, "transmit", ops.normalize(v + t["l_star"], n0), t["eT"], v, AT))
        res.glossy.append(closure_for(ops, plan.lobe, "interfere", ops.normalize(v + t["c_I"], n0), t["eI"], v, AI))
    return res
