"""Compensation measures and two-tailed Welch t-tests between groups (the paper's Tables 12-13)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

from fma.measurements import Side, side_landmarks
from fma.segmentation import RepetitionSegment
from fusion.errors import BadInputError
from fusion.topology import Landmark, Topology

COMPENSATION_NAMES: tuple[str, ...] = (
    "Trunk displacement range (m)",
    "Trunk tilt range (deg)",
    "Shoulder elevation range (m)",
)
"""Columns of :func:`compensation_measures`."""


def compensation_measures(
    positions: np.ndarray, topology: Topology, side: Side | str, segment: RepetitionSegment
) -> np.ndarray:
    """Trunk and shoulder-girdle compensation during one repetition.

    Parameters
    ----------
    positions : np.ndarray
        (T, J, 3) world joint positions, metres, z up; NaN where absent (ignored).
    topology : Topology
    side : Side or {"left", "right"}
        Moving arm (its shoulder is measured).
    segment : RepetitionSegment

    Returns
    -------
    np.ndarray
        (3,) named by :data:`COMPENSATION_NAMES`: the largest horizontal displacement of SpineShoulder
        from its position at the repetition's start (m); the range of the trunk's
        (SpineMid -> SpineShoulder) angle to the vertical (degrees); the range of the moving
        shoulder's height (m). NaN when the joints are never seen.
    """
    pos = np.asarray(positions, dtype=float)
    if pos.ndim != 3 or pos.shape[1:] != (topology.n_joints, 3) or segment.end_index >= pos.shape[0]:
        raise BadInputError(f"positions must be (T, {topology.n_joints}, 3) covering the segment, got {pos.shape}")
    p = pos[segment.frames]
    chest = p[:, topology.index(Landmark.SPINE_SHOULDER)]
    trunk = chest - p[:, topology.index(Landmark.SPINE_MID)]
    shoulder_z = p[:, topology.index(side_landmarks(side)["shoulder"]), 2]
    seen = np.flatnonzero(np.isfinite(chest).all(axis=1))
    with np.errstate(invalid="ignore"):
        tilt = np.degrees(np.arccos(np.clip(trunk[:, 2] / np.linalg.norm(trunk, axis=1), -1.0, 1.0)))
    shift = np.linalg.norm(chest[:, :2] - chest[seen[0], :2], axis=1) if seen.size else np.full(len(p), np.nan)
    return np.array([_nan_range(shift, from_zero=True), _nan_range(tilt), _nan_range(shoulder_z)])


def _nan_range(x: np.ndarray, *, from_zero: bool = False) -> float:
    x = x[np.isfinite(x)]
    if x.size == 0:
        return float("nan")
    return float(x.max() - (0.0 if from_zero else x.min()))


@dataclass(frozen=True)
class TTestResult:
    """Two-tailed Welch t-test of one measure between groups A and B.

    Attributes
    ----------
    name : str
    t, p : float
        Welch statistic (positive when A's mean is larger) and two-tailed p-value; NaN when a group
        has fewer than two values.
    mean_a, mean_b, std_a, std_b : float
        Group means and sample standard deviations (ddof 1), in the measure's unit.
    n_a, n_b : int
        Finite values per group.
    """

    name: str
    t: float
    p: float
    mean_a: float
    mean_b: float
    std_a: float
    std_b: float
    n_a: int
    n_b: int


def welch_t_tests(values: np.ndarray, in_a: np.ndarray, names: Sequence[str]) -> list[TTestResult]:
    """Welch t-tests of each column of (N, K) ``values`` between rows ``in_a`` and the rest.

    Parameters
    ----------
    values : np.ndarray
        (N, K) measures (e.g. compensation measures or features), NaN ignored per column.
    in_a : np.ndarray
        (N,) bool, True for group A (e.g. patients), False for group B.
    names : sequence of str
        K names.
    """
    v = np.asarray(values, dtype=float)
    a = np.asarray(in_a)
    if v.ndim != 2 or a.shape != (v.shape[0],) or a.dtype != bool or len(names) != v.shape[1]:
        raise BadInputError(f"values must be (N, {len(names)}) and in_a (N,) bool; got {v.shape}, {a.shape} {a.dtype}")
    out = []
    for k, name in enumerate(names):
        xa, xb = v[a, k][np.isfinite(v[a, k])], v[~a, k][np.isfinite(v[~a, k])]
        t = p = np.nan
        if xa.size >= 2 and xb.size >= 2:
            res = stats.ttest_ind(xa, xb, equal_var=False)
            t, p = float(res.statistic), float(res.pvalue)
        out.append(TTestResult(
            str(name), t, p,
            float(xa.mean()) if xa.size else np.nan, float(xb.mean()) if xb.size else np.nan,
            float(xa.std(ddof=1)) if xa.size > 1 else np.nan, float(xb.std(ddof=1)) if xb.size > 1 else np.nan,
            int(xa.size), int(xb.size),
        ))
    return out


def t_tests_markdown(results: Sequence[TTestResult], group_names: tuple[str, str] = ("patients", "healthy")) -> str:
    """A Markdown table of t-test results: measure, means +- std and n per group, t, p."""
    a, b = group_names
    lines = [f"| measure | {a} mean +- std (n) | {b} mean +- std (n) | t | p |", "| --- | --- | --- | --- | --- |"]
    lines += [
        f"| {r.name} | {r.mean_a:.4g} +- {r.std_a:.3g} ({r.n_a}) | {r.mean_b:.4g} +- {r.std_b:.3g} ({r.n_b}) "
        f"| {r.t:.3f} | {r.p:.3g} |"
        for r in results
    ]
    return "\n".join(lines) + "\n"


@dataclass(frozen=True)
class Interval:
    """Mean of repeated measurements with a two-sided Student-t confidence interval.

    Attributes
    ----------
    mean, low, high : float
        NaN when no value is finite; ``low == high == mean`` for a single value.
    n : int
        Number of finite values used.
    confidence : float
    """

    mean: float
    low: float
    high: float
    n: int
    confidence: float

    def __str__(self) -> str:
        if self.n == 0:
            return "n/a"
        return f"{self.mean:.3g} [{self.low:.3g}, {self.high:.3g}]"


def mean_interval(values: Sequence[float], confidence: float = 0.95) -> Interval:
    """Mean and t-interval of ``values`` (one per seed, say); NaN values are left out."""
    if not 0.0 < confidence < 1.0:
        raise BadInputError(f"confidence must be in (0, 1), got {confidence}")
    x = np.asarray(values, dtype=float).ravel()
    x = x[np.isfinite(x)]
    if x.size == 0:
        return Interval(float("nan"), float("nan"), float("nan"), 0, confidence)
    mean = float(x.mean())
    if x.size == 1:
        return Interval(mean, mean, mean, 1, confidence)
    half = float(stats.t.ppf(0.5 + confidence / 2, x.size - 1) * x.std(ddof=1) / np.sqrt(x.size))
    return Interval(mean, mean - half, mean + half, int(x.size), confidence)
