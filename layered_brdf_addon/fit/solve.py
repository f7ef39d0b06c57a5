"""The fit: robust least squares in CIELAB over bounded parameters, from several starts.

Interference colours repeat with thickness (each order of the film shows the sequence
again), so a local optimiser started anywhere finds the nearest order, not the best one:
the starts are the best few of a coarse scan over the mean thickness (the range's relative
width kept), plus the start itself.  Each runs ``scipy.optimize.least_squares`` (trust
region, bounds from the parameter table, ``soft_l1`` loss: a few pixels the model cannot
reach, a clipped highlight or a speck, do not pull the fit), and the best result wins.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from ..model.params import LayeredParams
from . import colour_space
from .free import FreeParameters, check_vary, default_vary, film_vary, search_range

THICKNESS_SCAN_NM = (20.0, 3000.0)
THICKNESS_SCAN_STEPS = 28
LOSS_SCALE = 2.0  # CIELAB units where soft_l1 turns from quadratic to linear
GOOD_ENOUGH = 0.5  # mean CIEDE2000 below which no further start is tried (about a just-noticeable difference)
START_MARGIN = 0.05  # a start this far inside the bounds (of their width)


class FitCancelled(Exception):
    """The caller asked the fit to stop (``should_stop``)."""


@dataclass
class FitResult:
    params: LayeredParams
    mean_delta_e: float  # CIEDE2000 over the target's fitted colours
    evaluations: int
    seconds: float
    vary: tuple[str, ...]
    starts: list = field(default_factory=list)  # (start's d_min, d_max, its final mean CIEDE2000)


class _Objective:
    """Residuals of a target at a parameter vector, counting evaluations and keeping the best."""

    def __init__(self, target, free: FreeParameters, progress, should_stop):
        self.target, self.free = target, free
        self.lab_observed = colour_space.lab(target.observed, target.white_y)
        self.progress, self.should_stop = progress, should_stop
        self.evaluations = 0

    def lab(self, params: LayeredParams) -> np.ndarray:
        rgb = np.nan_to_num(self.target.predict(params), nan=0.0, posinf=1e6, neginf=0.0)
        return colour_space.lab(np.maximum(rgb, 0.0), self.target.white_y)

    def __call__(self, x) -> np.ndarray:
        if self.should_stop is not None and self.should_stop():
            raise FitCancelled()
        self.evaluations += 1
        if self.progress is not None:
            self.progress(self.evaluations)
        return (self.lab(self.free.params(x)) - self.lab_observed).ravel()

    def mean_delta_e(self, params: LayeredParams) -> float:
        return float(np.mean(colour_space.delta_e_2000(self.lab(params), self.lab_observed)))


def _soft_l1(r: np.ndarray) -> float:
    z = (r / LOSS_SCALE) ** 2
    return float(np.sum(2.0 * (np.sqrt(1.0 + z) - 1.0)))


def thickness_starts(objective: _Objective, start: LayeredParams, count: int) -> list[LayeredParams]:
    """The start and the ``count`` best mean thicknesses of a coarse scan (local minima of the
    loss along the scan, best first), the range's relative width kept."""
    lo, hi = start.d_min, start.d_max
    mids = np.geomspace(*THICKNESS_SCAN_NM, THICKNESS_SCAN_STEPS)
    if getattr(objective.target, "uniform_film", False):
        candidates = [start.replace(d_min=m) for m in mids]
    else:
        half = min(max((hi - lo) / max(hi + lo, 1e-9), 0.0), 0.9)
        candidates = [start.replace(d_min=m * (1 - half), d_max=m * (1 + half)) for m in mids]
    losses = np.array([_soft_l1(objective(objective.free.vector(p, START_MARGIN))) for p in candidates])
    minima = [i for i in range(len(mids))
              if (i == 0 or losses[i] <= losses[i - 1]) and (i == len(mids) - 1 or losses[i] <= losses[i + 1])]
    minima.sort(key=lambda i: losses[i])
    return [start] + [candidates[i] for i in minima[:count]]


def fit(target, start: LayeredParams, vary: Sequence[str] | None = None, *, starts: int = 3,
        steps_per_start: int = 40, progress: Callable[[int], None] | None = None,
        should_stop: Callable[[], bool] | None = None) -> FitResult:
    """Parameters of ``start``'s modes whose closure form best matches ``target``.

    ``vary``: the free parameters (default :func:`~.free.default_vary`); the others keep
    ``start``'s values.  ``starts``: how many of the thickness scan's best orders are tried
    besides ``start`` (when the thickness is free), unless one already matches within
    :data:`GOOD_ENOUGH`; ``steps_per_start``: the optimiser's steps from each (each step
    evaluates the model once per free parameter for the slopes, and once more).  ``progress(evaluations)`` is called at
    each evaluation of the model; ``should_stop()`` returning True ends the fit with
    :class:`FitCancelled`.
    """
    from scipy.optimize import least_squares

    t0 = time.perf_counter()
    uniform = getattr(target, "uniform_film", False)
    if uniform:
        start = start.replace(d_max=search_range("d_max")[1])
    names = check_vary((film_vary if uniform else default_vary)(start) if vary is None else vary)
    free = FreeParameters(names, start)
    objective = _Objective(target, free, progress, should_stop)
    lo, hi = free.bounds()
    firsts = thickness_starts(objective, start, starts) if {"d_min", "d_max"} & set(names) else [start]
    best, best_cost, tried = None, np.inf, []
    for first in firsts:
        sol = least_squares(objective, free.vector(first, START_MARGIN), bounds=(lo, hi), loss="soft_l1", f_scale=LOSS_SCALE,
                            x_scale="jac", diff_step=1e-3, max_nfev=steps_per_start)
        params = free.params(sol.x)
        de = objective.mean_delta_e(params)
        tried.append((first.d_min, first.d_max, de))
        if sol.cost < best_cost:
            best, best_cost = params, sol.cost
        if de <= GOOD_ENOUGH:
            break
    de = objective.mean_delta_e(best)
    if uniform:
        best = best.replace(d_max=best.d_min)
    return FitResult(best, de, objective.evaluations, time.perf_counter() - t0, names, tried)
