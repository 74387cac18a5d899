"""Weighted least-squares rigid fit of corresponding point sets (Kabsch), vectorised over batches.

Both functions find the proper rigid transform ``T_a_b`` minimising
``sum_i w_i |apply(T_a_b, p_b[i]) - p_a[i]|^2``. They accept any number of leading batch axes, so
thousands of RANSAC hypotheses are solved in one call (one batched SVD of ``3 x 3`` matrices).

A problem is *degenerate* when fewer than three points carry positive weight, a weighted point is
not finite, or the weighted points are (numerically) collinear or coincident: the second singular
value of the weighted cross-covariance is at most ``RANK_RTOL`` times the first (for exact data,
points within about ``sqrt(RANK_RTOL)`` relative spread of a line). Then the rotation about the line
is undetermined. :func:`kabsch` raises on a degenerate problem; :func:`kabsch_batch` reports it in a
validity mask instead.
"""

from __future__ import annotations

import numpy as np

from fusion.errors import BadInputError

RANK_RTOL = 1e-9
"""Relative singular-value threshold below which the points count as collinear."""

_MIN_SPREAD_M2 = 1e-20
"""Largest singular value [m^2] below which the points count as coincident."""


def kabsch_batch(
    p_b: np.ndarray, p_a: np.ndarray, weights: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Fit rigid transforms to many point-set pairs at once, flagging degenerate ones.

    Parameters
    ----------
    p_b : np.ndarray
        (..., N, 3) points [m] in frame b.
    p_a : np.ndarray
        (..., N, 3) the corresponding points [m] in frame a.
    weights : np.ndarray or None
        (..., N) or (N,) non-negative weights; None weighs all points equally. A point with zero
        weight is ignored and may be NaN.

    Returns
    -------
    T_a_b : np.ndarray
        (..., 4, 4) proper rigid transforms (det R = +1, also when the best orthogonal fit is a
        reflection); the identity where ``ok`` is False.
    ok : np.ndarray
        (...,) bool, False where the problem is degenerate (see the module docstring).

    Raises
    ------
    BadInputError
        Mismatched or wrong shapes, or negative or non-finite weights.
    """
    p_b, p_a, w = _checked(p_b, p_a, weights)
    finite = np.isfinite(p_b).all(axis=-1) & np.isfinite(p_a).all(axis=-1)
    used = w > 0
    ok = ~np.any(used & ~finite, axis=-1) & (used.sum(axis=-1) >= 3)
    w = np.where(finite, w, 0.0)
    p_b = np.where(finite[..., None], p_b, 0.0)
    p_a = np.where(finite[..., None], p_a, 0.0)

    total = w.sum(axis=-1, keepdims=True)
    w = w / np.where(total > 0, total, 1.0)
    c_b = np.einsum("...n,...ni->...i", w, p_b)
    c_a = np.einsum("...n,...ni->...i", w, p_a)
    H = np.einsum("...n,...ni,...nj->...ij", w, p_b - c_b[..., None, :], p_a - c_a[..., None, :])
    U, S, Vt = np.linalg.svd(H)
    ok &= (S[..., 0] > _MIN_SPREAD_M2) & (S[..., 1] > RANK_RTOL * S[..., 0])

    V = np.swapaxes(Vt, -1, -2)
    Ut = np.swapaxes(U, -1, -2)
    D = np.ones(S.shape)
    D[..., 2] = np.where(np.linalg.det(V @ Ut) < 0, -1.0, 1.0)
    R = (V * D[..., None, :]) @ Ut
    t = c_a - np.einsum("...ij,...j->...i", R, c_b)

    T = np.zeros(ok.shape + (4, 4))
    T[..., :3, :3] = np.where(ok[..., None, None], R, np.eye(3))
    T[..., :3, 3] = np.where(ok[..., None], t, 0.0)
    T[..., 3, 3] = 1.0
    return T, ok


def kabsch(p_b: np.ndarray, p_a: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """Fit the rigid transform ``T_a_b`` mapping points of frame b onto their partners in frame a.

    Parameters
    ----------
    p_b : np.ndarray
        (N, 3) or (..., N, 3) points [m] in frame b, N >= 3.
    p_a : np.ndarray
        Same shape: the corresponding points [m] in frame a.
    weights : np.ndarray or None
        (N,) or (..., N) non-negative weights; None weighs all points equally. Points with zero
        weight are ignored and may be NaN.

    Returns
    -------
    np.ndarray
        (4, 4) or (..., 4, 4) proper rigid transforms ``T_a_b``.

    Raises
    ------
    BadInputError
        Bad shapes or weights, or any problem of the batch is degenerate: fewer than three weighted
        points, NaN in a weighted point, or collinear / coincident points.
    """
    T_a_b, ok = kabsch_batch(p_b, p_a, weights)
    if not np.all(ok):
        where = "" if ok.ndim == 0 else f" (batch item {tuple(int(i) for i in np.argwhere(~ok)[0])})"
        raise BadInputError(
            f"kabsch: degenerate point sets{where}: need at least 3 finite, weighted, non-collinear "
            "point pairs"
        )
    return T_a_b


def _checked(
    p_b: np.ndarray, p_a: np.ndarray, weights: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    p_b = np.asarray(p_b, dtype=float)
    p_a = np.asarray(p_a, dtype=float)
    if p_b.ndim < 2 or p_b.shape[-1] != 3 or p_b.shape != p_a.shape:
        raise BadInputError(f"kabsch: p_b and p_a must both have shape (..., N, 3), got {p_b.shape} and {p_a.shape}")
    if weights is None:
        return p_b, p_a, np.ones(p_b.shape[:-1])
    w = np.asarray(weights, dtype=float)
    try:
        w = np.broadcast_to(w, p_b.shape[:-1])
    except ValueError:
        raise BadInputError(f"kabsch: weights of shape {w.shape} do not match points {p_b.shape}") from None
    if not np.all(np.isfinite(w)) or np.any(w < 0):
        raise BadInputError("kabsch: weights must be finite and non-negative")
    return p_b, p_a, w
