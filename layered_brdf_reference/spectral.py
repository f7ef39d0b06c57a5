"""Spectral evaluation of the layered BRDF and its conversion to linear Rec.709 RGB.

The paper evaluates the model at three wavelengths (645, 525, 445 nm) and uses the
results directly as R, G and B.  Here the model is evaluated at ``N`` wavelengths
instead, with the layer index ``r1(lambda)`` from a Cauchy fit through the three RGB
indices, and the spectrum is integrated against the CIE 1931 2 degree colour-matching
functions under D65 (docs/spectral.md):

* ``N`` equal bins over 380-780 nm, the model sampled at the bin centres, each bin
  weighted by the integral (at 1 nm) of ``cmf(lambda) * D65(lambda)`` over the bin;
* the ground truth is the same sum at every nanometre of 380-780 nm (401 samples), the
  rectangle rule that ``colour.sd_to_XYZ(..., method="Integration")`` applies;
* XYZ is normalised so that a reflectance of 1 has ``Y = 1``, converted to linear
  Rec.709 with colour's matrix, and a diagonal correction then maps that reflectance to
  exactly ``(1, 1, 1)``.

Everything reduces to an ``(N, 3)`` matrix ``M`` with ``rgb = spectrum @ M``.

The tables come from colour-science: ``colour.MSDS_CMFS['CIE 1931 2 Degree Standard
Observer']`` (1 nm) and ``colour.SDS_ILLUMINANTS['D65']`` (5 nm, interpolated linearly
to 1 nm by colour's own interpolator, as CIE 15 recommends for the D illuminants).
:func:`cmf_wyman` is the analytic multi-lobe fit of Wyman, Sloan and Shirley (2013),
usable where tables are not (OSL, shader nodes).

The shaders read this module's tables baked into ``layered_brdf_addon/model/data/
spectral_tables.json`` (:func:`shader_tables`; rewritten by ``python -m
layered_brdf_reference.spectral``), so the extension needs no colour-science.
"""
from __future__ import annotations

import functools
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Literal

import colour
import numpy as np

from layered_brdf_addon.model import spectral_tables
from layered_brdf_addon.model.geometry import Z_AXIS
from layered_brdf_addon.model.params import WAVELENGTHS_NM, LayeredParams

from .exact_model import diffuse_rho, specular_brdf

LAMBDA_MIN_NM = 380.0
LAMBDA_MAX_NM = 780.0
CMFS_NAME = "CIE 1931 2 Degree Standard Observer"
ILLUMINANT_NAME = "D65"
COLOURSPACE_NAME = "ITU-R BT.709"
SAMPLE_COUNTS = (4, 8, 16, 32)

CmfName = Literal["cie1931", "wyman"]
Quadrature = Literal["bin", "point"]

# Index range of the parameters (LayeredParams); r1(lambda) is kept inside it.
INDEX_MIN = LayeredParams.spec("r1_r").min
INDEX_MAX = LayeredParams.spec("r1_r").max


# ----------------------------------------------------------------------------
# Tables and the analytic colour-matching functions.
def spectral_shape() -> colour.SpectralShape:
    """The 1 nm shape of the ground truth: 380-780 nm inclusive (401 samples)."""
    return colour.SpectralShape(LAMBDA_MIN_NM, LAMBDA_MAX_NM, 1.0)


@functools.lru_cache(maxsize=None)
def reference_cmfs_and_illuminant() -> tuple[colour.MultiSpectralDistributions, colour.SpectralDistribution]:
    """colour's CIE 1931 2 degree CMFs and D65, both on :func:`spectral_shape`.

    Returned as colour objects so that ``colour.sd_to_XYZ`` can be given exactly the
    data this module integrates against.  Callers must not modify them.
    """
    shape = spectral_shape()
    cmfs = colour.MSDS_CMFS[CMFS_NAME].copy().trim(shape)
    illuminant = colour.SDS_ILLUMINANTS[ILLUMINANT_NAME].copy().align(shape)
    return cmfs, illuminant


@functools.lru_cache(maxsize=None)
def _tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    cmfs, illuminant = reference_cmfs_and_illuminant()
    lam = np.asarray(cmfs.wavelengths, dtype=float)
    return lam, np.asarray(cmfs.values, dtype=float), np.asarray(illuminant.values, dtype=float)


def cmf_cie1931(wavelengths) -> np.ndarray:
    """The tabulated CIE 1931 2 degree CMFs at ``wavelengths`` (nm), shape (..., 3).

    Linear interpolation of colour's 1 nm table; 0 outside 380-780 nm.
    """
    lam, cmf, _ = _tables()
    w = np.asarray(wavelengths, dtype=float)
    return np.stack([np.interp(w, lam, cmf[:, k], left=0.0, right=0.0) for k in range(3)], axis=-1)


def d65(wavelengths) -> np.ndarray:
    """The D65 relative spectral power (colour's table, linearly interpolated), shape (...)."""
    lam, _, s = _tables()
    return np.interp(np.asarray(wavelengths, dtype=float), lam, s, left=0.0, right=0.0)


def _piecewise_gaussian(lam: np.ndarray, mu: float, sigma_below: float, sigma_above: float) -> np.ndarray:
    t = (lam - mu) / np.where(lam < mu, sigma_below, sigma_above)
    return np.exp(-0.5 * t * t)


# Wyman, Sloan & Shirley 2013, "Simple Analytic Approximations to the CIE XYZ Color
# Matching Functions", JCGT 2(2), multi-lobe fit of the CIE 1931 2 degree observer:
# (weight, mean, sigma below the mean, sigma above) per lobe, all in nm.
WYMAN_1931_LOBES: tuple[tuple[tuple[float, float, float, float], ...], ...] = (
    ((1.056, 599.8, 37.9, 31.0), (0.362, 442.0, 16.0, 26.7), (-0.065, 501.1, 20.4, 26.2)),
    ((0.821, 568.8, 46.9, 40.5), (0.286, 530.9, 16.3, 31.1)),
    ((1.217, 437.0, 11.8, 36.0), (0.681, 459.0, 26.0, 13.8)),
)


def cmf_wyman(wavelengths) -> np.ndarray:
    """Wyman-Sloan-Shirley (2013) multi-lobe piecewise-Gaussian CIE 1931 CMFs, shape (..., 3).

    Each of x, y, z is a sum of Gaussians whose standard deviation differs on either side
    of the mean: seven ``exp`` in all, no table, so it fits in OSL or a node group.
    """
    lam = np.asarray(wavelengths, dtype=float)
    return np.stack([sum(a * _piecewise_gaussian(lam, mu, s1, s2) for a, mu, s1, s2 in lobes)
                     for lobes in WYMAN_1931_LOBES], axis=-1)


_CMF_FUNCTIONS: dict[str, Callable[[np.ndarray], np.ndarray]] = {"cie1931": cmf_cie1931, "wyman": cmf_wyman}


def _cmf_table(cmf: str) -> np.ndarray:
    lam, table, _ = _tables()
    if cmf == "cie1931":
        return table
    if cmf not in _CMF_FUNCTIONS:
        raise ValueError(f"unknown colour-matching functions {cmf!r}: expected one of {sorted(_CMF_FUNCTIONS)}")
    return _CMF_FUNCTIONS[cmf](lam)


def wyman_table_error() -> dict[str, float]:
    """Largest absolute difference between :func:`cmf_wyman` and the CIE 1931 table (380-780 nm, 1 nm),
    per function, and relative to the function's peak."""
    lam, table, _ = _tables()
    diff = np.abs(cmf_wyman(lam) - table)
    out: dict[str, float] = {}
    for k, name in enumerate("xyz"):
        out[f"max_abs_{name}"] = float(diff[:, k].max())
        out[f"max_rel_peak_{name}"] = float(diff[:, k].max() / table[:, k].max())
        out[f"argmax_nm_{name}"] = float(lam[np.argmax(diff[:, k])])
    return out


# ----------------------------------------------------------------------------
# Colour space.
def _colourspace() -> colour.RGB_Colourspace:
    return colour.RGB_COLOURSPACES[COLOURSPACE_NAME]


def xyz_to_rec709_matrix() -> np.ndarray:
    """colour's XYZ -> linear Rec.709 matrix (rows give R, G, B)."""
    return np.asarray(_colourspace().matrix_XYZ_to_RGB, dtype=float)


def rec709_to_xyz_matrix() -> np.ndarray:
    """colour's linear Rec.709 -> XYZ matrix."""
    return np.asarray(_colourspace().matrix_RGB_to_XYZ, dtype=float)


def white_xy() -> np.ndarray:
    """Chromaticity of the Rec.709 (D65) white, used as the Lab reference white."""
    return np.asarray(_colourspace().whitepoint, dtype=float)


def rgb_to_xyz(rgb) -> np.ndarray:
    """Linear Rec.709 -> XYZ with ``(1, 1, 1)`` at ``Y = 1``; nothing is clipped."""
    return np.asarray(rgb, dtype=float) @ rec709_to_xyz_matrix().T


def rgb_to_lab(rgb) -> np.ndarray:
    """CIE Lab (D65 white, ``(1, 1, 1)`` is L* = 100) of linear Rec.709 values, unclipped."""
    return colour.XYZ_to_Lab(rgb_to_xyz(rgb), white_xy())


def delta_e_2000(rgb_a, rgb_b) -> np.ndarray:
    """CIEDE2000 between linear Rec.709 colours at their physical luminance (white Y = 1)."""
    return np.asarray(colour.delta_E(rgb_to_lab(rgb_a), rgb_to_lab(rgb_b), method="CIE 2000"), dtype=float)


# ----------------------------------------------------------------------------
# Sampling.
@dataclass(frozen=True)
class SpectralSampling:
    """Wavelengths at which the model is evaluated and the matrix to linear Rec.709.

    ``xyz``: (N, 3) weights with ``Y = 1`` for a unit reflectance; ``matrix``: (N, 3),
    ``rgb = spectrum @ matrix``; ``white_correction``: the diagonal that maps a unit
    reflectance to exactly ``(1, 1, 1)`` after colour's XYZ -> Rec.709 matrix.
    """

    wavelengths: np.ndarray
    xyz: np.ndarray
    matrix: np.ndarray
    white_correction: np.ndarray
    cmf: str
    quadrature: str
    label: str

    @property
    def n(self) -> int:
        return int(self.wavelengths.shape[0])

    def to_xyz(self, spectrum) -> np.ndarray:
        """XYZ (``Y = 1`` for a unit reflectance) of spectra sampled at :attr:`wavelengths`."""
        return np.asarray(spectrum, dtype=float) @ self.xyz

    def to_rgb(self, spectrum) -> np.ndarray:
        """Linear Rec.709 RGB of spectra sampled at :attr:`wavelengths`: ``spectrum @ matrix``."""
        return np.asarray(spectrum, dtype=float) @ self.matrix


def bin_edges(n: int) -> np.ndarray:
    """Edges of ``n`` equal bins over 380-780 nm."""
    if n < 1:
        raise ValueError(f"the number of wavelength bins must be at least 1, got {n}")
    return np.linspace(LAMBDA_MIN_NM, LAMBDA_MAX_NM, n + 1)


def bin_centres(n: int) -> np.ndarray:
    """Centres of ``n`` equal bins over 380-780 nm: the sampled wavelengths."""
    e = bin_edges(n)
    return 0.5 * (e[:-1] + e[1:])


def bin_partition(n: int) -> np.ndarray:
    """(n, 401) matrix: the share of each 1 nm sample's cell that falls in each bin.

    Sample ``lambda_j`` stands for the cell ``[lambda_j - 0.5, lambda_j + 0.5]`` (the
    rectangle rule of the ground truth).  A cell cut by a bin edge is split in proportion;
    the half cells of 380 and 780 nm outside the range belong to the end bins.  Every
    column sums to 1, so the bins partition the ground truth exactly.
    """
    lam, _, _ = _tables()
    edges = bin_edges(n).copy()
    edges[0], edges[-1] = -np.inf, np.inf
    lo = np.maximum((lam - 0.5)[None, :], edges[:-1, None])
    hi = np.minimum((lam + 0.5)[None, :], edges[1:, None])
    return np.maximum(hi - lo, 0.0)


def _finish(wavelengths: np.ndarray, xyz_raw: np.ndarray, cmf: str, quadrature: str, label: str) -> SpectralSampling:
    xyz = xyz_raw / xyz_raw[:, 1].sum()
    rgb = xyz @ xyz_to_rec709_matrix().T
    correction = 1.0 / rgb.sum(axis=0)
    matrix = rgb * correction
    for a in (wavelengths, xyz, matrix, correction):
        a.setflags(write=False)
    return SpectralSampling(wavelengths, xyz, matrix, correction, cmf, quadrature, label)


@functools.lru_cache(maxsize=None)
def ground_truth_sampling(cmf: CmfName = "cie1931") -> SpectralSampling:
    """Every nanometre of 380-780 nm, each sample weighted by ``cmf * D65 * 1 nm``."""
    lam, _, s = _tables()
    label = "ground truth 1 nm" + ("" if cmf == "cie1931" else f" ({cmf} CMF)")
    return _finish(lam.copy(), _cmf_table(cmf) * s[:, None], cmf, "bin", label)


@functools.lru_cache(maxsize=None)
def spectral_sampling(n: int, cmf: CmfName = "cie1931", quadrature: Quadrature = "bin") -> SpectralSampling:
    """``n`` wavelengths at the centres of equal bins over 380-780 nm.

    ``quadrature="bin"``: each bin's weight is the 1 nm integral of ``cmf * D65`` over the
    bin (:func:`bin_partition`).  ``"point"``: ``cmf * D65`` at the centre times the bin
    width, what a shader evaluating an analytic CMF per sample computes.
    """
    n = int(n)
    lam_c = bin_centres(n)
    if quadrature == "bin":
        _, _, s = _tables()
        raw = bin_partition(n) @ (_cmf_table(cmf) * s[:, None])
    elif quadrature == "point":
        if cmf not in _CMF_FUNCTIONS:
            raise ValueError(f"unknown colour-matching functions {cmf!r}")
        raw = _CMF_FUNCTIONS[cmf](lam_c) * d65(lam_c)[:, None] * ((LAMBDA_MAX_NM - LAMBDA_MIN_NM) / n)
    else:
        raise ValueError(f"unknown quadrature {quadrature!r}: expected 'bin' or 'point'")
    label = f"spectral {n}" + ("" if cmf == "cie1931" else f", {cmf} CMF") + ("" if quadrature == "bin" else
                                                                                 ", point-sampled")
    return _finish(lam_c, raw, cmf, quadrature, label)


def as_sampling(sampling: SpectralSampling | int) -> SpectralSampling:
    """A :class:`SpectralSampling`, or ``spectral_sampling(n)`` for an int ``n``."""
    if isinstance(sampling, SpectralSampling):
        return sampling
    return spectral_sampling(int(sampling))


# ----------------------------------------------------------------------------
# Dispersion: the Cauchy fit through the three RGB indices.
_CAUCHY_SCALE_NM = 500.0  # the fit is solved in x = (500 / lambda)^2 for conditioning


def cauchy_fit(r1_rgb, wavelengths=WAVELENGTHS_NM) -> np.ndarray:
    """Coefficients ``(A, B, C)`` of ``r(lambda) = A + B / lambda^2 + C / lambda^4`` (nm units)
    through the three indices at the three wavelengths, shape (..., 3).

    Three equal indices give exactly ``(r, 0, 0)``.
    """
    r = np.asarray(r1_rgb, dtype=float)
    lam = np.asarray(wavelengths, dtype=float)
    if r.shape[-1] != 3 or lam.shape != (3,):
        raise ValueError("cauchy_fit needs three indices and three wavelengths")
    x = (_CAUCHY_SCALE_NM / lam) ** 2
    vander = np.stack([np.ones(3), x, x * x], axis=-1)
    a = r @ np.linalg.inv(vander).T
    coeffs = a * np.array([1.0, _CAUCHY_SCALE_NM ** 2, _CAUCHY_SCALE_NM ** 4])
    equal = (r[..., 0] == r[..., 1]) & (r[..., 1] == r[..., 2])
    constant = np.stack([r[..., 0], np.zeros_like(r[..., 0]), np.zeros_like(r[..., 0])], axis=-1)
    return np.where(equal[..., None], constant, coeffs)


def index_at(coeffs, wavelengths) -> np.ndarray:
    """``A + B / lambda^2 + C / lambda^4``: coefficients (..., 3), wavelengths (N,) -> (..., N)."""
    c = np.asarray(coeffs, dtype=float)
    inv2 = 1.0 / np.asarray(wavelengths, dtype=float) ** 2
    return c[..., 0, None] + (c[..., 1, None] + c[..., 2, None] * inv2) * inv2


def dispersed_index(r1_rgb, wavelengths) -> np.ndarray:
    """``r1(lambda)`` from the Cauchy fit, kept inside the parameters' index range [0.1, 5]."""
    return np.clip(index_at(cauchy_fit(r1_rgb), wavelengths), INDEX_MIN, INDEX_MAX)


# ----------------------------------------------------------------------------
# The model, spectrally.
_CHUNK_ELEMENTS = 1 << 19  # (points x wavelengths) per specular_terms call


def spectral_specular_spectrum(i, o, n0, n1, r1_rgb, d, e0, e1, r0=1.0, wavelengths=WAVELENGTHS_NM,
                               ng=Z_AXIS) -> np.ndarray:
    """The specular ``rho(i, o)`` of eq. 5 at every wavelength, shape (..., N).

    ``r1(lambda)`` is :func:`dispersed_index` of the three RGB indices ``r1_rgb`` (shape (3,)
    or (..., 3)).  Large batches are evaluated in chunks to bound the temporaries.
    """
    lam = np.asarray(wavelengths, dtype=float)
    r1 = dispersed_index(r1_rgb, lam)
    batch = np.broadcast_shapes(np.shape(i)[:-1], np.shape(o)[:-1], np.shape(n0)[:-1], np.shape(n1)[:-1],
                                np.shape(d), r1.shape[:-1], np.shape(ng)[:-1])
    args = [np.broadcast_to(np.asarray(a, dtype=float), batch + (3,)).reshape(-1, 3) for a in (i, o, n0, n1, ng)]
    d_flat = np.broadcast_to(np.asarray(d, dtype=float), batch).reshape(-1)
    r1_flat = np.broadcast_to(r1, batch + lam.shape).reshape(-1, lam.shape[0]) if r1.ndim > 1 else r1
    count = d_flat.shape[0]
    out = np.empty((count, lam.shape[0]))
    step = max(1, _CHUNK_ELEMENTS // max(lam.shape[0], 1))
    for start in range(0, count, step):
        s = slice(start, start + step)
        ii, oo, nn0, nn1, gg = (a[s] for a in args)
        rr = r1_flat[s] if r1.ndim > 1 else r1
        out[s] = specular_brdf(ii, oo, nn0, nn1, rr, d_flat[s], e0, e1, r0, lam, gg)
    return out.reshape(batch + lam.shape)


def spectral_specular(i, o, n0, n1, r1_rgb, d, e0, e1, r0=1.0, sampling: SpectralSampling | int = 32,
                      ng=Z_AXIS) -> np.ndarray:
    """Linear Rec.709 RGB of the specular ``rho(i, o)`` evaluated spectrally, shape (..., 3).

    Same arguments as :func:`~.exact_model.specular_brdf` with ``r1_rgb`` the three RGB indices;
    ``sampling`` is a :class:`SpectralSampling` or a number of wavelengths.
    """
    s = as_sampling(sampling)
    return s.to_rgb(spectral_specular_spectrum(i, o, n0, n1, r1_rgb, d, e0, e1, r0, s.wavelengths, ng))


def spectral_diffuse_spectrum(r1_rgb, d, r0=1.0, wavelengths=WAVELENGTHS_NM) -> np.ndarray:
    """The diffuse ``rho_d`` of eq. 18 at every wavelength, shape (..., N)."""
    lam = np.asarray(wavelengths, dtype=float)
    return diffuse_rho(dispersed_index(r1_rgb, lam), d, r0, lam)


def spectral_diffuse(r1_rgb, d, r0=1.0, sampling: SpectralSampling | int = 32) -> np.ndarray:
    """Linear Rec.709 RGB of ``rho_d`` (eq. 18) evaluated spectrally, shape (..., 3)."""
    s = as_sampling(sampling)
    return s.to_rgb(spectral_diffuse_spectrum(r1_rgb, d, r0, s.wavelengths))


# ----------------------------------------------------------------------------
# Where the interference averages out.
def phase_spread(r1, d) -> np.ndarray:
    """``4 pi r1 d (1/380 - 1/780)``: how far the phase ``4 pi r1 d / lambda`` turns across
    the visible band (radians; dispersion ignored)."""
    return 4.0 * np.pi * np.asarray(r1, dtype=float) * np.asarray(d, dtype=float) * (
        1.0 / LAMBDA_MIN_NM - 1.0 / LAMBDA_MAX_NM)


# Past this optical thickness the 1 nm ground truth itself undersamples cos(4 pi D / lambda)
# (a quarter period per nanometre at 380 nm).
CUTOFF_SEARCH_MAX_OPTICAL_NM = LAMBDA_MIN_NM ** 2 / 8.0
_CUTOFF_STEP_OPTICAL_NM = 1.0


def interference_delta_e(optical_thickness_nm, modulation: float = 1.0, level: float = 1.0,
                         cmf: CmfName = "cie1931") -> np.ndarray:
    """CIEDE2000 between ``level (1 + m cos(4 pi D / lambda))`` and its mean ``level``.

    ``D = r1 d`` is the optical thickness (nm), ``m`` the modulation depth of the
    interference (1 where the two beams are equal, e.g. specular ``R = T``; the diffuse part
    has ``m = 2 sqrt(Td (1 - Td))``), ``level`` the mean reflectance (1: white at Y = 1).
    Evaluated with the 1 nm ground truth.
    """
    gt = ground_truth_sampling(cmf)
    D = np.asarray(optical_thickness_nm, dtype=float)
    flat = D.reshape(-1)
    mean_rgb = np.full(3, float(level))  # a flat spectrum maps to (level, level, level)
    out = np.empty(flat.shape)
    step = max(1, _CHUNK_ELEMENTS // gt.n)
    for start in range(0, flat.shape[0], step):
        dd = flat[start:start + step, None]
        spectrum = level * (1.0 + modulation * np.cos(4.0 * np.pi * dd / gt.wavelengths))
        out[start:start + step] = delta_e_2000(gt.to_rgb(spectrum), mean_rgb)
    return out.reshape(D.shape)


@functools.lru_cache(maxsize=256)
def interference_cutoff_optical_nm(tolerance_de: float = 1.0, modulation: float = 1.0, level: float = 1.0,
                                   cmf: CmfName = "cie1931") -> float:
    """Smallest optical thickness ``D*`` beyond which :func:`interference_delta_e` stays below
    ``tolerance_de`` (searched on a 1 nm grid up to :data:`CUTOFF_SEARCH_MAX_OPTICAL_NM`).

    Returns ``inf`` if the interference is still visible at the end of the search.
    """
    D = np.arange(0.0, CUTOFF_SEARCH_MAX_OPTICAL_NM + _CUTOFF_STEP_OPTICAL_NM, _CUTOFF_STEP_OPTICAL_NM)
    de = interference_delta_e(D, modulation, level, cmf)
    above = np.nonzero(de >= tolerance_de)[0]
    if above.size == 0:
        return 0.0
    last = int(above[-1])
    if last == D.shape[0] - 1:
        return math.inf
    return float(D[last + 1])


def interference_cutoff_nm(r1, tolerance_de: float = 1.0, modulation: float = 1.0, level: float = 1.0) -> float:
    """Thickness ``d*`` (nm) beyond which the layer's interference changes the colour by less
    than ``tolerance_de`` (CIEDE2000): past it the spectral colour is the interference-free mean.

    ``r1``: the layer index (a triple uses its smallest value, the largest cut-off).  The
    phase of both eq. 3 at normal incidence and eq. 18 is ``4 pi r1 d / lambda``, so
    ``d* = D* / r1`` with ``D*`` from :func:`interference_cutoff_optical_nm`.  The defaults
    are the worst case (equal beams, white level); pass the material's ``modulation`` and
    ``level`` for a tighter value.  Oblique specular paths shorten the phase by the
    refracted cosine, so there the cut-off is ``d* / cos(theta_t)``.
    """
    r = float(np.min(np.asarray(r1, dtype=float)))
    if not r > 0.0:
        raise ValueError(f"interference_cutoff_nm needs a positive index, got {r1!r}")
    return interference_cutoff_optical_nm(float(tolerance_de), float(modulation), float(level)) / r


# Baked tables for the shaders and the fit (no colour-science in Blender): model/data/*.json.
def shader_tables(n: int) -> dict:
    """Wavelengths, the Cauchy matrix ``K`` (``r1(lambda_j) = K[j] . r1_rgb``) and the
    spectrum-to-Rec.709 matrix ``M`` of ``spectral_sampling(n)``, as lists."""
    s = spectral_sampling(n)
    x = (_CAUCHY_SCALE_NM / np.asarray(WAVELENGTHS_NM)) ** 2
    vander_inv = np.linalg.inv(np.stack([np.ones(3), x, x * x], axis=-1))
    xj = (_CAUCHY_SCALE_NM / s.wavelengths) ** 2
    K = np.stack([np.ones_like(xj), xj, xj * xj], axis=-1) @ vander_inv
    return dict(wavelengths=s.wavelengths.tolist(), cauchy=K.tolist(), rgb=s.matrix.tolist())


def observer_tables() -> dict:
    """colour-science's CIE 1931 2 degree CMFs (its 1 nm table) and D65 (its 5 nm table) as tabulated,
    the Rec.709 -> XYZ matrix and white: what the fit's colour maths reads (``spectral_tables.observer``)."""
    cmfs, d65_sd = colour.MSDS_CMFS[CMFS_NAME], colour.SDS_ILLUMINANTS[ILLUMINANT_NAME]
    return dict(cmf_nm=np.asarray(cmfs.domain, dtype=float).tolist(), cmf=np.asarray(cmfs.values, dtype=float).tolist(),
                d65_nm=np.asarray(d65_sd.domain, dtype=float).tolist(), d65=np.asarray(d65_sd.values, dtype=float).tolist(),
                rec709_to_xyz=rec709_to_xyz_matrix().tolist(), white_xy=white_xy().tolist())


def write_shader_tables(path=None, observer_path=None) -> str:
    """(Re)write the baked tables (the shaders' and the observer's), each whole or not at all; their paths."""
    written = []
    for where, data in ((path or spectral_tables.PATH, {str(n): shader_tables(n) for n in SAMPLE_COUNTS}),
                        (observer_path or spectral_tables.OBSERVER_PATH, observer_tables())):
        tmp = Path(where).with_suffix(".partial")
        tmp.write_text(json.dumps(data, indent=1))
        os.replace(tmp, where)
        written.append(str(where))
    return "\n".join(written)


if __name__ == "__main__":
    print(write_shader_tables())
