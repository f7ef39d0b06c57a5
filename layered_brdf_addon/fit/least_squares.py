"""Bounded, robust nonlinear least squares in numpy alone: Levenberg-Marquardt steps projected
onto the bounds, with the soft-L1 loss by iteratively reweighted Gauss-Newton.

Minimises ``C(x) = 1/2 s^2 sum_i rho((f_i(x) / s)^2)``, ``rho(z) = 2 (sqrt(1 + z) - 1)``
(quadratic for residuals well under ``s``, linear beyond: a few pixels the model cannot reach
do not pull the fit), for ``lo <= x <= hi``.  Each step solves
``(J^T W J + lambda D) dx = -J^T W f`` on the variables not held at a bound (``W`` the loss's
weights ``rho'(z)``, ``D`` the largest diagonal of ``J^T W J`` met so far: Moré's scaling, as in
MINPACK), clips ``x + dx`` into the
bounds and keeps it when the cost falls; ``lambda`` follows the gain ratio (Nielsen 1999).
The fit's targets are smooth and its parameters scaled to their ranges, which is what this
needs; it replaces SciPy's ``least_squares(method="trf", loss="soft_l1")`` so that the fit runs in
Blender's own Python (benchmarks/fit_solvers.py measures the two on the same fits).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

FTOL = 1e-8  # stop when a step lowers the cost by less than this share of it
XTOL = 1e-8  # or moves x by less than this, relative to |x|
GTOL = 1e-10  # or the projected gradient is this small
DAMPING_START = 1e-3  # lambda's start (it multiplies D, so it has no unit)
DAMPING_CEILING = 1e12  # a step rejected at this damping ends the search
DAMPING_FLOOR = 1e-12  # the smallest diagonal D takes, relative to the largest


@dataclass
class Solution:
    x: np.ndarray
    cost: float
    nfev: int  # residual evaluations (the Jacobian's are the caller's to count)
    njev: int
    reason: str  # "ftol", "xtol", "gtol" or "max_nfev"


def soft_l1_cost(f: np.ndarray, f_scale: float) -> float:
    z = (np.asarray(f, dtype=float) / f_scale) ** 2
    return float(0.5 * f_scale * f_scale * np.sum(2.0 * (np.sqrt(1.0 + z) - 1.0)))


def _weights(f: np.ndarray, f_scale: float) -> np.ndarray:
    """``rho'(z)`` of the soft-L1 loss: 1 for small residuals, ``s / |f|`` for large ones."""
    return 1.0 / np.sqrt(1.0 + (f / f_scale) ** 2)


def least_squares(fun: Callable[[np.ndarray], np.ndarray], x0, jac: Callable[[np.ndarray], np.ndarray],
                  bounds: tuple, *, f_scale: float = 1.0, max_nfev: int = 40) -> Solution:
    """``x`` in ``bounds`` (two arrays) lowering the soft-L1 cost of the residuals ``fun(x)``
    (a vector), whose slopes ``jac(x)`` gives (rows: residuals, columns: variables), with at
    most ``max_nfev`` evaluations of ``fun``.  ``jac`` is only called at a point ``fun`` was
    last evaluated at."""
    lo, hi = (np.asarray(b, dtype=float) for b in bounds)
    x = np.clip(np.asarray(x0, dtype=float), lo, hi)
    f = np.asarray(fun(x), dtype=float)
    nfev, njev, cost = 1, 0, soft_l1_cost(f, f_scale)
    damping, growth = DAMPING_START, 2.0
    scale = np.zeros_like(x)
    while True:
        if nfev >= max_nfev:
            return Solution(x, cost, nfev, njev, "max_nfev")
        jacobian = np.asarray(jac(x), dtype=float)
        njev += 1
        w = _weights(f, f_scale)
        gradient = jacobian.T @ (w * f)
        held = ((x <= lo) & (gradient > 0)) | ((x >= hi) & (gradient < 0))
        free = ~held
        if not free.any() or np.max(np.abs(gradient[free])) <= GTOL:
            return Solution(x, cost, nfev, njev, "gtol")
        j = jacobian[:, free]
        normal = j.T @ (w[:, None] * j)
        scale = np.maximum(scale, np.einsum("ij,i,ij->j", jacobian, w, jacobian))  # Moré's: never shrinks
        diag = np.maximum(scale[free], DAMPING_FLOOR * max(float(np.max(scale)), DAMPING_FLOOR))
        while True:
            try:
                step = np.linalg.solve(normal + damping * np.diag(diag), -gradient[free])
            except np.linalg.LinAlgError:
                damping, growth = damping * growth, growth * 2.0
                continue
            trial = x.copy()
            trial[free] += step
            trial = np.clip(trial, lo, hi)
            moved = trial - x
            f_trial = np.asarray(fun(trial), dtype=float)
            nfev += 1
            cost_trial = soft_l1_cost(f_trial, f_scale)
            m = moved[free]
            predicted = -(gradient[free] @ m + 0.5 * m @ normal @ m)
            actual = cost - cost_trial
            if actual > 0.0 and np.all(np.isfinite(f_trial)):
                gain = actual / predicted if predicted > 0.0 else 1.0
                damping *= max(1.0 / 3.0, 1.0 - (2.0 * gain - 1.0) ** 3)
                growth = 2.0
                x, f, cost = trial, f_trial, cost_trial
                if actual <= FTOL * max(cost + actual, 1e-300):
                    return Solution(x, cost, nfev, njev, "ftol")
                if np.linalg.norm(moved) <= XTOL * (XTOL + np.linalg.norm(x)):
                    return Solution(x, cost, nfev, njev, "xtol")
                break
            damping, growth = damping * growth, growth * 2.0
            if damping > DAMPING_CEILING:  # no step, however short, lowers the cost: a minimum
                return Solution(x, cost, nfev, njev, "xtol")
            if nfev >= max_nfev:
                return Solution(x, cost, nfev, njev, "max_nfev")
