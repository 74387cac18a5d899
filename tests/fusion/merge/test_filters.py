import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fusion.errors import BadInputError
from fusion.merge.filters import (
    KalmanParams,
    OneEuroParams,
    TemporalFilter,
    enforce_bone_lengths,
    median_bone_lengths,
    smooth,
)
from fusion.merge.methods import MergedSkeleton, Reliability
from fusion.topology import KINECT_V2
from tests.fusion.skeleton_fakes import Motion
from tests.strategies import seeds

TOPO = KINECT_V2


def _merged(positions: np.ndarray, times: np.ndarray | None = None, reliability=None) -> MergedSkeleton:
    T, J = positions.shape[:2]
    present = ~np.isnan(positions).any(-1)
    if reliability is None:
        reliability = np.where(present, Reliability.HIGH, Reliability.NONE).astype(np.int8)
    times = np.arange(T) / 30 if times is None else times
    return MergedSkeleton(times, positions, reliability, present.astype(np.int16), np.full((T, J), -1))


def _line(T: int = 300, J: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Times (T,) and (T, J, 3) joints moving along straight lines at about 1 m/s."""
    t = np.arange(T) / 30
    velocity = np.array([[0.8, 0.5, -0.3], [-0.2, 0.1, 0.9]])[:J]
    return t, np.array([0.1, 1.0, 2.0]) + t[:, None, None] * velocity


def _rms(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.nanmean(np.sum((a - b) ** 2, axis=-1))))


# ---------------------------------------------------------------- Kalman


@pytest.mark.parametrize("smoother", [True, False])
def test_kalman_reduces_jitter_on_a_noisy_straight_line(smoother):
    t, truth = _line()
    noisy = truth + np.random.default_rng(0).normal(0, 0.01, truth.shape)
    out = smooth(_merged(noisy, t), TemporalFilter.KALMAN, kalman=KalmanParams(smoother=smoother))
    settled = slice(30, None)  # after the start-up transient
    assert _rms(out.positions[settled], truth[settled]) < (0.55 if smoother else 0.85) * _rms(noisy, truth)
    np.testing.assert_array_equal(out.reliability, Reliability.HIGH)


def test_kalman_bridges_a_short_gap_by_prediction():
    t, truth = _line()
    noisy = truth + np.random.default_rng(1).normal(0, 0.005, truth.shape)
    rel = np.full(truth.shape[:2], Reliability.HIGH, np.int8)
    gap = slice(100, 106)  # 0.2 s
    noisy[gap], rel[gap] = np.nan, Reliability.NONE
    out = smooth(_merged(noisy, t, rel), TemporalFilter.KALMAN)
    assert np.isfinite(out.positions).all()
    assert np.linalg.norm(out.positions[gap] - truth[gap], axis=-1).max() < 0.01
    np.testing.assert_array_equal(out.reliability[gap], Reliability.LOW)
    np.testing.assert_array_equal(out.n_cameras[gap], 0)


def test_kalman_leaves_long_gaps_and_the_ends_nan_and_restarts():
    t, truth = _line(120, 1)
    z = truth.copy()
    z[:5] = z[40:70] = z[-3:] = np.nan  # 1 s gap > max_gap_s
    out = smooth(_merged(z, t), TemporalFilter.KALMAN)
    np.testing.assert_array_equal(np.isnan(out.positions), np.isnan(z))
    np.testing.assert_allclose(out.positions[70], truth[70], atol=0.02)  # restarted at the measurement


def test_kalman_trusts_reliable_measurements_more():
    t = np.arange(60) / 30
    z = np.zeros((60, 1, 3))
    z[30, 0, 0] = 0.1  # one spike
    pull = {}
    for level in (Reliability.HIGH, Reliability.BACK_POSE):
        rel = np.full((60, 1), Reliability.HIGH, np.int8)
        rel[30] = level
        pull[level] = smooth(_merged(z, t, rel), TemporalFilter.KALMAN).positions[30, 0, 0]
    assert 0 < pull[Reliability.BACK_POSE] < 0.5 * pull[Reliability.HIGH]


@given(seeds, st.sampled_from([TemporalFilter.KALMAN, TemporalFilter.ONE_EURO]))
def test_filters_keep_a_still_skeleton_still(seed, method):
    rng = np.random.default_rng(seed)
    pose = rng.uniform(-2, 2, (1, 5, 3))
    z = np.repeat(pose, 20, axis=0)
    z[rng.random(z.shape[:2]) < 0.2] = np.nan
    out = smooth(_merged(z), method)
    finite = np.isfinite(out.positions).all(-1)
    assert (finite >= np.isfinite(z).all(-1)).all()
    np.testing.assert_allclose(out.positions[finite], np.broadcast_to(pose, z.shape)[finite], atol=1e-9)


# ---------------------------------------------------------------- One-Euro


def test_one_euro_reduces_jitter_at_rest_and_keeps_gaps():
    rng = np.random.default_rng(2)
    truth = np.broadcast_to([0.3, 1.2, 2.0], (200, 1, 3))
    z = truth + rng.normal(0, 0.01, truth.shape)
    z[50:53] = np.nan
    out = smooth(_merged(z), TemporalFilter.ONE_EURO)
    np.testing.assert_array_equal(np.isnan(out.positions), np.isnan(z))
    assert _rms(out.positions[20:], truth[20:]) < 0.5 * _rms(z[20:], truth[20:])


def test_one_euro_follows_fast_motion_with_little_lag():
    t, truth = _line(120, 1)
    out = smooth(_merged(truth, t), TemporalFilter.ONE_EURO, one_euro=OneEuroParams(beta=50.0))
    assert np.linalg.norm(out.positions[30:] - truth[30:], axis=-1).max() < 0.01


# ---------------------------------------------------------------- smooth: API


def test_smooth_none_is_identity_and_bad_arguments_raise():
    m = _merged(_line()[1])
    assert smooth(m, TemporalFilter.NONE) is m
    with pytest.raises(BadInputError):
        smooth(m, "kalman")
    for bad in (dict(acceleration_psd=0.0), dict(measurement_std_low_m=-1.0), dict(max_gap_s=np.inf)):
        with pytest.raises(BadInputError):
            KalmanParams(**bad)
    for bad in (dict(min_cutoff_hz=0.0), dict(beta=-1.0)):
        with pytest.raises(BadInputError):
            OneEuroParams(**bad)


def test_smooth_handles_empty_and_all_nan_streams():
    for method in TemporalFilter:
        assert smooth(_merged(np.zeros((0, 3, 3))), method).positions.shape == (0, 3, 3)
        assert np.isnan(smooth(_merged(np.full((5, 3, 3), np.nan)), method).positions).all()


# ---------------------------------------------------------------- bone lengths


def _rigid_motion(seed: int, T: int = 40) -> np.ndarray:
    return Motion.random(rng=np.random.default_rng(seed)).joints(np.arange(T) / 30)


def _lengths(p: np.ndarray) -> np.ndarray:
    bones = TOPO.bones
    return np.linalg.norm(p[:, bones[:, 1]] - p[:, bones[:, 0]], axis=-1)


@given(seeds)
def test_enforced_bone_lengths_are_constant_and_the_medians(seed):
    rng = np.random.default_rng(seed)
    noisy = _rigid_motion(seed) + rng.normal(0, 0.02, (40, TOPO.n_joints, 3))
    m = _merged(noisy)
    out = enforce_bone_lengths(m, TOPO)
    lengths = _lengths(out.positions)
    assert lengths.std(axis=0).max() < 1e-9
    np.testing.assert_allclose(lengths[0], np.median(_lengths(noisy), axis=0), atol=1e-12)
    np.testing.assert_array_equal(out.positions[:, 0], noisy[:, 0])  # the root stays
    np.testing.assert_array_equal(out.reliability, m.reliability)


@given(seeds)
def test_enforcing_bone_lengths_leaves_a_rigid_skeleton_unchanged(seed):
    rigid = _rigid_motion(seed)
    np.testing.assert_allclose(enforce_bone_lengths(_merged(rigid), TOPO).positions, rigid, atol=1e-12)


def test_bone_enforcement_keeps_absent_joints_and_orphans():
    p = _rigid_motion(0, 10) + np.random.default_rng(0).normal(0, 0.01, (10, TOPO.n_joints, 3))
    elbow, wrist = TOPO.index("ElbowLeft"), TOPO.index("WristLeft")
    p[3, elbow] = np.nan
    out = enforce_bone_lengths(_merged(p), TOPO).positions
    assert np.isnan(out[3, elbow]).all()
    np.testing.assert_array_equal(out[3, wrist], p[3, wrist])  # parent absent: kept as it was
    assert np.isfinite(out[np.arange(10) != 3]).all()


def test_median_bone_lengths_respect_min_reliability_and_topology():
    p = np.repeat(np.linspace(0, 1, TOPO.n_joints)[None, :, None] * [1.0, 0, 0], 4, axis=0)
    p[0] *= 2  # one frame with doubled lengths, and it is the only HIGH one
    rel = np.full((4, TOPO.n_joints), Reliability.LOW, np.int8)
    rel[0] = Reliability.HIGH
    m = _merged(p, reliability=rel)
    child = TOPO.bones[:, 1]
    expected = np.abs(p[1, child, 0] - p[1, TOPO.bones[:, 0], 0])
    np.testing.assert_allclose(median_bone_lengths(m, TOPO)[child], expected)
    np.testing.assert_allclose(median_bone_lengths(m, TOPO, min_reliability=Reliability.HIGH)[child], 2 * expected)
    assert np.isnan(median_bone_lengths(m, TOPO)[0])
    with pytest.raises(BadInputError):
        enforce_bone_lengths(_merged(np.zeros((2, 3, 3))), TOPO)


@given(seed=seeds)
def test_one_euro_steps_frame_by_frame_give_the_batch_filter(seed):
    from fusion.merge.filters import OneEuroFilter

    rng = np.random.default_rng(seed)
    times = np.cumsum(rng.uniform(0.01, 0.4, 40))
    z = rng.normal(size=(40, 4, 3))
    z[rng.random((40, 4)) < 0.2] = np.nan
    step = OneEuroFilter(4).step
    frames = np.array([step(t, p) for t, p in zip(times, z)])
    batch = smooth(_merged(z, times), TemporalFilter.ONE_EURO).positions
    assert frames.shape == (40, 4, 3)
    assert np.array_equal(frames, batch, equal_nan=True)
    with pytest.raises(BadInputError):
        step(times[-1] + 1, np.zeros((5, 3)))
