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
