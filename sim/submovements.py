"""Minimum-jerk profiles and sums of overlapping submovements: the time course of one joint-angle change.

A healthy movement is one minimum-jerk profile; a patient's is a sum of overlapping minimum-jerk
submovements (:func:`submovement_profile`) whose number, gaps and amplitudes come from the
:class:`sim.patient_motion.MovementProfile`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import brentq

from fusion.errors import BadInputError

_GAP = (0.1, 0.3)
"""Range of the pause between a submovement's velocity peak and the next one's onset, s."""


_SHRINK = (0.5, 0.8)
"""Range of the amplitude ratio of consecutive submovements."""


_CORRECTION = (0.2, 0.8)
"""Shortest and longest corrective submovement, s; the gaps shrink or grow to keep within."""


_PRIMARY_DOMINANCE = 0.7
"""Peak speed of the first correction relative to the primary submovement's, at most."""


def minimum_jerk(tau: ArrayLike) -> np.ndarray:
    """Minimum-jerk position profile s = 10 tau^3 - 15 tau^4 + 6 tau^5.

    Parameters
    ----------
    tau : array_like
        Normalised time; clipped to [0, 1].

    Returns
    -------
    numpy.ndarray
        Progress in [0, 1], same shape as ``tau``; zero velocity and acceleration at both ends.
    """
    tau = np.clip(np.asarray(tau, dtype=float), 0.0, 1.0)
    return tau**3 * (10.0 + tau * (-15.0 + 6.0 * tau))


def _peak_time(q: float) -> float:
    """Peak-velocity time of minimum_jerk(1 - (1 - tau)^q), as a fraction (closed form)."""
    m = 3.0 - 1.0 / q
    return 1.0 - (m / (m + 2.0)) ** (1.0 / q)


def _peak_speed(q: float) -> float:
    """Peak of d/dtau minimum_jerk(1 - (1 - tau)^q), in units of distance per duration."""
    m = 3.0 - 1.0 / q
    z = m / (m + 2.0)
    return 30.0 * q * (1.0 - z) ** 2 * z ** (2.0 + (q - 1.0) / q)


def _warp_exponent(fraction: float) -> float:
    """Exponent q >= 1 of the time warp that puts the velocity peak at min(fraction, 1 - fraction)."""
    early = min(fraction, 1.0 - fraction)
    if early >= 0.5:
        return 1.0
    return brentq(lambda q: _peak_time(q) - early, 1.0, 1e3)


@dataclass(frozen=True, eq=False)
class SubmovementProfile:
    """Progress 0 -> 1 as a sum of minimum-jerk submovements.

    The first submovement is time-warped so that its velocity peaks at ``first_peak_fraction``
    of its duration; the others are plain minimum-jerk.

    Attributes
    ----------
    onsets : numpy.ndarray
        (S,) start of each submovement, s, the first at 0.
    durations : numpy.ndarray
        (S,) duration of each submovement, s.
    amplitudes : numpy.ndarray
        (S,) share of the total progress, non-negative, summing to 1.
    first_peak_fraction : float
        Velocity peak of the first submovement as a fraction of its duration, in [0.05, 0.95].
    """

    onsets: np.ndarray
    durations: np.ndarray
    amplitudes: np.ndarray
    first_peak_fraction: float

    def __post_init__(self) -> None:
        arrays = [np.array(a, dtype=float) for a in (self.onsets, self.durations, self.amplitudes)]
        onsets, durations, amplitudes = arrays
        if onsets.ndim != 1 or onsets.size == 0 or any(a.shape != onsets.shape for a in arrays):
            raise BadInputError("onsets, durations and amplitudes must be non-empty (S,) arrays")
        if not all(np.isfinite(a).all() for a in arrays):
            raise BadInputError("submovement onsets, durations and amplitudes must be finite")
        if onsets[0] != 0.0 or (onsets < 0).any() or (durations <= 0).any() or (amplitudes < 0).any():
            raise BadInputError("need onsets >= 0 starting at 0, durations > 0 s and amplitudes >= 0")
        if abs(amplitudes.sum() - 1.0) > 1e-9:
            raise BadInputError(f"submovement amplitudes must sum to 1, got {amplitudes.sum()}")
        if not 0.05 <= self.first_peak_fraction <= 0.95:
            raise BadInputError(f"first_peak_fraction must be in [0.05, 0.95], got {self.first_peak_fraction}")
        for name, a in zip(("onsets", "durations", "amplitudes"), arrays):
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    @property
    def duration(self) -> float:
        """Time from the first onset to the last submovement's end, s."""
        return float(np.max(self.onsets + self.durations))

    @cached_property
    def _exponent(self) -> float:
        return _warp_exponent(self.first_peak_fraction)

    def sample(self, t: np.ndarray) -> np.ndarray:
        """Progress at times ``t`` (s since the onset, shape (T,)): 0 before, 1 after, shape (T,)."""
        tau = np.clip((np.asarray(t, dtype=float)[:, None] - self.onsets) / self.durations, 0.0, 1.0)
        if self.first_peak_fraction <= 0.5:
            tau[:, 0] = 1.0 - (1.0 - tau[:, 0]) ** self._exponent
        else:
            tau[:, 0] = tau[:, 0] ** self._exponent
        return minimum_jerk(tau) @ self.amplitudes


def ramp(duration: float) -> SubmovementProfile:
    """A single symmetric minimum-jerk profile over ``duration`` s."""
    return SubmovementProfile(np.zeros(1), np.array([duration]), np.ones(1), 0.5)


def submovement_profile(
    duration: float, n_submovements: int, peak_velocity_fraction: float, *, rng: np.random.Generator
) -> SubmovementProfile:
    """Draw a progress profile of ``n_submovements`` velocity peaks going 0 -> 1 in ``duration``.

    The primary submovement carries most of the way and peaks in speed at
    ``peak_velocity_fraction * duration``; each corrective one (0.2-0.8 s long) starts 100-300 ms
    after the previous velocity peak, overlaps it, and is smaller by a factor 0.5-0.8. Gaps
    stretch when the phase is long for its submovements and shrink when it is short. One
    submovement is a single time-warped minimum-jerk profile.

    Parameters
    ----------
    duration : float
        Total duration, s.
    n_submovements : int
        Number of submovements (velocity peaks), >= 1.
    peak_velocity_fraction : float
        Time of the highest speed as a fraction of ``duration``, in [0.05, 0.95].
    rng : numpy.random.Generator
        Draws the gaps and amplitude ratios.

    Returns
    -------
    SubmovementProfile
        Its velocity has ``n_submovements`` distinct peaks when the phase leaves room for the
        gaps (``duration`` >= about 0.45 s per submovement, ``peak_velocity_fraction`` <= 0.5).
    """
    duration = check_duration(duration, "duration")
    n = check_count(n_submovements, "n_submovements")
    if not (isinstance(peak_velocity_fraction, (int, float)) and 0.05 <= peak_velocity_fraction <= 0.95):
        raise BadInputError(f"peak_velocity_fraction must be in [0.05, 0.95], got {peak_velocity_fraction!r}")
    if n == 1:
        return SubmovementProfile(np.zeros(1), np.array([duration]), np.ones(1), peak_velocity_fraction)
    peak = peak_velocity_fraction * duration
    gaps = rng.uniform(*_GAP, size=n - 1)
    after_peak = duration - peak  # = sum(gaps) + n / 2 * correction
    correction = float(np.clip((after_peak - gaps.sum()) / (0.5 * n), *_CORRECTION))
    correction = min(correction, after_peak / (0.5 * n))
    gaps *= (after_peak - 0.5 * n * correction) / gaps.sum()
    onsets = np.concatenate(([0.0], peak + gaps[0] + np.cumsum(np.r_[0.0, gaps[1:] + 0.5 * correction])))
    primary = peak + gaps[0] + 0.25 * correction  # ends halfway up the first correction's speed
    first_fraction = float(np.clip(peak / primary, 0.05, 0.95))
    primary_speed = _peak_speed(_warp_exponent(first_fraction)) / primary
    ratios = rng.uniform(*_SHRINK, size=n - 1)
    ratios[0] = min(ratios[0], _PRIMARY_DOMINANCE * primary_speed * correction / _peak_speed(1.0))
    amplitudes = np.cumprod(np.r_[1.0, ratios])
    durations = np.r_[primary, np.full(n - 1, correction)]
    return SubmovementProfile(onsets, durations, amplitudes / amplitudes.sum(), first_fraction)


def check_duration(value: float, name: str) -> float:
    """``value`` as a float if it is a finite positive number of seconds; BadInputError naming ``name`` otherwise."""
    is_number = isinstance(value, (int, float, np.number)) and not isinstance(value, bool)
    if not (is_number and math.isfinite(value) and value > 0):
        raise BadInputError(f"{name} must be a positive number of seconds, got {value!r}")
    return float(value)


def check_count(value: int, name: str) -> int:
    """``value`` as an int if it is an integer >= 1; BadInputError naming ``name`` otherwise."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise BadInputError(f"{name} must be an int >= 1, got {value!r}")
    return int(value)
