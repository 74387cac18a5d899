"""A motion as a timeline: coordinated joint moves, oscillations, repetitions and their composition.

A :class:`Motion` is a function of time, ``sample(t) -> (T, K)`` over
:data:`sim.coordinates.COORDINATES`; segments are joined by :func:`compose`. Every segment starts
and ends standing at rest with zero velocity, so a composed session is C1. Each motion carries its
:class:`Repetition` annotations as ground truth for segmentation.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike

from fusion.errors import BadInputError
from sim.coordinates import COORDINATES, INDEX
from sim.patient_motion import Movement, Side
from sim.submovements import SubmovementProfile, check_duration, minimum_jerk

K = len(COORDINATES)
"""Number of coordinates, the width of a sampled motion."""


_FADE = 1.0
"""Fade-in and fade-out of oscillations at a segment's ends, s (at most a quarter of it)."""


@dataclass(frozen=True, eq=False)
class Coupled:
    """Progress of a coordinate coupled to an arm's progress past an onset (synergy).

    Raising: h(s) with h(x) = minimum_jerk((x - onset) / (1 - onset)). Lowering, the same
    relation to the arm's remaining elevation: 1 - h(1 - s).
    """

    arm: SubmovementProfile
    onset: float
    lowering: bool

    @property
    def duration(self) -> float:
        return self.arm.duration

    def sample(self, t: np.ndarray) -> np.ndarray:
        s = self.arm.sample(t)
        if self.lowering:
            return 1.0 - minimum_jerk((1.0 - s - self.onset) / (1.0 - self.onset))
        return minimum_jerk((s - self.onset) / (1.0 - self.onset))


@dataclass(frozen=True, eq=False)
class Move:
    """``delta`` (K,) added along ``progress`` from ``t0`` s on; fully added after it ends."""

    t0: float
    delta: np.ndarray
    progress: SubmovementProfile | Coupled


@dataclass(frozen=True, eq=False)
class Oscillation:
    """``weights`` (K,) times a sinusoid, faded in and out over [t0, t1] (C1 at both ends)."""

    weights: np.ndarray
    frequency: float
    phase: float
    t0: float
    t1: float

    def sample(self, t: np.ndarray) -> np.ndarray:
        fade = min(_FADE, 0.25 * (self.t1 - self.t0))
        window = minimum_jerk((t - self.t0) / fade) * minimum_jerk((self.t1 - t) / fade)
        return window * np.sin(2.0 * np.pi * self.frequency * t + self.phase)


@dataclass(frozen=True)
class Repetition:
    """Ground-truth annotation of one repetition (or of a whole idle / calibration segment).

    Attributes
    ----------
    movement : Movement
    side : Side or None
        Moving arm; None for IDLE and CALIBRATION.
    index : int
        0-based repetition number within its segment.
    t_start, t_peak, t_end : float
        Onset of the first coordinate to move, arrival at the top, end of the return, s from the
        motion's start. For idle and calibration: start, middle and end of the segment.
    """

    movement: Movement
    side: Side | None
    index: int
    t_start: float
    t_peak: float
    t_end: float

    def __post_init__(self) -> None:
        if not isinstance(self.movement, Movement):
            raise BadInputError(f"movement must be a Movement, got {self.movement!r}")
        needs_side = self.movement in (Movement.SALUTE, Movement.HAND_LIFT)
        if needs_side != isinstance(self.side, Side) or (not needs_side and self.side is not None):
            raise BadInputError(f"{self.movement.name} needs side {'a Side' if needs_side else 'None'}")
        if not (isinstance(self.index, int) and self.index >= 0):
            raise BadInputError(f"index must be an int >= 0, got {self.index!r}")
        times = (self.t_start, self.t_peak, self.t_end)
        if not (all(math.isfinite(t) for t in times) and self.t_start <= self.t_peak <= self.t_end):
            raise BadInputError(f"need finite t_start <= t_peak <= t_end, got {times}")


@dataclass(frozen=True, eq=False)
class Motion:
    """A trajectory of all coordinates over [0, duration] s, with its repetition annotations.

    Build motions with :func:`idle`, :func:`calibration_turn`, :func:`salute`, :func:`hand_lift`
    and :func:`compose`; ``moves`` and ``oscillations`` are their internal terms. A motion
    starts at the origin facing +x with every other coordinate at 0.

    Attributes
    ----------
    duration : float
        Length, s.
    repetitions : tuple of Repetition
        Annotations, ordered by ``t_start``, all inside [0, duration].
    """

    duration: float
    repetitions: tuple[Repetition, ...]
    moves: tuple[Move, ...]
    oscillations: tuple[Oscillation, ...]

    def __post_init__(self) -> None:
        check_duration(self.duration, "motion duration")
        for rep in self.repetitions:
            if not isinstance(rep, Repetition) or rep.t_start < 0.0 or rep.t_end > self.duration + 1e-9:
                raise BadInputError(f"repetition {rep!r} is not a Repetition inside [0, {self.duration}] s")
        starts = [rep.t_start for rep in self.repetitions]
        if starts != sorted(starts):
            raise BadInputError("repetitions must be ordered by t_start")
        for term in self.moves + self.oscillations:
            vector = term.delta if isinstance(term, Move) else term.weights
            if vector.shape != (K,):
                raise BadInputError(f"a motion term must act on ({K},) coordinates, got {vector.shape}")

    @cached_property
    def _move_ends(self) -> np.ndarray:
        """(M,) end time of each move, s."""
        return np.array([move.t0 + move.progress.duration for move in self.moves])

    @cached_property
    def _ends(self) -> np.ndarray:
        """(M,) move end times, sorted."""
        return np.sort(self._move_ends)

    @cached_property
    def _finished(self) -> np.ndarray:
        """(M + 1, K): row i is the sum of the deltas of the i moves that end first."""
        deltas = np.array([move.delta for move in self.moves]).reshape(-1, K)
        by_end = deltas[np.argsort(self._move_ends, kind="stable")]
        return np.vstack([np.zeros(K), np.cumsum(by_end, axis=0)])

    def sample(self, t: ArrayLike) -> np.ndarray:
        """Coordinates at times ``t``.

        Parameters
        ----------
        t : array_like
            (T,) times in [0, duration], s, in any order and at any rate.

        Returns
        -------
        numpy.ndarray
            (T, K) float64 over :data:`sim.coordinates.COORDINATES`: metres for ``root_x`` and
            ``root_y``, radians for the rest.
        """
        t = np.asarray(t, dtype=float)
        if t.ndim != 1 or not np.isfinite(t).all():
            raise BadInputError(f"t must be a finite (T,) array of seconds, got shape {t.shape}")
        tolerance = 1e-9 * max(1.0, self.duration)
        if t.size and (t.min() < -tolerance or t.max() > self.duration + tolerance):
            raise BadInputError(f"t must lie in [0, {self.duration}] s, got [{t.min()}, {t.max()}]")
        order = np.argsort(t, kind="stable")
        ts = t[order]
        done = np.searchsorted(self._ends, ts, side="right")  # moves finished by each time
        values = self._finished[done]
        for move, end in zip(self.moves, self._move_ends):
            lo, hi = np.searchsorted(ts, move.t0, side="right"), np.searchsorted(ts, end, side="left")
            if hi > lo:
                values[lo:hi] += np.outer(move.progress.sample(ts[lo:hi] - move.t0), move.delta)
        for osc in self.oscillations:
            lo, hi = np.searchsorted(ts, osc.t0, side="right"), np.searchsorted(ts, osc.t1, side="left")
            values[lo:hi] += np.outer(osc.sample(ts[lo:hi]), osc.weights)
        out = np.empty_like(values)
        out[order] = values
        return out


def compose(segments: Sequence[Motion]) -> Motion:
    """Concatenate motions into one timeline.

    Each segment continues where the previous one ended: its times are shifted and its floor
    position and facing are carried over (its root displacements are turned by the facing
    reached so far). Segments start and end at rest with zero velocity, so the result is C1.

    Parameters
    ----------
    segments : sequence of Motion

    Returns
    -------
    Motion
        Duration the sum of the segments', with all their repetitions, shifted.
    """
    if not segments or not all(isinstance(m, Motion) for m in segments):
        raise BadInputError("compose needs a non-empty sequence of Motion")
    moves, oscillations, repetitions = [], [], []
    offset, yaw = 0.0, 0.0
    for motion in segments:
        turn = np.eye(K)
        turn[np.ix_([INDEX["root_x"], INDEX["root_y"]], [INDEX["root_x"], INDEX["root_y"]])] = [
            [math.cos(yaw), -math.sin(yaw)],
            [math.sin(yaw), math.cos(yaw)],
        ]
        moves += [replace(m, t0=m.t0 + offset, delta=turn @ m.delta) for m in motion.moves]
        oscillations += [
            replace(
                o,
                t0=o.t0 + offset,
                t1=o.t1 + offset,
                phase=o.phase - 2 * np.pi * o.frequency * offset,
                weights=turn @ o.weights,
            )
            for o in motion.oscillations
        ]
        repetitions += [
            replace(r, t_start=r.t_start + offset, t_peak=r.t_peak + offset, t_end=r.t_end + offset)
            for r in motion.repetitions
        ]
        offset += motion.duration
        yaw += sum(m.delta[INDEX["root_yaw"]] for m in motion.moves)
    return Motion(offset, tuple(repetitions), tuple(moves), tuple(oscillations))
