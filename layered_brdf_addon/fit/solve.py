"""The fit: robust least squares in CIELAB over bounded parameters, from several starts.

Interference colours repeat with thickness (each order of the film shows the sequence
again), so a local optimiser started anywhere finds the nearest order, not the best one:
the start itself is fitted first, then, unless it already matches, the best few of a coarse
scan over the mean thickness (the range's relative width kept).  Each runs
:func:`.least_squares.least_squares` (bounded Levenberg-Marquardt in numpy, bounds from the
parameter table, soft-L1 loss: a few pixels the model cannot reach, a clipped highlight or a
speck, do not pull the fit), and the best result wins.

The slopes are forward differences (SciPy's steps), but the parameter sets of a Jacobian's columns
(and the scan's candidates) are evaluated together: a sphere target shades them in one run
of the shading program (``SphereTarget.predict_many``), whose numpy backend repeats the
Python work of its many small steps on every run, however few the points.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Sequence

import numpy as np

from ..model.params import LayeredParams
from . import colour_space
from .free import FreeParameters, vary_for
from .least_squares import least_squares

THICKNESS_SCAN_NM = (20.0, 3000.0)
THICKNESS_SCAN_STEPS = 28
STACK_SCAN_SCALES = (0.5, 2.0)  # a film stack's total thickness scanned over these times its own (its period: a
# Bragg peak moves with it, 5% a step)
INDEX_SCAN_FACTORS = (0.88, 1.14)  # the layer's indices scanned too, where free: their refraction moves the colours
SCAN_HALF_WIDTHS = (0.1, 0.4)  # relative half-widths of the range scanned, besides the start's
LOSS_SCALE = 2.0  # CIELAB units where soft_l1 turns from quadratic to linear
GOOD_ENOUGH = 0.5  # mean CIEDE2000 below which no further start is tried (about a just-noticeable difference)
DIFF_STEP = 1e-3  # the slopes' forward-difference step, relative to the parameter (scipy's ``diff_step``)
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
    """Residuals of a target at parameter vectors, counting evaluations; the slopes by forward
    differences, every column's parameters evaluated together."""

    def __init__(self, target, free: FreeParameters, progress, should_stop):
        self.target, self.free = target, free
        self.observed = features_observed(target, free.base)
        self.weights = feature_weights(target, free.base)[:, None]
        self.colours = colour_rows(target, free.base)
        self.progress, self.should_stop = progress, should_stop
        self.evaluations = 0
        self.bounds = free.bounds()
        self._last = None  # (x, residuals) of the last single evaluation: the slopes start there

    def features(self, params: LayeredParams) -> np.ndarray:
        return _finite(model_features(self.target, params))

    def _count(self) -> None:
        """One evaluation more: the caller may stop the fit, and hears how far it is."""
        if self.should_stop is not None and self.should_stop():
            raise FitCancelled()
        self.evaluations += 1
        if self.progress is not None:
            self.progress(self.evaluations)

    def residuals(self, xs: Sequence[np.ndarray]) -> np.ndarray:
        """(K, rows): the residuals at each of ``K`` vectors, their parameters evaluated
        together where the target can (:func:`model_features_many`)."""
        params = []
        for x in xs:
            self._count()
            params.append(self.free.params(x))
        feats = _finite(model_features_many(self.target, params))
        return ((feats - self.observed) * self.weights).reshape(len(params), -1)

    def __call__(self, x) -> np.ndarray:
        r = self.residuals([x])[0]
        self._last = (np.array(x, dtype=float), r)
        return r

    def jacobian(self, x) -> np.ndarray:
        """The residuals' slopes at ``x``: scipy's 2-point forward differences (its steps,
        turned back at a bound), the columns' vectors evaluated together.  ``x`` is where
        the optimiser last evaluated the residuals (they are reused), else they are evaluated."""
        x = np.asarray(x, dtype=float)
        f0 = self._last[1] if self._last is not None and np.array_equal(self._last[0], x) else self(x)
        h = difference_steps(x, *self.bounds)
        xs = [x + np.where(np.arange(x.size) == i, h, 0.0) for i in range(x.size)]
        dx = np.array([xi[i] - x[i] for i, xi in enumerate(xs)])
        return ((self.residuals(xs) - f0) / dx[:, None]).T

    def mean_delta_e(self, params: LayeredParams) -> float:
        return _mean_delta_e(self.features(params), self.observed, self.colours)


def difference_steps(x: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The forward-difference steps of scipy's ``least_squares(diff_step=DIFF_STEP)``:
    ``DIFF_STEP |x|`` signed as ``x`` (a zero step becomes ``sqrt(eps) max(1, |x|)``), turned
    back where it would leave the bounds, shortened to the farther bound where neither way fits."""
    sign = np.where(x >= 0, 1.0, -1.0)
    h = DIFF_STEP * sign * np.abs(x)
    h = np.where((x + h) - x == 0, np.finfo(float).eps ** 0.5 * sign * np.maximum(1.0, np.abs(x)), h)
    below, above = x - lo, hi - x
    fitting = np.abs(h) <= np.maximum(below, above)
    h = np.where(((x + h < lo) | (x + h > hi)) & fitting, -h, h)
    h = np.where(~fitting & (above >= below), above, h)
    return np.where(~fitting & (above < below), -below, h)


def _lab(target, rgb) -> np.ndarray:
    rgb = np.nan_to_num(np.asarray(rgb, dtype=float), nan=0.0, posinf=1e6, neginf=0.0)
    return colour_space.lab(np.maximum(rgb, 0.0), target.white_y)


def model_features(target, params: LayeredParams) -> np.ndarray:
    """The target's comparison rows (CIELAB) for ``params``: its own ``features`` where it
    has them (sphere targets: pixels, or statistics for a noise thickness), else the Lab of
    its predicted colours."""
    if hasattr(target, "features"):
        return target.features(params)
    return _lab(target, target.predict(params))


def model_features_many(target, params_list: Sequence[LayeredParams]) -> np.ndarray:
    """(K, rows, 3): :func:`model_features` of each parameter set, in one go where the target
    has ``features_many`` (a sphere target shades them in one run of the program)."""
    if hasattr(target, "features_many"):
        return target.features_many(params_list)
    return np.stack([model_features(target, p) for p in params_list])


def features_observed(target, params: LayeredParams) -> np.ndarray:
    if hasattr(target, "observed_features"):
        return target.observed_features(params)
    return _lab(target, target.observed)


def feature_weights(target, params: LayeredParams) -> np.ndarray:
    if hasattr(target, "feature_weights"):
        return target.feature_weights(params)
    return np.ones(len(target.observed))


def colour_rows(target, params: LayeredParams):
    return target.colour_rows(params) if hasattr(target, "colour_rows") else slice(None)


def _finite(features: np.ndarray) -> np.ndarray:
    """The model's CIELAB rows with NaN and infinities (a diverging parameter set) made finite and far."""
    return np.nan_to_num(features, nan=0.0, posinf=1e3, neginf=-1e3)


def _mean_delta_e(model: np.ndarray, observed: np.ndarray, rows) -> float:
    return float(np.mean(colour_space.delta_e_2000(model[rows], observed[rows])))


def sample_delta_e(target, params: LayeredParams) -> float:
    """The mean CIEDE2000 a fit reports for ``params`` on ``target``'s comparison rows (its sample's pixels,
    or the colours of a noise thickness's statistics)."""
    return _mean_delta_e(_finite(model_features(target, params)), features_observed(target, params),
                         colour_rows(target, params))


def _soft_l1(r: np.ndarray) -> float:
    z = (r / LOSS_SCALE) ** 2
    return float(np.sum(2.0 * (np.sqrt(1.0 + z) - 1.0)))


def thickness_starts(objective: _Objective, start: LayeredParams, count: int,
                     index_scan: bool = True) -> list[LayeredParams]:
    """The ``count`` best thickness ranges of a coarse scan (local minima of the loss along the mean
    thickness, best first; a film stack's total over :data:`STACK_SCAN_SCALES` of its own), at the start's relative width and at :data:`SCAN_HALF_WIDTHS`; with
    ``index_scan``, where the layer's three indices are free, at the start's indices scaled by
    :data:`INDEX_SCAN_FACTORS` too (a film of another index shows the same colours at another thickness,
    but refracts, and so tilts its colours, otherwise)."""
    lo, hi = start.d_min, start.d_max
    mids = np.geomspace(*THICKNESS_SCAN_NM, THICKNESS_SCAN_STEPS) if start.stack is None else \
        start.stack.total_nm * np.geomspace(*STACK_SCAN_SCALES, THICKNESS_SCAN_STEPS)
    if objective.free.uniform:
        candidates = [start.replace(d_min=m, d_max=m) for m in mids]
    else:
        half = min(max((hi - lo) / max(hi + lo, 1e-9), 0.0), 0.9)
        halves = sorted({round(half, 3), *SCAN_HALF_WIDTHS})
        candidates = [start.replace(d_min=m * (1 - h), d_max=m * (1 + h)) for h in halves for m in mids]
        if index_scan and {"r1_r", "r1_g", "r1_b"} <= set(objective.free.names):
            candidates += [c.replace(r1_r=c.r1_r * f, r1_g=c.r1_g * f, r1_b=c.r1_b * f)
                           for f in INDEX_SCAN_FACTORS for c in candidates[:len(mids) * len(halves)]]
    losses = np.array([_soft_l1(r) for r in objective.residuals([objective.free.vector(p, START_MARGIN)
                                                                 for p in candidates])])
    n = len(mids)
    minima = [i for i in range(len(candidates))
              if (i % n == 0 or losses[i] <= losses[i - 1]) and (i % n == n - 1 or losses[i] <= losses[i + 1])]
    minima.sort(key=lambda i: losses[i])
    return [candidates[i] for i in minima[:count]]


def fit(target, start: LayeredParams, vary: Sequence[str] | None = None, *, starts: int = 3,
        steps_per_start: int = 40, progress: Callable[[int], None] | None = None,
        should_stop: Callable[[], bool] | None = None, try_start: bool = True,
        index_scan: bool = True) -> FitResult:
    """Parameters of ``start``'s modes whose closure form best matches ``target``.

    ``vary``: the free parameters (default: what the target shows, :func:`~.free.vary_for`); the
    others keep ``start``'s values.  A target of one thickness (``uniform_film``) is fitted by a film
    of one thickness, from the middle of ``start``'s range.  ``starts``: how many of the thickness
    scan's best orders are tried besides ``start`` (when the thickness is free), unless one already
    matches within :data:`GOOD_ENOUGH` (0: ``start`` alone, no scan; the scan itself is run only
    once ``start``'s own fit falls short); ``steps_per_start``: the optimiser's steps from each (each step evaluates
    the model once per free parameter for the slopes, and once more);
    ``try_start=False``: the scan's orders only, not ``start``'s own thickness; ``index_scan=False``:
    the scan keeps the start's layer indices (:func:`thickness_starts`).  ``progress(evaluations)``
    is called at each evaluation of the model; ``should_stop()`` returning True ends the fit with
    :class:`FitCancelled`.
    """
    t0 = time.perf_counter()
    uniform = getattr(target, "uniform_film", False)  # a film of one thickness: d_max is d_min
    if uniform:  # from the middle of the start's range
        middle = 0.5 * (start.d_min + start.d_max)
        start = start.replace(d_min=middle, d_max=middle)
    names = vary_for(target, start, vary)
    if start.layer_index == "ior" and {"r1_r", "r1_g", "r1_b"} & set(names):
        # The three indices are free: the fit gives them, not an IOR and a Dispersion (which
        # bind them to a Cauchy law); they start at the IOR and Dispersion's.
        start = start.replace(layer_index="channels")
    free = FreeParameters(names, start, uniform)
    objective = _Objective(target, free, progress, should_stop)
    lo, hi = free.bounds()
    thickness_free = {"d_min", "d_max"} & set(names)
    scan = thickness_free and starts > 0
    best, best_de, tried = None, np.inf, []

    def firsts():
        """The start, then the scan's orders: the scan is run only if the start does not match."""
        if try_start or not scan:
            yield start
        if scan:
            yield from thickness_starts(objective, start, starts, index_scan)

    for first in firsts():
        sol = least_squares(objective, free.vector(first, START_MARGIN), objective.jacobian, (lo, hi),
                            f_scale=LOSS_SCALE, max_nfev=steps_per_start)
        params = free.params(sol.x)
        de = objective.mean_delta_e(params)
        tried.append((first.d_min, first.d_max, de))
        if de < best_de:  # the start whose result looks closest, not the lowest robust cost
            best, best_de = params, de
        if de <= GOOD_ENOUGH:
            break
    de = objective.mean_delta_e(best)
    return FitResult(best, de, objective.evaluations, time.perf_counter() - t0, names, tried)
