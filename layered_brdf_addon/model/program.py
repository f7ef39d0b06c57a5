"""The shading program, written once for every backend that runs it.

``layered_surface(ops, plan)`` is the whole shader: it reads the material's inputs,
computes the layer's thickness and lower normal at the shading point (the surface
prelude), and returns the closures that stand for the layered BRDF (the decomposition
of docs/closure-decomposition.md) with the shader's other outputs.  ``ops`` supplies
arithmetic and the shading point's geometry: numpy arrays (:mod:`.ops_numpy`, the
closure form used to predict renders), Blender shader nodes (the node group) or OSL
source text (the OSL shader).  Python control flow depends only on the
:class:`~.plan.EffectPlan`, never on parameter values, so every parameter stays a live
shader input.

Functions marked :func:`shader_function` are the program's named steps: the OSL backend
emits each as an OSL function of the same name, the others run them inline.

Values: scalars and 3-vectors of the backend; Python floats are constants.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import Any

from .params import WAVELENGTHS_NM, iter_sockets
from .plan import EffectPlan
from .spectral_band import MIN_PATH_COS, band_fit

INV_2PI = 0.5 / math.pi
DEG = math.pi / 180.0
MIN_COS = 0.05  # lower bound of the view cosine used to stretch Beckmann lobes
ANISO_FLOOR = 0.5  # the stretch 1/mu of a lobe across the view's plane stops at mu = alpha / 2
GRADIENT_STEP = 1.0e-3  # forward-difference step (world units) of the thickness gradient
D_LIMIT = 1.0e6  # largest thickness (nm): the range of d_min and d_max
FOLD_RIDGE = 1e-4  # ridge of the fold's 2x2 normal equations (equal lobes make them singular)


def shader_function(fn):
    """Mark ``fn(ops, *values, **settings)`` as a named step of the program.

    Values are backend scalars or vectors (or Python constants); keyword-only settings
    are Python values that select a variant.  A backend's ``ops.function`` runs it: numpy
    and the node backend inline it, the OSL backend emits an OSL function once and calls it.
    """
    @functools.wraps(fn)
    def step(ops, *values, **settings):
        return ops.function(fn, values, settings)

    step.program_step = fn
    return step


@dataclass
class Closure:
    """A glossy closure: normal, Phong exponent, Beckmann alpha, per-channel weights."""

    name: str
    normal: Any
    exponent: Any
    alpha: Any  # geometric mean of the two alphas (the Glossy BSDF's Roughness^2)
    weight: tuple  # (r, g, b) scalars
    anisotropy: Any = 0.0  # the Glossy BSDF's Anisotropy: the lobe's stretch along ``tangent``
    tangent: Any = None


@dataclass
class ShadingResult:
    glossy: list = field(default_factory=list)
    diffuse: tuple | None = None  # (r, g, b) colour of the diffuse closure (normal n0)
    extras: dict = field(default_factory=dict)


# ---------------------------------------------------------------- the paper's terms
@shader_function
def schlick(ops, cos_t, f):
    """Eq. 7 for a direction pointing away from the surface; a grazing or below-horizon
    direction gives F = 1 (the cosine is clamped)."""
    x = 1.0 - ops.clamp(cos_t, 0.0, 1.0)
    x2 = x * x
    return f + (1.0 - f) * (x2 * x2 * x)


@shader_function
def fresnel_f0(ops, r1, r0):
    """Eq. 8: Fresnel coefficient at normal incidence."""
    q = (r0 - r1) / (r0 + r1)
    return q * q


@shader_function
def transmission_factor(ops, s, f):
    """Eq. 9 with ``s = <v, -n0>`` of the in-layer direction: ``(1 - f)(1 - (1 - s)^5)``."""
    x = ops.clamp(1.0 - s, 0.0, 1.0)
    x2 = x * x
    return (1.0 - f) * (1.0 - x2 * x2 * x)


@shader_function
def angle2(ops, a, b):
    """Squared chord between unit vectors, ``2 - 2 <a, b>``: the squared angle for small
    angles.  Rounding can push it just below 0 for equal vectors: clamped."""
    return ops.maximum(2.0 - 2.0 * ops.dot(a, b), 0.0)


@shader_function
def beckmann_lambda(ops, alpha2, mu):
    """Cycles' rational approximation of Beckmann's Smith Lambda.  A grazing view floors
    ``mu^2`` at 1e-12; a normal view floors ``a``."""
    mu2 = ops.maximum(mu * mu, 1e-12)
    t = alpha2 * ops.maximum(1.0 / mu2 - 1.0, 0.0)
    a = 1.0 / ops.sqrt(ops.maximum(t, 1e-12))
    lam = ((0.396 * a - 1.259) * a + 1.0) / ((2.181 * a + 3.535) * a)
    return ops.select(ops.lt(t, 0.39), 0.0, lam)


@shader_function
def lobe_alphas(ops, e_within, e_across, mu):
    """Beckmann alphas of a lobe about a closure normal seen at cosine ``mu``, from its Phong
    exponents within the plane of the view and the closure normal (``e_within``) and
    across it (``e_across``): ``(alpha, anisotropy)`` in the Glossy BSDF's convention
    (``alpha`` = Roughness^2, the tangent across the plane, docs/closure-decomposition.md),
    and the two alphas themselves, ``alpha_x`` across the plane and ``alpha_y`` within it
    (what Cycles derives from the first two: exponents up to 1e5 give ratios up to 447, inside
    the 10^4 that its anisotropy range, +-0.99, allows).

    A half vector turned by ``delta`` within that plane turns the mirrored direction by
    ``2 delta``, across it by ``2 mu delta``: a round Phong lobe ``cos^e`` is a Beckmann lobe
    of alpha ``sqrt(2 / (4 e + 2))`` within the plane and ``1/mu`` times that across it (the
    long, thin highlight of a grazing view).  The stretch is bounded by the lobe's own width
    (``mu >= ANISO_FLOOR alpha_within``): beyond that the small-angle map overshoots.  The
    exponents are non-negative (clamped inputs), so both alphas are at most 1.
    """
    a_in = ops.sqrt(2.0 / (4.0 * e_within + 2.0))
    a_across = ops.sqrt(2.0 / (4.0 * e_across + 2.0))
    a_across = ops.minimum(a_across / ops.maximum(mu, ops.maximum(ANISO_FLOOR * a_in, MIN_COS)), 1.0)
    alpha = ops.sqrt(a_in * a_across)
    # Cycles: anisotropy a < 0 gives alpha_x = alpha / (1 + a) along the tangent, a > 0
    # gives alpha_x = alpha (1 - a); both keep alpha_x alpha_y = alpha^2.
    ratio = ops.sqrt(a_in / a_across)
    aniso = ops.select(ops.gt(a_across, a_in), ratio - 1.0, 1.0 - 1.0 / ratio)
    return alpha, ops.clamp(aniso, -0.99, 0.99), a_across, a_in


@shader_function
def glossy_alphas(ops, alpha, aniso):
    """Cycles' Beckmann alphas along the tangent and across it (``alpha_x``, ``alpha_y``) from
    the Glossy BSDF's alpha and anisotropy, as the node derives them."""
    neg = ops.lt(aniso, 0.0)
    a_x = ops.select(neg, alpha / (1.0 + aniso), alpha * (1.0 - aniso))
    a_y = ops.select(neg, alpha * (1.0 + aniso), alpha / (1.0 - aniso))
    return a_x, a_y


@shader_function
def lobe_peak(ops, e, a_x, a_y, mu, *, lobe):
    """The closure's value (light cosine included) at its own mirror direction; ``mu`` is
    floored at 1e-4 so that the peak and its inverse stay finite at a grazing view."""
    mu = ops.maximum(mu, 1e-4)
    if lobe == "phong":
        # phong_ramp: cosNO (e + 2)/(2 pi) cos^e, which is mu (e + 2)/(2 pi) at the mirror.
        return mu * (e + 2.0) * INV_2PI
    # Beckmann: D / (4 cosNV (1 + Lambda_V + Lambda_L)) at the mirror, D(h = N) =
    # 1/(pi alpha_x alpha_y); the view and its mirror lie in the plane, where alpha is alpha_y.
    return 1.0 / (math.pi * a_x * a_y * 4.0 * mu * (1.0 + 2.0 * beckmann_lambda(ops, a_y * a_y, mu)))


@shader_function
def closure_tangent(ops, N, v, aniso):
    """The tangent across the plane of the view and the closure normal, ``cross(N, v)``
    (Cycles normalises it with the normal's frame); where that plane is undefined (view
    along the normal) the lobe is made isotropic, which ignores the tangent."""
    c = ops.cross(N, v)
    return c, ops.select(ops.gt(ops.dot(c, c), 1e-8), aniso, 0.0)


@shader_function
def lobe_shape(ops, mu, e, e_within, e_across, *, lobe):
    """A closure about a normal seen at cosine ``mu`` whose lobe has the Phong exponents
    ``e_within`` and ``e_across``: its alpha, anisotropy and the inverse of its value at
    its centre (a weight that makes the centre's value an amplitude ``A`` is ``A`` times
    that).  ``e``: the round exponent (the geometric mean of the two) that Phong lobes
    take."""
    alpha, aniso, a_x, a_y = lobe_alphas(ops, e_within, e_across, mu)
    return 1.0 / lobe_peak(ops, e, a_x, a_y, mu, lobe=lobe), alpha, aniso


def closure_for(ops, lobe, name, normal, e, v, amplitudes):
    """A closure about ``normal`` whose value at its centre equals ``amplitudes`` (r, g, b)."""
    mu = ops.named(f"mu_{name}", ops.dot(normal, v))
    alpha, aniso, a_x, a_y = lobe_alphas(ops, e, e, mu)
    tangent, aniso = closure_tangent(ops, normal, v, aniso)
    tangent = ops.named(f"tangent_{name}", tangent)
    inv = ops.named(f"inv_peak_{name}", 1.0 / lobe_peak(ops, e, a_x, a_y, mu, lobe=lobe))
    return Closure(name, normal, e, alpha, tuple(a * inv for a in amplitudes), aniso, tangent)


@shader_function
def lobe_correlation(ops, p, q, delta2):
    """Normalised overlap <gp, gq> / (|gp| |gq|) of two tangent-plane Gaussian lobes whose
    centres are ``delta2`` apart (squared), and ``1 - rho^2`` written without cancellation
    (equal lobes give rho -> 1, and float32 shaders would lose every digit)."""
    s = p + q
    qq = 2.0 * ops.sqrt(p * q) / s  # 1 for equal exponents
    x = 0.5 * (p * q) / s * delta2
    e = ops.exp(-x)
    rho = qq * e
    diff = (p - q) / s
    one_minus_rho2 = diff * diff + qq * qq * (1.0 - e * e)
    return rho, one_minus_rho2


@shader_function
def fold_basis(ops, eR, eT, eI, dRT, dRI, dTI):
    """The geometry of :func:`fold_interference`'s least-squares fit, which the lobes'
    exponents and centres (``d..``: squared angles between them) fix whatever the
    amplitudes: the norms ``u`` of Gaussian lobes ``g = exp(-e theta^2 / 2)`` in the
    tangent plane (``|g|^2 = 1/(2e)`` up to a common factor), their normalised overlaps
    ``rho`` and the determinant of the normal equations with a small ridge (equal lobes
    make them singular).  Wavelengths that share lobe centres share this."""
    eR = ops.maximum(eR, 1e-3)  # exponent 0 has no finite Gaussian norm
    eT = ops.maximum(eT, 1e-3)
    eI = ops.maximum(eI, 1e-3)
    uR = 1.0 / ops.sqrt(2.0 * eR)
    uT = 1.0 / ops.sqrt(2.0 * eT)
    uI = 1.0 / ops.sqrt(2.0 * eI)
    rRT, one_minus = lobe_correlation(ops, eR, eT, dRT)
    rRI, _ = lobe_correlation(ops, eR, eI, dRI)
    rTI, _ = lobe_correlation(ops, eT, eI, dTI)
    det = 2.0 * FOLD_RIDGE + FOLD_RIDGE * FOLD_RIDGE + one_minus  # (1 + ridge)^2 - rho^2
    return dict(uR=uR, uT=uT, uI=uI, rRT=rRT, rRI=rRI, rTI=rTI, det=det)


@shader_function
def fold_weights(ops, AR, AT, AI, uR, uT, uI, rRT, rRI, rTI, det):
    """Non-negative least-squares fit of ``AR gR + AT gT + AI gI`` by ``wR gR + wT gT`` in
    the basis of :func:`fold_basis`: ``(wR, wT)``.  Where the 2x2 solution has a negative
    weight, the better single-lobe fit is used."""
    aR, aT, aI = AR * uR, AT * uT, AI * uI  # coefficients on unit-norm lobes
    bR = aR + rRT * aT + rRI * aI
    bT = rRT * aR + aT + rTI * aI
    wR2 = ((1.0 + FOLD_RIDGE) * bR - rRT * bT) / det
    wT2 = ((1.0 + FOLD_RIDGE) * bT - rRT * bR) / det
    both = ops.gt(wR2, 0.0) * ops.gt(wT2, 0.0)
    wR1 = ops.maximum(bR, 0.0)
    wT1 = ops.maximum(bT, 0.0)
    r_better = ops.gt(bR * wR1, bT * wT1)  # the fit that removes more of ||f||^2
    wR = ops.select(both, wR2, ops.select(r_better, wR1, 0.0)) / uR
    wT = ops.select(both, wT2, ops.select(r_better, 0.0, wT1)) / uT
    return wR, wT


def fold_interference(ops, AR, AT, AI, basis):
    """The interference lobe of eq. 5 (``2 cos(2 Phi) sqrt(R T)``, of either sign) folded
    into the reflected and transmitted lobes: ``(wR, wT)``, the non-negative least-squares
    fit of ``AR gR + AT gT + AI gI`` by ``wR gR + wT gT`` (:func:`fold_basis`,
    :func:`fold_weights`).  Cycles clamps a negative closure weight to 0, so destructive
    interference cannot be a closure of its own; constructive interference is folded too,
    which saves a closure per channel (docs/closure-decomposition.md has what that costs in
    accuracy and saves in time).  Works per channel on triples."""
    return fold_weights(ops, AR, AT, AI, *(basis[k] for k in FOLD_BASIS))


FOLD_BASIS = ("uR", "uT", "uI", "rRT", "rRI", "rTI", "det")


# ---------------------------------------------------------------- thin-film optics
# The physical mode (``optics="physical"``): the paper's lower boundary is a perfect mirror
# with no phase change.  Thin-film optics (Born & Wolf; docs/physical-optics.md) gives each
# boundary its Fresnel amplitudes, for the s and p polarisations, the lower one complex where
# the medium under the layer absorbs (a metal, index n2 + i k2).  Summing the beams that leave
# the layer after 0, 1, 2... reflections on the lower boundary (Airy) gives the reflectance as
# a constant plus cosines of multiples of the phase 2 delta:
#
#     R(delta) = DC + 2 |Z1| cos(2 delta + arg Z1) + 2 |Z2| cos(4 delta + arg Z2) + ...
#
# per polarisation, with a = r01 (real: the layer and the outside are clear), b = t01 t10 r12
# = (1 - a^2) r12, c = r10 r12 = -a r12 and q = 1 / (1 - |c|^2):
#
#     DC = a^2 + |b|^2 q,   Z1 = a b + |b|^2 q c,   Z_m = c^(m-1) Z1.
#
# DC - a^2 is the transmitted lobe's share; Z1 and Z2 are its interference with the top
# reflection, each integrated over a colour band in closed form like the paper's cosine.
# Complex values are pairs (re, im) of channel values.
def c_mul(a, b):
    return a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0]


def c_div(ops, a, b):
    inv = 1.0 / ops.maximum(b[0] * b[0] + b[1] * b[1], 1e-30)
    return (a[0] * b[0] + a[1] * b[1]) * inv, (a[1] * b[0] - a[0] * b[1]) * inv


def c_abs2(a):
    return a[0] * a[0] + a[1] * a[1]


@shader_function
def c_sqrt(ops, re, im):
    """Principal square root of ``re + i im`` for ``im >= 0`` (the root with a non-negative
    imaginary part: the wave that decays into an absorbing medium)."""
    m = ops.sqrt(re * re + im * im)
    return ops.sqrt(ops.maximum((m + re) * 0.5, 0.0)), ops.sqrt(ops.maximum((m - re) * 0.5, 0.0))


@shader_function
def top_amplitudes(ops, cos0, eta, cos1):
    """Fresnel amplitudes ``(r_s, r_p)`` of the upper boundary, outside to layer, for a
    direction at cosine ``cos0`` outside and ``cos1`` inside (``eta = r0 / r1``); real: both
    media are clear.  Divided through by ``r1`` so that only the ratio appears."""
    a = eta * cos0
    b = eta * cos1
    rs = (a - cos1) / ops.maximum(a + cos1, 1e-9)
    rp = (cos0 - b) / ops.maximum(cos0 + b, 1e-9)
    return rs, rp


@shader_function
def lower_amplitudes(ops, cos1, r1, n2, k2):
    """Fresnel amplitudes ``r_s``, ``r_p`` (each ``(re, im)``) of the lower boundary, layer
    (index ``r1``, direction at cosine ``cos1``) to the medium of complex index ``n2 + i k2``.
    With ``u = n2~ cos theta2 = sqrt(n2~^2 - r1^2 sin^2 theta1)`` (the decaying root; total
    internal reflection where ``n2 < r1`` makes it imaginary): ``r_s = (r1 cos1 - u) / (r1
    cos1 + u)``, ``r_p = (n2~^2 cos1 - r1 u) / (n2~^2 cos1 + r1 u)``."""
    eps_re = n2 * n2 - k2 * k2
    eps_im = 2.0 * n2 * k2
    u = c_sqrt(ops, eps_re - r1 * r1 * ops.maximum(1.0 - cos1 * cos1, 0.0), eps_im)
    a = r1 * cos1
    rs = c_div(ops, (a - u[0], -u[1]), (a + u[0], u[1]))
    e_cos = (eps_re * cos1, eps_im * cos1)
    rp = c_div(ops, (e_cos[0] - r1 * u[0], e_cos[1] - r1 * u[1]), (e_cos[0] + r1 * u[0], e_cos[1] + r1 * u[1]))
    return rs[0], rs[1], rp[0], rp[1]


def beam_sums(ops, a, r12, orders):
    """One polarisation's ``(a^2, DC - a^2, [Z1, Z2, ...])`` of the beams (see above): the
    m-th harmonic is ``Z_m = c^(m-1) Z1``.  ``|c| <= |a| < 1`` but at grazing incidence, where
    ``|a| -> 1`` and ``b -> 0`` (total internal reflection below makes ``|r12| = 1``): the floor
    keeps ``0 / 0`` at 0."""
    b = ((1.0 - a * a) * r12[0], (1.0 - a * a) * r12[1])
    c = (-a * r12[0], -a * r12[1])
    bq = c_abs2(b) / ops.maximum(1.0 - c_abs2(c), 1e-6)
    z = [(a * b[0] + bq * c[0], a * b[1] + bq * c[1])]
    for _ in range(1, orders):
        z.append(c_mul(z[-1], c))
    return a * a, bq, z


@shader_function
def film_beams(ops, cos0, cos1, r1, r0, n2, k2, *, orders=1):
    """The film's reflectance at outside cosine ``cos0`` (in-layer cosine ``cos1``),
    unpolarised (the mean of s and p) and split as the program's lobes need it: the top
    reflection ``R01``, the transmitted beams' share ``T`` (their sum over every bounce,
    without interference), and per harmonic m the coherence ``g_m = |Z_m| / sqrt(R01 T)``
    and phase ``arg Z_m`` of its cosine (``2 sqrt(R01 T) g_m cos(2 m delta + arg Z_m)``)."""
    rs, rp = top_amplitudes(ops, cos0, r0 / r1, cos1)
    l_s = lower_amplitudes(ops, cos1, r1, n2, k2)
    s = beam_sums(ops, rs, (l_s[0], l_s[1]), orders)
    p = beam_sums(ops, rp, (l_s[2], l_s[3]), orders)
    R01 = (s[0] + p[0]) * 0.5
    T = (s[1] + p[1]) * 0.5
    inv = 1.0 / ops.sqrt(ops.maximum(R01 * T, 1e-12))
    out = dict(R01=R01, T=T)
    for m in range(1, orders + 1):
        z = ((s[2][m - 1][0] + p[2][m - 1][0]) * 0.5, (s[2][m - 1][1] + p[2][m - 1][1]) * 0.5)
        out[f"g{m}"] = ops.sqrt(c_abs2(z)) * inv
        out[f"phi{m}"] = gather(ops, [ops.atan2(y, x) for y, x in zip(channels(ops, z[1]), channels(ops, z[0]))])
    return out


@shader_function
def fresnel_reflectance(ops, cos0, eta):
    """Unpolarised Fresnel reflectance of the upper boundary at outside cosine ``cos0``
    (``eta = r0 / r1``): total where the light cannot enter (a layer of lower index)."""
    k = (1.0 - eta * eta) + eta * eta * (cos0 * cos0)
    cos1 = ops.sqrt(ops.maximum(k, 0.0))
    rs, rp = top_amplitudes(ops, cos0, eta, cos1)
    return ops.select(ops.gt(k, 0.0), (rs * rs + rp * rp) * 0.5, 1.0)


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


@shader_function
def film_amplitudes(ops, r1, lam, e0, e1, ks, r0, n2, k2, d, cos_v, cos_ls, cos_ci, tail, through, atten, *,
                    interference=True, band=False, dispersion=True, footprint=False, orders=1):
    """:func:`lobe_amplitudes` with thin-film optics (the physical mode): the reflected lobe
    carries the top boundary's exact reflectance, the transmitted lobe what the lower
    boundary reflects back through the top one (all its bounces), the interference lobe the
    harmonics of :func:`film_beams` with their reflection phases.  The film's optics are taken
    at the view's angle; the transmitted lobe's light side crosses the top boundary at its
    own angle (``cos_ls``)."""
    eta = r0 / r1
    eta2 = eta * eta
    s_o = ops.sqrt(ops.maximum((1.0 - eta2) + eta2 * (cos_v * cos_v), 0.0))  # <t_o, -n0>
    f = film_beams(ops, cos_v, s_o, r1, r0, n2, k2, orders=orders)
    AR_amp = f["R01"] * (ks * (e0 + 2.0) * INV_2PI)
    # The transmitted beams cross the top boundary at l*, not at the view: (1 - R01(l*)) / (1 - R01(v)).
    cross = (1.0 - fresnel_reflectance(ops, cos_ls, eta)) / ops.maximum(1.0 - f["R01"], 1e-6)
    AT_amp = f["T"] * cross * tail * (ks * (e1 + 2.0) * INV_2PI / (r1 * r1))
    AT = ops.select(through, AT_amp * cos_ls, 0.0)
    if not interference:
        return AR_amp * cos_v, AT, 0.0  # averaged over the band: the cosines have mean 0
    s_i = ops.sqrt((1.0 - eta2) + eta2 * (cos_ci * cos_ci))
    opd, slope = interference_path(ops, r1, d, s_i, s_o)
    wave = harmonics(ops, f, lam, opd, slope, r1, orders, band=band, dispersion=dispersion, footprint=footprint)
    AI = ops.select(through, wave * ops.sqrt(AR_amp * AT_amp) * (atten * cos_ci) * 2.0, 0.0)
    return AR_amp * cos_v, AT, AI


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


# ---------------------------------------------------------------- the channels
# A channel value is a scalar (one wavelength, the spectral modes) or a triple (the three
# RGB channels at once, one component each: a shader evaluates them as one vector).  The
# arithmetic is the same; only the directions differ per channel, so they are computed
# channel by channel.
def channels(ops, x):
    """The per-channel scalars of a channel value."""
    return list(ops.components(x)) if ops.is_vector(x) else [x]


def gather(ops, parts):
    """A channel value from per-channel scalars."""
    if len(parts) == 3:
        return ops.combine(*parts)
    return parts[0]


def spread(ops, x, like):
    """``x`` (one channel's scalar) as a channel value shaped like ``like``."""
    return ops.combine(x, x, x) if ops.is_vector(like) and not ops.is_vector(x) else x


@shader_function
def layer_path(ops, eta, s_o, cos_v, n0, n1, v):
    """The view's path into the layer (eqs. 10, 11): ``-v`` refracted into the layer
    (``t_o``) and mirrored on the lower boundary: ``r``, with ``<r, n0>`` and ``<t_o, n1>``
    (eq. 11 needs ``<t_o, n1> < 0``: the path reaches the lower boundary)."""
    t_o = v * (-eta) + n0 * (eta * cos_v - s_o)
    to_n1 = ops.dot(t_o, n1)
    r = t_o - n1 * (2.0 * to_n1)
    return r, ops.dot(r, n0), to_n1


@shader_function
def exit_direction(ops, eta, cos_r, e1):
    """Where the in-layer direction ``r`` (cosine ``cos_r`` to ``n0``) leaves the layer: the
    light direction ``l* = a r + b n0`` (a unit vector), its cosine ``cos_l`` to ``n0``, the
    in-layer cosine ``cos_t`` of the path that leaves along it, and ``tail``.

    Where ``r`` leaves (inside the critical cone, ``sin theta_c = eta``), ``l*`` is ``r``
    refracted out and ``tail`` is 1.  Where it cannot (beyond the critical angle, or
    heading down) the in-layer lobe ``cos^e1`` about ``r`` still sends its tail out through
    the critical cone: ``l*`` is the exit direction, in the plane of ``r`` and ``n0``, where
    the tail's light is largest, and ``tail`` the lobe's value there (``exp(-e1 (1 - cos
    delta))``, ``delta`` the in-layer angle from ``r``).  Near grazing exit that light goes
    as ``u^2 cos^e1(delta0 + b u^2)`` (``u`` the exit cosine, ``delta0`` the angle of ``r``
    beyond the critical angle, ``b = eta / (2 cos theta_c)``; Snell's law and Schlick's
    ``1 - F ~ 5 u``): largest at ``u^2 = (sqrt(delta0^2 + 4 / e1) - delta0) / (2 b)``.
    Scalars or channel triples."""
    inv_eta = 1.0 / eta
    inv_eta2 = inv_eta * inv_eta
    k_l = (1.0 - inv_eta2) + inv_eta2 * (cos_r * cos_r)
    leaves = ops.gt(k_l, 0.0) * ops.gt(cos_r, 0.0)
    sin_r = ops.sqrt(ops.maximum(1.0 - cos_r * cos_r, 0.0))
    cos_c = ops.sqrt(ops.maximum(1.0 - eta * eta, 1e-6))
    delta0 = ops.maximum(sin_r * cos_c - cos_r * eta, 0.0)  # sin(theta_r - theta_c)
    u2 = ops.clamp((ops.sqrt(delta0 * delta0 + 4.0 / ops.maximum(e1, 1e-3)) - delta0) * (cos_c / eta), 4e-4, 1.0)
    u = ops.sqrt(u2)
    sin_x = ops.sqrt(1.0 - u2)
    sin_in = eta * sin_x
    cos_in = ops.sqrt(ops.maximum(1.0 - sin_in * sin_in, 0.0))
    cos_delta = cos_r * cos_in + sin_r * sin_in
    tail = ops.select(leaves, 1.0, ops.exp(-ops.maximum(e1, 0.0) * (1.0 - cos_delta)))
    s_l = ops.sqrt(ops.maximum(k_l, 0.0))
    # The tail's exit direction u n0 + sin_x p, with p = (r - cos_r n0) / sin_r.
    q = sin_x / ops.maximum(sin_r, 1e-6)
    a = ops.select(leaves, inv_eta, q)
    b = ops.select(leaves, s_l - inv_eta * cos_r, u - cos_r * q)
    return a, b, ops.select(leaves, s_l, u), ops.select(leaves, cos_r, cos_in), tail


@shader_function
def interference_centre(ops, e0, e1p, w_sum, e01, d_RT, cos_v, cos_l):
    """The interference lobe's centre ``c_I = (e0 r_v + e1' l*) / L`` (eq. 5: the weighted
    centre of the reflected and transmitted lobes) without forming it: its cosine to
    ``n0`` and its squared chords ``d_RI``, ``d_TI`` to ``r_v`` and ``l*``, from the chord
    ``d_RT = 2 - 2 <r_v, l*>`` and the centres' cosines ``cos_v``, ``cos_l``.  Exact:
    ``L^2 = e0^2 + e1'^2 + 2 e0 e1' <r_v, l*> = (e0 + e1')^2 - e0 e1' d_RT``, at least
    ``(e0 - e1')^2``; ``w_sum``: ``e0 + e1'`` floored, so that two zero exponents give a
    zero lobe, not a division by zero; ``e01 = e0 e1'``."""
    inv_L = 1.0 / ops.maximum(ops.sqrt(w_sum * w_sum - e01 * d_RT), 1e-6)
    c = 1.0 - 0.5 * d_RT  # <r_v, l*>
    cos_ci = ops.clamp((e0 * cos_v + e1p * cos_l) * inv_L, 0.0, 1.0)
    d_RI = ops.maximum(2.0 - 2.0 * (e0 + e1p * c) * inv_L, 0.0)
    d_TI = ops.maximum(2.0 - 2.0 * (e1p + e0 * c) * inv_L, 0.0)
    return cos_ci, d_RI, d_TI


@shader_function
def lobe_geometry(ops, r1, e0, e1, r0, n0, n1, v, cos_v, r_v):
    """Where each channel's lobes lie and how wide they are (eqs. 4, 5, 10, 11): what the
    index ``r1`` fixes, but not the wavelength's phase.  ``r1``: a scalar (one channel) or
    a triple (three).  Wavelengths whose lobes share a closure share this
    (:func:`lobe_amplitudes` gives each its own amplitudes on it)."""
    eta = r0 / r1
    eta2 = eta * eta
    k_o = (1.0 - eta2) + eta2 * (cos_v * cos_v)
    s_o = ops.sqrt(k_o)  # <t_o, -n0>
    entering = ops.gt(k_o, 0.0) * ops.gt(cos_v, 0.0)
    # The light direction l* whose path through the layer leaves along v (eqs. 10, 11):
    # each channel's path, then how it leaves, computed on the channels at once.
    paths = [layer_path(ops, e, s, cos_v, n0, n1, v) for e, s in zip(channels(ops, eta), channels(ops, s_o))]
    cos_r = gather(ops, [p[1] for p in paths])
    to_n1 = gather(ops, [p[2] for p in paths])
    a, b, cos_ls, s_ls, tail = exit_direction(ops, eta, cos_r, e1)
    cos_ls = ops.clamp(cos_ls, 0.0, 1.0)
    # Eq. 11: no path, T = 0, and l* is the mirror direction.  A path whose centre cannot
    # leave keeps its tail.
    through = entering * ops.lt(to_n1, 0.0) * ops.gt(cos_ls, 0.0)
    l_stars = [ops.select_vec(ok, p[0] * ak + n0 * bk, r_v)
               for p, ok, ak, bk in zip(paths, channels(ops, through), channels(ops, a), channels(ops, b))]
    # The in-layer lobe seen from outside: exponent e1 / r1^2, times cos(l*)/cos(t) for the
    # stretch within the plane of incidence (geometric mean of the two directions).
    # Per axis (the closures are anisotropic): across the plane of incidence e1 / r1^2,
    # within it e1 / r1^2 (cos(l*)/cos(t))^2.
    stretch = ops.select(through, cos_ls / ops.maximum(s_ls, 1e-6), 1.0)
    e1_across = e1 / (r1 * r1)
    e1p = e1_across * stretch
    e1_within = e1p * stretch
    # Interference, eq. 5: sqrt(R T) of two Phong lobes is a lobe of exponent
    # (e0 + e1')/2 about their weighted centre, attenuated by their distance.
    w_sum = ops.maximum(e0 + e1p, 1e-6)
    d_RT = spread(ops, gather(ops, [angle2(ops, r_v, ls) for ls in l_stars]), r1)
    e01 = e0 * e1p
    atten = ops.exp(e01 * d_RT * (-0.25) / w_sum)
    cos_ci, d_RI, d_TI = interference_centre(ops, e0, e1p, w_sum, e01, d_RT, cos_v,
                                             ops.select(through, cos_ls, cos_v))
    out = dict(through=through, tail=tail, cos_ls=cos_ls, cos_ci=cos_ci, atten=atten, eT=e1p,
               eI=0.5 * (e0 + e1p), d_RT=d_RT, d_RI=d_RI, d_TI=d_TI, eT_within=e1_within, eT_across=e1_across)
    for k, ls in enumerate(l_stars):
        out[f"l_star{k}"] = ls
    return out


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


def diffuse_colour(ops, P, d, wavelengths=WAVELENGTHS_NM, band=False, dispersion=True, interference=True,
                   footprint=False, optics="paper", orders=1):
    """``kd base rho_d`` per channel (eq. 14), the three channels as one triple; without
    ``interference`` (a layer so thick that it averages out over the band) ``rho_d = 1``
    (with thin-film optics, the film's mean transmission, twice)."""
    if optics == "physical":
        rho = film_diffuse_rho(ops, ops.combine(*P["r1"]), P["r0"], ops.combine(*P["r2"]), ops.combine(*P["k2"]),
                               ops.triple(*wavelengths), d, band=band, dispersion=dispersion, footprint=footprint,
                               orders=orders, interference=interference)
        colour = ops.named("diffuse_colour", ops.combine(*P["base"]) * (P["kd"] * rho))
        return ops.components(colour)
    if not interference:
        return tuple(P["kd"] * b for b in P["base"])
    rho = diffuse_rho(ops, ops.combine(*P["r1"]), P["r0"], ops.triple(*wavelengths), d, band=band,
                      dispersion=dispersion, footprint=footprint)
    colour = ops.named("diffuse_colour", ops.combine(*P["base"]) * (P["kd"] * rho))
    return ops.components(colour)


def channel_lobes(ops, r1, e0, e1, r0, n0, n1, v, lobe="beckmann", interference=True):
    """The lobes of one channel or three (``r1`` a scalar or a triple) as closures would
    place them: :func:`lobe_geometry`, the fold's basis, and per channel the transmitted
    closure's normal ``N_T``, tangent ``U_T``, exponent, alpha, anisotropy and inverse
    peak (a lobe centred on the direction c is a closure about normalize(v + c))."""
    cos_v = ops.clamp(ops.dot(v, n0), 0.0, 1.0)
    r_v = n0 * (2.0 * ops.dot(v, n0)) - v
    geo = lobe_geometry(ops, r1, e0, e1, r0, n0, n1, v, cos_v, r_v)
    out = {k: geo[k] for k in LOBE_PLACEMENT}
    out["cos_v"] = cos_v
    if interference:
        out.update(fold_basis(ops, e0, geo["eT"], geo["eI"], geo["d_RT"], geo["d_RI"], geo["d_TI"]))
    n = 3 if ops.is_vector(r1) else 1
    normals = [ops.normalize(v + geo[f"l_star{k}"], n0) for k in range(n)]
    mu = spread(ops, gather(ops, [ops.dot(N, v) for N in normals]), r1)
    inv_peak, alpha, aniso = lobe_shape(ops, mu, geo["eT"], geo["eT_within"], geo["eT_across"], lobe=lobe)
    frames = [closure_tangent(ops, N, v, a) for N, a in zip(normals, channels(ops, aniso))]
    out.update(e_T=geo["eT"], alpha_T=alpha, inv_peak_T=inv_peak, aniso_T=gather(ops, [f[1] for f in frames]))
    out.update({f"N_T{k}": N for k, N in enumerate(normals)})
    out.update({f"U_T{k}": f[0] for k, f in enumerate(frames)})
    return out


LOBE_PLACEMENT = ("cos_ls", "cos_ci", "tail", "through", "atten")  # what lobe_amplitudes takes from the lobes


def channel_block(ops, r1, lam, e0, e1, ks, r0, n0, n1, v, d, r1_lobes=None, n2=None, k2=None, lobe="beckmann",
                  interference=True, band=False, footprint=False, optics="paper", orders=1):
    """The channels' lobes (eqs. 3-11), the interference folded into the other two, and the
    normals, exponents, alphas and weights of their transmitted closures (``N_T0``.., one
    per lobe direction).  ``r1``, ``lam``: a scalar (one wavelength) or a triple (the RGB
    channels); ``r1_lobes``: the index that places the lobes, where the channels share
    them (equal indices), else ``r1``; ``band``: the interference integrated over each RGB
    channel's band (the analytic mode), with ``footprint`` over the pixel's too; ``optics``:
    the paper's amplitudes or thin-film optics' (:func:`film_amplitudes`, the lower medium
    ``n2 + i k2``, ``orders`` harmonics)."""
    lobes = channel_lobes(ops, r1 if r1_lobes is None else r1_lobes, e0, e1, r0, n0, n1, v, lobe, interference)
    placed = [spread(ops, lobes[k], r1) for k in LOBE_PLACEMENT]
    modes = dict(interference=interference, band=band, dispersion=r1_lobes is None, footprint=footprint)
    if optics == "physical":
        AR, AT, AI = film_amplitudes(ops, r1, lam, e0, e1, ks, r0, n2, k2, d, lobes["cos_v"], *placed,
                                     orders=orders, **modes)
    else:
        AR, AT, AI = lobe_amplitudes(ops, r1, lam, e0, e1, ks, r0, d, lobes["cos_v"], *placed, **modes)
    if interference:
        AR, AT = fold_interference(ops, AR, AT, AI, {k: spread(ops, lobes[k], r1) for k in FOLD_BASIS})
    out = dict(lobes, AR=AR, w_T=AT * spread(ops, lobes["inv_peak_T"], r1))
    return {k: out[k] for k in ["AR", "w_T", "e_T", "alpha_T", "aniso_T"] + [k for k in out if k[:3] in ("N_T", "U_T")]}


def spectral_step(ops, acc_R, acc_D, acc_T, r1, lam, m, e0, e1, ks, r0, d, cos_v, cos_ls, cos_ci, tail, through,
                  atten, uR=None, uT=None, uI=None, rRT=None, rRI=None, rTI=None, det=None, n2=None, k2=None,
                  diffuse=True, interference=True, optics="paper", orders=1):
    """One wavelength of the spectral mode, chained: it takes the running sums of the
    reflected, diffuse and its lobe group's transmitted light and returns them updated, so
    a shader holds only the sums, whatever the number of wavelengths.  The lobes are its
    group's (:func:`channel_lobes` of the group's lead wavelength, computed once); only
    the amplitudes are the wavelength's own.  ``m``: the wavelength's row of the
    spectrum-to-Rec.709 matrix (a vector)."""
    out = {}
    # Everything this step computes depends on the index, which waits for the whole
    # previous state, so that a node backend evaluates the steps one after the other and
    # only the running state stays alive, whatever the number of wavelengths (Cycles' SVM
    # has a stack of 255 floats).
    r1 = ops.after((acc_R, acc_D, acc_T), r1)
    if not diffuse:
        out["acc_D"] = acc_D
    elif optics == "physical":
        out["acc_D"] = acc_D + m * film_diffuse_rho(ops, r1, r0, n2, k2, lam, d, orders=orders,
                                                    interference=interference)
    elif not interference:
        out["acc_D"] = acc_D + m  # rho_d averaged over the band: 1
    else:
        out["acc_D"] = acc_D + m * diffuse_rho(ops, r1, r0, lam, d)
    if optics == "physical":
        AR, AT, AI = film_amplitudes(ops, r1, lam, e0, e1, ks, r0, n2, k2, d, cos_v, cos_ls, cos_ci, tail, through,
                                     atten, interference=interference, orders=orders)
    else:
        AR, AT, AI = lobe_amplitudes(ops, r1, lam, e0, e1, ks, r0, d, cos_v, cos_ls, cos_ci, tail, through, atten,
                                     interference=interference)
    if interference:
        AR, AT = fold_weights(ops, AR, AT, AI, uR, uT, uI, rRT, rRI, rTI, det)
    out["acc_R"] = acc_R + m * AR
    out["acc_T"] = acc_T + m * AT
    return out


_UNIT = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def spectral_groups(lams, dispersion: bool):
    """Lobe group of each wavelength (the nearest of the three RGB wavelengths with
    dispersion, one group without) and, per group, the wavelength whose lobe it uses."""
    groups = [min(range(3), key=lambda c: abs(WAVELENGTHS_NM[c] - lam)) if dispersion else 0 for lam in lams]
    leads = {}
    for g in sorted(set(groups)):
        centre = WAVELENGTHS_NM[g] if dispersion else WAVELENGTHS_NM[1]
        leads[g] = min((j for j in range(len(lams)) if groups[j] == g), key=lambda j: abs(lams[j] - centre))
    return groups, leads


def merged_group_weights(ops, accs):
    """Closure weights (r, g, b) of the lobe groups from their Rec.709 sums ``accs``.

    A group's sum can be negative in a channel (the colour matching functions are: the
    green group's wavelengths subtract red), and Cycles clamps a closure weight at 0.
    Clamping each group alone would discard that negative part and add its light back;
    instead, per channel, the negative parts are taken from the groups' positive parts in
    proportion, so the groups' total keeps the channel's sum (clamped at 0 only if the sum
    itself is negative)."""
    out = [[None] * 3 for _ in accs]
    for c in range(3):
        parts = [ops.dot(acc, _UNIT[c]) for acc in accs]
        if len(parts) == 1:
            out[0][c] = ops.maximum(parts[0], 0.0)
            continue
        pos = [ops.maximum(x, 0.0) for x in parts]
        total, pos_total = parts[0], pos[0]
        for x, q in zip(parts[1:], pos[1:]):
            total = total + x
            pos_total = pos_total + q
        scale = ops.maximum(total, 0.0) / ops.maximum(pos_total, 1e-30)
        for g, q in enumerate(pos):
            out[g][c] = q * scale
    return [tuple(w) for w in out]


def shade_spectral(ops, P, n0, n1, d, v, plan: EffectPlan) -> ShadingResult:
    """Spectral mode: the channel program at N wavelengths (``r1(lambda)`` from the Cauchy
    fit through the three indices, a linear map), summed into RGB closures with baked
    CIE 1931 / D65 weights (model/spectral_tables.py).  Transmitted lobes keep a bounded
    number of directions: each wavelength joins the lobe group of the nearest of the three
    RGB wavelengths (three groups with dispersion, one without), whose lobes are placed
    once, by the group's wavelength nearest to it; each wavelength adds its own amplitudes
    on them.
    """
    from .spectral_tables import tables

    t = tables(plan.spectral)
    lams, K, M = t["wavelengths"], t["cauchy"], t["rgb"]
    groups, leads = spectral_groups(lams, plan.dispersion)

    def through_channels(j, values, lo, hi):
        k = K[j]
        return ops.clamp(k[0] * values[0] + k[1] * values[1] + k[2] * values[2], lo, hi)

    def index(j):
        return through_channels(j, P["r1"], 0.1, 5.0)

    optics = optics_settings(plan)

    def lower_medium(j):
        """The lower medium's n and k at wavelength j, by the same map through the channels' values."""
        if not optics:
            return {}
        return dict(n2=through_channels(j, P["r2"], 0.01, 10.0), k2=through_channels(j, P["k2"], 0.0, 20.0))

    order = sorted(leads)
    lead_r1 = gather(ops, [index(leads[g]) for g in order])
    lobes = ops.call("lobe groups", channel_lobes,
                     dict(r1=lead_r1, e0=P["e0"], e1=P["e1"], r0=P["r0"], n0=n0, n1=n1, v=v),
                     lobe=plan.lobe, interference=plan.interference)
    per_group = list(LOBE_PLACEMENT + (FOLD_BASIS if plan.interference else ()))
    split = {k: channels(ops, spread(ops, lobes[k], lead_r1)) for k in per_group}
    zero = (0.0, 0.0, 0.0)
    acc_R, acc_D, acc_T = zero, zero, {g: zero for g in order}
    for j, (lam, m) in enumerate(zip(lams, M)):
        g = groups[j]
        slot = order.index(g)
        state = ops.call("spectral step", spectral_step,
                         dict(acc_R=acc_R, acc_D=acc_D, acc_T=acc_T[g], r1=index(j), lam=float(lam),
                              m=tuple(float(x) for x in m), e0=P["e0"], e1=P["e1"], ks=P["ks"], r0=P["r0"], d=d,
                              cos_v=lobes["cos_v"], **{k: split[k][slot] for k in per_group}, **lower_medium(j)),
                         diffuse=plan.diffuse, interference=plan.interference, **optics)
        acc_R, acc_D, acc_T[g] = state["acc_R"], state["acc_D"], state["acc_T"]
    res = ShadingResult()

    def rgb(vec):
        return tuple(ops.maximum(ops.dot(vec, _UNIT[c]), 0.0) for c in range(3))

    if plan.diffuse:
        res.diffuse = tuple(P["kd"] * b * x for b, x in zip(P["base"], rgb(acc_D)))
    if not plan.specular:
        return res
    res.glossy.append(closure_for(ops, plan.lobe, "reflect", n0, P["e0"], v, rgb(acc_R)))
    inv_peak = channels(ops, lobes["inv_peak_T"])
    weights = merged_group_weights(ops, [acc_T[g] * inv_peak[slot] for slot, g in enumerate(order)])
    e, alpha, aniso = (channels(ops, lobes[k]) for k in ("e_T", "alpha_T", "aniso_T"))
    for slot, (g, w) in enumerate(zip(order, weights)):
        res.glossy.append(Closure(f"transmit_{g}", lobes[f"N_T{slot}"], e[slot], alpha[slot], w, aniso[slot],
                                  lobes[f"U_T{slot}"]))
    return res


def shade(ops, P, n0, n1, d, v, plan: EffectPlan, wavelengths=WAVELENGTHS_NM) -> ShadingResult:
    """Closures of the layered BRDF at one shading point.

    ``P``: dict with ``r1`` (3 values), ``r0``, ``e0``, ``e1``, ``ks``, ``kd``, ``base``
    (3 values); ``n0``, ``n1``: unit normals; ``d``: thickness (nm); ``v``: unit view
    direction (towards the camera).
    """
    if plan.spectral:
        return shade_spectral(ops, P, n0, n1, d, v, plan)
    res = ShadingResult()
    optics = optics_settings(plan)
    if plan.diffuse:
        res.diffuse = diffuse_colour(ops, P, d, wavelengths, band=plan.analytic, dispersion=plan.dispersion,
                                     interference=plan.interference, footprint=plan.analytic and plan.footprint,
                                     **optics)
    if not plan.specular:
        return res
    inputs = dict(r1=ops.combine(*P["r1"]), lam=tuple(float(x) for x in wavelengths), e0=P["e0"], e1=P["e1"],
                  ks=P["ks"], r0=P["r0"], n0=n0, n1=n1, v=v, d=d)
    if optics:
        inputs.update(n2=ops.combine(*P["r2"]), k2=ops.combine(*P["k2"]))
    if not plan.dispersion:
        # Equal indices: every channel's lobes have the same centre and exponent, placed
        # once (by green's index); each channel keeps its own amplitudes.
        inputs["r1_lobes"] = P["r1"][1]
    # The analytic mode's variant of the block (the paper's RGB keeps its interference).
    band = dict(band=True, interference=plan.interference, footprint=plan.footprint) if plan.analytic else {}
    b = ops.call("channels" if plan.dispersion else "channels, shared lobes", channel_block, inputs, lobe=plan.lobe,
                 **band, **optics)
    res.glossy.append(closure_for(ops, plan.lobe, "reflect", n0, P["e0"], v, ops.components(b["AR"])))
    w = ops.components(b["w_T"])
    if not plan.dispersion:
        res.glossy.append(Closure("transmit", b["N_T0"], b["e_T"], b["alpha_T"], w, b["aniso_T"], b["U_T0"]))
        return res
    # Each channel's lobes have their own centres and exponents: a closure per channel.
    e, alpha, aniso = (ops.components(b[f"{k}_T"]) for k in ("e", "alpha", "aniso"))
    for c in range(3):
        weight = tuple(w[c] if k == c else 0.0 for k in range(3))
        res.glossy.append(Closure(f"transmit_{'rgb'[c]}", b[f"N_T{c}"], e[c], alpha[c], weight,
                                  aniso[c], b[f"U_T{c}"]))
    return res


# ---------------------------------------------------------------- the surface prelude
@shader_function
def rotate_about(ops, a, axis, angle):
    """Rotate ``a`` about the unit ``axis`` by ``angle`` radians (Rodrigues)."""
    c = ops.cos(angle)
    s = ops.sin(angle)
    return a * c + ops.cross(axis, a) * s + axis * (ops.dot(axis, a) * (1.0 - c))


@shader_function
def tangent_axis(ops, n0, up, fallback):
    """Tilt axis ``normalize(cross(up, n0))``; at the poles, where n0 is along ``up`` and the
    cross product vanishes (length below 1e-4), ``fallback``."""
    c = ops.cross(up, n0)
    return ops.select_vec(ops.lt(ops.length(c), 1e-4), fallback, ops.normalize(c, fallback))


@shader_function
def tilted_normal(ops, n0, tilt_deg, azimuth_deg, up, fallback):
    """Lower normal of a constant tilt: ``n0`` rotated by ``tilt_deg`` about the tilt axis,
    the axis first turned about ``n0`` by ``azimuth_deg``.  Any tilt up to 180 degrees is
    valid: at 90 or 180 degrees no path crosses the layer (eq. 11)."""
    t = tangent_axis(ops, n0, up, fallback)
    t = rotate_about(ops, t, n0, azimuth_deg * DEG)
    return ops.normalize(rotate_about(ops, n0, t, tilt_deg * DEG), n0)


@shader_function
def correlated_normal(ops, n0, grad_d, strength):
    """Lower normal from the thickness gradient: ``normalize(n0 + s grad_t(d))``, the
    tangential part of the gradient only; a degenerate sum falls back to ``n0``."""
    g = grad_d - n0 * ops.dot(grad_d, n0)
    return ops.normalize(n0 + g * strength, n0)


@shader_function
def thickness_factor(ops, p, scale, detail, roughness, phase, *, pattern):
    """The thickness pattern's factor at the object-space position ``p``: Blender's Noise
    Texture (4D fBm, W = phase, lacunarity 2, normalised), or ``clamp(0.5 - 0.5 z, 0, 1)``,
    a film that thickens downwards like a draining soap film."""
    if pattern == "noise":
        return ops.noise_fbm(p, phase, scale, detail, roughness)
    return ops.clamp(0.5 - 0.5 * ops.dot(p, (0.0, 0.0, 1.0)), 0.0, 1.0)


@shader_function
def thickness_at(ops, p, d_min, d_max, scale, detail, roughness, phase, *, pattern):
    """``d = d_min + (d_max - d_min) clamp(n, 0, 1)`` in nm, within [0, D_LIMIT].  With
    ``d_min > d_max`` (sockets fed by textures) the same formula holds: the pattern runs
    from ``d_min`` where the factor is 0 down to ``d_max`` where it is 1."""
    n = thickness_factor(ops, p, scale, detail, roughness, phase, pattern=pattern)
    return ops.clamp(d_min + (d_max - d_min) * ops.clamp(n, 0.0, 1.0), 0.0, D_LIMIT)


@shader_function
def thickness_gradient(ops, p, d, d_min, d_max, scale, detail, roughness, phase, *, pattern):
    """World-space gradient of the thickness ``d`` at ``p`` (nm per world unit), by forward
    differences along the world axes, each step taken into object space: component k is
    ``(d(p + M^-1 h e_k) - d(p)) / h``, which is ``(M^-T grad_obj d)_k``, the inverse
    transpose that a gradient (a covector) needs under rotation and non-uniform scale."""
    h = GRADIENT_STEP
    args = (d_min, d_max, scale, detail, roughness, phase)
    dx = thickness_at(ops, p + ops.world_to_object((h, 0.0, 0.0)), *args, pattern=pattern) - d
    dy = thickness_at(ops, p + ops.world_to_object((0.0, h, 0.0)), *args, pattern=pattern) - d
    dz = thickness_at(ops, p + ops.world_to_object((0.0, 0.0, h)), *args, pattern=pattern) - d
    return ops.combine(dx, dy, dz) * (1.0 / h)


def pattern_inputs(P):
    """The inputs of :func:`thickness_at` after the position."""
    return (P["d_min"], P["d_max"], P["noise_scale"], P["noise_detail"], P["noise_roughness"], P["noise_phase"])


def layer_thickness(ops, P, p_obj, plan: EffectPlan):
    """Thickness ``d`` (nm) at the object-space position ``p_obj``."""
    if plan.thickness == "constant":
        return P["d_min"]
    return thickness_at(ops, p_obj, *pattern_inputs(P), pattern=plan.thickness)


def lower_normal(ops, P, n0, p_obj, d, plan: EffectPlan):
    """Lower boundary normal ``n1`` (world space) at a point of upper normal ``n0``."""
    if plan.normals == "tilted":
        # The object's axes in world space: the tilt sticks to the object.
        up = ops.normalize(ops.object_to_world((0.0, 0.0, 1.0)), (0.0, 0.0, 1.0))
        x_axis = ops.normalize(ops.object_to_world((1.0, 0.0, 0.0)), (1.0, 0.0, 0.0))
        return tilted_normal(ops, n0, P["tilt"], P["tilt_azimuth"], up, x_axis)
    if plan.normals == "correlated" and plan.thickness != "constant":
        grad = thickness_gradient(ops, p_obj, d, *pattern_inputs(P), pattern=plan.thickness)
        return correlated_normal(ops, n0, grad, P["bump_strength"])
    return n0


FLOAT_LIMIT = 1.0e38  # an infinite component of a direction input counts as this


@shader_function
def direction_input(ops, v):
    """A direction from a socket, scaled by its largest component so that a huge but finite
    vector keeps its direction (squaring it would overflow float32).  A vector with a NaN
    component becomes 0, and so falls back wherever it is normalised; an infinite component
    counts as the largest finite one."""
    x, y, z = ops.components(v)
    # "c < 1 or c > 0" holds for every number but NaN.
    valid = (ops.gt(ops.lt(x, 1.0) + ops.gt(x, 0.0), 0.5) * ops.gt(ops.lt(y, 1.0) + ops.gt(y, 0.0), 0.5)
             * ops.gt(ops.lt(z, 1.0) + ops.gt(z, 0.0), 0.5))
    xs = ops.clamp(ops.nan_to_zero(x), -FLOAT_LIMIT, FLOAT_LIMIT)
    ys = ops.clamp(ops.nan_to_zero(y), -FLOAT_LIMIT, FLOAT_LIMIT)
    zs = ops.clamp(ops.nan_to_zero(z), -FLOAT_LIMIT, FLOAT_LIMIT)
    largest = ops.maximum(ops.maximum(ops.abs(xs), ops.abs(ys)), ops.abs(zs))
    return ops.combine(xs, ys, zs) * (valid / largest)


def clamped_inputs(ops):
    """Every shader input, clamped to its parameter's allowed range (a texture or a driver
    may feed any value)."""
    return {spec.name: ops.named(f"{spec.name}_c", ops.clamp_input(ops.input(spec.name), spec.min, spec.max))
            for spec in iter_sockets()}


def program_inputs(P):
    """The inputs of :func:`shade` from the per-parameter values ``P``."""
    return dict(r1=(P["r1_r"], P["r1_g"], P["r1_b"]), r0=P["r0"], e0=P["e0"], e1=P["e1"], ks=P["ks"], kd=P["kd"],
                base=(P["base_r"], P["base_g"], P["base_b"]), r2=(P["r2_r"], P["r2_g"], P["r2_b"]),
                k2=(P["k2_r"], P["k2_g"], P["k2_b"]))


def base_weight(ops, r1, r0, cos_v):
    """What the top boundary transmits to the artist's base shader, ``1 - F(v)``: the mean
    over the channels (a Mix Shader takes one factor)."""
    F = schlick(ops, cos_v, fresnel_f0(ops, ops.combine(*r1), r0))
    return 1.0 - ops.dot(F, (1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0))


HARMONICS_MULTIBEAM = 3  # harmonics of the interference where the plan keeps the beams that bounce inside


def harmonic_count(plan: EffectPlan) -> int:
    """How many harmonics of the interference the plan's thin-film optics sum."""
    return HARMONICS_MULTIBEAM if plan.multibeam else 1


def optics_settings(plan: EffectPlan) -> dict:
    """The settings that select thin-film optics in the program's steps (none: the paper's)."""
    return dict(optics="physical", orders=harmonic_count(plan)) if plan.optics == "physical" else {}


CLEAR_K = 1e-3  # a lower medium of smaller extinction is clear: it passes on what enters it


@shader_function
def film_transmittance(ops, r1, r0, n2, k2, kd, cos_v, *, orders=1):
    """What reaches the Base Shader with thin-film optics: the light that the film neither
    reflects nor gives to the diffuse part (``kd``), where the lower medium is clear; a medium
    that absorbs (``k2`` above :data:`CLEAR_K`, a metal) keeps it.  A Mix Shader takes one
    factor for every channel, and the film's reflectance at a point lies anywhere between the
    troughs and crests of its interference: the factor is what passes where the film reflects
    most, ``1 - max(DC + 2 sqrt(R01 T) sum g_m)`` over the channels, so that reflected and
    passed light never add up to more than arrives."""
    eta = r0 / r1
    cos1 = ops.sqrt(ops.maximum((1.0 - eta * eta) + eta * eta * (cos_v * cos_v), 0.0))
    f = film_beams(ops, cos_v, cos1, r1, r0, n2, k2, orders=orders)
    swing = f["g1"]
    for m in range(2, orders + 1):
        swing = swing + f[f"g{m}"]
    crest = f["R01"] + f["T"] + 2.0 * ops.sqrt(f["R01"] * f["T"]) * swing
    passed = ops.clamp(1.0 - crest, 0.0, 1.0) * ops.lt(k2, CLEAR_K)
    r, g, b = ops.components(passed)
    return ops.minimum(ops.minimum(r, g), b) * (1.0 - kd)


def layered_surface(ops, plan: EffectPlan) -> ShadingResult:
    """The whole shader at one shading point, from the material's inputs.

    ``extras`` carries the shader's other outputs: ``thickness`` (nm), ``lower_normal``,
    ``upper_normal`` (world space) and ``base_weight`` (the factor of the Base Shader input).
    """
    with ops.stage("Inputs, each kept within its range; the upper normal n0"):
        P = clamped_inputs(ops)
        # A zero-length or NaN Normal input (unconnected, or a broken texture) falls back to
        # the shading normal.
        n0 = ops.normalize(direction_input(ops, ops.input("Normal")), ops.shading_normal())
        v = ops.incoming()
        p_obj = ops.object_position()
    with ops.stage("Layer thickness d (nm): noise or height"):
        d = layer_thickness(ops, P, p_obj, plan)
    with ops.stage("Lower boundary normal n1: parallel, tilted or following d"):
        n1 = lower_normal(ops, P, n0, p_obj, d, plan)
    with ops.stage("Lobes and interference: eqs. 3-11 (specular), 14-18 (diffuse)"):
        inputs = program_inputs(P)
        res = shade(ops, inputs, n0, n1, d, v, plan)
    if plan.optics == "physical" and not plan.passes:
        transmitted = 0.0  # an absorbing lower medium (a metal) keeps what enters it
    elif plan.optics == "physical":
        with ops.stage("What reaches the Base Shader: what the film neither reflects nor absorbs"):
            cos_v = ops.clamp(ops.dot(v, n0), 0.0, 1.0)
            transmitted = film_transmittance(ops, ops.combine(*inputs["r1"]), inputs["r0"],
                                             ops.combine(*inputs["r2"]), ops.combine(*inputs["k2"]), inputs["kd"],
                                             cos_v, orders=harmonic_count(plan))
    else:
        with ops.stage("What reaches the Base Shader: 1 - F(v)"):
            cos_v = ops.clamp(ops.dot(v, n0), 0.0, 1.0)
            transmitted = base_weight(ops, inputs["r1"], inputs["r0"], cos_v)
    res.extras.update(thickness=d, lower_normal=n1, upper_normal=n0, base_weight=transmitted)
    return res
