"""The layered RGB BRDF of Granier & Heidrich (2003), exact and vectorised.

Conventions (SPEC): ``i`` points towards the surface, ``o`` away from it; channel
axis last.  Equation numbers are the journal paper's.  :func:`layered_brdf` evaluates it
in a material's accuracy mode (the paper's RGB, the analytic band integral, or N
wavelengths), the colour model its shader approximates.

The reference that the shaders' closure form is measured against (tests, benchmarks);
not part of the extension, which ships the shading program (``layered_brdf_addon.model``).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from layered_brdf_addon.model import ops_numpy
from layered_brdf_addon.model.geometry import Z_AXIS
from layered_brdf_addon.model.params import WAVELENGTHS_NM, LayeredParams
from layered_brdf_addon.model.policy import spectral_count
from layered_brdf_addon.model.program import (band_cosine, film_beams, film_diffuse_rho, fresnel_reflectance,
                                              harmonics, interference_path)
from layered_brdf_addon.model.spectral_band import per_channel
from layered_brdf_addon.model.spectral_tables import tables

from .lobe_albedo import layer_albedo, reflected_albedo

TWO_PI = 2.0 * np.pi
EXACT_HARMONICS = 4  # the exact model's thin-film optics: harmonics of the beams bouncing in the layer


def channel_cosine(opd_nm, r1_rgb=None, slope_nm=None) -> np.ndarray:
    """``C_c`` from the baked fit (numpy), the formula the shaders evaluate
    (:func:`~layered_brdf_addon.model.program.band_cosine`).  ``opd_nm``: the path difference
    ``D`` (...), or (..., 3) per channel; with ``r1_rgb`` (the three indices) and ``slope_nm``
    (``dD/dr1``) the path follows the dispersed index.  What it approximates, the 1 nm integral, is
    ``layered_brdf_reference.band_fitting.channel_cosine_numeric``."""
    D = per_channel(opd_nm)
    if r1_rgb is None:
        return np.asarray(band_cosine(ops_numpy, ops_numpy.vec(D), 0.0, 0.0, dispersion=False))
    S = per_channel(slope_nm, D.shape)
    r1 = ops_numpy.vec(np.broadcast_to(np.asarray(r1_rgb, dtype=float), D.shape))
    return np.asarray(band_cosine(ops_numpy, ops_numpy.vec(D), ops_numpy.vec(S), r1, dispersion=True))


def fresnel_f0(r1, r0=1.0):
    """Fresnel coefficient at normal incidence, eq. 8: ``((r0 - r1) / (r0 + r1))^2``."""
    r1 = np.asarray(r1, dtype=float)
    return ((r0 - r1) / (r0 + r1)) ** 2


def _pow5(x):
    x2 = x * x
    return x2 * x2 * x


def schlick(cos_theta, f):
    """Schlick's approximation, eq. 7, for a direction pointing away from the surface."""
    return f + (1.0 - f) * _pow5(1.0 - np.clip(cos_theta, 0.0, 1.0))


def transmission_factor(cos_down, f):
    """Eq. 9: ``(1 - f)(1 - (1 + <v, n0>)^5)`` for an in-layer direction ``v`` pointing down."""
    return (1.0 - f) * (1.0 - _pow5(np.clip(1.0 + cos_down, 0.0, 1.0)))


def phong_lobe(c, e):
    """``max(c, 0)^e``, and 0 wherever ``c <= 0`` even for ``e = 0`` (never ``0^0``)."""
    c = np.asarray(c, dtype=float)
    if np.ndim(e) == 0 and e > 0.0:
        with np.errstate(under="ignore"):
            return np.power(np.maximum(c, 0.0), e)  # 0^e = 0 for e > 0
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


def _rows(v):
    v = np.asarray(v, dtype=float)
    return v[..., 0], v[..., 1], v[..., 2]


def _dot3(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _unit_rows(v, fallback=None):
    """Components of ``v / |v|``; rows that are zero or not finite take ``fallback``'s."""
    c = _rows(v)
    n2 = _dot3(c, c)
    ok = np.isfinite(n2) & (n2 > 1e-24)
    if np.all(ok):
        inv = 1.0 / np.sqrt(n2)
        return (c[0] * inv, c[1] * inv, c[2] * inv), ok
    inv = 1.0 / np.sqrt(np.where(ok, n2, 1.0))
    if fallback is None:
        return tuple(np.where(ok, x * inv, 0.0) for x in c), ok
    return tuple(np.where(ok, x * inv, f) for x, f in zip(c, fallback)), ok


def specular_terms(i, o, n0, n1, r1, d, e0, e1, r0=1.0, wavelengths=WAVELENGTHS_NM, ng=Z_AXIS,
                   band=False, optics="paper", n2=None, k2=None, orders=1) -> SpecularTerms:
    """Evaluate eqs. 3-11 with the lobe normalisations of SPEC.

    ``optics="physical"``: thin-film optics (:func:`~layered_brdf_addon.model.program.film_beams`)
    instead of the paper's mirror: the exact Fresnel reflectance of the top boundary at the light's angle,
    the transmitted beams of the lower medium ``n2 + i k2`` (channel triples) crossing the top
    boundary at the light and the view, and ``orders`` harmonics of the interference with
    their reflection phases, each direction pair on its own.

    ``band``: the analytic mode, ``r1`` the three RGB indices and the interference cosine
    of eq. 5 integrated over each channel's band (:func:`channel_cosine`)
    instead of taken at ``wavelengths``.

    ``i``, ``o``, ``n0``, ``n1``: (..., 3).  ``r1`` and ``wavelengths``: (C,) or (..., C).
    ``d``: thickness in nm, shape (...).  ``ng``: fallback for a degenerate ``n0``
    (a degenerate ``n1`` falls back to ``n0``).  Directions below the horizon of ``n0``
    give 0.

    Everything is computed from six dot products of the unit vectors (refracted
    directions are linear in the incident one and the normal), per channel on 1-D
    arrays: no (..., C, 3) temporaries.
    """
    g, _ = _unit_rows(ng, (0.0, 0.0, 1.0))
    n0u, _ = _unit_rows(n0, g)
    n1u, _ = _unit_rows(n1, n0u)
    iu, ok_i = _unit_rows(i)
    ou, ok_o = _unit_rows(o)

    i_n0 = _dot3(iu, n0u)
    o_n0 = _dot3(ou, n0u)
    i_o = _dot3(iu, ou)
    i_n1 = _dot3(iu, n1u)
    o_n1 = _dot3(ou, n1u)
    n0_n1 = _dot3(n0u, n1u)
    ok = ok_i & ok_o & (i_n0 < 0.0) & (o_n0 > 0.0)

    cos_l = np.where(ok, -i_n0, 0.0)[..., None]  # <-i, n0>
    cos_v = np.where(ok, o_n0, 0.0)[..., None]
    c_r = np.where(ok, i_o - 2.0 * i_n0 * o_n0, 0.0)[..., None]  # <r_i, o>; 0 gives no lobe
    r1 = np.asarray(r1, dtype=float)
    lam = np.asarray(wavelengths, dtype=float)
    d = np.asarray(d, dtype=float)[..., None]
    f = fresnel_f0(r1, r0)

    # Reflected part, eq. 6.
    F = schlick(cos_l, f)
    R = F * phong_norm(e0) * phong_lobe(c_r, e0)

    # Refraction into the layer (Snell): t = eta v + a n0 with a = eta cos - sqrt(k).
    eta = r0 / r1
    k_i = 1.0 - eta * eta * (1.0 - cos_l * cos_l)
    k_o = 1.0 - eta * eta * (1.0 - cos_v * cos_v)
    refracts = (k_i >= 0.0) & (k_o >= 0.0)
    s_i = np.sqrt(np.maximum(k_i, 0.0))  # <t_i, -n0>
    s_o = np.sqrt(np.maximum(k_o, 0.0))  # <t_o, -n0>
    a_i = eta * cos_l - s_i
    a_o = eta * cos_v - s_o
    ti_n1 = eta * i_n1[..., None] + a_i * n0_n1[..., None]
    to_n1 = -eta * o_n1[..., None] + a_o * n0_n1[..., None]
    # <t_i, t_o> = eta^2 <i, -o> + eta a_o <i, n0> + eta a_i <n0, -o> + a_i a_o
    ti_to = -eta * eta * i_o[..., None] - eta * a_o * cos_l - eta * a_i * cos_v + a_i * a_o
    c_t = -(ti_to - 2.0 * ti_n1 * to_n1)  # <r_ti, -t_o>, eq. 10
    through = refracts & (ti_n1 < 0.0) & (to_n1 < 0.0) & ok[..., None]  # eq. 11
    if optics == "physical":
        rti_n0 = -s_i - 2.0 * ti_n1 * n0_n1[..., None]  # <r_ti, n0>: the transmitted lobe's centre
        # The microfacet that mirrors the light into o: its cosine to the light, half the angle between them.
        cos_h = np.sqrt(np.clip((1.0 - np.where(ok, i_o, 1.0)) * 0.5, 0.0, 1.0))[..., None]
        return _film_terms(cos_l, cos_v, c_r, np.where(through, c_t, 0.0), cos_h, r1, d, e0, e1, r0, lam, band,
                           n2, k2, orders, rti_n0)

    # Transmitted part, eqs. 9-10, lobe normalised by (e1 + 2) / (2 pi r1^2) (SPEC).
    Tc = transmission_factor(-s_o, f)
    T = (1.0 - F) * (Tc * (phong_norm(e1) / (r1 * r1))) * phong_lobe(np.where(through, c_t, 0.0), e1)

    # Phase, eq. 3, and the total, eq. 5.
    phase = (np.pi * r1 / lam) * (d * (s_i + s_o))  # meaningful where T > 0
    if band:
        opd, slope = interference_path(ops_numpy, r1, d, s_i, s_o)
        cos2phi = channel_cosine(opd, np.broadcast_to(r1, opd.shape), slope)
    else:
        cos2phi = np.cos(2.0 * phase)
    rho = R + T + 2.0 * cos2phi * np.sqrt(R * T)
    rho = np.maximum(rho, 0.0)  # exact value is >= (sqrt R - sqrt T)^2; removes round-off
    return SpecularTerms(R, T, phase, rho)


def _channel_values(x, shape):
    """``x`` broadcast to ``shape`` (..., C) as the shading program's channel value: a triple
    where C = 3 (the RGB channels, which its ops treat channel by channel), else a plain
    array that they evaluate elementwise (wavelengths of a spectral mode, each like the
    scalar channel value of a shader's spectral step)."""
    a = np.broadcast_to(np.asarray(x, dtype=float), shape)
    return ops_numpy.vec(a) if shape[-1] == 3 else a


def _film_terms(cos_l, cos_v, c_r, c_t, cos_h, r1, d, e0, e1, r0, lam, band, n2, k2, orders, rti_n0):
    """The physical mode's terms of :func:`specular_terms` (see there), per channel.

    The film's optics (its reflectances, the beams' phases and the path through it) are taken at the
    microfacet that mirrors the light into ``o`` (``cos_h``: its cosine to the light), as a rough film
    reflects; for a smooth film, at the mirror direction, that is the light's own angle.

    Energy-keeping lobes: each lobe is divided by its own directional albedo at the light's
    incidence (:mod:`.lobe_albedo`: the reflected lobe's about the mirror direction, clipped at the
    horizon; the transmitted lobe's inside the layer about its centre ``r_ti``, through the critical
    cone), so that, integrated over the outgoing hemisphere, the reflected lobe returns the top
    boundary's reflectance ``R01`` and the transmitted lobe the beams' share ``T`` at every incidence
    and roughness, and a film that absorbs nothing, over a clear base, returns all the light with
    what the base passes."""
    shape = np.broadcast_shapes(np.shape(cos_l), np.shape(r1), np.shape(cos_h), np.shape(d))

    def v(x):
        return _channel_values(x, shape)

    r1v, n2v, k2v = v(r1), v(n2), v(k2)
    eta = r0 / np.asarray(r1, dtype=float)
    s_h = np.sqrt(np.maximum(1.0 - eta * eta * (1.0 - cos_h * cos_h), 0.0))  # in the layer, under the microfacet
    f = film_beams(ops_numpy, v(cos_h), v(s_h), r1v, r0, n2v, k2v, orders=orders)
    R01, Tb = np.asarray(f["R01"]), np.asarray(f["T"])
    R = R01 * phong_norm(e0) * phong_lobe(c_r, e0) / np.maximum(reflected_albedo(e0, cos_l), 1e-6)
    # The beams leave through the top boundary at the view, not at the light.
    R01_l = np.asarray(fresnel_reflectance(ops_numpy, v(cos_l), r0 / r1v))
    leave = (1.0 - np.asarray(fresnel_reflectance(ops_numpy, v(cos_v), r0 / r1v))) / np.maximum(1.0 - R01_l, 1e-6)
    shape_t = layer_albedo(e1, eta, np.broadcast_to(rti_n0, shape)) / np.maximum(
        1.0 - R01_l, 1e-6)
    T = Tb * leave * (phong_norm(e1) / (r1 * r1)) * phong_lobe(c_t, e1) / np.maximum(shape_t, 1e-6)
    opd, slope = interference_path(ops_numpy, r1, d, s_h, s_h)
    phase = np.pi * opd / lam
    waves = np.asarray(harmonics(ops_numpy, f, v(lam), v(opd), v(slope), r1v, orders, band=band, dispersion=True,
                                 footprint=False))
    rho = np.maximum(R + T + 2.0 * waves * np.sqrt(R * T), 0.0)
    return SpecularTerms(R, T, phase, rho)


def specular_brdf(i, o, n0, n1, r1, d, e0, e1, r0=1.0, wavelengths=WAVELENGTHS_NM, ng=Z_AXIS, band=False,
                  **optics):
    """The specular ``rho(i, o)`` of eq. 5, shape (..., C); ``optics``: see :func:`specular_terms`."""
    return specular_terms(i, o, n0, n1, r1, d, e0, e1, r0, wavelengths, ng, band, **optics).rho


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


def diffuse_rho(r1, d, r0=1.0, wavelengths=WAVELENGTHS_NM, band=False):
    """Eq. 18: ``1 + 2 cos(4 pi r1 d / lambda) sqrt(Td (1 - Td))``, shape (..., C); ``band``:
    the cosine integrated over each RGB channel's band (path ``2 r1 d``, slope ``2 d``)."""
    td = diffuse_td(r1, r0)
    amp = 2.0 * np.sqrt(np.clip(td * (1.0 - td), 0.0, None))
    if band:
        opd = 2.0 * np.asarray(r1, dtype=float) * np.asarray(d, dtype=float)[..., None]
        c = channel_cosine(opd, np.broadcast_to(r1, opd.shape), 2.0 * np.asarray(d, dtype=float)[..., None])
    else:
        c = np.cos(2.0 * diffuse_phase(r1, d, wavelengths))
    return np.maximum(1.0 + c * amp, 0.0)


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
    """Full BRDF ``ks rho + kd base rho_d / pi`` (SPEC), shape (..., 3), in the colour model of
    ``params.accuracy``, the one its shader approximates (docs/spectral.md):

    * ``"rgb"``: eqs. 5 and 18 at the paper's three ``wavelengths``, taken as R, G and B;
    * ``"analytic"``: the same three channels, the interference cosines integrated over
      each channel's band (:func:`channel_cosine`);
    * ``"spectralN"``: N wavelengths summed into linear Rec.709 (:func:`spectral_parts`;
      ``wavelengths`` is not used).

    The base colour multiplies the diffuse factor once its colour is formed, as the
    diffuse closure's weight does.
    """
    p = params
    n = spectral_count(p.accuracy)
    if n:
        fs, rho_d = spectral_parts(i, o, n0, n1, d, p, n, ng)
    else:
        fs, rho_d = channel_parts(i, o, n0, n1, d, p, p.r1, p.r2, p.k2, wavelengths, ng, p.accuracy == "analytic")
    return p.ks * fs + p.kd * (rho_d * np.asarray(p.base_color) / np.pi)


def channel_parts(i, o, n0, n1, d, p, r1, r2, k2, wavelengths, ng=Z_AXIS, band=False):
    """The specular ``rho`` (eq. 5) and the diffuse factor ``rho_d`` (eq. 18) of ``p`` at the
    channels' ``wavelengths``, shape (..., C) each; ``r1``, ``r2``, ``k2``: the layer's and the
    lower medium's indices there, (C,).  With ``p.optics == "physical"``, thin-film optics
    (:func:`specular_terms`, :func:`film_diffuse`); ``band``: see :func:`specular_terms`."""
    if p.optics == "physical":
        orders = EXACT_HARMONICS  # wherever the closures sum fewer
        fs = specular_brdf(i, o, n0, n1, r1, d, p.e0, p.e1, p.r0, wavelengths, ng, band, optics="physical",
                           n2=r2, k2=k2, orders=orders)
        return fs, film_diffuse(r1, r2, k2, p.r0, d, wavelengths, band, orders)
    fs = specular_brdf(i, o, n0, n1, r1, d, p.e0, p.e1, p.r0, wavelengths, ng, band)
    return fs, diffuse_rho(r1, d, p.r0, wavelengths, band)


def spectral_parts(i, o, n0, n1, d, p, n, ng=Z_AXIS):
    """:func:`channel_parts` of the spectral mode of ``n`` wavelengths, in linear Rec.709,
    shape (..., 3) each: the model at each wavelength of the mode's sampling (the centres of
    ``n`` equal bins over 380-780 nm), its indices from the Cauchy fit through the three
    channels' values, summed with the bins' CIE 1931 / D65 weights: the baked tables of the
    shader's spectral steps (:mod:`~layered_brdf_addon.model.spectral_tables`,
    :func:`~layered_brdf_addon.model.program.shade_spectral`).

    One wavelength at a time, so that only the running sums are (..., 3) arrays, whatever
    ``n``.  What the closures approximate, not what they compute: every wavelength refracts
    on its own (no lobe groups), the interference stays whatever the thickness (the planner
    drops it past the cut-off), and a sum outside the Rec.709 gamut keeps its negative
    channel.  Sampled like this the colour converges to the 1 nm ground truth
    (:mod:`.spectral`) as ``n`` grows, and aliases where the optical path is too long for
    the bins (docs/spectral.md)."""
    t = tables(n)
    fs = rho_d = 0.0
    for lam, row, m in zip(t["wavelengths"], t["cauchy"], t["rgb"]):
        r1, r2, k2 = (_at_wavelength(row, values, name) for values, name in ((p.r1, "r1_r"), (p.r2, "r2_r"),
                                                                               (p.k2, "k2_r")))
        s, sd = channel_parts(i, o, n0, n1, d, p, r1, r2, k2, (lam,), ng)
        fs = fs + s * np.asarray(m)
        rho_d = rho_d + sd * np.asarray(m)
    return fs, rho_d


def _at_wavelength(row, values, name):
    """A channel triple's value at one wavelength of a spectral mode, shape (1,): ``row .
    values`` (the Cauchy fit through the three values, a baked row), kept inside the range of
    the parameter ``name``, as the shader keeps it."""
    spec = LayeredParams.spec(name)
    return np.clip([float(np.dot(row, values))], spec.min, spec.max)


def film_diffuse(r1, r2, k2, r0, d, wavelengths=WAVELENGTHS_NM, band=False, orders=1):
    """The physical mode's diffuse factor
    (:func:`~layered_brdf_addon.model.program.film_diffuse_rho`) of the channels' indices ``r1``,
    ``r2`` and ``k2`` at ``wavelengths``, (C,) each; shape (..., C)."""
    d = np.asarray(d, dtype=float)
    shape = d.shape + np.shape(wavelengths)

    def v(x):
        return _channel_values(x, shape)

    return np.asarray(film_diffuse_rho(ops_numpy, v(r1), r0, v(r2), v(k2), v(wavelengths), v(d[..., None]),
                                       band=band, orders=orders))
