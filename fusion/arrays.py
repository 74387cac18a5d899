"""Small numeric helpers shared by every stage: frozen arrays, time axes, unit vectors, NaN-aware means."""

from __future__ import annotations

import numpy as np

from fusion.errors import BadInputError


def frozen(arr: np.ndarray) -> np.ndarray:
    """``arr`` made read-only (in place) and returned, for the arrays of frozen value objects."""
    arr.setflags(write=False)
    return arr


def check_times(times: np.ndarray) -> np.ndarray:
    """(T,) float64 copy of ``times`` [s]; BadInputError unless 1-D, finite and strictly increasing."""
    times = np.array(times, dtype=np.float64)
    if times.ndim != 1:
        raise BadInputError(f"times must be 1-D, got shape {times.shape}")
    if not np.all(np.isfinite(times)):
        raise BadInputError("times contain NaN or infinite values")
    if np.any(np.diff(times) <= 0):
        raise BadInputError("times must be strictly increasing")
    return times


def unit(v: np.ndarray) -> np.ndarray:
    """(..., 3) vectors scaled to unit length along the last axis; NaN where a vector is zero or NaN."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return v / np.linalg.norm(v, axis=-1, keepdims=True)


def nanmean(x: np.ndarray, axis: int, *, empty: float = np.nan) -> np.ndarray:
    """Mean of the finite entries of ``x`` along ``axis``; ``empty`` where there are none (no warning)."""
    valid = np.isfinite(x)
    n = valid.sum(axis=axis)
    return np.where(n > 0, np.where(valid, x, 0.0).sum(axis=axis) / np.maximum(n, 1), empty)


def nanmedian(x: np.ndarray, axis: int = 0) -> np.ndarray:
    """Median of the non-NaN entries of ``x`` along ``axis``; NaN where there are none (no warning).

    Equal to ``np.nanmedian`` (the mean of the two middle values for an even count) and much faster
    on small arrays.
    """
    s = np.sort(np.moveaxis(np.asarray(x, dtype=np.float64), axis, 0), axis=0)  # NaN sorts last
    if s.shape[0] == 0:
        return np.full(s.shape[1:], np.nan)
    n = (~np.isnan(s)).sum(axis=0)
    lo = np.take_along_axis(s, np.maximum((n - 1) // 2, 0)[None], axis=0)[0]
    hi = np.take_along_axis(s, np.minimum(n // 2, s.shape[0] - 1)[None], axis=0)[0]
    return np.where(n > 0, 0.5 * (lo + hi), np.nan)


def segment_distances(x: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance (N, K) [m] of points ``x`` (N, 3) from the segments ``a -> b`` (K, 3) and the clamped
    position along each (N, K) (0 at ``a``, 1 at ``b``); matrix products, no (N, K, 3) array."""
    d = b - a
    dd = np.einsum("kc,kc->k", d, d)
    xd = x @ d.T - np.einsum("kc,kc->k", a, d)  # (x - a) . d
    s = np.clip(xd / dd, 0.0, 1.0)
    xa2 = np.einsum("nc,nc->n", x, x)[:, None] - 2.0 * x @ a.T + np.einsum("kc,kc->k", a, a)  # |x - a|^2
    return np.sqrt(np.maximum(xa2 - 2.0 * s * xd + s**2 * dd, 0.0)), s
