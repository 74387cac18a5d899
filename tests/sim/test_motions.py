"""Tests of sim.patient_motion and sim.motions: profiles, submovements, segments, annotations, humanoid oracle."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.signal import find_peaks

from fusion.errors import BadInputError
from fusion.topology import K4ABT, KINECT_V2, Topology
from sim.coordinates import COORDINATES, INDEX
from sim.motions import calibration_turn, hand_lift, idle, salute
from sim.patient_motion import (
    Group,
    Movement,
    MovementProfile,
    Side,
    SubjectProfile,
    sample_profile,
)
from sim.submovements import minimum_jerk, submovement_profile
from sim.timeline import K, Motion, Repetition, compose

HEALTHY = SubjectProfile.healthy()
LIFT = MovementProfile.healthy(Movement.HAND_LIFT)
SALUTE = MovementProfile.healthy(Movement.SALUTE)
seeds = st.integers(0, 2**32 - 1)


def rng(seed: int = 0) -> np.random.Generator:
    return np.random.default_rng(seed)


def column(name: str, side: Side) -> int:
    return INDEX[f"{name}_{side.value}"]


def session(seed: int) -> Motion:
    r = rng(seed)
    patient = sample_profile(Group.MODERATE_SEVERE, rng=r, affected_side=Side.LEFT)
    return compose(
        [
            idle(2.0, rng=r),
            calibration_turn(8.0, rng=r),
            salute(Side.RIGHT, 2, patient.salute_right, rng=r),
            hand_lift(Side.LEFT, 3, patient.hand_lift_left, rng=r),
            idle(1.0, rng=r),
        ]
    )


# --- minimum jerk and submovements ------------------------------------------------------------------


def test_minimum_jerk_boundaries_and_clipping():
    np.testing.assert_allclose(minimum_jerk([-1.0, 0.0, 0.5, 1.0, 2.0]), [0.0, 0.0, 0.5, 1.0, 1.0])
    h = 1e-4
    speed = (minimum_jerk([h, 1.0]) - minimum_jerk([0.0, 1.0 - h])) / h
    np.testing.assert_allclose(speed, 0.0, atol=1e-6)
    tau = np.linspace(0, 1, 1001)
    assert np.all(np.diff(minimum_jerk(tau)) >= 0)
    assert np.gradient(minimum_jerk(tau), tau).max() == pytest.approx(1.875, abs=1e-4)


@given(st.floats(0.0, 1.0))
def test_minimum_jerk_is_point_symmetric(tau):
    assert minimum_jerk(tau) + minimum_jerk(1.0 - tau) == pytest.approx(1.0, abs=1e-12)


@given(seeds, st.integers(1, 8), st.floats(0.0, 1.0), st.floats(0.25, 0.5))
def test_submovement_peaks_and_time_to_peak_velocity(seed, n, stretch, fraction):
    duration = max(0.3, 0.45 * n) + stretch * 4.0  # well separated: >= 0.45 s per submovement
    profile = submovement_profile(duration, n, fraction, rng=rng(seed))
    t = np.linspace(0.0, duration, 6001)
    s = profile.sample(t)
    speed = np.gradient(s, t)
    assert profile.duration == pytest.approx(duration)
    assert s[0] == 0.0 and s[-1] == pytest.approx(1.0, abs=1e-12)
    assert np.all(np.diff(s) >= -1e-12)
    peaks, _ = find_peaks(speed, prominence=1e-3 * speed.max())
    assert len(peaks) == n
    assert t[np.argmax(speed)] / duration == pytest.approx(fraction, abs=2e-3)


def test_submovement_profile_bad_input():
    with pytest.raises(BadInputError):
        submovement_profile(-1.0, 2, 0.4, rng=rng())
    with pytest.raises(BadInputError):
        submovement_profile(2.0, 0, 0.4, rng=rng())
    with pytest.raises(BadInputError):
        submovement_profile(2.0, 2, 1.0, rng=rng())


# --- profiles -------------------------------------------------------------------------------------


def test_movement_profile_validates_ranges():
    with pytest.raises(BadInputError):
        dataclasses.replace(LIFT, rise_time=-1.0)
    with pytest.raises(BadInputError):
        dataclasses.replace(LIFT, n_submovements=2.5)
    with pytest.raises(BadInputError):
        dataclasses.replace(LIFT, peak_elevation=math.nan)
    with pytest.raises(BadInputError):
        dataclasses.replace(LIFT, tremor_amplitude=0.003, tremor_frequency=0.0)
    with pytest.raises(BadInputError):
        MovementProfile.healthy(Movement.IDLE)


def test_subject_profile_group_and_side_agree():
    with pytest.raises(BadInputError):
        dataclasses.replace(HEALTHY, affected_side=Side.LEFT)
    with pytest.raises(BadInputError):
        dataclasses.replace(HEALTHY, group=Group.MILD)
    with pytest.raises(BadInputError):
        sample_profile(Group.HEALTHY, rng=rng(), affected_side=Side.RIGHT)
    with pytest.raises(BadInputError):
        HEALTHY.movement(Movement.SALUTE, "r")
    assert HEALTHY.movement(Movement.HAND_LIFT, Side.RIGHT) is HEALTHY.hand_lift_right


@given(seeds, st.sampled_from(Group))
def test_sampled_profiles_follow_the_fma_ranges(seed, group):
    subject = sample_profile(group, rng=rng(seed))
    assert subject.group is group and (subject.affected_side is None) == (group is Group.HEALTHY)
    units = {Group.HEALTHY: (1, 2), Group.MILD: (2, 4), Group.MODERATE_SEVERE: (3, 8)}[group]
    flexion = {Group.HEALTHY: (85, 95), Group.MILD: (75, 95), Group.MODERATE_SEVERE: (40, 80)}[group]
    rise = {Group.HEALTHY: (0.9, 1.5), Group.MILD: (1.3, 2.5), Group.MODERATE_SEVERE: (2.0, 5.0)}[group]
    lift = subject.movement(Movement.HAND_LIFT, subject.affected_side or Side.RIGHT)
    assert units[0] <= lift.n_submovements <= units[1]
    assert flexion[0] <= math.degrees(lift.peak_elevation) <= flexion[1]
    assert rise[0] <= lift.rise_time <= rise[1]
    if group is not Group.HEALTHY:
        other = subject.movement(Movement.HAND_LIFT, Side.LEFT if subject.affected_side is Side.RIGHT else Side.RIGHT)
        assert other.rise_time >= 0.9 * 1.05 and math.degrees(other.synergy_elbow_flexion) <= 10


# --- segments -------------------------------------------------------------------------------------


@pytest.mark.parametrize("side", list(Side))
def test_healthy_hand_lift_reaches_the_profile_peak_with_a_straight_elbow(side):
    motion = hand_lift(side, 2, LIFT, rng=rng())
    x = motion.sample(np.arange(0.0, motion.duration, 0.005))
    peak = math.degrees(x[:, column("sh_elevation", side)].max())
    assert peak == pytest.approx(math.degrees(LIFT.peak_elevation), abs=1.0)
    assert math.degrees(x[:, column("elbow_flexion", side)].max()) < 10.0
    other = Side.LEFT if side is Side.RIGHT else Side.RIGHT
    assert np.abs(x[:, column("sh_elevation", other)]).max() == 0.0


def test_patient_synergy_starts_past_the_onset_angle():
    profile = dataclasses.replace(
        LIFT, peak_elevation=math.radians(80), synergy_onset=math.radians(50), synergy_elbow_flexion=math.radians(25)
    )
    motion = hand_lift(Side.RIGHT, 1, profile, rng=rng())
    x = motion.sample(np.linspace(0.0, motion.duration, 4001))
    elevation, elbow = x[:, column("sh_elevation", Side.RIGHT)], x[:, column("elbow_flexion", Side.RIGHT)]
    assert np.abs(elbow[elevation < profile.synergy_onset]).max() < 1e-9
    assert elbow.max() == pytest.approx(profile.synergy_elbow_flexion)


@pytest.mark.parametrize("frequency", [3.0, 4.5, 6.0])
def test_tremor_shows_in_the_spectrum_at_its_frequency(frequency):
    profile = dataclasses.replace(LIFT, tremor_frequency=frequency, tremor_amplitude=0.003)
    motion = hand_lift(Side.RIGHT, 3, profile, rng=rng(1))
    rate = 100.0
    x = motion.sample(np.arange(0.0, motion.duration, 1 / rate))[:, column("sh_elevation", Side.RIGHT)]
    curvature = np.diff(x, 2)  # suppresses the slow movement
    spectrum = np.abs(np.fft.rfft(curvature * np.hanning(curvature.size)))
    freqs = np.fft.rfftfreq(curvature.size, 1 / rate)
    band = (freqs > 2.0) & (freqs < 20.0)
    assert freqs[band][np.argmax(spectrum[band])] == pytest.approx(frequency, abs=0.1)


def test_same_seed_same_motion_other_seed_other_motion():
    t = np.arange(0.0, 20.0, 1 / 30)
    np.testing.assert_array_equal(session(7).sample(t), session(7).sample(t))
    assert not np.array_equal(session(7).sample(t), session(8).sample(t))


def test_sampling_is_pointwise_at_any_rate_and_order():
    motion = session(3)
    t = np.arange(0.0, motion.duration, 1 / 30)
    x = motion.sample(t)
    assert x.shape == (t.size, K) and x.dtype == np.float64
    shuffled = rng(0).permutation(t.size)
    np.testing.assert_array_equal(motion.sample(t[shuffled]), x[shuffled])
    np.testing.assert_allclose(motion.sample(t[::3]), x[::3])


@given(seeds)
def test_calibration_turn_covers_a_full_turn_in_place(seed):
    motion = calibration_turn(12.0, rng=rng(seed))
    x = motion.sample(np.linspace(0.0, motion.duration, 2401))
    yaw = x[:, INDEX["root_yaw"]]
    assert abs(yaw[-1] - yaw[0]) == pytest.approx(2 * math.pi)
    assert np.all(np.diff(yaw) * np.sign(yaw[-1]) >= -1e-12)
    assert np.hypot(x[:, INDEX["root_x"]], x[:, INDEX["root_y"]]).max() < 0.05
    for side in Side:
        assert math.degrees(x[:, column("knee_flexion", side)].max()) > 30.0
        assert math.degrees(x[:, column("sh_elevation", side)].max()) > 30.0


def test_session_is_c1_and_starts_and_ends_at_rest():
    motion = session(5)
    dt = 1e-3
    x = motion.sample(np.arange(0.0, motion.duration, dt))
    velocity = np.diff(x, axis=0) / dt
    assert np.abs(np.diff(velocity, axis=0)).max() < 0.2  # rad/s per ms: no velocity jumps
    ends = motion.sample(np.array([0.0, motion.duration]))
    not_root = [i for i, name in enumerate(COORDINATES) if not name.startswith("root")]
    np.testing.assert_allclose(ends[:, not_root], 0.0, atol=1e-12)
    assert abs(ends[1, INDEX["root_yaw"]]) == pytest.approx(2 * math.pi)


def test_compose_turns_later_displacements_with_the_facing():
    r = rng(2)
    turn = calibration_turn(6.0, rng=r)
    yaw = turn.sample(np.array([turn.duration]))[0, INDEX["root_yaw"]]
    rest = idle(4.0, rng=r)
    motion = compose([turn, rest])
    t = np.linspace(0.0, rest.duration, 101)
    alone = rest.sample(t)[:, [INDEX["root_x"], INDEX["root_y"]]]
    placed = motion.sample(turn.duration + t)[:, [INDEX["root_x"], INDEX["root_y"]]]
    start = motion.sample(np.array([turn.duration]))[0, [INDEX["root_x"], INDEX["root_y"]]]
    rotation = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    np.testing.assert_allclose(placed - start, alone @ rotation.T, atol=1e-12)


def test_repetitions_are_annotated_in_order_inside_the_span():
    motion = session(11)
    kinds = [(rep.movement, rep.side, rep.index) for rep in motion.repetitions]
    assert kinds == [
        (Movement.IDLE, None, 0),
        (Movement.CALIBRATION, None, 0),
        (Movement.SALUTE, Side.RIGHT, 0),
        (Movement.SALUTE, Side.RIGHT, 1),
        (Movement.HAND_LIFT, Side.LEFT, 0),
        (Movement.HAND_LIFT, Side.LEFT, 1),
        (Movement.HAND_LIFT, Side.LEFT, 2),
        (Movement.IDLE, None, 0),
    ]
    bounds = [(rep.t_start, rep.t_peak, rep.t_end) for rep in motion.repetitions]
    for (start, peak, end), (next_start, _, _) in zip(bounds, bounds[1:] + [(motion.duration, 0, 0)]):
        assert 0.0 <= start < peak < end <= next_start <= motion.duration


def test_repetition_times_mark_rest_and_top():
    r = rng(4)
    profile = sample_profile(Group.MILD, rng=r, affected_side=Side.RIGHT).hand_lift_right
    motion = hand_lift(Side.RIGHT, 3, profile, rng=r)
    elevation = column("sh_elevation", Side.RIGHT)
    for rep in motion.repetitions:
        at = motion.sample(np.array([rep.t_start, rep.t_peak, rep.t_end]))[:, elevation]
        np.testing.assert_allclose(at, [0.0, profile.peak_elevation, 0.0], atol=1e-12)
        before = motion.sample(np.array([rep.t_peak - 0.05]))[0, elevation]
        assert before < profile.peak_elevation


def test_durations_vary_from_trial_to_trial_by_the_profile_cv():
    profile = dataclasses.replace(LIFT, duration_cv=0.2, hold_time=0.0)
    motion = hand_lift(Side.LEFT, 300, profile, rng=rng(9), rest=0.0)
    lengths = np.array([rep.t_end - rep.t_start for rep in motion.repetitions])
    assert np.std(lengths) / np.mean(lengths) == pytest.approx(0.2, rel=0.25)


@pytest.mark.parametrize(
    "call",
    [
        lambda: idle(-1.0, rng=rng()),
        lambda: idle(0.0, rng=rng()),
        lambda: calibration_turn(2.0, rng=rng()),
        lambda: hand_lift("r", 1, LIFT, rng=rng()),
        lambda: salute(None, 1, SALUTE, rng=rng()),
        lambda: hand_lift(Side.LEFT, 0, LIFT, rng=rng()),
        lambda: salute(Side.LEFT, 1.5, SALUTE, rng=rng()),
        lambda: salute(Side.LEFT, True, SALUTE, rng=rng()),
        lambda: hand_lift(Side.LEFT, 1, LIFT, rng=rng(), rest=-0.5),
        lambda: hand_lift(Side.LEFT, 1, HEALTHY, rng=rng()),
        lambda: compose([]),
        lambda: idle(1.0, rng=rng()).sample(np.array([0.5, 1.5])),
        lambda: idle(1.0, rng=rng()).sample(np.zeros((2, 2))),
        lambda: Repetition(Movement.SALUTE, None, 0, 0.0, 1.0, 2.0),
        lambda: Repetition(Movement.IDLE, None, 0, 2.0, 1.0, 3.0),
    ],
)
def test_bad_input_raises(call):
    with pytest.raises(BadInputError):
        call()


# --- against the humanoid -------------------------------------------------------------------------


@pytest.fixture(scope="module")
def humanoid():
    from sim.anthropometry import Anthropometry
    from sim.humanoid_model import build_humanoid

    return build_humanoid(Anthropometry())


def _points(humanoid, motion: Motion, times: list[float], topology: Topology = K4ABT) -> dict[str, np.ndarray]:
    p = humanoid.joint_positions(motion.sample(np.array(times)), topology)
    return {name: p[:, topology.index(name)] for name in topology.joints}


@pytest.mark.parametrize("side", list(Side))
def test_hand_lift_puts_the_hand_in_front_at_shoulder_height(humanoid, side):
    motion = hand_lift(side, 2, LIFT, rng=rng())
    s = side.name.capitalize()
    for rep in motion.repetitions:
        p = _points(humanoid, motion, [rep.t_start, rep.t_peak], KINECT_V2)
        reach = p[f"Hand{s}"] - p[f"Shoulder{s}"]
        assert reach[1, 0] > 0.55  # in front
        assert abs(reach[1, 2]) < 0.05  # at shoulder height
        assert abs(reach[1, 1]) < 0.08  # in the sagittal plane, within the 5 degree abduction
        assert reach[0, 2] < -0.55  # hanging at the start
        sternum = p["SpineShoulder"][1, 0] - p["SpineShoulder"][0, 0]
        assert sternum == pytest.approx(LIFT.trunk_forward, abs=0.01)


@pytest.mark.parametrize("side", list(Side))
def test_salute_goes_from_the_opposite_knee_to_the_ear(humanoid, side):
    motion = salute(side, 2, SALUTE, rng=rng())
    s, o = side.name, ("RIGHT" if side is Side.LEFT else "LEFT")
    for rep in motion.repetitions:
        p = _points(humanoid, motion, [rep.t_start, rep.t_peak])
        hand = p[f"HAND_{s}"]
        assert np.linalg.norm(hand[1] - p[f"EAR_{s}"][1]) < 0.12
        assert np.linalg.norm(hand[1] - p[f"EAR_{s}"][1]) < np.linalg.norm(hand[1] - p[f"EAR_{o}"][1])
        assert np.linalg.norm(hand[0] - p[f"KNEE_{o}"][0]) < 0.3
        assert np.linalg.norm(hand[0] - p[f"KNEE_{o}"][0]) < np.linalg.norm(hand[0] - p[f"KNEE_{s}"][0])


def test_patient_salute_falls_short_of_the_ear(humanoid):
    profile = dataclasses.replace(SALUTE, peak_elevation=math.radians(50))
    motion = salute(Side.RIGHT, 1, profile, rng=rng())
    rep = motion.repetitions[0]
    p = _points(humanoid, motion, [rep.t_peak])
    assert np.linalg.norm(p["HAND_RIGHT"][0] - p["EAR_RIGHT"][0]) > 0.2
