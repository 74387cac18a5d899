"""Moving-block bootstrap intervals of statistics over frames.

A statistic of per-frame rows (a median, a mean, a share) gets the 2.5 and 97.5 percentiles of its values
over resamples made of blocks of consecutive frames, so that the frames' correlation in time widens the
interval as it should.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from fusion.arrays import nanmean, nanmedian


@dataclass(frozen=True)
class Interval:
    """A statistic with its bootstrap interval (NaN when it could not be measured).

    Attributes
    ----------
    value : float
        The statistic on all the data.
    low, high : float
        2.5 and 97.5 percentiles of its bootstrap distribution.
    n : int
        Number of samples it was computed from.
    """

    value: float
    low: float
    high: float
    n: int

    def as_dict(self) -> dict[str, float]:
        """Plain-number form (for JSON and TOML)."""
        return {"value": self.value, "low": self.low, "high": self.high, "n": self.n}


_BATCH = 20  # bootstrap resamples evaluated at once: a batch holds 20 copies of the values


def bootstrap(per_frame: np.ndarray, statistic: Callable[[np.ndarray], np.ndarray], *, block: int, n_boot: int,
              rng: np.random.Generator) -> Interval:
    """A statistic of per-frame rows with its moving-block bootstrap interval.

    Parameters
    ----------
    per_frame : (T, ...) values, one row per frame (NaN where absent).
    statistic : maps a (B, T', ...) stack of B row sets to their (B,) statistics (:func:`median_of_each`).
    block : block length [frames].
    n_boot : number of resamples (0 gives a NaN interval).
    rng : source of the resamples.
    """
    values = np.asarray(per_frame, dtype=float)
    n = int(np.isfinite(values).sum())
    if values.shape[0] == 0 or n == 0:
        return Interval(np.nan, np.nan, np.nan, 0)
    value = float(statistic(values[None])[0])
    if n_boot == 0:
        return Interval(value, np.nan, np.nan, n)
    frames = values.shape[0]
    block = max(1, min(block, frames))
    starts = rng.integers(0, frames - block + 1, size=(n_boot, -(-frames // block)))
    rows = (starts[..., None] + np.arange(block)).reshape(n_boot, -1)[:, :frames]  # (n_boot, T) frame indices
    low, high = np.nanpercentile(np.concatenate([statistic(values[rows[k : k + _BATCH]])
                                                 for k in range(0, n_boot, _BATCH)]), [2.5, 97.5])
    return Interval(value, float(low), float(high), n)


def median_of_each(x: np.ndarray) -> np.ndarray:
    """(B,) median of the finite entries of each of the (B, ...) sets (NaN for an empty one)."""
    return nanmedian(x.reshape(len(x), -1), axis=1)


def mean_of_each(x: np.ndarray) -> np.ndarray:
    """(B,) mean of the finite entries of each of the (B, ...) sets (NaN for an empty one)."""
    return nanmean(x.reshape(len(x), -1), axis=1)
