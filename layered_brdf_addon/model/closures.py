"""The closure form: the layered BRDF as Cycles closures with view-dependent weights.

Neither an OSL shader nor a node group sees the light direction.  They can only
return a weighted sum of built-in closures (glossy lobes with a normal of their
own, a diffuse lobe), the weights computed from the view direction ``v``.  This
module is the numpy twin of what ``osl/layered_brdf.osl`` and the node group
compute, so a render can be predicted pixel by pixel, and the distance of the
closure form from the exact ``rho(i, o)`` measured (docs/closure-decomposition.md).

Per channel ``c`` and shading point, with ``r_v`` the mirror of ``v`` about ``n0``:

* **reflected lobe** about ``r_v`` (closure normal ``n0``), exponent ``e0``,
  amplitude ``A_R = ks F(v) (e0 + 2)/(2 pi)``;
* **transmitted lobe** about ``l*_c``, the light direction whose path through the
  layer (refract at ``n0``, mirror at ``n1``, refract out) leaves along ``v``
  (closure normal ``normalize(v + l*_c)``), exponent ``e1 / r1^2`` (the in-layer
  lobe seen from outside), amplitude ``A_T = ks (1 - F(l*)) Tc(t_o) (e1 + 2)/(2 pi r1^2)``;
* **interference lobe** ``2 cos(2 Phi) sqrt(R T)``: the geometric mean of two
  Phong lobes is a Phong lobe of exponent ``(e0 + e1')/2`` about the weighted
  centre ``normalize(e0 r_v + e1' l*)``, amplitude
  ``2 cos(2 Phi) sqrt(A_R A_T) exp(-e0 e1' delta^2 / (4 (e0 + e1')))``, with
  ``delta`` the angle between the two centres and ``Phi`` eq. 3 at that centre.

Cycles clamps negative closure weights to 0, so a destructive interference lobe
(``cos 2 Phi < 0``) is folded into the other two: its least-squares projection on
the reflected and transmitted lobes (Gaussian approximation of the lobes in the
tangent plane) is subtracted from their amplitudes, which are clamped at 0.

Each amplitude is the pixel value per unit irradiance at the lobe's centre, and is
turned into a closure weight by dividing by that closure's own value there
(Beckmann: ``D / (4 cos (1 + 2 Lambda))``; Phong: ``cos (e + 2)/(2 pi)``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .brdf import diffuse_rho, fresnel_f0, schlick, specular_brdf, transmission_factor
from .geometry import dot, safe_normalize
from .params import WAVELENGTHS_NM, LayeredParams

INV_2PI = 0.5 / np.pi


# --------------------------------------------------------------------------
# Lobe conversions and Cycles' own closure evaluations (Blender 5.0 kernel).
def phong_to_alpha(e, cos_nv=1.0):
    """Beckmann ``alpha`` for a reflection-vector Phong exponent: ``sqrt(2 / (4 e + 2))`` (SPEC).

    With ``cos_nv`` < 1 it is widened by ``1 / sqrt(cos_nv)``: a half-vector lobe seen at
    incidence ``theta`` covers ``cos theta`` times the solid angle of the Phong lobe it
    stands for, so this keeps the lobe's energy.
    """
    return np.sqrt(2.0 / ((4.0 * np.maximum(e, 0.0) + 2.0) * np.clip(cos_nv, 0.05, 1.0)))


def alpha_to_roughness(alpha):
    """The Glossy BSDF node's Roughness socket is ``sqrt(alpha)``."""
    return np.sqrt(alpha)


def beckmann_lambda(alpha2, cos_n):
    """Smith Lambda of Beckmann, Cycles' rational approximation."""
    cos2 = np.maximum(cos_n * cos_n, 1e-30)
    t = alpha2 * np.maximum(1.0 / cos2 - 1.0, 0.0)
    a = 1.0 / np.sqrt(np.maximum(t, 1e-30))
    lam = ((0.396 * a - 1.259) * a + 1.0) / ((2.181 * a + 3.535) * a)
    return np.where(t < 0.39, 0.0, lam)


def beckmann_eval(N, v, l, alpha):
    """Cycles' Beckmann closure (no Fresnel): ``D / (4 cosNV (1 + Lambda_V + Lambda_L))``, cosine included."""
    alpha2 = alpha * alpha
    cos_nv = dot(N, v)
    cos_nl = dot(N, l)
    h = safe_normalize(v + l, N)
    cos_nh2 = np.minimum(dot(N, h) ** 2, 1.0)
    with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
        D = 1.0 / (np.exp((1.0 - cos_nh2) / np.maximum(cos_nh2 * alpha2, 1e-300)) * np.pi * alpha2 * cos_nh2 ** 2)
    D = np.where(np.isfinite(D), D, 0.0)
    val = D / (4.0 * np.maximum(cos_nv, 1e-30) * (1.0 + beckmann_lambda(alpha2, cos_nv) + beckmann_lambda(alpha2, cos_nl)))
    return np.where((cos_nv > 0.0) & (cos_nl >= 0.0), val, 0.0)


def beckmann_peak(cos_nv, alpha):
    """Value of :func:`beckmann_eval` at the mirror direction of ``v``."""
    alpha2 = alpha * alpha
    mu = np.maximum(cos_nv, 1e-30)
    return 1.0 / (np.pi * alpha2 * 4.0 * mu * (1.0 + 2.0 * beckmann_lambda(alpha2, mu)))


def phong_ramp_eval(N, v, l, e):
    """Cycles' ``phong_ramp`` with eight equal colours: ``cosNL (e + 2)/(2 pi) cos^e(R, l)``."""
    cos_nv = dot(N, v)
    cos_nl = dot(N, l)
    r = 2.0 * cos_nv[..., None] * N - v
    c = dot(r, l)
    with np.errstate(under="ignore"):
        val = cos_nl * (e + 2.0) * INV_2PI * np.power(np.maximum(c, 0.0), e)
    return np.where((cos_nv > 0) & (cos_nl > 0) & (c > 0), val, 0.0)


def phong_peak(cos_nv, e):
    return np.maximum(cos_nv, 0.0) * (e + 2.0) * INV_2PI


def ensure_valid_specular_reflection(Ng, v, N):
    """Cycles bends a glossy closure's normal so the mirrored view stays above ``Ng``."""
    R = 2.0 * dot(N, v)[..., None] * N - v
    iz = dot(v, Ng)
    threshold = np.minimum(0.9 * iz, 0.01)
    ok = dot(Ng, R) >= threshold
    X = safe_normalize(N - dot(N, Ng)[..., None] * Ng, N)
    ix = dot(v, X)
    a = ix * ix + iz * iz
    b = 2.0 * (a + iz * threshold)
    c = (threshold + iz) ** 2
    disc = np.sqrt(np.maximum(b * b - 4.0 * a * c, 0.0))
    a_safe = np.where(a > 0, a, 1.0)
    nz2 = np.where(ix < 0, 0.25 * (b + disc) / a_safe, 0.25 * (b - disc) / a_safe)
    bent = np.sqrt(np.maximum(1.0 - nz2, 0.0))[..., None] * X + np.sqrt(np.maximum(nz2, 0.0))[..., None] * Ng
    return np.where(ok[..., None], N, bent)


# --------------------------------------------------------------------------
@dataclass
class Lobe:
    """One glossy closure: its normal (..., 3), Phong exponent (...), RGB weight (..., 3)."""

    name: str
    normal: np.ndarray
    exponent: np.ndarray
    weight: np.ndarray


def _gauss_overlap(p, q, delta2):
    """Integral of exp(-p|x-a|^2/2) exp(-q|x-b|^2/2) over the plane, |a - b|^2 = delta2."""
    return 2.0 * np.pi / (p + q) * np.exp(-p * q / (2.0 * (p + q)) * delta2)


def _angle2(a, b):
    """Squared angle between unit vectors (robust for small angles)."""
    return (2.0 * np.arctan2(np.sqrt(dot(a - b, a - b)), np.sqrt(dot(a + b, a + b)))) ** 2


def fold_interference(AR, AT, AI, eR, eT, eI, cR, cT, cI):
    """Fold a negative interference amplitude into the reflected and transmitted ones.

    The target ``f = AR gR + AT gT + AI gI`` (Gaussian lobes ``exp(-e theta^2 / 2)`` in
    the tangent plane, ``AI < 0``) is replaced by its non-negative least-squares fit
    ``wR gR + wT gT``: the unconstrained 2x2 solution where both weights are >= 0,
    otherwise the better of the single-lobe fits.  Returns ``(AR, AT, AI)``, unchanged
    where ``AI >= 0``.
    """
    gRR = _gauss_overlap(eR, eR, 0.0)
    gTT = _gauss_overlap(eT, eT, 0.0)
    gRT = _gauss_overlap(eR, eT, _angle2(cR, cT))
    gRI = _gauss_overlap(eR, eI, _angle2(cR, cI))
    gTI = _gauss_overlap(eT, eI, _angle2(cT, cI))
    # <f, gR> and <f, gT>
    bR = AR * gRR + AT * gRT + AI * gRI
    bT = AR * gRT + AT * gTT + AI * gTI
    ridge = 1e-6 * (gRR + gTT)  # equal lobes make the system singular
    m11, m22 = gRR + ridge, gTT + ridge
    det = m11 * m22 - gRT * gRT
    wR2 = (m22 * bR - gRT * bT) / det
    wT2 = (m11 * bT - gRT * bR) / det
    both = (wR2 >= 0.0) & (wT2 >= 0.0)
    wR1 = np.maximum(bR, 0.0) / gRR
    wT1 = np.maximum(bT, 0.0) / gTT
    r_better = bR * wR1 >= bT * wT1  # the fit that removes more of ||f||^2
    wR = np.where(both, wR2, np.where(r_better, wR1, 0.0))
    wT = np.where(both, wT2, np.where(r_better, 0.0, wT1))
    negative = AI < 0.0
    return np.where(negative, wR, AR), np.where(negative, wT, AT), np.where(negative, 0.0, AI)


def _refract(v, n, eta):
    cosi = -dot(v, n)
    k = 1.0 - eta * eta * (1.0 - cosi * cosi)
    ok = (cosi > 0.0) & (k >= 0.0)
    t = eta * v + (eta * cosi - np.sqrt(np.maximum(k, 0.0)))[..., None] * n
    return np.where(ok[..., None], t, 0.0), ok


def specular_lobes(params: LayeredParams, n0, n1, d, v, wavelengths=WAVELENGTHS_NM, fold=True):
    """The closure decomposition at each shading point (see the module docstring).

    Returns a list of :class:`Lobe` whose amplitudes are pixel values per unit
    irradiance at the lobe centre (not yet divided by the closure's peak) and the
    lobe centres, as ``(lobes, centres)``.
    """
    p = params
    n0 = np.asarray(n0, dtype=float)
    v = np.broadcast_to(np.asarray(v, dtype=float), n0.shape)
    n1 = np.asarray(n1, dtype=float)
    d = np.asarray(d, dtype=float)
    cos_v = np.clip(dot(v, n0), 0.0, 1.0)
    r_v = 2.0 * dot(v, n0)[..., None] * n0 - v
    e0 = float(p.e0)
    shape = n0.shape[:-1]
    AR_all = np.zeros(shape + (3,))
    lobes, centres = [], []
    for c, (r1, lam) in enumerate(zip(p.r1, wavelengths)):
        f = fresnel_f0(r1, p.r0)
        F = schlick(cos_v, f)
        AR = p.ks * F * (e0 + 2.0) * INV_2PI * cos_v
        eta = p.r0 / r1
        t_o, ok_o = _refract(-v, n0, eta)
        r = t_o - 2.0 * dot(t_o, n1)[..., None] * n1
        l_star, ok_l = _refract(r, -n0, 1.0 / eta)
        through = ok_o & ok_l & (dot(t_o, n1) < 0.0) & (cos_v > 0.0)
        l_star = np.where(through[..., None], safe_normalize(l_star, r_v), r_v)
        cos_ls = np.clip(dot(l_star, n0), 0.0, 1.0)
        through &= cos_ls > 0.0
        # The in-layer lobe seen from outside: angles shrink by 1/r1 across the plane of
        # incidence and by cos(l*)/(r1 cos t) within it; the geometric mean keeps its solid angle.
        s_ls = np.sqrt(np.maximum(1.0 - eta * eta * (1.0 - cos_ls * cos_ls), 1e-12))
        e1p = p.e1 / (r1 * r1) * np.where(through, cos_ls / s_ls, 1.0)
        Tc = transmission_factor(dot(t_o, n0), f)
        F_l = schlick(cos_ls, f)
        AT_amp = p.ks * (1.0 - F_l) * Tc * (p.e1 + 2.0) * INV_2PI / (r1 * r1)
        AR_amp = p.ks * F * (e0 + 2.0) * INV_2PI
        AT = np.where(through, AT_amp * cos_ls, 0.0)
        # Interference lobe.
        w_sum = e0 + e1p
        safe_sum = np.where(w_sum > 0, w_sum, 1.0)
        c_I = safe_normalize(e0 * r_v + e1p[..., None] * l_star, r_v)
        delta2 = _angle2(r_v, l_star)
        atten = np.where(w_sum > 0, np.exp(-(e0 * e1p) / (4.0 * safe_sum) * delta2), 1.0)
        cos_ci = np.clip(dot(c_I, n0), 0.0, 1.0)
        s_i = np.sqrt(np.maximum(1.0 - eta * eta * (1.0 - cos_ci * cos_ci), 0.0))
        s_o = -dot(t_o, n0)
        phase = np.pi * r1 * d / lam * (s_i + s_o)
        AI = np.where(through, 2.0 * np.cos(2.0 * phase) * np.sqrt(AR_amp * np.maximum(AT_amp, 0.0)) * atten * cos_ci, 0.0)
        eI = 0.5 * w_sum
        if fold:
            AR, AT, AI = fold_interference(AR, AT, AI, e0, e1p, eI, r_v, l_star, c_I)
        AR_all[..., c] = AR
        wT = np.zeros(shape + (3,))
        wT[..., c] = AT
        wI = np.zeros(shape + (3,))
        wI[..., c] = AI
        lobes.append(Lobe(f"transmit_{'rgb'[c]}", safe_normalize(v + l_star, n0), e1p, wT))
        lobes.append(Lobe(f"interfere_{'rgb'[c]}", safe_normalize(v + c_I, n0), eI, wI))
        centres += [l_star, c_I]
    lobes.insert(0, Lobe("reflect", n0, np.full(shape, e0), AR_all))
    centres.insert(0, r_v)
    return lobes, centres


def closure_value(lobe_kind, N, v, l, e, ng=None):
    """Value of one closure (cosine included) and its value at its own mirror direction."""
    if ng is not None:
        N = ensure_valid_specular_reflection(ng, v, N)
    cos_nv = dot(N, v)
    if lobe_kind == "phong":
        return phong_ramp_eval(N, v, l, e), phong_peak(cos_nv, e)
    alpha = np.minimum(phong_to_alpha(e, cos_nv), 1.0)
    return beckmann_eval(N, v, l, alpha), beckmann_peak(cos_nv, alpha)


def evaluate_lobes(lobes, v, l, lobe_kind="beckmann", ng=None):
    """Pixel per unit irradiance of amplitude-weighted lobes for light ``l``."""
    v = np.broadcast_to(np.asarray(v, dtype=float), lobes[0].normal.shape)
    l = np.broadcast_to(np.asarray(l, dtype=float), v.shape)
    out = np.zeros(v.shape[:-1] + (3,))
    for lobe in lobes:
        val, peak = closure_value(lobe_kind, lobe.normal, v, l, lobe.exponent, ng)
        ratio = np.where(peak > 0, val / np.where(peak > 0, peak, 1.0), 0.0)
        out += np.maximum(lobe.weight, 0.0) * ratio[..., None]
    return out


def diffuse_shading(params, n0, d, l, wavelengths=WAVELENGTHS_NM):
    cos_l = np.maximum(dot(n0, np.asarray(l)), 0.0)
    return params.kd * diffuse_rho(params.r1, d, params.r0, wavelengths) * np.asarray(params.base_color) \
        * (cos_l / np.pi)[..., None]


def closure_shading(params: LayeredParams, n0, n1, d, l, v, wavelengths=WAVELENGTHS_NM, ng=None, fold=True):
    """What the shaders render per unit sun irradiance (same signature as ``exact_shading``)."""
    lobes, _ = specular_lobes(params, n0, n1, d, v, wavelengths, fold)
    spec = evaluate_lobes(lobes, v, l, params.lobe, ng)
    return spec + diffuse_shading(params, n0, d, l, wavelengths)


def single_lobe_shading(params: LayeredParams, n0, n1, d, l, v, exponent=None, wavelengths=WAVELENGTHS_NM,
                        lobe_kind="phong"):
    """Baseline: one lobe per channel about the mirror direction, its weight the exact ``rho``
    at the mirror configuration, exponent ``e0`` unless given."""
    n0 = np.asarray(n0, dtype=float)
    v = np.broadcast_to(np.asarray(v, dtype=float), n0.shape)
    r_v = 2.0 * dot(v, n0)[..., None] * n0 - v
    rho = specular_brdf(-r_v, v, n0, n1, params.r1, d, params.e0, params.e1, params.r0, wavelengths, ng=n0)
    cos_v = np.clip(dot(v, n0), 0.0, 1.0)
    e = params.e0 if exponent is None else exponent
    lobe = Lobe("single", n0, np.full(n0.shape[:-1], float(e)), params.ks * rho * cos_v[..., None])
    spec = evaluate_lobes([lobe], v, l, lobe_kind)
    return spec + diffuse_shading(params, n0, d, l, wavelengths)
