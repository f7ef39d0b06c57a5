"""The layered RGB BRDF of Granier & Heidrich (2003), exact and vectorised.

Conventions (SPEC): ``i`` points towards the surface, ``o`` away from it; channel
axis last.  Equation numbers are the journal paper's.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .geometry import Z_AXIS, dot, reflect, refract, safe_normalize
from .params import WAVELENGTHS_NM

TWO_PI = 2.0 * np.pi


def fresnel_f0(r1, r0=1.0):
    """Fresnel coefficient at normal incidence, eq. 8: ``((r0 - r1) / (r0 + r1))^2``."""
    r1 = np.asarray(r1, dtype=float)
    return ((r0 - r1) / (r0 + r1)) ** 2


def schlick(cos_theta, f):
    """Schlick's approximation, eq. 7, for a direction pointing away from the surface."""
    c = np.clip(cos_theta, 0.0, 1.0)
    return f + (1.0 - f) * (1.0 - c) ** 5


def transmission_factor(cos_down, f):
    """Eq. 9: ``(1 - f)(1 - (1 + <v, n0>)^5)`` for an in-layer direction ``v`` pointing down."""
    x = np.clip(1.0 + cos_down, 0.0, 1.0)
    return (1.0 - f) * (1.0 - x ** 5)


def phong_lobe(c, e):
    """``max(c, 0)^e``, and 0 wherever ``c <= 0`` even for ``e = 0`` (never ``0^0``)."""
    c = np.asarray(c, dtype=float)
    pos = c > 0.0
    with np.errstate(divide="ignore", invalid="ignore", under="ignore"):
        v = np.power(np.where(pos, np.minimum(c, 1.0), 1.0), e)
    return np.where(pos, v, 0.0)


def phong_norm(e):
    """Modified-Phong normalisation ``(e + 2) / (2 pi)`` (what Cycles' Phong closure uses)."""
    return (np.asarray(e, dtype=float) + 2.0) / TWO_PI


class SpecularTerms(NamedTuple):
    """Per-channel parts of the specular BRDF, shape (..., C)."""

    R: np.ndarray  # reflected lobe, normalised, eq. 6
    T: np.ndarray  # transmitted lobe, normalised, eq. 10
    phase: np.ndarray  # eq. 3
    rho: np.ndarray  # eq. 5


def _prepare(i, o, n0, n1, ng):
    ng = safe_normalize(np.asarray(ng, dtype=float))
    n0 = safe_normalize(np.asarray(n0, dtype=float), ng)
    n1 = safe_normalize(np.asarray(n1, dtype=float), n0)
    i = np.asarray(i, dtype=float)
    o = np.asarray(o, dtype=float)
    i_len = np.sqrt(dot(i, i))
    o_len = np.sqrt(dot(o, o))
    ok = np.isfinite(i_len) & np.isfinite(o_len) & (i_len > 0) & (o_len > 0)
    i = safe_normalize(i)
    o = safe_normalize(o)
    return i, o, n0, n1, ok


def specular_terms(i, o, n0, n1, r1, d, e0, e1, r0=1.0, wavelengths=WAVELENGTHS_NM, ng=Z_AXIS) -> SpecularTerms:
    """Evaluate eqs. 3-11 with the lobe normalisations of SPEC.

    ``i``, ``o``, ``n0``, ``n1``: (..., 3).  ``r1`` and ``wavelengths``: (C,) or (..., C).
    ``d``: thickness in nm, shape (...).  ``ng``: fallback for a degenerate ``n0``.
    Directions below the horizon of ``n0`` give 0.
    """
    i, o, n0, n1, ok = _prepare(i, o, n0, n1, ng)
    r1 = np.asarray(r1, dtype=float)
    lam = np.asarray(wavelengths, dtype=float)
    d = np.asarray(d, dtype=float)[..., None]
    f = fresnel_f0(r1, r0)

    cos_l = -dot(i, n0)  # <-i, n0>
    cos_v = dot(o, n0)
    ok = ok & (cos_l > 0.0) & (cos_v > 0.0)

    # Reflected part, eq. 6.
    F = schlick(cos_l[..., None], f)
    r_i = reflect(i, n0)
    R = F * phong_norm(e0) * phong_lobe(dot(r_i, o), e0)[..., None]

    # Transmitted part, eqs. 9-11.
    eta = r0 / r1
    ic = i[..., None, :]
    oc = o[..., None, :]
    n0c = n0[..., None, :]
    n1c = n1[..., None, :]
    t_i, ok_i = refract(ic, n0c, eta)
    t_o, ok_o = refract(-oc, n0c, eta)
    r_ti = reflect(t_i, n1c)
    through = ok_i & ok_o & (dot(t_i, n1c) < 0.0) & (dot(t_o, n1c) < 0.0)
    Tc = transmission_factor(dot(t_o, n0c), f)
    T = (1.0 - F) * Tc * phong_norm(e1) / (r1 * r1) * phong_lobe(-dot(r_ti, t_o), e1)
    T = np.where(through, T, 0.0)

    # Phase, eq. 3, and the total, eq. 5.
    phase = np.pi * r1 * d / lam * (-dot(t_i + t_o, n0c))
    phase = np.where(through, phase, 0.0)
    rho = R + T + 2.0 * np.cos(2.0 * phase) * np.sqrt(R * T)
    rho = np.maximum(rho, 0.0)  # exact value is >= (sqrt R - sqrt T)^2; removes round-off
    okc = ok[..., None]
    return SpecularTerms(np.where(okc, R, 0.0), np.where(okc, T, 0.0), phase, np.where(okc, rho, 0.0))


def specular_brdf(i, o, n0, n1, r1, d, e0, e1, r0=1.0, wavelengths=WAVELENGTHS_NM, ng=Z_AXIS):
    """The specular ``rho(i, o)`` of eq. 5, shape (..., C)."""
    return specular_terms(i, o, n0, n1, r1, d, e0, e1, r0, wavelengths, ng).rho


def diffuse_rd(r1, r0=1.0):
    """Eq. 14: cosine-weighted hemispherical average of Schlick's F."""
    r1 = np.asarray(r1, dtype=float)
    return (21.0 * (r1 * r1 + r0 * r0) - 38.0 * r0 * r1) / (21.0 * (r1 + r0) ** 2)


def diffuse_td(r1, r0=1.0):
    """Eq. 15: ``1 - Rd``."""
    r1 = np.asarray(r1, dtype=float)
    return 80.0 * r0 * r1 / (21.0 * (r1 + r0) ** 2)


def diffuse_phase(r1, d, wavelengths=WAVELENGTHS_NM):
    """Eq. 17: the average phase ``2 pi r1 d / lambda`` (per channel)."""
    return TWO_PI * np.asarray(r1, dtype=float) * np.asarray(d, dtype=float)[..., None] / np.asarray(wavelengths)


def diffuse_rho(r1, d, r0=1.0, wavelengths=WAVELENGTHS_NM):
    """Eq. 18: ``1 + 2 cos(4 pi r1 d / lambda) sqrt(Td (1 - Td))``, shape (..., C)."""
    td = diffuse_td(r1, r0)
    amp = 2.0 * np.sqrt(np.clip(td * (1.0 - td), 0.0, None))
    return np.maximum(1.0 + np.cos(2.0 * diffuse_phase(r1, d, wavelengths)) * amp, 0.0)


def average_refracted_cosine(r1, r0=1.0):
    """Eq. 16: mean of ``<t_i, -n0>`` over incident directions uniform in solid angle.

    Defined for ``r1 >= r0`` (for ``r1 < r0`` some directions are totally reflected);
    it tends to 1 as ``r1 -> r0``.
    """
    r1 = np.asarray(r1, dtype=float)
    if np.any(r1 < r0):
        raise ValueError(f"average_refracted_cosine needs r1 >= r0 = {r0:g}, got r1 = {r1!r}")
    close = np.isclose(r1, r0, rtol=0.0, atol=1e-12)
    r = np.where(close, r0 + 1.0, r1)
    with np.errstate(divide="ignore"):
        val = 0.25 * (np.log((r + r0) / (r - r0)) * (r * r - r0 * r0) + 2.0 * r * r0) / (r * r0)
    return np.where(close, 1.0, val)


def layered_brdf(i, o, n0, n1, d, params, ng=Z_AXIS, wavelengths=WAVELENGTHS_NM):
    """Full BRDF ``ks rho + kd base rho_d / pi`` (SPEC), shape (..., 3)."""
    p = params
    fs = specular_brdf(i, o, n0, n1, p.r1, d, p.e0, p.e1, p.r0, wavelengths, ng)
    fd = diffuse_rho(p.r1, d, p.r0, wavelengths) * np.asarray(p.base_color) / np.pi
    return p.ks * fs + p.kd * fd
