"""A small bounded nonlinear least-squares solver for many tiny problems solved one after another.

:func:`bounded_least_squares` is Levenberg-Marquardt within box bounds, for problems of tens of
unknowns warm-started next to their solution (a retargeted frame starts from the previous frame's
fit, :mod:`sim.retarget`). On such problems :func:`scipy.optimize.least_squares` spends most of its
time in per-call work (the trust region's scaling, an SVD per step); the fit of a frame here costs
little more than its residual and Jacobian evaluations.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

FTOL, XTOL, TAU = 1e-3, 1e-4, 1e-3
"""Relative fall of the cost and relative step below which the fit stops, and the starting damping
relative to the largest diagonal entry of the normal matrix."""


@dataclass
class Solution:
    """The unknowns found, the residual evaluations spent, and 1 if the fit stopped on its tolerances
    (0: it ran out of evaluations)."""

    x: np.ndarray
    nfev: int
    status: int


def bounded_least_squares(residuals: Callable[[np.ndarray], np.ndarray], jacobian: Callable[[np.ndarray], np.ndarray],
                          x0: np.ndarray, lower: np.ndarray, upper: np.ndarray, max_nfev: int) -> Solution:
    """Minimise ``|residuals(x)|^2`` for ``lower <= x <= upper`` from ``x0``.

    Levenberg-Marquardt with Marquardt's scaling (the damping multiplies the normal matrix's
    diagonal) and Nielsen's update of the damping from the gain ratio, actual over predicted fall of
    the cost (Madsen, Nielsen & Tingleff, *Methods for non-linear least squares problems*, 2nd ed.,
    DTU 2004, section 3.2). A step is clipped to the bounds, and an unknown at a bound that the
    gradient pushes further out is held there. Stops after ``max_nfev`` residual evaluations, or when
    the cost falls by less than :data:`FTOL` of itself or the step is shorter than :data:`XTOL` times
    ``|x|``.

    Parameters
    ----------
    residuals : callable
        (N,) -> (M,) residuals.
    jacobian : callable
        (N,) -> (M, N) their Jacobian.
    x0 : (N,) start, clipped to the bounds.
    lower, upper : (N,) bounds (infinite: none).
    max_nfev : int
        Most residual evaluations.

    Returns
    -------
    Solution
    """
    x = np.clip(x0, lower, upper)
    r = residuals(x)
    J = jacobian(x)
    H = J.T @ J
    cost, nfev, status = r @ r, 1, 0
    damping, grow = TAU * float(np.max(np.diag(H))), 2.0
    while nfev < max_nfev:
        g = J.T @ r
        free = ~(((x <= lower) & (g > 0)) | ((x >= upper) & (g < 0)))
        Hf = H[np.ix_(free, free)]
        step = np.zeros_like(x)
        step[free] = -np.linalg.solve(Hf + damping * np.diag(np.maximum(np.diag(Hf), 1e-12)), g[free])
        trial = np.clip(x + step, lower, upper)
        r_trial = residuals(trial)
        nfev += 1
        cost_trial = r_trial @ r_trial
        if not cost_trial < cost:
            damping, grow = damping * grow, grow * 2.0
            continue
        dx, fall = trial - x, cost - cost_trial
        predicted = -(2.0 * g @ dx + dx @ H @ dx)
        gain = fall / predicted if predicted > 0 else -1.0  # a model that saw no fall is not trusted
        x, r, cost = trial, r_trial, cost_trial
        damping, grow = damping * max(1.0 / 3.0, 1.0 - (2.0 * gain - 1.0) ** 3), 2.0
        if fall < FTOL * cost or np.linalg.norm(dx) < XTOL * (XTOL + np.linalg.norm(x)):
            status = 1
            break
        if nfev < max_nfev:
            J = jacobian(x)
            H = J.T @ J
    return Solution(x, nfev, status)
