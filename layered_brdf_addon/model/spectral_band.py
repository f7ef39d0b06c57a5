"""The interference cosine integrated over each colour channel's band, in closed form.

Both interference terms of the model are a cosine of an optical path difference ``D``
over the wavelength: ``cos(2 Phi) = cos(2 pi D / lambda)`` with ``D = r1 d (s_i + s_o)``
(eq. 3; ``s`` the refracted cosines) and ``cos(4 pi r1 d / lambda)`` with ``D = 2 r1 d``
(eq. 18).  Seen through a linear Rec.709 channel ``c`` of the spectral ground truth (1 nm,
CIE 1931 under D65, model/spectral.py), a term ``A + B cos(2 pi D / lambda)`` whose ``A``
and ``B`` vary slowly with the wavelength is ``A + B C_c(D)`` with

    C_c(D) = sum_lambda M[lambda, c] cos(2 pi D / lambda),

the real part of the Fourier transform of the channel's weight in wavenumber.  A sum of
Gaussians in wavenumber transforms into damped cosines, so

    C_c(D) ~ sum_k a_kc exp(-b_kc D^2) cos(2 pi nu_kc D),

four per channel (:data:`SLOTS`), fitted once by least squares over ``D`` in 0-8,000 nm
(:func:`fit_band`) and baked into ``data/band_fit.json``: the shaders evaluate four
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

numpy only at render time; the fit itself uses scipy and colour-science (through
:mod:`.spectral`) and runs only when the table is rebuilt:
``make band-fit``.
"""
from __future__ import annotations

import functools
import json
import math
import os
from pathlib import Path

import numpy as np

from .params import WAVELENGTHS_NM

PATH = Path(__file__).with_name("data") / "band_fit.json"
SLOTS = 4  # Gaussians per channel
FIT_OPD_MAX_NM = 8000.0  # the fit's range of optical path difference
FIT_OPD_STEP_NM = 4.0
FIT_AMPLITUDE_BOUND = 3.0  # |a| bound: the terms must not cancel each other in float32
FIT_AMPLITUDE_RIDGE = 0.01  # weight of the amplitudes' penalty (keeps them moderate)
FIT_RESTARTS = 120
MIN_PATH_COS = 0.1  # floor of the refracted cosines in the path's slope dD/dr1 (first order only)
_CAUCHY_SCALE_NM = 500.0  # as model/spectral.py: the Cauchy fit in x = (500 / lambda)^2


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
def _per_channel(x, shape=None) -> np.ndarray:
    """``x`` as a per-channel array (..., 3): a trailing axis of 3 (or 1) is the channel's,
    anything else is one value for the three channels; broadcast to ``shape`` if given."""
    a = np.asarray(x, dtype=float)
    if a.ndim == 0 or a.shape[-1] not in (1, 3):
        a = a[..., None]
    target = shape if shape is not None else a.shape[:-1] + (3,)
    return np.broadcast_to(a, np.broadcast_shapes(a.shape, target))


def channel_cosine_numeric(opd_nm, r1_rgb=None, slope_nm=None) -> np.ndarray:
    """``C_c`` by numerical integration over the 1 nm ground truth, shape (..., 3).

    ``opd_nm``: the path difference ``D`` (...), or (..., 3) per channel.  With ``r1_rgb``
    (the three indices) the path follows the dispersed index: at each wavelength it is
    ``D + slope (r1(lambda) - r1_c)`` (``slope_nm`` = ``dD/dr1``, shape like ``opd_nm``),
    exact for eq. 18 (``D = 2 r1 d``, slope ``2 d``) and the first order of eq. 3.
    """
    from . import spectral as sp

    gt = sp.ground_truth_sampling()
    lam, M = gt.wavelengths, gt.matrix
    D = _per_channel(opd_nm)
    out = np.empty(D.shape)
    if r1_rgb is None:
        for c in range(3):
            out[..., c] = np.cos(2.0 * np.pi * D[..., c, None] / lam) @ M[:, c]
        return out
    r1 = np.asarray(r1_rgb, dtype=float)
    r_lam = sp.index_at(sp.cauchy_fit(r1), lam)  # (N,) for one triple
    S = _per_channel(slope_nm, D.shape)
    for c in range(3):
        path = D[..., c, None] + S[..., c, None] * (r_lam - r1[c])
        out[..., c] = np.cos(2.0 * np.pi * path / lam) @ M[:, c]
    return out


def channel_cosine(opd_nm, r1_rgb=None, slope_nm=None) -> np.ndarray:
    """``C_c`` from the baked fit (numpy), the formula the shaders evaluate
    (:func:`~.program.band_cosine`); arguments as :func:`channel_cosine_numeric`."""
    from . import ops_numpy as O
    from .program import band_cosine

    D = _per_channel(opd_nm)
    if r1_rgb is None:
        return np.asarray(band_cosine(O, O.vec(D), 0.0, 0.0, dispersion=False))
    S = _per_channel(slope_nm, D.shape)
    r1 = O.vec(np.broadcast_to(np.asarray(r1_rgb, dtype=float), D.shape))
    return np.asarray(band_cosine(O, O.vec(D), O.vec(S), r1, dispersion=True))


# ---------------------------------------------------------------- the fit
def _model(p: np.ndarray, x: np.ndarray) -> np.ndarray:
    a, b, nu = p[0::3], p[1::3], p[2::3]
    return (a * np.exp(-b * x[:, None] ** 2) * np.cos(2.0 * np.pi * nu * x[:, None])).sum(axis=1)


def fit_band(restarts: int = FIT_RESTARTS, seed: int = 2017) -> dict:
    """Fit :data:`SLOTS` damped cosines to each channel's ``C_c`` (the 1 nm ground truth,
    no dispersion) over 0-:data:`FIT_OPD_MAX_NM`.  Least squares with ``C_c(0) = 1``
    enforced (amplitudes rescaled to sum to 1 after the fit), ``|a| <=``
    :data:`FIT_AMPLITUDE_BOUND` and a small penalty on the amplitudes; the best of
    ``restarts`` random starts.  Parameters are solved in scaled units (``sigma``,
    ``nu`` in 1/um) and stored in 1/nm."""
    from scipy.optimize import least_squares

    x = np.arange(0.0, FIT_OPD_MAX_NM + FIT_OPD_STEP_NM, FIT_OPD_STEP_NM)
    target = channel_cosine_numeric(x)
    rng = np.random.default_rng(seed)
    lo = np.array([-FIT_AMPLITUDE_BOUND, 0.005, 1.2] * SLOTS)
    hi = np.array([FIT_AMPLITUDE_BOUND, 1.0, 2.7] * SLOTS)

    def params(q):  # (a, sigma [1/um], nu [1/um]) -> (a, b [nm^-2], nu [1/nm])
        p = q.copy()
        p[1::3] = 2.0 * math.pi ** 2 * (q[1::3] * 1e-3) ** 2
        p[2::3] = q[2::3] * 1e-3
        return p

    channels = []
    for c in range(3):
        best = None
        for _ in range(restarts):
            q0 = np.ravel([[rng.normal(0.3, 0.7), rng.uniform(0.02, 0.3), 1e3 / rng.uniform(400.0, 700.0)]
                           for _ in range(SLOTS)])
            q0 = np.clip(q0, lo + 1e-6, hi - 1e-6)

            def residual(q):
                p = params(q)
                return np.r_[_model(p, x) - target[:, c], 30.0 * (p[0::3].sum() - 1.0),
                             FIT_AMPLITUDE_RIDGE * p[0::3]]

            r = least_squares(residual, q0, bounds=(lo, hi))
            if best is None or r.cost < best.cost:
                best = r
        p = params(best.x).reshape(SLOTS, 3)
        p = p[np.argsort(p[:, 2])]  # slots in order of wavenumber
        p[:, 0] /= p[:, 0].sum()  # C_c(0) = 1 exactly: a zero path gives the RGB mode's value
        channels.append(p)
    slots = []
    for k in range(SLOTS):
        nu = [float(channels[c][k, 2]) for c in range(3)]
        damping = [float(channels[c][k, 1]) for c in range(3)]
        shift, slope, chirp = derived_rows(nu, damping)
        slots.append(dict(amplitude=[float(channels[c][k, 0]) for c in range(3)], damping=damping,
                          wavenumber=nu, index_shift=shift, index_slope=slope, index_chirp=chirp))
    return dict(slots=slots, opd_max_nm=FIT_OPD_MAX_NM, restarts=restarts, seed=seed)


def fit_error(opd_max_nm: float = FIT_OPD_MAX_NM, step_nm: float = 1.0) -> dict:
    """Largest difference, per channel, between the baked closed form and the numerical
    integral over ``D`` in 0-``opd_max_nm`` (no dispersion)."""
    x = np.arange(0.0, opd_max_nm + step_nm, step_nm)
    diff = np.abs(channel_cosine(x) - channel_cosine_numeric(x))
    return {f"max_abs_{'rgb'[c]}": float(diff[:, c].max()) for c in range(3)}


def write_band_fit(path=None, **kwargs) -> str:
    """Fit and (re)write the baked table atomically; returns the path."""
    path = Path(path or PATH)
    data = fit_band(**kwargs)
    tmp = path.with_suffix(".partial")
    tmp.write_text(json.dumps(data, indent=1))
    os.replace(tmp, path)
    band_fit.cache_clear()
    return str(path)


def main() -> int:
    """Refit the table (a few minutes) and print the fit's error."""
    print(write_band_fit())
    print(fit_error())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
