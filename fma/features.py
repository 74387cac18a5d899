"""Per-repetition features of the measurements, and the paper's data variants.

For each repetition: its time length, and for each measurement the min, max, mean and variance of
the values, the start-stop difference (last minus first value), and the min, max, average and
variance of the first (speed) and second (acceleration) time derivatives. Statistics ignore NaN samples; variances are population
variances (ddof 0). Data variants (section 4): raw (one sample per repetition), repetition average
(one per subject and side) and asymmetry ``|R - L| / |R + L|`` (one per subject, 0/0 := 0).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from fma.measurements import MEASUREMENT_NAMES, Side
from fma.segmentation import RepetitionSegment
from fusion.errors import BadInputError

STATISTICS: tuple[str, ...] = (
    "min", "max", "mean", "variance", "start-stop difference",
    "speed min", "speed max", "speed average", "speed variance",
    "acceleration min", "acceleration max", "acceleration average", "acceleration variance",
)
"""Per-measurement statistics, in the order :func:`repetition_features` writes them."""

TIME_LENGTH = "Time length"


class Derivative(enum.Enum):
    """How speed and acceleration are summarised: the signed derivative or its magnitude."""

    SIGNED = "signed"
    MAGNITUDE = "magnitude"


class DataVariant(enum.Enum):
    """The paper's data variants."""

    RAW = "raw"
    REPETITION_AVERAGE = "repetition_average"
    ASYMMETRY = "asymmetry"


def feature_names(measurement_names: tuple[str, ...] = MEASUREMENT_NAMES) -> tuple[str, ...]:
    """Names of the F = 1 + 13 M features (M measurements): ``"Time length"``, then ``"<measurement> <statistic>"``."""
    return (TIME_LENGTH,) + tuple(f"{m} {s}" for m in measurement_names for s in STATISTICS)


FEATURE_NAMES: tuple[str, ...] = feature_names()
"""Feature names for the 13 measurements of :data:`fma.measurements.MEASUREMENT_NAMES` (F = 170)."""


def _nan_stats(x: np.ndarray) -> np.ndarray:
    """(4, M) min, max, mean, population variance of (N, M) columns ignoring NaN (all NaN -> NaN)."""
    ok = np.isfinite(x)
    n = ok.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(ok, x, 0.0).sum(axis=0) / n
        var = np.where(ok, (x - mean) ** 2, 0.0).sum(axis=0) / n
    lo = np.where(ok, x, np.inf).min(axis=0, initial=np.inf)
    hi = np.where(ok, x, -np.inf).max(axis=0, initial=-np.inf)
    empty = n == 0
    return np.stack([np.where(empty, np.nan, lo), np.where(empty, np.nan, hi), mean, var])


def _first_last(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First and last finite value of each column of (N, M) ``x`` (NaN for an all-NaN column)."""
    ok = np.isfinite(x)
    cols = np.arange(x.shape[1])
    first = x[ok.argmax(axis=0), cols]
    last = x[x.shape[0] - 1 - ok[::-1].argmax(axis=0), cols]
    empty = ~ok.any(axis=0)
    return np.where(empty, np.nan, first), np.where(empty, np.nan, last)


def repetition_features(
    times: np.ndarray,
    measurements: np.ndarray,
    segment: RepetitionSegment,
    *,
    derivative: Derivative = Derivative.SIGNED,
) -> np.ndarray:
    """Features of one repetition.

    Parameters
    ----------
    times : np.ndarray
        (T,) strictly increasing seconds.
    measurements : np.ndarray
        (T, M) per-frame measurements (e.g. :func:`fma.measurements.compute_measurements`).
    segment : RepetitionSegment
        The repetition; needs at least 3 frames.
    derivative : Derivative
        ``SIGNED`` summarises d/dt and d2/dt2 as they are (min = fastest decrease); ``MAGNITUDE``
        their absolute values.

    Returns
    -------
    np.ndarray
        (1 + 13 M,) float64, named by :func:`feature_names`: time length in seconds, then per
        measurement the :data:`STATISTICS` in the measurement's unit, unit/s and unit/s^2.
        Derivatives are second-order finite differences (exact for quadratics); a derivative next
        to a NaN sample is NaN and ignored.
    """
    t = np.asarray(times, dtype=float)
    m = np.asarray(measurements, dtype=float)
    if t.ndim != 1 or m.ndim != 2 or m.shape[0] != t.size:
        raise BadInputError(f"times must be (T,) and measurements (T, M); got {t.shape} and {m.shape}")
    if segment.end_index >= t.size or segment.end_index - segment.start_index < 2:
        raise BadInputError(f"segment {segment} needs >= 3 frames inside the {t.size} given")
    ts, x = t[segment.frames], m[segment.frames]
    if np.any(np.diff(ts) <= 0):
        raise BadInputError("times must be strictly increasing")
    speed = np.gradient(x, ts, axis=0, edge_order=2)
    accel = np.gradient(speed, ts, axis=0, edge_order=2)
    if derivative is Derivative.MAGNITUDE:
        speed, accel = np.abs(speed), np.abs(accel)
    first, last = _first_last(x)
    per_measurement = np.concatenate([_nan_stats(x), (last - first)[None], _nan_stats(speed), _nan_stats(accel)])
    return np.concatenate([[ts[-1] - ts[0]], per_measurement.T.ravel()])


def segments_features(
    times: np.ndarray,
    measurements: np.ndarray,
    segments: list[RepetitionSegment],
    *,
    derivative: Derivative = Derivative.SIGNED,
) -> np.ndarray:
    """(R, F) features of R repetitions of one recording (see :func:`repetition_features`)."""
    f = [repetition_features(times, measurements, s, derivative=derivative) for s in segments]
    return np.array(f).reshape(len(segments), 1 + len(STATISTICS) * np.shape(measurements)[1])


@dataclass(frozen=True, eq=False)
class FeatureTable:
    """Samples x features with the subject, side and label of each sample.

    Attributes
    ----------
    X : np.ndarray
        (N, F) float64 features; NaN allowed.
    feature_names : tuple of str
        F names.
    subjects : np.ndarray
        (N,) str subject identifiers (the cross-validation groups).
    sides : np.ndarray
        (N,) str: ``"left"``, ``"right"``, or ``"both"`` for asymmetry samples.
    labels : np.ndarray
        (N,) int class labels (0/1 patient/healthy, or 0/1/2 item scores).
    """

    X: np.ndarray
    feature_names: tuple[str, ...]
    subjects: np.ndarray
    sides: np.ndarray
    labels: np.ndarray

    def __post_init__(self) -> None:
        X = np.array(self.X, dtype=float)
        subjects, sides = np.array(self.subjects, dtype=str), np.array(self.sides, dtype=str)
        labels = np.array(self.labels)
        if X.ndim != 2 or X.shape[1] != len(self.feature_names):
            raise BadInputError(f"X must be (N, {len(self.feature_names)}), got {X.shape}")
        if any(a.shape != (X.shape[0],) for a in (subjects, sides, labels)):
            raise BadInputError(f"subjects, sides and labels must all have shape ({X.shape[0]},)")
        if not np.all(np.isin(sides, [s.value for s in Side] + ["both"])):
            raise BadInputError(f"sides must be 'left', 'right' or 'both', got {sorted(set(sides))}")
        if labels.size and not np.issubdtype(labels.dtype, np.integer):
            raise BadInputError(f"labels must be integers, got dtype {labels.dtype}")
        if np.any(np.isinf(X)):
            raise BadInputError("X contains infinite values")
        object.__setattr__(self, "feature_names", tuple(self.feature_names))
        for name, arr in (("X", X), ("subjects", subjects), ("sides", sides), ("labels", labels.astype(int))):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def n_samples(self) -> int:
        """Number of samples N."""
        return self.X.shape[0]


def _group_mean(X: np.ndarray, inverse: np.ndarray, n_groups: int) -> np.ndarray:
    """(G, F) NaN-ignoring mean of the rows of (N, F) ``X`` per group index."""
    ok = np.isfinite(X)
    sums = np.zeros((n_groups, X.shape[1]))
    counts = np.zeros((n_groups, X.shape[1]))
    np.add.at(sums, inverse, np.where(ok, X, 0.0))
    np.add.at(counts, inverse, ok)
    with np.errstate(invalid="ignore", divide="ignore"):
        return sums / counts


def _group_labels(labels: np.ndarray, inverse: np.ndarray, n_groups: int, what: str) -> np.ndarray:
    out = np.full(n_groups, -1)
    out[inverse] = labels
    if np.any(out[inverse] != labels):
        raise BadInputError(f"labels differ within one {what}; give every sample of a {what} the same label")
    return out


def repetition_average(table: FeatureTable) -> FeatureTable:
    """One sample per (subject, side): the NaN-ignoring mean of its repetitions (and cameras)."""
    keys = np.char.add(np.char.add(table.subjects, "\x00"), table.sides)
    uniq, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    return FeatureTable(
        _group_mean(table.X, inverse, uniq.size), table.feature_names, table.subjects[first],
        table.sides[first], _group_labels(table.labels, inverse, uniq.size, "subject and side"),
    )


def asymmetry(table: FeatureTable) -> FeatureTable:
    """One sample per subject: ``|R - L| / |R + L|`` of the side averages, with 0/0 := 0.

    Every subject needs both sides and one label. Where ``R = -L != 0`` the ratio is infinite and
    reported as NaN.
    """
    avg = repetition_average(table)
    subjects, inverse = np.unique(avg.subjects, return_inverse=True)
    left, right = np.full((2, subjects.size, avg.X.shape[1]), np.nan)
    is_left = avg.sides == Side.LEFT.value
    is_right = avg.sides == Side.RIGHT.value
    left[inverse[is_left]] = avg.X[is_left]
    right[inverse[is_right]] = avg.X[is_right]
    missing = subjects[np.bincount(inverse[is_left], minlength=subjects.size)
                       * np.bincount(inverse[is_right], minlength=subjects.size) == 0]
    if missing.size:
        raise BadInputError(f"asymmetry needs both sides of every subject; one side missing for {list(missing)}")
    num, den = np.abs(right - left), np.abs(right + left)
    with np.errstate(invalid="ignore", divide="ignore"):
        X = np.where((num == 0) & (den == 0), 0.0, num / den)
    return FeatureTable(
        np.where(np.isinf(X), np.nan, X), avg.feature_names, subjects, np.full(subjects.size, "both"),
        _group_labels(avg.labels, inverse, subjects.size, "subject"),
    )


def apply_variant(table: FeatureTable, variant: DataVariant) -> FeatureTable:
    """The table of raw repetition samples turned into ``variant``."""
    return {DataVariant.RAW: lambda t: t, DataVariant.REPETITION_AVERAGE: repetition_average,
            DataVariant.ASYMMETRY: asymmetry}[variant](table)
