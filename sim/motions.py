"""Motion scripts: continuous-time trajectories of the humanoid's clinical coordinates.

A :class:`Motion` is a function of time, ``sample(t) -> (T, K)`` over
:data:`sim.coordinates.COORDINATES`, built from segments (:func:`idle`,
:func:`calibration_turn`, :func:`salute`, :func:`hand_lift`) joined by :func:`compose`. Every
segment starts and ends standing at rest with zero velocity, so a composed session is C1. Each
motion carries its :class:`Repetition` annotations as ground truth for segmentation.

Joint angles move along minimum-jerk profiles; a patient's along a sum of overlapping
minimum-jerk submovements (:func:`submovement_profile`). Healthy and patient motion come from the
same functions: the :class:`sim.profile.MovementProfile` passed in makes the difference.

The shoulder is a Y-X-Y sequence (:mod:`sim.humanoid`): an arm elevated in plane ``sh_plane``
without axial twist has ``sh_rotation = sh_plane``, so a clinical external rotation ``er`` is
written ``sh_rotation = sh_plane + er`` throughout.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike
from scipy.optimize import brentq

from fusion.errors import BadInputError
from sim.coordinates import ARM, COORDINATES, INDEX
from sim.profile import Movement, MovementProfile, Side

K = len(COORDINATES)
"""Number of coordinates, the width of a sampled motion."""

_deg = math.radians

_GAP = (0.1, 0.3)
"""Range of the pause between a submovement's velocity peak and the next one's onset, s."""
_SHRINK = (0.5, 0.8)
"""Range of the amplitude ratio of consecutive submovements."""
_CORRECTION = (0.2, 0.8)
"""Shortest and longest corrective submovement, s; the gaps shrink or grow to keep within."""
_PRIMARY_DOMINANCE = 0.7
"""Peak speed of the first correction relative to the primary submovement's, at most."""

# Levers turning the profile's displacements into angles, for the humanoid of a 1.75 m subject.
_STERNUM_LEVER = 0.48
"""Trunk pivot (hip centres) to the sternal notch, m (trunk forward displacement -> trunk flexion)."""
_CLAVICLE_LEVER = 0.18
"""Clavicle pivot (sternal notch) to the shoulder, sideways, m (shoulder hiking -> clavicle elevation)."""
_ARM_LEVER = 0.64
"""Shoulder to hand, m (tremor amplitude at the hand -> shoulder angle)."""
_MAX_LEAD = 0.2
"""Trunk and shoulder-girdle compensation starts up to this long before the arm, s."""
_FADE = 1.0
"""Fade-in and fade-out of oscillations at a segment's ends, s (at most a quarter of it)."""
_SALUTE_PREP = 1.2
"""Time to go from standing to the salute's start (hand at the opposite knee) and back, s."""
_HAND_LIFT_PREP = 0.5
"""Time to set the hanging arm's plane of elevation to sagittal and back (no visible motion), s."""
_SALUTE_FULL_ELEVATION = _deg(90.0)
"""Abduction at which the salute's other components reach their full range."""
_MIN_TURN = 4.0
"""Shortest calibration turn, s."""
_SQUAT = {"hip_flexion": 20.0, "knee_flexion": 40.0, "ankle_flexion": 20.0}
"""Knee bend (degrees, both legs) that helps a standing subject reach the salute's start."""


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


def _ramp(duration: float) -> SubmovementProfile:
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
    duration = _positive(duration, "duration")
    n = _count(n_submovements, "n_submovements")
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


@dataclass(frozen=True, eq=False)
class _Coupled:
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
class _Move:
    """``delta`` (K,) added along ``progress`` from ``t0`` s on; fully added after it ends."""

    t0: float
    delta: np.ndarray
    progress: SubmovementProfile | _Coupled


@dataclass(frozen=True, eq=False)
class _Oscillation:
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
    moves: tuple[_Move, ...]
    oscillations: tuple[_Oscillation, ...]

    def __post_init__(self) -> None:
        _positive(self.duration, "motion duration")
        for rep in self.repetitions:
            if not isinstance(rep, Repetition) or rep.t_start < 0.0 or rep.t_end > self.duration + 1e-9:
                raise BadInputError(f"repetition {rep!r} is not a Repetition inside [0, {self.duration}] s")
        starts = [rep.t_start for rep in self.repetitions]
        if starts != sorted(starts):
            raise BadInputError("repetitions must be ordered by t_start")
        for term in self.moves + self.oscillations:
            vector = term.delta if isinstance(term, _Move) else term.weights
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


# --- segments -------------------------------------------------------------------------------------


def idle(duration: float, *, rng: np.random.Generator) -> Motion:
    """Standing still with slight postural sway (2-5 mm, 0.3-0.5 degrees) and breathing.

    Parameters
    ----------
    duration : float
        Length, s, > 0.
    rng : numpy.random.Generator

    Returns
    -------
    Motion
        Annotated with one IDLE :class:`Repetition` spanning it.
    """
    duration = _positive(duration, "duration")
    rep = Repetition(Movement.IDLE, None, 0, 0.0, 0.5 * duration, duration)
    return Motion(duration, (rep,), (), _postural(duration, rng))


def calibration_turn(duration: float, *, rng: np.random.Generator) -> Motion:
    """Turning in place through 360 degrees while raising the arms in varied poses.

    The direction of the turn is random. Small steps (alternating hip and knee flexion lifting
    the feet) accompany it, each shifting the pelvis to a random spot within 3 cm of the start;
    each arm keeps making raises to random planes (0-100 degrees), elevations (30-150 degrees),
    elbow flexions (0-90 degrees), external rotations (-30-45 degrees) and forearm rotations.

    Parameters
    ----------
    duration : float
        Length, s, >= 4.
    rng : numpy.random.Generator

    Returns
    -------
    Motion
        Annotated with one CALIBRATION :class:`Repetition`: start, half turn, end of the turn.
    """
    duration = _positive(duration, "duration")
    if duration < _MIN_TURN:
        raise BadInputError(f"a calibration turn needs at least {_MIN_TURN} s, got {duration}")
    margin = 0.5
    turn_start, turn_time = margin, duration - 2 * margin
    direction = 1.0 if rng.random() < 0.5 else -1.0
    moves = [_Move(turn_start, _pose(root_yaw=direction * 2 * np.pi), _ramp(turn_time))]

    n_steps = int(np.clip(round(turn_time / 2.0), 4, 12))
    step_time = 0.7
    first = Side.LEFT if direction > 0 else Side.RIGHT
    position = np.zeros(2)
    for k in range(n_steps):
        leg = first if k % 2 == 0 else _other(first)
        t = turn_start + (k + 0.5) * turn_time / n_steps - 0.5 * step_time
        lift = _pose(leg, hip_flexion=_deg(rng.uniform(20, 30)), knee_flexion=_deg(rng.uniform(35, 55)))
        radius, angle = 0.03 * math.sqrt(rng.random()), rng.uniform(0, 2 * np.pi)
        target = radius * np.array([math.cos(angle), math.sin(angle)])
        shift = _pose(root_x=target[0] - position[0], root_y=target[1] - position[1])
        position = target
        moves += [
            _Move(t, lift, _ramp(0.5 * step_time)),
            _Move(t + 0.5 * step_time, -lift, _ramp(0.5 * step_time)),
            _Move(t, shift, _ramp(step_time)),
        ]

    for side in Side:
        t = margin + rng.uniform(0.0, 1.5)
        while True:
            up, hold, down = rng.uniform(0.7, 1.2), rng.uniform(0.2, 0.8), rng.uniform(0.7, 1.2)
            if t + up + hold + down > duration - margin:
                break
            plane = _deg(rng.uniform(0, 100))
            raise_ = _pose(
                side,
                sh_plane=plane,
                sh_elevation=_deg(rng.uniform(30, 150)),
                elbow_flexion=_deg(rng.uniform(0, 90)),
                sh_rotation=plane + _deg(rng.uniform(-30, 45)),
                forearm_rotation=_deg(rng.uniform(-45, 45)),
            )
            moves += [_Move(t, raise_, _ramp(up)), _Move(t + up + hold, -raise_, _ramp(down))]
            t += up + hold + down + rng.uniform(0.2, 1.0)

    rep = Repetition(Movement.CALIBRATION, None, 0, turn_start, turn_start + 0.5 * turn_time, turn_start + turn_time)
    return Motion(duration, (rep,), tuple(moves), _postural(duration, rng))


def hand_lift(
    side: Side, repetitions: int, profile: MovementProfile, *, rng: np.random.Generator, rest: float = 1.0
) -> Motion:
    """Fugl-Meyer item A.III: shoulder flexion 0 -> 90 degrees, elbow straight, hold, lower.

    The arm rises in the sagittal plane with the forearm in mid position to
    ``profile.peak_elevation``; past ``profile.synergy_onset`` the elbow flexes and the arm
    abducts, reaching ``profile.synergy_elbow_flexion`` and ``profile.synergy_abduction`` at the
    top. Trunk flexion, lean and rotation and shoulder hiking start up to 0.2 s before the arm
    and peak with it. Durations vary from trial to trial with ``profile.duration_cv``; a tremor
    in the profile shakes the shoulder angles throughout.

    Parameters
    ----------
    side : Side
        The moving arm.
    repetitions : int
        Number of lifts, >= 1.
    profile : MovementProfile
    rng : numpy.random.Generator
    rest : float
        Pause with the arm down before, between and after the lifts, s.

    Returns
    -------
    Motion
        Annotated with one HAND_LIFT :class:`Repetition` per lift.
    """
    _check_movement(side, repetitions, profile, rest)
    onset = profile.synergy_onset / profile.peak_elevation
    abduction = profile.synergy_abduction
    synergy = _pose(side, elbow_flexion=profile.synergy_elbow_flexion, sh_plane=-abduction, sh_rotation=-abduction)
    return _movement(
        Movement.HAND_LIFT,
        side,
        repetitions,
        profile,
        rest,
        ready=_pose(side, sh_plane=_deg(90.0), sh_rotation=_deg(90.0)),
        prep_time=_HAND_LIFT_PREP,
        arm=_pose(side, sh_elevation=profile.peak_elevation),
        synergy=synergy if onset < 1.0 and synergy.any() else None,
        onset=onset,
        rng=rng,
    )


def salute(
    side: Side, repetitions: int, profile: MovementProfile, *, rng: np.random.Generator, rest: float = 1.0
) -> Motion:
    """Fugl-Meyer item A.II (flexor synergy): hand from the opposite knee to the ipsilateral ear.

    Start (extensor synergy): shoulder adducted across the body (plane 118 degrees, elevation
    33) and internally rotated 46 degrees, elbow extended, forearm pronated 70 degrees; standing,
    the trunk flexes 40 degrees and the knees bend 40 degrees to bring the hand to the lower
    thigh, about 0.2 m above the opposite knee. Top: shoulder abducted to
    ``profile.peak_elevation`` in a plane 40 degrees forward, externally rotated 25 degrees,
    elbow flexed 145 degrees, forearm supinated 50 degrees, shoulder girdle retracted 15 and
    elevated 8 degrees, standing upright: the hand is about 0.1 m from the ear. With less than
    90 degrees of abduction the other arm components shrink in proportion. Compensation (trunk,
    extra shoulder hiking), trial-to-trial variability and tremor as in :func:`hand_lift`.

    Parameters
    ----------
    side : Side
        The moving arm.
    repetitions : int
        Number of salutes, >= 1.
    profile : MovementProfile
    rng : numpy.random.Generator
    rest : float
        Pause at the start position before, between and after the salutes, s.

    Returns
    -------
    Motion
        Annotated with one SALUTE :class:`Repetition` per salute.
    """
    _check_movement(side, repetitions, profile, rest)
    squat = {f"{joint}_{leg.value}": _deg(angle) for leg in Side for joint, angle in _SQUAT.items()}
    ready = _pose(
        side,
        trunk_flexion=_deg(40.0),
        clav_retraction=_deg(-10.0),
        sh_plane=_deg(118.0),
        sh_elevation=_deg(33.0),
        sh_rotation=_deg(118.0 - 46.0),
        elbow_flexion=_deg(5.0),
        forearm_rotation=_deg(-70.0),
        **squat,
    )
    ear = _pose(
        side,
        clav_elevation=_deg(8.0),
        clav_retraction=_deg(15.0),
        sh_plane=_deg(40.0),
        sh_rotation=_deg(40.0 + 25.0),
        elbow_flexion=_deg(145.0),
        forearm_rotation=_deg(50.0),
    )
    arm = ear - ready
    arm[[_column(name, side) for name in ARM]] *= min(1.0, profile.peak_elevation / _SALUTE_FULL_ELEVATION)
    arm[_column("sh_elevation", side)] = profile.peak_elevation - ready[_column("sh_elevation", side)]
    return _movement(
        Movement.SALUTE,
        side,
        repetitions,
        profile,
        rest,
        ready=ready,
        prep_time=_SALUTE_PREP,
        arm=arm,
        synergy=None,
        onset=0.0,
        rng=rng,
    )


def _movement(
    movement: Movement,
    side: Side,
    repetitions: int,
    profile: MovementProfile,
    rest: float,
    *,
    ready: np.ndarray,
    prep_time: float,
    arm: np.ndarray,
    synergy: np.ndarray | None,
    onset: float,
    rng: np.random.Generator,
) -> Motion:
    """Rest -> ``ready`` pose, then repetitions of ``arm`` (+ coupled ``synergy``) up and down, -> rest.

    ``arm`` and ``synergy`` are (K,) displacements from ``ready`` to the top; compensation
    comes from the profile.
    """
    compensation = _compensation(side, profile)
    moves = [_Move(0.0, ready, _ramp(prep_time))]
    reps = []
    t = prep_time + rest
    sigma = math.sqrt(math.log1p(profile.duration_cv**2))
    for index in range(repetitions):
        pace, hold_pace = (float(x) for x in rng.lognormal(-0.5 * sigma**2, sigma, size=2))
        rise, hold, lower = profile.rise_time * pace, profile.hold_time * hold_pace, profile.return_time * pace
        lead = float(rng.uniform(0.0, _MAX_LEAD))
        up = submovement_profile(rise, profile.n_submovements, profile.peak_velocity_fraction, rng=rng)
        down = submovement_profile(lower, profile.n_submovements, profile.peak_velocity_fraction, rng=rng)
        t_arm = t + lead
        t_down = t_arm + rise + hold
        moves += [
            _Move(t_arm, arm, up),
            _Move(t, compensation, _ramp(lead + rise)),
            _Move(t_down, -arm, down),
            _Move(t_down, -compensation, _ramp(lower)),
        ]
        if synergy is not None:
            moves += [
                _Move(t_arm, synergy, _Coupled(up, onset, lowering=False)),
                _Move(t_down, -synergy, _Coupled(down, onset, lowering=True)),
            ]
        reps.append(Repetition(movement, side, index, t, t_arm + rise, t_down + lower))
        t = t_down + lower + rest
    moves.append(_Move(t, -ready, _ramp(prep_time)))
    duration = t + prep_time
    return Motion(duration, tuple(reps), tuple(moves), _postural(duration, rng) + _tremor(side, profile, duration, rng))


def _compensation(side: Side, profile: MovementProfile) -> np.ndarray:
    """(K,) trunk flexion, lean away from the arm, rotation bringing it forward, and hiking."""
    toward = 1.0 if side is Side.RIGHT else -1.0  # + trunk_rotation brings the right shoulder forward
    return _pose(
        side,
        trunk_flexion=math.asin(profile.trunk_forward / _STERNUM_LEVER),
        trunk_lateral=-toward * profile.trunk_lateral,
        trunk_rotation=toward * profile.trunk_rotation,
        clav_elevation=math.asin(profile.shoulder_hiking / _CLAVICLE_LEVER),
    )


def _tremor(
    side: Side, profile: MovementProfile, duration: float, rng: np.random.Generator
) -> tuple[_Oscillation, ...]:
    """Vertical and horizontal (twist-free) arm oscillations at the tremor frequency, random phases."""
    if profile.tremor_amplitude == 0.0:
        return ()
    angle = profile.tremor_amplitude / _ARM_LEVER
    directions = (_pose(side, sh_elevation=angle), _pose(side, sh_plane=angle, sh_rotation=angle))
    return tuple(
        _Oscillation(weights, profile.tremor_frequency, rng.uniform(0, 2 * np.pi), 0.0, duration)
        for weights in directions
    )


def _postural(duration: float, rng: np.random.Generator) -> tuple[_Oscillation, ...]:
    """Breathing (0.2-0.33 Hz, shoulders rise 0.4-0.8 degrees) and slow sway (0.05-0.3 Hz)."""
    breath = _deg(rng.uniform(0.4, 0.8))
    terms = [
        _Oscillation(
            _pose(clav_elevation_l=breath, clav_elevation_r=breath, trunk_flexion=-0.3 * breath),
            rng.uniform(0.2, 0.33),
            rng.uniform(0, 2 * np.pi),
            0.0,
            duration,
        )
    ]
    for name, amplitude in (
        ("root_x", rng.uniform(0.002, 0.005)),
        ("root_y", rng.uniform(0.002, 0.005)),
        ("trunk_flexion", _deg(rng.uniform(0.2, 0.5))),
        ("trunk_lateral", _deg(rng.uniform(0.2, 0.5))),
    ):
        frequency, phase = rng.uniform(0.05, 0.3), rng.uniform(0, 2 * np.pi)
        terms.append(_Oscillation(_pose(**{name: amplitude}), frequency, phase, 0.0, duration))
    return tuple(terms)


# --- helpers --------------------------------------------------------------------------------------


def _column(name: str, side: Side) -> int:
    return INDEX[f"{name}_{side.value}"]


def _pose(side: Side | None = None, **values: float) -> np.ndarray:
    """(K,) vector from coordinate names; with ``side``, per-side names may omit the suffix."""
    vector = np.zeros(K)
    for name, value in values.items():
        vector[INDEX[name] if name in INDEX else _column(name, side)] = value
    return vector


def _other(side: Side) -> Side:
    return Side.LEFT if side is Side.RIGHT else Side.RIGHT


def _positive(value: float, name: str) -> float:
    is_number = isinstance(value, (int, float, np.number)) and not isinstance(value, bool)
    if not (is_number and math.isfinite(value) and value > 0):
        raise BadInputError(f"{name} must be a positive number of seconds, got {value!r}")
    return float(value)


def _count(value: int, name: str) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
        raise BadInputError(f"{name} must be an int >= 1, got {value!r}")
    return int(value)


def _check_movement(side: Side, repetitions: int, profile: MovementProfile, rest: float) -> None:
    if not isinstance(side, Side):
        raise BadInputError(f"side must be Side.LEFT or Side.RIGHT, got {side!r}")
    _count(repetitions, "repetitions")
    if not isinstance(profile, MovementProfile):
        raise BadInputError(f"profile must be a MovementProfile, got {type(profile).__name__}")
    if isinstance(rest, bool) or not isinstance(rest, (int, float)) or not math.isfinite(rest) or rest < 0:
        raise BadInputError(f"rest must be a number of seconds >= 0, got {rest!r}")
