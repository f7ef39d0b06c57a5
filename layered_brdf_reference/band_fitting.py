"""Fitting the analytic mode's closed form (``layered_brdf_addon/model/data/band_fit.json``):
each colour channel's band-integrated interference cosine, from the 1 nm ground truth, as a
sum of damped cosines (the method: ``layered_brdf_addon/model/spectral_band.py``).  An
offline tool: it needs scipy and colour-science, and runs only when the table is rebuilt
(``make band-fit``, a few minutes).
"""
from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

from layered_brdf_addon.model.spectral_band import PATH, SLOTS, band_fit, derived_rows, per_channel

from . import spectral
from .exact_model import channel_cosine

FIT_OPD_MAX_NM = 8000.0  # the fit's range of optical path difference
FIT_OPD_STEP_NM = 4.0
FIT_AMPLITUDE_BOUND = 3.0  # |a| bound: the terms must not cancel each other in float32
FIT_AMPLITUDE_RIDGE = 0.01  # weight of the amplitudes' penalty (keeps them moderate)
FIT_RESTARTS = 120


def channel_cosine_numeric(opd_nm, r1_rgb=None, slope_nm=None) -> np.ndarray:
    """``C_c`` by numerical integration over the 1 nm ground truth, shape (..., 3).

    ``opd_nm``: the path difference ``D`` (...), or (..., 3) per channel.  With ``r1_rgb``
    (the three indices) the path follows the dispersed index: at each wavelength it is
    ``D + slope (r1(lambda) - r1_c)`` (``slope_nm`` = ``dD/dr1``, shape like ``opd_nm``),
    exact for eq. 18 (``D = 2 r1 d``, slope ``2 d``) and the first order of eq. 3.
    """
    gt = spectral.ground_truth_sampling()
    lam, M = gt.wavelengths, gt.matrix
    D = per_channel(opd_nm)
    out = np.empty(D.shape)
    if r1_rgb is None:
        for c in range(3):
            out[..., c] = np.cos(2.0 * np.pi * D[..., c, None] / lam) @ M[:, c]
        return out
    r1 = np.asarray(r1_rgb, dtype=float)
    r_lam = spectral.index_at(spectral.cauchy_fit(r1), lam)  # (N,) for one triple
    S = per_channel(slope_nm, D.shape)
    for c in range(3):
        path = D[..., c, None] + S[..., c, None] * (r_lam - r1[c])
        out[..., c] = np.cos(2.0 * np.pi * path / lam) @ M[:, c]
    return out


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
