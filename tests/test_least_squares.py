"""The fit's numpy solver (fit/least_squares.py) against SciPy's ``least_squares`` on problems
with known answers: a curve with outliers (the soft-L1 loss), a minimum on a bound, a curved
valley, a residual that does not depend on one variable, and the evaluation budget."""
import numpy as np
import pytest
from scipy.optimize import least_squares as scipy_least_squares

from layered_brdf_addon.fit.least_squares import least_squares, soft_l1_cost


def numeric_jacobian(fun):
    def jac(x):
        f0 = fun(x)
        h = 1e-7 * np.maximum(1.0, np.abs(x))
        return np.stack([(fun(x + np.eye(x.size)[i] * h[i]) - f0) / h[i] for i in range(x.size)], axis=-1)
    return jac


def both(fun, x0, bounds, f_scale=1.0, max_nfev=200):
    ours = least_squares(fun, x0, numeric_jacobian(fun), bounds, f_scale=f_scale, max_nfev=max_nfev)
    theirs = scipy_least_squares(fun, x0, jac=numeric_jacobian(fun), bounds=bounds, loss="soft_l1",
                                 f_scale=f_scale, max_nfev=max_nfev)
    return ours, theirs


def test_a_decay_with_outliers_is_fitted_as_scipy_fits_it():
    t = np.linspace(0.0, 4.0, 60)
    y = 3.0 * np.exp(-1.3 * t) + 0.2
    y[::12] += 2.5  # outliers the loss must not follow
    fun = lambda x: x[0] * np.exp(-x[1] * t) + x[2] - y  # noqa: E731
    ours, theirs = both(fun, np.array([1.0, 0.5, 0.0]), ([0.0, 0.0, -1.0], [10.0, 5.0, 1.0]), f_scale=0.1)
    assert np.allclose(ours.x, theirs.x, atol=1e-3)
    assert np.allclose(ours.x, [3.0, 1.3, 0.2], atol=0.05)  # the outliers pull soft-L1 a little
    assert soft_l1_cost(fun(ours.x), 0.1) <= theirs.cost * (1 + 1e-6)


def test_a_minimum_beyond_a_bound_stops_on_the_bound():
    fun = lambda x: np.array([x[0] - 3.0, 2.0 * (x[1] + 1.0), x[0] * x[1] * 0.1])  # noqa: E731
    ours, theirs = both(fun, np.array([0.5, 0.5]), ([0.0, 0.0], [2.0, 1.0]))
    assert ours.x[0] == pytest.approx(2.0) and ours.x[1] == pytest.approx(0.0, abs=1e-9)
    assert np.allclose(ours.x, theirs.x, atol=1e-6)


def test_rosenbrock_s_valley():
    fun = lambda x: np.array([10.0 * (x[1] - x[0] ** 2), 1.0 - x[0]])  # noqa: E731
    ours, theirs = both(fun, np.array([-1.2, 1.0]), ([-2.0, -2.0], [2.0, 2.0]))
    assert np.allclose(ours.x, [1.0, 1.0], atol=1e-6) and np.allclose(theirs.x, [1.0, 1.0], atol=1e-6)


def test_a_variable_the_residuals_ignore_stays_where_it_started():
    fun = lambda x: np.array([x[0] - 0.25, 2.0 * (x[0] - 0.25)])  # noqa: E731
    sol = least_squares(fun, np.array([0.9, 0.4]), numeric_jacobian(fun), ([0.0, 0.0], [1.0, 1.0]))
    assert sol.x == pytest.approx([0.25, 0.4])
    assert sol.reason in ("ftol", "xtol", "gtol")


def test_the_budget_of_evaluations_is_kept_and_the_start_clipped_into_the_bounds():
    calls = []

    def fun(x):
        calls.append(x.copy())
        return np.array([10.0 * (x[1] - x[0] ** 2), 1.0 - x[0]])

    sol = least_squares(fun, np.array([-5.0, 3.0]), numeric_jacobian(fun), ([-2.0, -2.0], [2.0, 2.0]), max_nfev=5)
    assert sol.nfev == 5 and sol.reason == "max_nfev"
    assert np.all(np.abs(calls[0]) <= 2.0)
    assert np.all(np.isfinite(sol.x)) and np.all(np.abs(sol.x) <= 2.0)


def test_a_parameter_on_its_bound_gives_a_value_inside_its_range():
    from layered_brdf_addon.fit.free import FreeParameters, search_range
    from layered_brdf_addon.model.presets import preset

    names = ("e0", "e1", "d_min", "d_max")
    free = FreeParameters(names, preset("oil_slick"))
    lo, hi = free.bounds()
    for x in (lo, hi):
        p = free.params(x)
        for name in names:
            assert search_range(name)[0] <= getattr(p, name) <= search_range(name)[1]
