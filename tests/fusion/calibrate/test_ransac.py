import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fusion.calibrate.ransac import ransac_skeleton_pair
from fusion.calibrate.ransac_result import PairCalibration
from fusion.calibrate.sync import associate
from fusion.errors import BadInputError, CalibrationError
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, Region, TrackingState
from fusion.transforms import apply, compose, from_rotvec, invert, transform_difference
from tests.fusion.skeleton_fakes import Motion, observe, permuted
from tests.strategies import seeds, transforms


def _session(seed: int, T_a_b: np.ndarray, *, n_frames: int = 90, noise_m: float = 0.005,
             outlier_fraction: float = 0.0, moving: bool = True):
    """Two cameras watching one walking-ish person; camera b's outliers are ``outlier_fraction``."""
    rng = np.random.default_rng(seed)
    times = np.arange(n_frames) / 30
    joints = Motion.random(rng=rng, moving=moving).joints(times)
    a = observe(joints, np.eye(4), times, rng=rng, noise_m=noise_m)
    b = observe(joints, invert(T_a_b), times + 0.002, rng=rng, noise_m=noise_m, outlier_fraction=outlier_fraction)
    return a, b, associate(a.timestamps, b.timestamps)


def _turn(angle: float, axis, t) -> np.ndarray:
    """Transform rotating by ``angle`` [rad] about ``axis`` and translating by ``t`` [m]."""
    axis = np.asarray(axis, dtype=float)
    return from_rotvec(angle * axis / np.linalg.norm(axis), np.asarray(t, dtype=float))


def _error(result: PairCalibration, b: SkeletonStream, T_a_b: np.ndarray) -> tuple[float, float]:
    """Rotation error [deg] and error [m] at the body (the centroid of camera b's candidates).

    The translation part alone would mix in the rotation error times the distance to camera b.
    """
    centre_b = np.mean(b.positions[result.candidates[:, 1], result.candidates[:, 2]], axis=0)
    angle, _ = transform_difference(result.T_a_b, T_a_b)
    return float(angle), float(np.linalg.norm(apply(result.T_a_b, centre_b) - apply(T_a_b, centre_b)))


def _calibrate(a, b, pairs=None, seed=0, **kwargs) -> PairCalibration:
    pairs = associate(a.timestamps, b.timestamps) if pairs is None else pairs
    return ransac_skeleton_pair(a, b, pairs, rng=np.random.default_rng(seed), **kwargs)


@given(transforms(), seeds, st.floats(0.0, 0.4))
def test_recovers_random_transform_with_up_to_40_percent_outliers(T_a_b, seed, outliers):
    a, b, pairs = _session(seed, T_a_b, outlier_fraction=outliers)
    result = ransac_skeleton_pair(a, b, pairs, rng=np.random.default_rng(seed), n_trials=500)
    angle, dist = _error(result, b, T_a_b)
    assert angle < 0.15 and dist < 0.002
    assert result.support > 0.95 * (1 - outliers) - 0.05
    assert result.rmse < 0.02


@given(transforms(), seeds)
def test_reverse_calibration_is_the_inverse(T_a_b, seed):
    a, b, _ = _session(seed, T_a_b, outlier_fraction=0.2)
    forward = _calibrate(a, b, seed=seed, n_trials=300)
    backward = _calibrate(b, a, seed=seed, n_trials=300)
    np.testing.assert_allclose(compose(forward.T_a_b, backward.T_a_b), np.eye(4), atol=1e-6)


@given(seeds)
def test_same_seed_gives_identical_result(seed):
    a, b, pairs = _session(seed, _turn(np.pi, [1, 0, 0], [0.5, 0.0, 2.0]), outlier_fraction=0.3)
    r1, r2 = _calibrate(a, b, pairs, seed=seed, n_trials=300), _calibrate(a, b, pairs, seed=seed, n_trials=300)
    np.testing.assert_array_equal(r1.T_a_b, r2.T_a_b)
    np.testing.assert_array_equal(r1.inlier_mask, r2.inlier_mask)
    assert r1.n_valid_trials == r2.n_valid_trials and r1.n_refits == r2.n_refits


@given(transforms(), seeds)
def test_joint_order_does_not_matter(T_a_b, seed):
    a, b, pairs = _session(seed, T_a_b, outlier_fraction=0.2)
    order = np.random.default_rng(seed).permutation(KINECT_V2.n_joints)
    base = _calibrate(a, b, pairs, seed=seed, n_trials=300)
    shuffled = _calibrate(permuted(a, order), permuted(b, order), pairs, seed=seed + 1, n_trials=300)
    angle, dist = transform_difference(shuffled.T_a_b, base.T_a_b)
    assert angle < 0.01 and dist < 1e-4
    np.testing.assert_allclose(shuffled.residuals_per_joint, base.residuals_per_joint[order], atol=1e-4)


def test_large_session_diagnostics():
    T_a_b = _turn(2.5, [0.3, 1.0, 0.1], [2.0, 0.1, 3.0])
    a, b, pairs = _session(1, T_a_b, n_frames=600, noise_m=0.01, outlier_fraction=0.1)
    result = _calibrate(a, b, pairs)
    K = result.candidates.shape[0]
    assert K > 4096  # exercises the pre-scoring on a subset
    assert result.candidates.shape == (K, 3) and result.inlier_mask.shape == (K,)
    assert result.region_counts.sum() == K and np.all(result.region_counts > 0)
    assert result.n_inliers == result.inlier_mask.sum() and result.support == pytest.approx(result.n_inliers / K)
    assert result.n_trials == 2000 and 0 < result.n_valid_trials <= 2000 and result.n_refits >= 1
    assert result.residuals_per_joint.shape == (KINECT_V2.n_joints,)
    # 1 cm per axis in each camera: inlier distances are Maxwell with sigma 1.4 cm, rms 2.4 cm
    assert result.rmse == pytest.approx(0.01 * np.sqrt(6), rel=0.1)
    angle, dist = _error(result, b, T_a_b)
    assert angle < 0.05 and dist < 0.002
    frame_a, frame_b, joint = result.candidates.T
    assert np.all(a.states[frame_a, joint] >= TrackingState.TRACKED) and np.all(b.states[frame_b, joint] >= 2)
    residual = np.linalg.norm(apply(result.T_a_b, b.positions[frame_b, joint]) - a.positions[frame_a, joint], axis=1)
    np.testing.assert_array_equal(result.inlier_mask, residual < result.inlier_threshold_m)


def test_excluded_back_facing_frames_are_not_used():
    T_a_b = _turn(1.0, [0, 1, 0], [1.0, 0.0, 2.0])
    a, b, pairs = _session(4, T_a_b, n_frames=150)
    flipped = np.zeros(b.n_frames, dtype=bool)
    flipped[40:110] = True  # camera b reports a left/right swapped skeleton here
    positions, states = b.positions.copy(), b.states.copy()
    positions[flipped] = positions[flipped][:, KINECT_V2.mirror]
    states[flipped] = states[flipped][:, KINECT_V2.mirror]
    b = SkeletonStream(KINECT_V2, b.timestamps, positions, states)
    result = _calibrate(a, b, pairs, exclude_frames_b=flipped)
    assert not np.any(flipped[result.candidates[:, 1]])
    angle, dist = _error(result, b, T_a_b)
    assert angle < 0.15 and dist < 0.002


def test_joint_weights_drop_joints_and_keep_accuracy():
    T_a_b = _turn(0.5, [1, 0, 0], [0.0, 1.0, 0.0])
    a, b, pairs = _session(5, T_a_b)
    weights = np.ones(KINECT_V2.n_joints)
    weights[KINECT_V2.index("HandTipLeft")] = 0.0
    weights[KINECT_V2.index("Head")] = 5.0
    result = _calibrate(a, b, pairs, joint_weights=weights)
    assert KINECT_V2.index("HandTipLeft") not in result.candidates[:, 2]
    assert np.isnan(result.residuals_per_joint[KINECT_V2.index("HandTipLeft")])
    angle, dist = _error(result, b, T_a_b)
    assert angle < 0.15 and dist < 0.002


def test_no_frame_pairs_raises():
    a, b, _ = _session(0, np.eye(4))
    far = SkeletonStream(KINECT_V2, b.timestamps + 100.0, b.positions.copy(), b.states.copy())
    with pytest.raises(CalibrationError, match="no frame pairs"):
        _calibrate(a, far)


def test_all_frames_excluded_raises():
    a, b, pairs = _session(0, np.eye(4))
    with pytest.raises(CalibrationError, match="excluded"):
        _calibrate(a, b, pairs, exclude_frames_a=np.ones(a.n_frames, dtype=bool))


def test_too_few_shared_tracked_joints_raises_with_counts():
    a, b, pairs = _session(0, np.eye(4), n_frames=3)
    shared = np.flatnonzero((a.states[0] == TrackingState.TRACKED) & (b.states[0] == TrackingState.TRACKED))[:3]
    states = np.minimum(b.states, TrackingState.INFERRED)
    states[0, shared] = TrackingState.TRACKED
    b = SkeletonStream(KINECT_V2, b.timestamps, b.positions.copy(), states)
    with pytest.raises(CalibrationError, match=r"found 3 .* need at least 10"):
        _calibrate(a, b, pairs)


def _untracked(b: SkeletonStream, regions: list[Region]) -> SkeletonStream:
    """``b`` with every joint of ``regions`` no better than inferred (legs behind a table, say)."""
    hidden = np.isin(KINECT_V2.region_array, regions)
    states = b.states.copy()
    states[:, hidden] = np.minimum(states[:, hidden], TrackingState.INFERRED)
    return SkeletonStream(KINECT_V2, b.timestamps, b.positions.copy(), states)


def test_one_region_without_candidates_calibrates_from_the_others():
    T_a_b = _turn(0.4, [0, 1, 0], [1.2, 0.0, 0.3])
    a, b, pairs = _session(0, T_a_b)
    result = _calibrate(a, _untracked(b, [Region.LOWER]), pairs)
    assert result.region_counts[Region.LOWER] == 0
    rot_deg, trans_m = _error(result, b, T_a_b)
    assert rot_deg < 1.0 and trans_m < 0.02


def test_two_regions_without_candidates_raise_naming_them():
    a, b, pairs = _session(0, np.eye(4))
    with pytest.raises(CalibrationError, match="MID, LOWER"):
        _calibrate(a, _untracked(b, [Region.MID, Region.LOWER]), pairs)


def test_static_person_raises():
    a, b, pairs = _session(0, _turn(0.3, [0, 1, 0], [1.0, 0.0, 0.0]), moving=False, outlier_fraction=0.1)
    with pytest.raises(CalibrationError, match="coplanar-thin"):
        _calibrate(a, b, pairs)


def test_collinear_joints_raise():
    times = np.arange(20) / 30
    positions = np.zeros((20, KINECT_V2.n_joints, 3))
    positions[..., 1] = np.linspace(0.0, 1.8, KINECT_V2.n_joints)[None] + 0.1 * np.sin(times)[:, None]
    states = np.full(positions.shape[:2], TrackingState.TRACKED, dtype=np.int8)
    a = SkeletonStream(KINECT_V2, times, positions, states)
    b = SkeletonStream(KINECT_V2, times, positions + 1.0, states)
    with pytest.raises(CalibrationError, match="collinear"):
        _calibrate(a, b)


@pytest.mark.parametrize(
    "kwargs",
    [
        {"rng": 0},
        {"n_trials": 0},
        {"inlier_threshold_m": -0.1},
        {"exclude_frames_a": np.zeros(3, dtype=bool)},
        {"exclude_frames_b": np.zeros(90)},
        {"joint_weights": -np.ones(25)},
        {"joint_weights": np.ones(24)},
        {"min_correspondences": 2},
    ],
)
def test_bad_arguments_raise(kwargs):
    a, b, pairs = _session(0, np.eye(4))
    kwargs = {"rng": np.random.default_rng(0)} | kwargs
    with pytest.raises(BadInputError):
        ransac_skeleton_pair(a, b, pairs, **kwargs)


def test_pairs_from_other_streams_raise():
    a, b, pairs = _session(0, np.eye(4))
    with pytest.raises(BadInputError, match="index past"):
        ransac_skeleton_pair(a.subset(np.arange(10)), b, pairs, rng=np.random.default_rng(0))


def test_result_validates_its_fields():
    a, b, pairs = _session(0, np.eye(4))
    result = _calibrate(a, b, pairs, n_trials=50)
    fields = {name: getattr(result, name) for name in result.__dataclass_fields__}
    with pytest.raises(BadInputError):
        PairCalibration(**(fields | {"n_inliers": result.n_inliers + 1}))
    with pytest.raises(BadInputError):
        PairCalibration(**(fields | {"T_a_b": np.diag([1.0, 1.0, -1.0, 1.0])}))
    assert not result.T_a_b.flags.writeable and not result.inlier_mask.flags.writeable
