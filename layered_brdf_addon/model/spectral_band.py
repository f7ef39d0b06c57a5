"""The interference cosine integrated over each colour channel's band, in closed form.

Both interference terms of the model are a cosine of an optical path difference ``D``
over the wavelength: ``cos(2 Phi) = cos(2 pi D / lambda)`` with ``D = r1 d (s_i + s_o)``
(eq. 3; ``s`` the refracted cosines) and ``cos(4 pi r1 d / lambda)`` with ``D = 2 r1 d``
(eq. 18).  Seen through a linear Rec.709 channel ``c`` of the spectral ground truth (1 nm,
CIE 1931 under D65, layered_brdf_reference/spectral.py), a term ``A + B cos(2 pi D /
lambda)`` whose ``A`` and ``B`` vary slowly with the wavelength is ``A + B C_c(D)`` with

    C_c(D) = sum_lambda M[lambda, c] cos(2 pi D / lambda),

the real part of the Fourier transform of the channel's weight in wavenumber.  A sum of
Gaussians in wavenumber transforms into damped cosines, so

    C_c(D) ~ sum_k a_kc exp(-b_kc D^2) cos(2 pi nu_kc D),

four per channel (:data:`SLOTS`), fitted once by least squares over ``D`` in 0-8,000 nm
(``layered_brdf_reference/band_fitting.py``) and baked into ``data/band_fit.json``: the shaders evaluate four
``exp`` and four ``cos`` on channel triples, where the paper's RGB mode evaluates one
``cos`` at one wavelength per channel.  A thick layer's interference then fades to its
band average instead of aliasing into false colours.

Dispersion (``r1(lambda)`` from the Cauchy fit through the three indices) is kept to second
order in each Gaussian: the phase ``2 pi nu D(nu)`` is expanded about the Gaussian's centre
``nu_k``, where ``D`` is the path at the index there, its slope gives the *group* path
``D + nu dD/dnu`` that damps the term, and its curvature a chirp ``c`` (a Gaussian times a
quadratic phase still integrates in closed form: the damping is divided by ``1 + c^2``, the
amplitude by ``(1 + c^2)^(1/4)``, and the phase moves by ``atan(c)/2``).  All three are
linear in the three indices through constant rows baked with the fit (``index_shift``:
``r1(nu_k) - r1_c``; ``index_slope``: ``nu dr1/dnu``; ``index_chirp``), times the path's
slope ``dD/dr1`` (``d (1/s_i + 1/s_o)``, ``2 d`` for eq. 18).

This module reads the baked table (numpy and the standard library); the numpy evaluation is
``layered_brdf_reference.exact_model.channel_cosine``.  The fit uses scipy and colour-science and lives with the
reference tools (``layered_brdf_reference/band_fitting.py``); it runs only when the table is
rebuilt: ``make band-fit``.
"""
from __future__ import annotations

import functools
import json
import math
from pathlib import Path

import numpy as np

from .params import WAVELENGTHS_NM

PATH = Path(__file__).with_name("data") / "band_fit.json"
SLOTS = 4  # Gaussians per channel
MIN_PATH_COS = 0.1  # floor of the refracted cosines in the path's slope dD/dr1 (first order only)
_CAUCHY_SCALE_NM = 500.0  # as layered_brdf_reference/spectral.py: the Cauchy fit in x = (500 / lambda)^2


@functools.lru_cache(maxsize=None)
def band_fit() -> dict:
    """The baked fit: ``slots``, a list of :data:`SLOTS` dicts with per-channel triples
    ``amplitude`` (a), ``damping`` (b, nm^-2), ``wavenumber`` (nu, 1/nm) and the rows
    ``index_shift``, ``index_slope`` (3 x 3: channel, then the three RGB indices)."""
    return json.loads(PATH.read_text())


def _cauchy_rows(wavelength_nm: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows with ``r1(lambda) = k . r1_rgb``, ``nu dr1/dnu = q . r1_rgb`` and
    ``nu^2 d2r1/dnu2 = w . r1_rgb`` for the Cauchy law through the three RGB indices
    (``r = a0 + a1 x + a2 x^2``, ``x = (500/lambda)^2 = 500^2 nu^2``, so ``nu r' = 2 a1 x +
    4 a2 x^2`` and ``nu^2 r'' = 2 a1 x + 12 a2 x^2``)."""
    x_rgb = (_CAUCHY_SCALE_NM / np.asarray(WAVELENGTHS_NM, dtype=float)) ** 2
    vander_inv = np.linalg.inv(np.stack([np.ones(3), x_rgb, x_rgb * x_rgb], axis=-1))
    x = (_CAUCHY_SCALE_NM / wavelength_nm) ** 2
    return (np.array([1.0, x, x * x]) @ vander_inv, np.array([0.0, 2.0 * x, 4.0 * x * x]) @ vander_inv,
            np.array([0.0, 2.0 * x, 12.0 * x * x]) @ vander_inv)


def derived_rows(wavenumbers, damping) -> tuple[list, list, list]:
    """``index_shift``, ``index_slope`` and ``index_chirp`` of one slot from its three
    wavenumbers (1/nm) and dampings (nm^-2).

    The phase is ``phi(nu) = 2 pi nu D(nu)`` with ``D(nu) = D_c + S (r1(nu) - r1_c)``; about the
    Gaussian's centre its slope gives the group path ``D + S nu r1'`` and its curvature
    ``phi'' = 2 pi S (2 nu r1' + nu^2 r1'') / nu`` the chirp ``sigma^2 phi''``, with
    ``sigma^2 = b / (2 pi^2)``: ``S`` times ``index_chirp . r1_rgb``."""
    shift, slope, chirp = [], [], []
    for c, (nu, b) in enumerate(zip(wavenumbers, damping)):
        k, q, w = _cauchy_rows(1.0 / float(nu))
        k = k.copy()
        k[c] -= 1.0  # r1(nu_k) - r1_c
        shift.append(k.tolist())
        slope.append(q.tolist())
        chirp.append((float(b) / (math.pi * float(nu)) * (2.0 * q + w)).tolist())
    return shift, slope, chirp


# ---------------------------------------------------------------- the integral itself
def per_channel(x, shape=None) -> np.ndarray:
    """``x`` as a per-channel array (..., 3): a trailing axis of 3 (or 1) is the channel's,
    anything else is one value for the three channels; broadcast to ``shape`` if given."""
    a = np.asarray(x, dtype=float)
    if a.ndim == 0 or a.shape[-1] not in (1, 3):
        a = a[..., None]
    target = shape if shape is not None else a.shape[:-1] + (3,)
    return np.broadcast_to(a, np.broadcast_shapes(a.shape, target))
