"""Thin-film optics, the physical mode (``optics="physical"``).

The paper's lower boundary is a perfect mirror with no phase change.  Thin-film optics
(Born & Wolf; docs/physical-optics.md) gives each boundary its Fresnel amplitudes, for the s
and p polarisations, the lower one complex where the medium under the layer absorbs (a metal,
index n2 + i k2).  Summing the beams that leave the layer after 0, 1, 2... reflections on the
lower boundary (Airy) gives the reflectance as a constant plus cosines of multiples of the
phase 2 delta:

    R(delta) = DC + 2 |Z1| cos(2 delta + arg Z1) + 2 |Z2| cos(4 delta + arg Z2) + ...

per polarisation, with a = r01 (real: the layer and the outside are clear), b = t01 t10 r12
= (1 - a^2) r12, c = r10 r12 = -a r12 and q = 1 / (1 - |c|^2):

    DC = a^2 + |b|^2 q,   Z1 = a b + |b|^2 q c,   Z_m = c^(m-1) Z1.

DC - a^2 is the transmitted lobe's share; Z1 and Z2 are its interference with the top
reflection, each integrated over a colour band in closed form like the paper's cosine.
Complex values are pairs (re, im) of channel values.  :func:`optics_settings` gives the
settings that select these optics in the program's steps.
"""
from __future__ import annotations

from ..plan import EffectPlan
from .step import shader_function
from .values import channels, gather


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


HARMONICS_MULTIBEAM = 3  # harmonics of the interference where the plan keeps the beams that bounce inside


def harmonic_count(plan: EffectPlan) -> int:
    """How many harmonics of the interference the plan's thin-film optics sum."""
    return HARMONICS_MULTIBEAM if plan.multibeam else 1


def optics_settings(plan: EffectPlan) -> dict:
    """The settings that select thin-film optics in the program's steps (none: the paper's)."""
    return dict(optics="physical", orders=harmonic_count(plan)) if plan.optics == "physical" else {}
