"""Motion scripts: continuous-time trajectories of the humanoid's clinical coordinates.

A :class:`Motion` is a function of time, ``sample(t) -> (T, K)`` over
:data:`sim.coordinates.COORDINATES`, built from segments (:func:`idle`,
:func:`calibration_turn`, :func:`salute`, :func:`hand_lift`) joined by :func:`compose`. Every
segment starts and ends standing at rest with zero velocity, so a composed session is C1. Each
motion carries its :class:`Repetition` annotations as ground truth for segmentation.

Joint angles move along minimum-jerk profiles; a patient's along a sum of overlapping
minimum-jerk submovements (:func:`submovement_profile`). Healthy and patient motion come from the
same functions: the :class:`sim.patient_motion.MovementProfile` passed in makes the difference.

The shoulder is a Y-X-Y sequence (:mod:`sim.humanoid`): an arm elevated in plane ``sh_plane``
without axial twist has ``sh_rotation = sh_plane``, so a clinical external rotation ``er`` is
written ``sh_rotation = sh_plane + er`` throughout.
"""

from __future__ import annotations

import math

import numpy as np

from fusion.errors import BadInputError
from sim.coordinates import ARM, INDEX
from sim.patient_motion import Movement, MovementProfile, Side
from sim.submovements import check_count, check_duration, ramp, submovement_profile
from sim.timeline import Coupled, K, Motion, Move, Oscillation, Repetition

_deg = math.radians


# Levers turning the profile's displacements into angles, for the humanoid of a 1.75 m subject.
_STERNUM_LEVER = 0.48
"""Trunk pivot (hip centres) to the sternal notch, m (trunk forward displacement -> trunk flexion)."""


_CLAVICLE_LEVER = 0.18
"""Clavicle pivot (sternal notch) to the shoulder, sideways, m (shoulder hiking -> clavicle elevation)."""


_ARM_LEVER = 0.64
"""Shoulder to hand, m (tremor amplitude at the hand -> shoulder angle)."""


_MAX_LEAD = 0.2
"""Trunk and shoulder-girdle compensation starts up to this long before the arm, s."""


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
    duration = check_duration(duration, "duration")
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
    duration = check_duration(duration, "duration")
    if duration < _MIN_TURN:
        raise BadInputError(f"a calibration turn needs at least {_MIN_TURN} s, got {duration}")
    margin = 0.5
    turn_start, turn_time = margin, duration - 2 * margin
    direction = 1.0 if rng.random() < 0.5 else -1.0
    moves = [Move(turn_start, _pose(root_yaw=direction * 2 * np.pi), ramp(turn_time))]

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
            Move(t, lift, ramp(0.5 * step_time)),
            Move(t + 0.5 * step_time, -lift, ramp(0.5 * step_time)),
            Move(t, shift, ramp(step_time)),
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
            moves += [Move(t, raise_, ramp(up)), Move(t + up + hold, -raise_, ramp(down))]
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
    moves = [Move(0.0, ready, ramp(prep_time))]
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
            Move(t_arm, arm, up),
            Move(t, compensation, ramp(lead + rise)),
            Move(t_down, -arm, down),
            Move(t_down, -compensation, ramp(lower)),
        ]
        if synergy is not None:
            moves += [
                Move(t_arm, synergy, Coupled(up, onset, lowering=False)),
                Move(t_down, -synergy, Coupled(down, onset, lowering=True)),
            ]
        reps.append(Repetition(movement, side, index, t, t_arm + rise, t_down + lower))
        t = t_down + lower + rest
    moves.append(Move(t, -ready, ramp(prep_time)))
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
) -> tuple[Oscillation, ...]:
    """Vertical and horizontal (twist-free) arm oscillations at the tremor frequency, random phases."""
    if profile.tremor_amplitude == 0.0:
        return ()
    angle = profile.tremor_amplitude / _ARM_LEVER
    directions = (_pose(side, sh_elevation=angle), _pose(side, sh_plane=angle, sh_rotation=angle))
    return tuple(
        Oscillation(weights, profile.tremor_frequency, rng.uniform(0, 2 * np.pi), 0.0, duration)
        for weights in directions
    )


def _postural(duration: float, rng: np.random.Generator) -> tuple[Oscillation, ...]:
    """Breathing (0.2-0.33 Hz, shoulders rise 0.4-0.8 degrees) and slow sway (0.05-0.3 Hz)."""
    breath = _deg(rng.uniform(0.4, 0.8))
    terms = [
        Oscillation(
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
        terms.append(Oscillation(_pose(**{name: amplitude}), frequency, phase, 0.0, duration))
    return tuple(terms)


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


def _check_movement(side: Side, repetitions: int, profile: MovementProfile, rest: float) -> None:
    if not isinstance(side, Side):
        raise BadInputError(f"side must be Side.LEFT or Side.RIGHT, got {side!r}")
    check_count(repetitions, "repetitions")
    if not isinstance(profile, MovementProfile):
        raise BadInputError(f"profile must be a MovementProfile, got {type(profile).__name__}")
    if isinstance(rest, bool) or not isinstance(rest, (int, float)) or not math.isfinite(rest) or rest < 0:
        raise BadInputError(f"rest must be a number of seconds >= 0, got {rest!r}")
