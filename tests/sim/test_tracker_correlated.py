"""Tracker model: slow correlated error, bone rigidity and low-confidence runs, against oracles."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings

from fusion.errors import BadInputError
from fusion.topology import K4ABT, KINECT_V2, TrackingState
from sim.tracker_bones import hold_bone_lengths
from sim.tracker_noise import GroupNoise, JointGroup, TrackerNoise, ar1, joint_groups
from tests.sim.test_tracker import quiet, run
from tests.strategies import seeds


def _only(noise: TrackerNoise, **group_changes) -> TrackerNoise:
    return quiet(dataclasses.replace(noise, flip_enabled=False), **({"jitter_m": 0.0, "bias_m": (0.0, 0.0)} | group_changes))


def test_ar1_oracle() -> None:
    a = 0.9
    x = ar1((20000, 4), a, np.random.default_rng(0))
    assert x.shape == (20000, 4)
    assert np.var(x) == pytest.approx(1.0, rel=0.1)
    lag1 = np.mean(x[1:] * x[:-1]) / np.mean(x * x)
    assert lag1 == pytest.approx(a, abs=0.02)
    with pytest.raises(BadInputError, match="coefficient"):
        ar1((3,), 1.0, np.random.default_rng(0))


def test_wobble_std_and_correlation() -> None:
    noise = dataclasses.replace(_only(TrackerNoise.none(), wobble_m=0.01), wobble_tau_s=0.5)
    stream, truth, *_ = run(KINECT_V2, np.zeros(6000), noise, seed=2)
    err = stream.positions - truth.joints_cam
    assert np.std(err) == pytest.approx(0.01, rel=0.1)
    e = err[:, 0, 0]
    assert np.corrcoef(e[1:], e[:-1])[0, 1] == pytest.approx(np.exp(-1 / 30 / 0.5), abs=0.03)


@pytest.mark.parametrize("rigidity", [0.0, 0.5, 1.0])
def test_bone_rigidity_scales_length_spread(rigidity: float) -> None:
    rng = np.random.default_rng(3)
    p = np.cumsum(rng.standard_normal((200, K4ABT.n_joints, 3)) * 0.001, axis=0) + rng.uniform(-1, 1, (K4ABT.n_joints, 3))
    reported = np.ones(p.shape[:2], dtype=bool)
    out = hold_bone_lengths(p, reported, K4ABT, rigidity)
    parents = np.asarray(K4ABT.parents)
    j = int(np.flatnonzero(parents >= 0)[3])
    before = np.linalg.norm(p[:, j] - p[:, parents[j]], axis=-1)
    after = np.linalg.norm(out[:, j] - out[:, parents[j]], axis=-1)
    np.testing.assert_allclose(after - np.median(before), (1 - rigidity) * (before - np.median(before)), atol=1e-9)
    root = int(np.flatnonzero(parents < 0)[0])
    np.testing.assert_array_equal(out[:, root], p[:, root])


@settings(max_examples=10)
@given(seeds)
def test_low_confidence_share(seed: int) -> None:
    noise = _only(TrackerNoise.none())
    groups = dict(noise.groups)
    groups[JointGroup.HAND] = dataclasses.replace(groups[JointGroup.HAND], low_confidence=(0.3, 0.3))
    stream, *_ = run(KINECT_V2, np.zeros(3000), dataclasses.replace(noise, groups=groups), seed=seed)
    hand = np.array([g is JointGroup.HAND for g in joint_groups(KINECT_V2)])
    share = np.mean(stream.states[:, hand] == TrackingState.INFERRED)
    assert share == pytest.approx(0.3, abs=0.12)
    assert np.all(stream.states[:, ~hand] == TrackingState.TRACKED)


def test_bad_parameters() -> None:
    with pytest.raises(BadInputError, match="wobble_m"):
        GroupNoise((0, 0), 0.0, 0.0, (0, 0), wobble_m=-1.0)
    with pytest.raises(BadInputError, match="low_confidence"):
        GroupNoise((0, 0), 0.0, 0.0, (0, 0), low_confidence=(0.5, 1.5))
    with pytest.raises(BadInputError, match="bone_rigidity"):
        GroupNoise((0, 0), 0.0, 0.0, (0, 0), bone_rigidity=2.0)
    with pytest.raises(BadInputError, match="wobble_tau_s"):
        TrackerNoise(wobble_tau_s=0.0)


def test_ar1_scale_sets_the_spread() -> None:
    a = 0.5
    scale = np.r_[np.ones(20000), 3 * np.ones(20000)][:, None]
    x = ar1((40000, 3), a, np.random.default_rng(1), scale=scale)
    assert np.std(x[1000:20000]) == pytest.approx(1.0, rel=0.05)
    assert np.std(x[21000:]) == pytest.approx(3.0, rel=0.05)


def test_speed_scales_the_noise() -> None:
    noise = _only(TrackerNoise.none(), jitter_m=0.002)
    T = 600
    root = np.column_stack([0.05 * np.arange(T) / 30.0, np.zeros(T)])  # walks 0.05 m/s along x
    plain, truth, *_ = run(KINECT_V2, np.zeros(T), noise, seed=4, root_xy=root)
    fast, truth_fast, *_ = run(KINECT_V2, np.zeros(T), dataclasses.replace(noise, speed_ref_m_s=0.05), seed=4,
                               root_xy=root)
    # every joint moves at 0.05 m/s: the same draws, doubled
    np.testing.assert_allclose(fast.positions - truth_fast.joints_cam, 2 * (plain.positions - truth.joints_cam),
                               atol=1e-9)
    with pytest.raises(BadInputError, match="speed_ref_m_s"):
        TrackerNoise(speed_ref_m_s=-1.0)


def test_speed_gain_oracle() -> None:
    from sim.tracker import speed_gain

    t = np.arange(100) / 30
    joints = np.zeros((100, 2, 3))
    joints[:, 1, 0] = 0.6 * t  # 0.6 m/s along x
    gain = speed_gain(joints, t, 0.2)
    np.testing.assert_allclose(gain[:, 0], 1.0)
    np.testing.assert_allclose(gain[:, 1], 4.0)
    np.testing.assert_array_equal(speed_gain(joints, t, 0.0), np.ones((100, 2)))


@pytest.mark.parametrize("share", [0.0, 1.0])
def test_hidden_low_confidence_share(share: float) -> None:
    noise = _only(TrackerNoise.none(), hidden_low_confidence=share)
    T, J = 600, KINECT_V2.n_joints
    hidden = np.zeros((T, J), dtype=bool)
    hidden[:, :5] = True
    stream, *_ = run(KINECT_V2, np.zeros(T), noise, seed=5, visibility=~hidden)
    inferred = stream.states == TrackingState.INFERRED
    assert np.mean(inferred[:, :5]) == pytest.approx(share, abs=0.05)
    assert not inferred[:, 5:].any()
    with pytest.raises(BadInputError, match="hidden_low_confidence"):
        GroupNoise((0, 0), 0.0, 0.0, (0, 0), hidden_low_confidence=1.5)


def test_bone_rigidity_per_child() -> None:
    rng = np.random.default_rng(6)
    p = rng.uniform(-1, 1, (300, K4ABT.n_joints, 3))
    reported = np.ones(p.shape[:2], dtype=bool)
    r = np.zeros(K4ABT.n_joints)
    parents = np.asarray(K4ABT.parents)
    j = int(np.flatnonzero(parents >= 0)[5])
    r[j] = 1.0
    out = hold_bone_lengths(p, reported, K4ABT, r)
    length = np.linalg.norm(out[:, j] - out[:, parents[j]], axis=-1)
    np.testing.assert_allclose(length, length[0], atol=1e-9)
    k = int(np.flatnonzero(parents >= 0)[0])
    before = np.linalg.norm(p[:, k] - p[:, parents[k]], axis=-1)
    after = np.linalg.norm(out[:, k] - out[:, parents[k]], axis=-1)
    np.testing.assert_allclose(after, before, atol=1e-9)


def test_activity_scales_view_bias_jitter_and_wobble() -> None:
    noise = dataclasses.replace(_only(TrackerNoise.none(), jitter_m=0.002, wobble_m=0.003, bias_m=(0.01, 0.02)),
                                model_fraction=0.0)  # all of the bias is the view bias
    T = 600
    root = np.column_stack([0.05 * np.arange(T) / 30.0, np.zeros(T)])  # every joint at 0.05 m/s
    plain, truth, *_ = run(KINECT_V2, np.zeros(T), noise, seed=7, root_xy=root)
    busy, truth_busy, *_ = run(KINECT_V2, np.zeros(T), dataclasses.replace(
        noise, activity_exponent=2.0, activity_ref_m_s=0.025, activity_range_m_s=(0.01, 0.1)), seed=7, root_xy=root)
    # activity 0.05 m/s, twice the reference: (2) ** 2 = 4 times the same draws
    np.testing.assert_allclose(busy.positions - truth_busy.joints_cam, 4 * (plain.positions - truth.joints_cam),
                               atol=1e-9)
    with pytest.raises(BadInputError, match="activity_ref_m_s"):
        TrackerNoise(activity_ref_m_s=0.5)  # outside the default range


def test_session_activity_oracle() -> None:
    from sim.tracker import activity_factor, session_activity

    t = np.arange(100) / 30
    joints = np.zeros((100, 4, 3))
    joints[:, 1, 0] = 0.8 * t  # one joint of four at 0.8 m/s
    assert session_activity(joints, t) == pytest.approx(0.2)
    assert session_activity(joints[:1], t[:1]) == 0.0
    noise = TrackerNoise(activity_exponent=1.5, activity_ref_m_s=0.05, activity_range_m_s=(0.05, 0.4))
    assert activity_factor(joints, t, noise) == pytest.approx(4.0 ** 1.5)
    assert activity_factor(joints, t, TrackerNoise()) == 1.0
    # beyond the fitted range the factor stays at the range's end: no extrapolation
    assert activity_factor(joints, t, dataclasses.replace(noise, activity_range_m_s=(0.05, 0.1))) == \
        pytest.approx(2.0 ** 1.5)
    assert activity_factor(np.zeros((100, 4, 3)), t, noise) == 1.0


def test_a_groups_own_activity_exponent_scales_its_jitter_and_wobble_only() -> None:
    noise = dataclasses.replace(_only(TrackerNoise.none(), jitter_m=0.002, wobble_m=0.003),
                                activity_ref_m_s=0.025, activity_range_m_s=(0.01, 0.1))
    T = 600
    root = np.column_stack([0.05 * np.arange(T) / 30.0, np.zeros(T)])  # every joint at 0.05 m/s
    plain, truth, *_ = run(KINECT_V2, np.zeros(T), noise, seed=7, root_xy=root)
    groups = {**noise.groups, JointGroup.TORSO: dataclasses.replace(noise.groups[JointGroup.TORSO], activity_exponent=1.0)}
    busy, truth_busy, *_ = run(KINECT_V2, np.zeros(T), dataclasses.replace(noise, groups=groups), seed=7, root_xy=root)
    torso = np.array(joint_groups(KINECT_V2)) == JointGroup.TORSO
    err, err_busy = plain.positions - truth.joints_cam, busy.positions - truth_busy.joints_cam
    # activity twice the reference: the torso's errors twice the same draws, the others' unchanged
    np.testing.assert_allclose(err_busy[:, torso], 2 * err[:, torso], atol=1e-9)
    np.testing.assert_allclose(err_busy[:, ~torso], err[:, ~torso], atol=1e-9)
    with pytest.raises(BadInputError, match="activity_exponent must lie in"):
        dataclasses.replace(noise.groups[JointGroup.TORSO], activity_exponent=float("nan"))
