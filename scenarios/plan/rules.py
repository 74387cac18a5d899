"""The planner's statistics and sanity rules: bootstrap intervals over seeds, the degenerate-layout
rule, and the check that the budget separates the top layouts.

Intervals are percentile bootstraps of the mean over the sessions (seeds): every resampled mean is a
mean of measured values, so an interval never leaves the range of the data (no negative bound for a
non-negative quantity, unlike a t-interval on two or four seeds).

A layout is *degenerate* when two of its cameras stand closer than :data:`MIN_SEPARATION_M` or
are nearly in line as seen from the patient (directions from the patient's centre at aim height
less than :data:`MIN_VIEW_ANGLE_DEG` apart): such a pair sees the same side of the body, shares its
occlusions and adds little to the fusion, while a few noisy sessions can make it look best.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from fusion.errors import BadInputError

MIN_SEPARATION_M = 0.75
"""Two cameras closer than this [m] count as one viewpoint: at 2-3 m from the patient, 0.75 m is
about 15-20 deg of parallax, below what separates the views of one arm from those of the trunk."""

MIN_VIEW_ANGLE_DEG = 20.0
"""Two cameras whose directions from the patient are closer than this [deg] see the same side of the
body (the paper's pairs are 90 deg apart, a ring of six 60 deg)."""

BOOTSTRAP_RESAMPLES = 2000
"""Resamples per bootstrap interval."""


def bootstrap_interval(values: Sequence[float], *, rng: np.random.Generator, level: float = 0.9
                       ) -> tuple[float, float, float]:
    """Mean and percentile-bootstrap ``level`` interval of the mean of ``values``.

    Parameters
    ----------
    values : (S,) one value per session (NaN entries are ignored), any unit.
    rng : draws the resamples.
    level : two-sided coverage in (0, 1).

    Returns
    -------
    tuple of float
        (mean, low, high) in the unit of ``values``; all NaN without finite values, low = high = mean
        with a single one. ``min(values) <= low <= mean <= high <= max(values)``.
    """
    if not 0 < level < 1:
        raise BadInputError(f"level must be in (0, 1), got {level}")
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    if v.size == 0:
        return (float("nan"),) * 3
    mean = float(v.mean())
    if v.size == 1:
        return mean, mean, mean
    means = v[rng.integers(0, v.size, size=(BOOTSTRAP_RESAMPLES, v.size))].mean(axis=1)
    lo, hi = np.quantile(means, [0.5 - level / 2, 0.5 + level / 2])
    return mean, float(min(lo, mean)), float(max(hi, mean))


def degenerate_reason(centre_m: np.ndarray, places_m: np.ndarray) -> str | None:
    """Why a layout is degenerate (see the module docstring), or None when it is not.

    Parameters
    ----------
    centre_m : (3,) the patient's centre at aim height, room frame [m].
    places_m : (C, 3) camera centres, room frame [m].

    Returns
    -------
    str or None
        The first offending pair (1-based camera numbers), its distance [m] or angle [deg] and the threshold.
    """
    p = np.asarray(places_m, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or np.asarray(centre_m).shape != (3,):
        raise BadInputError(f"places_m must be (C, 3) and centre_m (3,), got {p.shape} and {np.shape(centre_m)}")
    d = p - np.asarray(centre_m, dtype=float)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    for i in range(len(p)):
        for j in range(i + 1, len(p)):
            gap = float(np.linalg.norm(p[i] - p[j]))
            if gap < MIN_SEPARATION_M:
                return f"cameras {i + 1} and {j + 1} are {gap:.2f} m apart (< {MIN_SEPARATION_M} m)"
            angle = float(np.degrees(np.arccos(np.clip(d[i] @ d[j], -1.0, 1.0))))
            if angle < MIN_VIEW_ANGLE_DEG:
                return (f"cameras {i + 1} and {j + 1} are {angle:.0f} deg apart as seen from the patient "
                        f"(< {MIN_VIEW_ANGLE_DEG:g} deg)")
    return None


def overlap_warning(names: Sequence[str], intervals: Sequence[tuple[float, float, float]]) -> str | None:
    """A warning when the best layout's interval overlaps the runner-up's (lower scores are better).

    Parameters
    ----------
    names : (L,) layout names.
    intervals : (L,) (mean, low, high) of each layout's score.

    Returns
    -------
    str or None
        The warning (naming both layouts and their intervals, and what to do), None when the best is
        separated or fewer than two layouts have a finite score.
    """
    rows = sorted((iv, n) for n, iv in zip(names, intervals) if np.isfinite(iv[0]))
    if len(rows) < 2:
        return None
    (best, a), (second, b) = rows[0], rows[1]
    if best[2] < second[1]:
        return None
    return (f"the budget cannot separate the top layouts: {a} scores {best[0]:.1f} [{best[1]:.1f}, {best[2]:.1f}] "
            f"and {b} {second[0]:.1f} [{second[1]:.1f}, {second[2]:.1f}] (90 % intervals overlap); raise "
            "--final-seeds (and --trials, --seeds) before choosing between them")
