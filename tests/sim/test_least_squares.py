"""The bounded least-squares solver: minima inside and on the bounds, agreement with scipy, its budget."""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from sim.least_squares import bounded_least_squares


def _rosenbrock(x):
    return np.array([10 * (x[1] - x[0] ** 2), 1 - x[0]])


def _rosenbrock_jac(x):
    return np.array([[-20 * x[0], 10.0], [-1.0, 0.0]])


def test_finds_an_interior_minimum():
    fit = bounded_least_squares(_rosenbrock, _rosenbrock_jac, np.array([-1.2, 1.0]), np.full(2, -np.inf),
                                np.full(2, np.inf), max_nfev=200)
    assert fit.status == 1
    np.testing.assert_allclose(fit.x, [1.0, 1.0], atol=0.05)


def test_a_minimum_beyond_a_bound_stops_on_the_bound():
    fit = bounded_least_squares(_rosenbrock, _rosenbrock_jac, np.array([0.0, 0.0]), np.array([-2.0, -2.0]),
                                np.array([0.5, 2.0]), max_nfev=200)
    assert fit.x[0] == 0.5  # held on the bound, not past it
    ref = least_squares(_rosenbrock, [0.0, 0.0], jac=_rosenbrock_jac, bounds=([-2, -2], [0.5, 2]))
    np.testing.assert_allclose(fit.x, ref.x, atol=1e-3)


def test_agrees_with_scipy_on_a_small_curve_fit():
    rng = np.random.default_rng(3)
    t = np.linspace(0, 3, 40)
    y = 2.0 * np.exp(-1.3 * t) + 0.5 + rng.normal(0, 0.01, t.size)

    def residuals(p):
        return p[0] * np.exp(-p[1] * t) + p[2] - y

    def jacobian(p):
        e = np.exp(-p[1] * t)
        return np.column_stack([e, -p[0] * t * e, np.ones_like(t)])

    lo, hi = np.zeros(3), np.full(3, 5.0)
    fit = bounded_least_squares(residuals, jacobian, np.array([1.0, 1.0, 0.0]), lo, hi, max_nfev=100)
    ref = least_squares(residuals, [1.0, 1.0, 0.1], jac=jacobian, bounds=(lo, hi))
    np.testing.assert_allclose(fit.x, ref.x, atol=1e-3)
    assert np.all(fit.x >= lo) and np.all(fit.x <= hi)


def test_the_evaluation_budget_is_kept_and_reported():
    calls = []

    def residuals(x):
        calls.append(1)
        return _rosenbrock(x)

    fit = bounded_least_squares(residuals, _rosenbrock_jac, np.array([-1.2, 1.0]), np.full(2, -np.inf),
                                np.full(2, np.inf), max_nfev=3)
    assert len(calls) == fit.nfev == 3 and fit.status == 0
