"""Lobe shapes: a Phong lobe about a closure normal as the Glossy BSDF's Beckmann alphas and
anisotropy, the closure's value at its centre (dividing a lobe's amplitude by it gives the
closure's weight), and :func:`closure_for`, the closure of given amplitudes.
"""
from __future__ import annotations

import math

from .closures import Closure
from .energy import INV_2PI, energy_peak
from .step import shader_function

MIN_COS = 0.05  # lower bound of the view cosine used to stretch Beckmann lobes
ANISO_FLOOR = 0.5  # the stretch 1/mu of a lobe across the view's plane stops at mu = alpha / 2


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
def lobe_peak(ops, e, a_x, a_y, mu, *, lobe, energy=False):
    """The closure's value (light cosine included) at its own mirror direction; ``mu`` is
    floored at 1e-4 so that the peak and its inverse stay finite at a grazing view.  With
    ``energy`` (the physical mode), what a lobe's amplitude is divided by instead: the lobe's
    normalised peak ``(e + 2)/(2 pi)`` times the closure's own albedo (:mod:`.energy`), so that the
    closure returns the reflectance its amplitude carries."""
    mu = ops.maximum(mu, 1e-4)
    if energy:
        return energy_peak(ops, e, a_x, a_y, mu, lobe=lobe)
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
def lobe_shape(ops, mu, e, e_within, e_across, *, lobe, energy=False):
    """A closure about a normal seen at cosine ``mu`` whose lobe has the Phong exponents
    ``e_within`` and ``e_across``: its alpha, anisotropy and the inverse of its value at
    its centre (a weight that makes the centre's value an amplitude ``A`` is ``A`` times
    that).  ``e``: the round exponent (the geometric mean of the two) that Phong lobes
    take; ``energy``: see :func:`lobe_peak`."""
    alpha, aniso, a_x, a_y = lobe_alphas(ops, e_within, e_across, mu)
    return 1.0 / lobe_peak(ops, e, a_x, a_y, mu, lobe=lobe, energy=energy), alpha, aniso


def closure_for(ops, lobe, name, normal, e, v, amplitudes, energy=False):
    """A closure about ``normal`` whose value at its centre equals ``amplitudes`` (r, g, b); with
    ``energy``, whose albedo equals the reflectance they carry (:func:`lobe_peak`)."""
    mu = ops.named(f"mu_{name}", ops.dot(normal, v))
    alpha, aniso, a_x, a_y = lobe_alphas(ops, e, e, mu)
    tangent, aniso = closure_tangent(ops, normal, v, aniso)
    tangent = ops.named(f"tangent_{name}", tangent)
    inv = ops.named(f"inv_peak_{name}", 1.0 / lobe_peak(ops, e, a_x, a_y, mu, lobe=lobe, energy=energy))
    return Closure(name, normal, e, alpha, tuple(a * inv for a in amplitudes), aniso, tangent)
