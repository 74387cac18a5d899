"""Kinematic profiles of a subject performing the Fugl-Meyer salute and hand lift.

A :class:`MovementProfile` holds the per-trial parameters of one movement by one arm; a
:class:`SubjectProfile` holds one per movement and side. Magnitudes and ranges follow
``shared/reference/fma.md``. All values are SI: seconds, radians, metres, hertz.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, fields, replace

import numpy as np

from fusion.errors import BadInputError


class Side(enum.Enum):
    """Body side; the value is the suffix of the side's coordinates in :mod:`sim.coordinates`."""

    LEFT = "l"
    RIGHT = "r"


class Movement(enum.Enum):
    """What a stretch of a motion shows."""

    SALUTE = "salute"
    HAND_LIFT = "hand_lift"
    CALIBRATION = "calibration"
    IDLE = "idle"


class Group(enum.Enum):
    """Clinical group of a subject (FMA-UE: mild >= 50, moderate-severe 20-49)."""

    HEALTHY = "healthy"
    MILD = "mild"
    MODERATE_SEVERE = "moderate_severe"


_deg = math.radians

FMA_UE_MAX = 66
"""Highest upper-extremity Fugl-Meyer motor score (33 items scored 0/1/2)."""

# name -> (lowest, highest) value accepted on construction: physically plausible, wider than fma.md.
_LIMITS: dict[str, tuple[float, float]] = {
    "rise_time": (0.2, 20.0),
    "n_submovements": (1, 12),
    "peak_velocity_fraction": (0.1, 0.9),
    "peak_elevation": (_deg(10.0), _deg(150.0)),
    "synergy_onset": (0.0, _deg(150.0)),
    "synergy_elbow_flexion": (0.0, _deg(140.0)),
    "synergy_abduction": (0.0, _deg(80.0)),
    "trunk_forward": (0.0, 0.25),
    "trunk_lateral": (0.0, _deg(30.0)),
    "trunk_rotation": (0.0, _deg(30.0)),
    "shoulder_hiking": (0.0, 0.06),
    "tremor_frequency": (0.0, 15.0),
    "tremor_amplitude": (0.0, 0.02),
    "duration_cv": (0.0, 0.5),
    "hold_time": (0.0, 20.0),
    "return_time": (0.2, 20.0),
}


@dataclass(frozen=True)
class MovementProfile:
    """Kinematic parameters of one movement (salute or hand lift) by one arm.

    Attributes
    ----------
    rise_time : float
        Duration of the rise phase (hand lift 0 -> peak, salute knee -> ear), s.
    n_submovements : int
        Velocity peaks (movement units) per phase, 1 for a smooth movement.
    peak_velocity_fraction : float
        Time to peak velocity as a fraction of the phase, in [0.1, 0.9].
    peak_elevation : float
        Peak shoulder elevation, rad: flexion in the hand lift, abduction in the salute.
    synergy_onset : float
        Shoulder elevation past which elbow flexion and abduction grow (hand lift), rad.
    synergy_elbow_flexion : float
        Elbow flexion reached at the top of the hand lift, rad.
    synergy_abduction : float
        Shoulder abduction out of the sagittal plane at the top of the hand lift, rad.
    trunk_forward : float
        Forward displacement of the sternum at the top, m.
    trunk_lateral : float
        Trunk lean away from the moving arm at the top, rad.
    trunk_rotation : float
        Trunk axial rotation bringing the moving shoulder forward at the top, rad.
    shoulder_hiking : float
        Extra acromion rise (clavicle elevation) at the top, m.
    tremor_frequency : float
        Tremor frequency, Hz (0 with no tremor).
    tremor_amplitude : float
        Tremor amplitude at the hand, m (0 for none).
    duration_cv : float
        Trial-to-trial coefficient of variation of the phase durations.
    hold_time : float
        Time held at the top, s.
    return_time : float
        Duration of the return phase, s.

    Notes
    -----
    The three ``synergy_*`` parameters shape the hand lift only; the salute is itself the flexor
    synergy, and a patient's incomplete salute comes from a smaller ``peak_elevation``.
    """

    rise_time: float
    n_submovements: int
    peak_velocity_fraction: float
    peak_elevation: float
    synergy_onset: float
    synergy_elbow_flexion: float
    synergy_abduction: float
    trunk_forward: float
    trunk_lateral: float
    trunk_rotation: float
    shoulder_hiking: float
    tremor_frequency: float
    tremor_amplitude: float
    duration_cv: float
    hold_time: float
    return_time: float

    def __post_init__(self) -> None:
        if not isinstance(self.n_submovements, (int, np.integer)):
            raise BadInputError(f"n_submovements must be an int, got {self.n_submovements!r}")
        for f in fields(self):
            value = getattr(self, f.name)
            lo, hi = _LIMITS[f.name]
            is_number = isinstance(value, (int, float, np.number)) and not isinstance(value, bool)
            if not (is_number and math.isfinite(value) and lo <= value <= hi):
                raise BadInputError(f"{f.name} must be a number in [{lo:.4g}, {hi:.4g}] (SI units), got {value!r}")
        if self.tremor_amplitude > 0.0 and self.tremor_frequency == 0.0:
            raise BadInputError("tremor_amplitude > 0 needs tremor_frequency > 0 Hz")

    @classmethod
    def healthy(cls, movement: Movement) -> MovementProfile:
        """Mid-range healthy parameters of ``movement`` (SALUTE or HAND_LIFT) from fma.md."""
        common = dict(
            n_submovements=1,
            peak_velocity_fraction=0.45,
            trunk_forward=0.025,
            trunk_lateral=_deg(1.5),
            trunk_rotation=_deg(1.5),
            shoulder_hiking=0.005,
            tremor_frequency=0.0,
            tremor_amplitude=0.0,
            duration_cv=0.075,
            hold_time=1.0,
        )
        if movement is Movement.HAND_LIFT:
            return cls(
                rise_time=1.2,
                peak_elevation=_deg(90.0),
                synergy_onset=0.0,
                synergy_elbow_flexion=_deg(5.0),
                synergy_abduction=_deg(5.0),
                return_time=1.1,
                **common,
            )
        if movement is Movement.SALUTE:
            return cls(
                rise_time=1.3,
                peak_elevation=_deg(95.0),
                synergy_onset=0.0,
                synergy_elbow_flexion=0.0,
                synergy_abduction=0.0,
                return_time=1.2,
                **common,
            )
        raise BadInputError(f"movement must be Movement.SALUTE or Movement.HAND_LIFT, got {movement!r}")


@dataclass(frozen=True)
class SubjectProfile:
    """One :class:`MovementProfile` per test movement and side, with the subject's group.

    Attributes
    ----------
    group : Group
    affected_side : Side or None
        The paretic side of a patient, None for a healthy subject.
    salute_left, salute_right, hand_lift_left, hand_lift_right : MovementProfile
    fma_ue : float or None
        Upper-extremity Fugl-Meyer motor score of the affected arm, 0-66 points (None: not modelled,
        e.g. a healthy subject or a profile drawn from the group ranges alone).
    initiation_delay : float
        Extra pause before each repetition against a healthy subject (slowed initiation), s.
    """

    group: Group
    affected_side: Side | None
    salute_left: MovementProfile
    salute_right: MovementProfile
    hand_lift_left: MovementProfile
    hand_lift_right: MovementProfile
    fma_ue: float | None = None
    initiation_delay: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.group, Group):
            raise BadInputError(f"group must be a Group, got {self.group!r}")
        if self.group is Group.HEALTHY and self.affected_side is not None:
            raise BadInputError("a healthy subject has no affected side; pass affected_side=None")
        if self.group is not Group.HEALTHY and not isinstance(self.affected_side, Side):
            raise BadInputError(f"a {self.group.value} subject needs affected_side Side.LEFT or Side.RIGHT")
        for name in ("salute_left", "salute_right", "hand_lift_left", "hand_lift_right"):
            if not isinstance(getattr(self, name), MovementProfile):
                raise BadInputError(f"{name} must be a MovementProfile")
        if self.fma_ue is not None and not (isinstance(self.fma_ue, (int, float)) and 0.0 <= self.fma_ue <= FMA_UE_MAX):
            raise BadInputError(f"fma_ue must be None or a score in [0, {FMA_UE_MAX}], got {self.fma_ue!r}")
        delay = self.initiation_delay
        if not (isinstance(delay, (int, float)) and math.isfinite(delay) and 0.0 <= delay <= 5.0):
            raise BadInputError(f"initiation_delay must be in [0, 5] s, got {delay!r}")

    @classmethod
    def healthy(cls) -> SubjectProfile:
        """A healthy subject with mid-range parameters on both sides."""
        salute = MovementProfile.healthy(Movement.SALUTE)
        lift = MovementProfile.healthy(Movement.HAND_LIFT)
        return cls(Group.HEALTHY, None, salute, salute, lift, lift)

    def movement(self, movement: Movement, side: Side) -> MovementProfile:
        """The profile of ``movement`` (SALUTE or HAND_LIFT) by the arm on ``side``."""
        if not isinstance(side, Side):
            raise BadInputError(f"side must be Side.LEFT or Side.RIGHT, got {side!r}")
        if movement is Movement.SALUTE:
            return self.salute_left if side is Side.LEFT else self.salute_right
        if movement is Movement.HAND_LIFT:
            return self.hand_lift_left if side is Side.LEFT else self.hand_lift_right
        raise BadInputError(f"movement must be Movement.SALUTE or Movement.HAND_LIFT, got {movement!r}")


@dataclass(frozen=True)
class _Ranges:
    """fma.md ranges of one movement for one group, SI units, each (low, high)."""

    rise_time: tuple[float, float]
    n_submovements: tuple[int, int]
    peak_velocity_fraction: tuple[float, float]
    peak_elevation: tuple[float, float]
    synergy_onset: tuple[float, float]
    synergy_elbow_flexion: tuple[float, float]
    synergy_abduction: tuple[float, float]
    trunk_forward: tuple[float, float]
    trunk_lean: tuple[float, float]
    shoulder_hiking: tuple[float, float]
    duration_cv: tuple[float, float]


def _degs(lo: float, hi: float) -> tuple[float, float]:
    return _deg(lo), _deg(hi)


def _cm(lo: float, hi: float) -> tuple[float, float]:
    return lo / 100.0, hi / 100.0


_NONE = (0.0, 0.0)


def _ranges_table() -> dict[tuple[Group, Movement], _Ranges]:
    """fma.md's table per group; the salute reuses the hand lift's rows except its own timing."""
    table = {}
    for group, lift_time, salute_time, units, tpv, peak, salute_peak, onset, elbow, abd, trunk, lean, hike, cv in (
        (Group.HEALTHY, (0.9, 1.5), (1.0, 1.6), (1, 2), (0.40, 0.50), _degs(85, 95), _degs(90, 100),
         _NONE, _degs(0, 10), _degs(0, 10), _cm(1, 4), _degs(0, 3), _cm(0, 1), (0.05, 0.10)),
        (Group.MILD, (1.3, 2.5), (1.5, 3.0), (2, 4), (0.30, 0.40), _degs(75, 95), _degs(75, 95),
         _degs(45, 70), _degs(10, 30), _degs(10, 25), _cm(3, 8), _degs(3, 8), _cm(1, 2), (0.10, 0.20)),
        (Group.MODERATE_SEVERE, (2.0, 5.0), (2.5, 6.0), (3, 8), (0.25, 0.40), _degs(40, 80), _degs(40, 80),
         _NONE, _degs(30, 70), _degs(20, 45), _cm(8, 15), _degs(5, 15), _cm(2, 4), (0.15, 0.30)),
    ):
        table[group, Movement.HAND_LIFT] = _Ranges(
            lift_time, units, tpv, peak, onset, elbow, abd, trunk, lean, hike, cv
        )
        table[group, Movement.SALUTE] = _Ranges(
            salute_time, units, tpv, salute_peak, _NONE, _NONE, _NONE, trunk, lean, hike, cv
        )
    return table


_RANGES = _ranges_table()
_HEALTHY_SECOND_UNIT = 0.15
"""Probability that a healthy phase has two velocity peaks instead of one."""
_SECONDS_PER_UNIT = (0.5, 0.9)
"""Range of a patient's phase duration per submovement, s: longer phases have more of them."""
_TREMOR_PREVALENCE = 0.15
"""Fraction of moderate-severe patients with a visible tremor (3-6 Hz, 2-5 mm)."""
_UNAFFECTED_SLOWING = (1.05, 1.25)
"""Duration factor of a patient's unaffected side against a healthy subject's."""


def _draw(ranges: _Ranges, group: Group, tremor: tuple[float, float], *, rng: np.random.Generator) -> MovementProfile:
    """Draw one MovementProfile; compensation and synergy grow with the missing range."""
    rise = rng.uniform(*ranges.rise_time)
    lo, hi = ranges.n_submovements
    if group is Group.HEALTHY:
        units = 2 if rng.random() < _HEALTHY_SECOND_UNIT else 1
    else:
        units = int(np.clip(round(rise / rng.uniform(*_SECONDS_PER_UNIT)), lo, hi))
    peak = rng.uniform(*ranges.peak_elevation)
    p_lo, p_hi = ranges.peak_elevation
    deficit = (p_hi - peak) / (p_hi - p_lo)

    def severity(bounds: tuple[float, float]) -> float:
        u = float(np.clip(deficit + rng.normal(0.0, 0.2), 0.0, 1.0))
        return bounds[0] + u * (bounds[1] - bounds[0])

    return MovementProfile(
        rise_time=rise,
        n_submovements=units,
        peak_velocity_fraction=rng.uniform(*ranges.peak_velocity_fraction),
        peak_elevation=peak,
        synergy_onset=rng.uniform(*ranges.synergy_onset),
        synergy_elbow_flexion=severity(ranges.synergy_elbow_flexion),
        synergy_abduction=severity(ranges.synergy_abduction),
        trunk_forward=severity(ranges.trunk_forward),
        trunk_lateral=severity(ranges.trunk_lean),
        trunk_rotation=severity(ranges.trunk_lean),
        shoulder_hiking=severity(ranges.shoulder_hiking),
        tremor_frequency=tremor[0],
        tremor_amplitude=tremor[1],
        duration_cv=rng.uniform(*ranges.duration_cv),
        hold_time=rng.uniform(0.5, 1.5),
        return_time=rise * rng.uniform(0.8, 1.1),
    )


def sample_profile(group: Group, *, rng: np.random.Generator, affected_side: Side | None = None) -> SubjectProfile:
    """Draw a subject of ``group`` with every parameter from the fma.md ranges of that group.

    Parameters
    ----------
    group : Group
    rng : numpy.random.Generator
    affected_side : Side, optional
        Paretic side of a patient; drawn at random when None. Must be None for HEALTHY.

    Returns
    -------
    SubjectProfile
        Within a group, trunk compensation, shoulder hiking and synergy grow with the missing
        shoulder range. A patient's unaffected side draws healthy parameters, 5-25 % slower, with
        a second velocity peak more often. 15 % of moderate-severe patients have a 3-6 Hz,
        2-5 mm tremor on the affected side.
    """
    if not isinstance(group, Group):
        raise BadInputError(f"group must be a Group ({', '.join(g.name for g in Group)}), got {group!r}")
    if affected_side is not None and not isinstance(affected_side, Side):
        raise BadInputError(f"affected_side must be Side.LEFT, Side.RIGHT or None, got {affected_side!r}")
    if group is Group.HEALTHY:
        if affected_side is not None:
            raise BadInputError("a healthy subject has no affected side; pass affected_side=None")
    elif affected_side is None:
        affected_side = Side.LEFT if rng.random() < 0.5 else Side.RIGHT

    tremor = (0.0, 0.0)
    if group is Group.MODERATE_SEVERE and rng.random() < _TREMOR_PREVALENCE:
        tremor = (rng.uniform(3.0, 6.0), rng.uniform(0.002, 0.005))

    def side_profile(movement: Movement, side: Side) -> MovementProfile:
        if side is affected_side:
            return _draw(_RANGES[group, movement], group, tremor, rng=rng)
        profile = _draw(_RANGES[Group.HEALTHY, movement], Group.HEALTHY, (0.0, 0.0), rng=rng)
        if group is Group.HEALTHY:
            return profile
        slowing = rng.uniform(*_UNAFFECTED_SLOWING)
        return replace(
            profile,
            rise_time=profile.rise_time * slowing,
            return_time=profile.return_time * slowing,
            n_submovements=max(profile.n_submovements, 2 if rng.random() < 2 * _HEALTHY_SECOND_UNIT else 1),
        )

    return SubjectProfile(
        group=group,
        affected_side=affected_side,
        salute_left=side_profile(Movement.SALUTE, Side.LEFT),
        salute_right=side_profile(Movement.SALUTE, Side.RIGHT),
        hand_lift_left=side_profile(Movement.HAND_LIFT, Side.LEFT),
        hand_lift_right=side_profile(Movement.HAND_LIFT, Side.RIGHT),
    )
