"""Robust cylinder fits of many point sets at once: a limb's axis from the points of its surface.

Each set's residuals are the points' distances from the cylinder's surface, ``|(x - c) x d| - r``
for an axis through ``c`` along the unit ``d`` and a radius ``r``. Gauss-Newton with an analytic
Jacobian moves the axis in the two directions across it and turns it about two axes across it (four
degrees of freedom, plus the radius when it is free), with Huber weights; after each step the axis
point is re-centred along the axis on the points, which leaves the line unchanged. One fit on all
points is followed by two refits on the points near the surface (trimming), so points of a
neighbouring surface, once the axis has found the limb, no longer pull on it. All sets are fitted in
one batch of numpy operations.
"""

from __future__ import annotations

import warnings

import numpy as np

from fusion.arrays import unit


def _tangents(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.where((np.abs(d[..., 0]) < 0.9)[..., None], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
    e1 = unit(np.cross(d, helper))
    return e1, np.cross(d, e1)


def fit_cylinders(P: np.ndarray, mask: np.ndarray, c0: np.ndarray, d0: np.ndarray, radius: np.ndarray | None, *,
                  huber_m: float = 0.005, trim_m: float = 0.015, iterations: int = 8
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Robust cylinder fits of many point sets at once (module docstring).

    Parameters
    ----------
    P, mask : (B, N, 3) [m] points and (B, N) which are points.
    c0, d0 : (B, 3) a starting point of each axis [m] and its direction.
    radius : (B,) [m] fixed radii, or None to fit them.
    huber_m : scale of the Huber weights [m].
    trim_m : the refits keep the points within this distance of the surface [m].
    iterations : Gauss-Newton steps per fit (one fit on all points, two trimmed refits).

    Returns
    -------
    centres (B, 3) [m], unit directions (B, 3), radii (B,) [m], RMS residual of the kept points (B,) [m]
    and the kept points (B, N) bool.
    """
    c, d = c0.astype(float).copy(), unit(d0)
    free = radius is None
    v = P - c[:, None]
    rho = np.linalg.norm(v - np.einsum("bnc,bc->bn", v, d)[..., None] * d[:, None], axis=-1)
    if free:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # a set without points: its median is NaN
            r = np.nanmedian(np.where(mask, rho, np.nan), axis=1)
        r = np.where(np.isfinite(r), r, 0.05)
    else:
        r = radius.astype(float).copy()
    kept = mask.copy()
    for trim in (None, trim_m, trim_m):
        if trim is not None:
            kept = mask & (np.abs(rho - r[:, None]) < trim)
        for _ in range(iterations):
            e1, e2 = _tangents(d)
            v = P - c[:, None]
            along = np.einsum("bnc,bc->bn", v, d)
            q = v - along[..., None] * d[:, None]
            rho = np.linalg.norm(q, axis=-1)
            n = q / np.maximum(rho, 1e-9)[..., None]
            f = rho - r[:, None]
            ne1, ne2 = np.einsum("bnc,bc->bn", n, e1), np.einsum("bnc,bc->bn", n, e2)
            J = np.stack([-ne1, -ne2, -along * ne1, -along * ne2, -np.ones_like(f)], axis=-1)
            if not free:
                J = J[..., :4]
            w = kept * np.minimum(1.0, huber_m / np.maximum(np.abs(f), 1e-12))
            H = np.einsum("bn,bni,bnj->bij", w, J, J) + 1e-9 * np.eye(J.shape[-1])
            step = -np.linalg.solve(H, np.einsum("bn,bni,bn->bi", w, J, f)[..., None])[..., 0]
            c = c + step[:, :1] * e1 + step[:, 1:2] * e2
            d = unit(d + step[:, 2:3] * e1 + step[:, 3:4] * e2)
            if free:
                r = r + step[:, 4]
            count = np.maximum(kept.sum(axis=1), 1)
            c = c + (np.einsum("bn,bnc,bc->b", kept, P - c[:, None], d) / count)[:, None] * d  # centre along the axis
        v = P - c[:, None]
        rho = np.linalg.norm(v - np.einsum("bnc,bc->bn", v, d)[..., None] * d[:, None], axis=-1)
    rms = np.sqrt((kept * (rho - r[:, None]) ** 2).sum(axis=1) / np.maximum(kept.sum(axis=1), 1))
    return c, d, r, rms, kept
