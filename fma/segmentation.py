"""Repetition segmentation from the moving hand's height and speed.

A repetition is the hand rising above a rest band and coming back. The smoothed hand height is
thresholded with hysteresis (enter above ``rest + enter_fraction * range``, leave below
``rest + exit_fraction * range``) and each detected excursion is widened to where the smoothed 3-D
hand speed drops below ``speed_fraction`` of that excursion's peak speed (but never below twice the
median speed at rest, the noise floor): the movement's onset and stop, not the threshold crossings.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from fma.measurements import Side, side_landmarks
from fusion.errors import BadInputError
from fusion.topology import Topology


@dataclass(frozen=True)
class RepetitionSegment:
    """One repetition: frame indices (inclusive) and times in seconds.

    Attributes
    ----------
    start_index, peak_index, end_index : int
        Movement onset, highest hand position and movement stop; ``start <= peak <= end``.
    t_start, t_end : float
        Times of the onset and stop frames, seconds.
    """

    start_index: int
    peak_index: int
    end_index: int
    t_start: float
    t_end: float

    def __post_init__(self) -> None:
        if not 0 <= self.start_index <= self.peak_index <= self.end_index:
            raise BadInputError(
                f"segment needs 0 <= start <= peak <= end, got {self.start_index}, {self.peak_index}, {self.end_index}"
            )
        if not self.t_end >= self.t_start:
            raise BadInputError(f"segment needs t_end >= t_start, got {self.t_start}, {self.t_end}")

    @property
    def duration(self) -> float:
        """Length of the repetition in seconds."""
        return self.t_end - self.t_start

    @property
    def frames(self) -> slice:
        """Slice selecting the repetition's frames."""
        return slice(self.start_index, self.end_index + 1)


def _fill_gaps(times: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Linear interpolation over NaN frames of (T, 3) ``x``; constant extension at the ends."""
    ok = np.isfinite(x).all(axis=1)
    return np.stack([np.interp(times, times[ok], x[ok, k]) for k in range(3)], axis=1)


def segment_repetitions(
    times: np.ndarray,
    positions: np.ndarray,
    topology: Topology,
    side: Side | str,
    *,
    smoothing_s: float = 0.1,
    enter_fraction: float = 0.3,
    exit_fraction: float = 0.15,
    speed_fraction: float = 0.03,
    min_amplitude_m: float = 0.1,
    min_duration_s: float = 0.3,
) -> list[RepetitionSegment]:
    """Find the start, peak and end of every repetition of the arm on ``side``.

    Parameters
    ----------
    times : np.ndarray
        (T,) strictly increasing seconds.
    positions : np.ndarray
        (T, J, 3) world joint positions, metres, z up; NaN where absent. The hand is used, the
        wrist where the hand is missing; frames missing both are interpolated linearly in time.
    topology : Topology
        Joint set of ``positions``.
    side : Side or {"left", "right"}
        Moving arm.
    smoothing_s : float
        Standard deviation of the Gaussian smoothing of the hand trajectory, seconds.
    enter_fraction, exit_fraction : float
        Hysteresis thresholds as fractions of the hand's height range above the rest height
        (5th percentile); ``0 < exit_fraction < enter_fraction < 1``.
    speed_fraction : float
        The onset / stop is where the smoothed 3-D hand speed falls below this fraction of the
        repetition's peak speed, or twice the median rest speed if that is larger (searched outwards
        from the threshold crossings, never into the neighbouring repetitions).
    min_amplitude_m : float
        No repetitions are reported when the hand's height range (5th to 95th percentile) is
        smaller than this, metres.
    min_duration_s : float
        Excursions shorter than this (seconds, between threshold crossings) are discarded as jitter.

    Returns
    -------
    list of RepetitionSegment
        In time order, non-overlapping.
    """
    t = np.asarray(times, dtype=float)
    pos = np.asarray(positions, dtype=float)
    if t.ndim != 1 or pos.shape != (t.size, topology.n_joints, 3):
        raise BadInputError(
            f"times must be (T,) and positions (T, {topology.n_joints}, 3); got {t.shape} and {pos.shape}"
        )
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise BadInputError("times must be finite and strictly increasing")
    if not 0 < exit_fraction < enter_fraction < 1:
        raise BadInputError(f"need 0 < exit_fraction < enter_fraction < 1, got {exit_fraction}, {enter_fraction}")
    if smoothing_s < 0 or not 0 < speed_fraction < 1:
        raise BadInputError("smoothing_s must be >= 0 and speed_fraction in (0, 1)")
    lms = side_landmarks(side)
    hand = pos[:, topology.index(lms["hand"])]
    wrist = pos[:, topology.index(lms["wrist"])]
    hand = np.where(np.isfinite(hand).all(axis=1, keepdims=True), hand, wrist)
    if np.isfinite(hand).all(axis=1).sum() < 3:
        return []
    hand = _fill_gaps(t, hand)
    sigma = smoothing_s / np.median(np.diff(t))
    if sigma > 0:
        hand = gaussian_filter1d(hand, sigma, axis=0, mode="nearest")
    z = hand[:, 2]
    speed = np.linalg.norm(np.gradient(hand, t, axis=0), axis=1)

    rest, top = np.percentile(z, [5, 95])
    if top - rest < min_amplitude_m:
        return []
    enter, leave = rest + enter_fraction * (top - rest), rest + exit_fraction * (top - rest)
    excursions = []
    i, n = 0, t.size
    while i < n:
        above = np.flatnonzero(z[i:] > enter)
        if above.size == 0:
            break
        up = i + int(above[0])
        below = np.flatnonzero(z[up:] < leave)
        down = up + int(below[0]) if below.size else n - 1
        if t[down] - t[up] >= min_duration_s:
            excursions.append((up, down))
        i = down + 1
    rest_speed = np.median(speed[z < leave])
    segments: list[RepetitionSegment] = []
    for k, (up, down) in enumerate(excursions):
        lo = segments[-1].end_index if segments else 0
        hi = excursions[k + 1][0] if k + 1 < len(excursions) else n - 1
        threshold = max(speed_fraction * speed[up:down + 1].max(), 2.0 * rest_speed)
        start = _last_below(speed, lo, up, threshold)
        end = _first_below(speed, down, hi, threshold)
        peak = start + int(np.argmax(z[start:end + 1]))
        segments.append(RepetitionSegment(start, peak, end, float(t[start]), float(t[end])))
    return segments


def _last_below(speed: np.ndarray, lo: int, hi: int, threshold: float) -> int:
    """Last index in [lo, hi] where ``speed < threshold`` (``lo`` if none)."""
    idx = np.flatnonzero(speed[lo:hi + 1] < threshold)
    return lo + int(idx[-1]) if idx.size else lo


def _first_below(speed: np.ndarray, lo: int, hi: int, threshold: float) -> int:
    """First index in [lo, hi] where ``speed < threshold`` (``hi`` if none)."""
    idx = np.flatnonzero(speed[lo:hi + 1] < threshold)
    return lo + int(idx[0]) if idx.size else hi
