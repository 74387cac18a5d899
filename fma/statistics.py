"""Compensation measures, two-tailed Welch t-tests between groups (the paper's Tables 12-13) and their
person-level counterparts (person means, mixed model, Hedges' g), which do not count a person's
repetitions as independent samples."""

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


@dataclass(frozen=True)
class PersonTestResult:
    """One measure compared between groups A and B with the person as the unit of analysis.

    Attributes
    ----------
    name : str
    n_persons_a, n_persons_b : int
        Persons per group with at least one finite value.
    mean_a, mean_b : float
        Mean of the person means per group, in the measure's unit.
    t, p : float
        Welch t-test on the person means (one value per person); NaN below two persons per group.
    lmm_effect, lmm_p : float
        Group coefficient (A minus B, the measure's unit) of a linear mixed model ``value ~ group``
        with a random intercept per person, fitted on the repetitions (REML), and its Wald p-value;
        NaN when the fit is impossible, fails or does not converge.
    lmm_ok : bool
        True when the mixed model converged.
    lmm_note : str
        Why ``lmm_ok`` is False ("" when it is True).
    hedges_g, g_low, g_high : float
        Hedges' g of the person means (A minus B, in pooled standard deviations) and its 95 %
        percentile interval by bootstrap over persons within each group; NaN when undefined.
    """

    name: str
    n_persons_a: int
    n_persons_b: int
    mean_a: float
    mean_b: float
    t: float
    p: float
    lmm_effect: float
    lmm_p: float
    lmm_ok: bool
    lmm_note: str
    hedges_g: float
    g_low: float
    g_high: float


def person_means(values: np.ndarray, subjects: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Sorted persons (P,) and the (P, K) mean of each person's finite rows of (N, K) ``values``
    (NaN where a person has none)."""
    v = np.asarray(values, dtype=float)
    s = np.asarray(subjects).astype(str)
    if v.ndim != 2 or s.shape != (v.shape[0],):
        raise BadInputError(f"values must be (N, K) and subjects (N,); got {v.shape}, {s.shape}")
    persons, inverse = np.unique(s, return_inverse=True)
    finite = np.isfinite(v)
    sums = np.zeros((persons.size, v.shape[1]))
    counts = np.zeros((persons.size, v.shape[1]))
    np.add.at(sums, inverse, np.where(finite, v, 0.0))
    np.add.at(counts, inverse, finite.astype(float))
    with np.errstate(invalid="ignore", divide="ignore"):
        return persons, np.where(counts > 0, sums / np.maximum(counts, 1.0), np.nan)


def hedges_g(xa: np.ndarray, xb: np.ndarray) -> float:
    """Hedges' g (bias-corrected standardised mean difference, A minus B) of two samples; NaN when
    a group has fewer than two values or the pooled standard deviation is zero."""
    return float(_hedges_g_rows(np.asarray(xa, dtype=float)[None], np.asarray(xb, dtype=float)[None])[0])


def _hedges_g_rows(xa: np.ndarray, xb: np.ndarray) -> np.ndarray:
    """Hedges' g of each row pair of (B, na) and (B, nb) arrays."""
    na, nb = xa.shape[1], xb.shape[1]
    if na < 2 or nb < 2:
        return np.full(xa.shape[0], np.nan)
    pooled = np.sqrt(((na - 1) * xa.var(axis=1, ddof=1) + (nb - 1) * xb.var(axis=1, ddof=1)) / (na + nb - 2))
    with np.errstate(invalid="ignore", divide="ignore"):
        d = np.where(pooled > 0, (xa.mean(axis=1) - xb.mean(axis=1)) / pooled, np.nan)
    return d * (1.0 - 3.0 / (4.0 * (na + nb) - 9.0))


def _mixed_model(y: np.ndarray, a: np.ndarray, persons: np.ndarray) -> tuple[float, float, bool, str]:
    """Group coefficient, p-value, converged flag and note of ``y ~ a + (1 | person)``."""
    if np.unique(persons[a]).size < 2 or np.unique(persons[~a]).size < 2:
        return np.nan, np.nan, False, "fewer than two persons per group"
    import warnings

    import statsmodels.api as sm

    exog = np.column_stack([np.ones(y.size), a.astype(float)])
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # boundary and convergence warnings: judged below
            fit = sm.MixedLM(y, exog, groups=persons).fit(reml=True)
        effect, p = float(np.asarray(fit.fe_params)[1]), float(np.asarray(fit.pvalues)[1])
    except Exception as exc:  # noqa: BLE001 - any numerical failure becomes NaN, never a crash
        return np.nan, np.nan, False, f"fit failed: {type(exc).__name__}"
    if not fit.converged:
        return np.nan, np.nan, False, "did not converge"
    if not (np.isfinite(effect) and np.isfinite(p)):
        return np.nan, np.nan, False, "non-finite estimate"
    return effect, p, True, ""


def person_level_tests(values: np.ndarray, in_a: np.ndarray, subjects: np.ndarray, names: Sequence[str], *,
                       n_boot: int = 2000, seed: int = 0) -> list[PersonTestResult]:
    """Group comparisons of each column of (N, K) repetition ``values`` with the person as the unit.

    Parameters
    ----------
    values : np.ndarray
        (N, K) measures, one row per repetition; NaN ignored per column.
    in_a : np.ndarray
        (N,) bool, True for group A; constant within a person.
    subjects : np.ndarray
        (N,) person of each row.
    names : sequence of str
        K names.
    n_boot : int
        Bootstrap resamples of the persons for the Hedges' g interval.
    seed : int
        Seed of the bootstrap (results are reproducible).

    Raises
    ------
    BadInputError
        Mismatched shapes, ``in_a`` not bool, or a person in both groups.
    """
    v = np.asarray(values, dtype=float)
    a = np.asarray(in_a)
    s = np.asarray(subjects).astype(str)
    if (v.ndim != 2 or a.shape != (v.shape[0],) or a.dtype != bool or s.shape != (v.shape[0],)
            or len(names) != v.shape[1]):
        raise BadInputError(f"values must be (N, {len(names)}), in_a (N,) bool and subjects (N,); "
                            f"got {v.shape}, {a.shape} {a.dtype}, {s.shape}")
    persons, means = person_means(v, s)
    group = np.array([a[s == p][0] for p in persons], dtype=bool)
    mixed = [p for p in persons if np.unique(a[s == p]).size > 1]
    if mixed:
        raise BadInputError(f"person(s) {', '.join(mixed)} are in both groups")
    rng = np.random.default_rng(seed)
    out = []
    for k, name in enumerate(names):
        ma, mb = means[group, k], means[~group, k]
        ma, mb = ma[np.isfinite(ma)], mb[np.isfinite(mb)]
        t = p = g_low = g_high = np.nan
        if ma.size >= 2 and mb.size >= 2:
            res = stats.ttest_ind(ma, mb, equal_var=False)
            t, p = float(res.statistic), float(res.pvalue)
            boot = _hedges_g_rows(ma[rng.integers(ma.size, size=(n_boot, ma.size))],
                                  mb[rng.integers(mb.size, size=(n_boot, mb.size))])
            if np.isfinite(boot).any():
                g_low, g_high = (float(q) for q in np.nanpercentile(boot, [2.5, 97.5]))
        rows = np.isfinite(v[:, k])
        effect, lmm_p, ok, note = _mixed_model(v[rows, k], a[rows], s[rows])
        out.append(PersonTestResult(
            str(name), int(ma.size), int(mb.size),
            float(ma.mean()) if ma.size else np.nan, float(mb.mean()) if mb.size else np.nan,
            t, p, effect, lmm_p, ok, note, hedges_g(ma, mb), g_low, g_high,
        ))
    return out


def person_tests_markdown(results: Sequence[PersonTestResult],
                          group_names: tuple[str, str] = ("patients", "healthy")) -> str:
    """A Markdown table of person-level results: person means and counts, Welch t and p on the person
    means, mixed-model group effect and p, Hedges' g with its bootstrap 95 % interval."""
    a, b = group_names
    lines = [(f"| measure | {a} mean (persons) | {b} mean (persons) | t | p | mixed-model effect | mixed-model p "
              "| Hedges' g [95 % CI] |"), "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in results:
        lmm = f"{r.lmm_effect:.4g} | {r.lmm_p:.3g}" if r.lmm_ok else f"n/a ({r.lmm_note}) | n/a"
        lines.append(f"| {r.name} | {r.mean_a:.4g} ({r.n_persons_a}) | {r.mean_b:.4g} ({r.n_persons_b}) "
                     f"| {r.t:.3f} | {r.p:.3g} | {lmm} | {r.hedges_g:.2f} [{r.g_low:.2f}, {r.g_high:.2f}] |")
    return "\n".join(lines) + "\n"
