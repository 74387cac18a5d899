import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fusion.calibrate import clock_offset
from fusion.calibrate.clock_offset import ClockOffset, estimate_clock_offset
from fusion.calibrate.sync import FramePairs, associate, interpolate_stream
from fusion.errors import BadInputError, CalibrationError
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, TrackingState
from fusion.transforms import from_rotvec
from tests.fusion.skeleton_fakes import Motion, observe
from tests.strategies import seeds, transforms

# ---------------------------------------------------------------- associate


def _stamps(rng: np.random.Generator, n: int, rate_hz: float = 30.0, drop: float = 0.1) -> np.ndarray:
    """Timestamps of a camera with a random phase, jitter and dropped frames."""
    t = rng.uniform(0, 1 / rate_hz) + np.arange(n) / rate_hz + rng.normal(0, 0.001, n)
    return t[rng.random(n) >= drop]


def test_associate_identical_clocks_pairs_every_frame():
    ts = np.arange(10) / 30
    pairs = associate(ts, ts)
    np.testing.assert_array_equal(pairs.indices, np.column_stack([np.arange(10), np.arange(10)]))
    np.testing.assert_array_equal(pairs.dt_s, 0.0)
    assert pairs.n_pairs == 10 and pairs.tolerance_s == pytest.approx(1 / 60)


def test_associate_offset_convention():
    """Camera b's clock runs 0.5 s ahead: its frame stamped t + 0.5 pairs with camera a's frame t."""
    ts_a = np.arange(30) / 30
    ts_b = ts_a[5:] + 0.5
    pairs = associate(ts_a, ts_b, offset_s=0.5)
    np.testing.assert_array_equal(pairs.index_a, np.arange(5, 30))
    np.testing.assert_array_equal(pairs.index_b, np.arange(25))
    assert associate(ts_a, ts_b).n_pairs == 10  # without the offset only the overlap [0.67, 0.97] s pairs


def test_associate_skips_dropped_frames_instead_of_reusing_neighbours():
    ts_a = np.array([0.0, 0.033, 0.066, 0.1])
    ts_b = np.array([0.010, 0.076, 0.110])  # b dropped its frame near 0.043
    pairs = associate(ts_a, ts_b)
    np.testing.assert_array_equal(pairs.indices, [[0, 0], [2, 1], [3, 2]])


def test_associate_ties_go_to_the_earlier_frame():
    pairs = associate(np.array([0.0, 0.01]), np.array([0.005]))
    np.testing.assert_array_equal(pairs.indices, [[0, 0]])


def test_associate_no_overlap_gives_no_pairs():
    pairs = associate(np.arange(5.0), np.arange(5.0) + 100.0)
    assert pairs.n_pairs == 0 and pairs.indices.shape == (0, 2)
    assert associate(np.zeros(0), np.arange(3.0)).n_pairs == 0


@given(seeds, st.floats(0.002, 0.05), st.floats(-0.1, 0.1))
def test_associate_is_one_to_one_mutual_nearest_within_tolerance(seed, tolerance, offset):
    rng = np.random.default_rng(seed)
    ts_a, ts_b = _stamps(rng, 60), _stamps(rng, 60) + offset
    pairs = associate(ts_a, ts_b, tolerance_s=tolerance, offset_s=offset)
    i, j = pairs.index_a, pairs.index_b
    assert np.all(np.diff(i) > 0) and np.all(np.diff(j) > 0)
    tb = ts_b - offset
    np.testing.assert_allclose(pairs.dt_s, np.abs(ts_a[i] - tb[j]))
    assert np.all(pairs.dt_s <= tolerance)
    gap = np.abs(ts_a[:, None] - tb[None, :])
    assert np.all(gap[i, j] <= gap[i].min(axis=1)) and np.all(gap[i, j] <= gap[:, j].min(axis=0))
    mutual = (gap.argmin(axis=1)[gap.argmin(axis=0)] == np.arange(tb.size)) & (gap.min(axis=0) <= tolerance)
    assert pairs.n_pairs == mutual.sum()


@pytest.mark.parametrize(
    "ts_a, ts_b, kwargs",
    [
        (np.array([0.0, 0.0]), np.arange(3.0), {}),
        (np.array([0.0, np.nan]), np.arange(3.0), {}),
        (np.zeros((2, 2)), np.arange(3.0), {}),
        (np.arange(3.0), np.arange(3.0), {"tolerance_s": 0.0}),
        (np.arange(3.0), np.arange(3.0), {"offset_s": np.inf}),
    ],
)
def test_associate_bad_input(ts_a, ts_b, kwargs):
    with pytest.raises(BadInputError):
        associate(ts_a, ts_b, **kwargs)


def test_frame_pairs_validation():
    with pytest.raises(BadInputError):
        FramePairs(np.array([[0, 0], [0, 1]]), np.zeros(2), 0.0, 0.01)
    with pytest.raises(BadInputError):
        FramePairs(np.array([[0.0, 0.0]]), np.zeros(1), 0.0, 0.01)
    with pytest.raises(BadInputError):
        FramePairs(np.array([[0, 0]]), np.zeros(2), 0.0, 0.01)


# ---------------------------------------------------------------- interpolate_stream


def _linear_stream(ts: np.ndarray, seed: int = 0) -> SkeletonStream:
    rng = np.random.default_rng(seed)
    p0, v = rng.normal(size=(KINECT_V2.n_joints, 3)), rng.normal(size=(KINECT_V2.n_joints, 3))
    positions = p0 + ts[:, None, None] * v
    states = np.full(positions.shape[:2], TrackingState.TRACKED, dtype=np.int8)
    return SkeletonStream(KINECT_V2, ts, positions, states)


def test_interpolate_at_own_timestamps_is_identity():
    s = _linear_stream(np.arange(5) / 30)
    assert interpolate_stream(s, s.timestamps).equals(s)


@given(seeds)
def test_interpolate_reproduces_linear_motion(seed):
    rng = np.random.default_rng(seed)
    ts = np.cumsum(rng.uniform(0.02, 0.05, 20))
    s = _linear_stream(ts, seed)
    times = np.sort(rng.uniform(ts[0], ts[-1], 15))
    times = times[np.diff(times, prepend=-1) > 0]
    out = interpolate_stream(s, times)
    np.testing.assert_allclose(out.positions, _linear_stream(times, seed).positions, atol=1e-12)
    np.testing.assert_array_equal(out.timestamps, times)


def test_interpolate_states_absent_neighbours_gaps_and_outside():
    ts = np.array([0.0, 0.1, 0.2, 0.5])
    s = _linear_stream(ts)
    positions, states = s.positions.copy(), s.states.copy()
    states[1, 0] = TrackingState.INFERRED
    states[2, 1] = TrackingState.NOT_TRACKED
    positions[2, 1] = np.nan
    s = SkeletonStream(KINECT_V2, ts, positions, states)
    out = interpolate_stream(s, np.array([-0.1, 0.05, 0.15, 0.3, 0.5, 0.6]), max_gap_s=0.2)
    assert out.states[1, 0] == TrackingState.INFERRED and out.states[1, 2] == TrackingState.TRACKED
    np.testing.assert_allclose(out.positions[1, 2], 0.5 * (positions[0, 2] + positions[1, 2]))
    assert out.states[2, 1] == TrackingState.NOT_TRACKED and np.isnan(out.positions[2, 1]).all()
    assert np.all(out.states[[0, 3, 5]] == TrackingState.NOT_TRACKED)  # outside, gap 0.3 s > 0.2 s, outside
    assert np.isnan(out.positions[[0, 3, 5]]).all()
    np.testing.assert_array_equal(out.positions[4], positions[3])  # the last frame, exactly


def test_interpolate_bad_times():
    s = _linear_stream(np.arange(3.0))
    with pytest.raises(BadInputError):
        interpolate_stream(s, np.array([1.0, 0.5]))
    with pytest.raises(BadInputError):
        interpolate_stream(s, np.array([0.5]), max_gap_s=-1.0)


# ---------------------------------------------------------------- estimate_clock_offset


def _two_cameras(seed: int, offset_s: float, T_b_a: np.ndarray, duration_s: float = 12.0, moving: bool = True,
                 noise_m: float = 0.01, outlier_fraction: float = 0.02):
    """Streams of one motion; camera b's clock runs ``offset_s`` ahead of camera a's (= true time)."""
    rng = np.random.default_rng(seed)
    motion = Motion.random(rng=rng, moving=moving)
    n = int(duration_s * 30)
    true_a, true_b = _stamps(rng, n, drop=0.01), _stamps(rng, n, drop=0.01)
    T_a_world = from_rotvec(rng.normal(size=3), rng.normal(size=3) * 2)
    kw = dict(noise_m=noise_m, outlier_fraction=outlier_fraction, inferred_fraction=0.1, missing_fraction=0.03)
    a = observe(motion.joints(true_a), T_a_world, true_a + rng.normal(0, 0.001, true_a.size), rng=rng, **kw)
    b = observe(motion.joints(true_b), T_b_a @ T_a_world, true_b + offset_s + rng.normal(0, 0.001, true_b.size),
                rng=rng, **kw)
    return a, b


@settings(max_examples=12)
@given(seeds, st.floats(-0.15, 0.15), transforms())
def test_recovers_a_known_clock_offset_within_3_ms(seed, offset, T_b_a):
    a, b = _two_cameras(seed, offset, T_b_a, duration_s=30.0)
    result = estimate_clock_offset(a, b)
    assert result.converged
    assert abs(result.offset_s - offset) < 0.003
    assert result.peak_score > 0.9 and result.n_signals > 0


def test_offset_sign_convention_and_use_with_associate():
    a, b = _two_cameras(7, 0.08, np.eye(4))
    result = estimate_clock_offset(a, b)
    assert result.offset_s == pytest.approx(0.08, abs=0.003)
    assert result.lags_s.shape == result.score.shape and result.lags_s[0] == pytest.approx(-0.2)
    back = estimate_clock_offset(b, a)
    assert back.offset_s == pytest.approx(-result.offset_s, abs=0.002)
    pairs = associate(a.timestamps, b.timestamps, offset_s=result.offset_s)
    assert np.median(pairs.dt_s) < 0.01 and pairs.n_pairs > 0.8 * min(a.n_frames, b.n_frames)


def test_mirrored_skeletons_give_the_same_signal():
    a, b = _two_cameras(11, -0.05, np.eye(4))
    flipped = SkeletonStream(b.topology, b.timestamps, b.positions[:, KINECT_V2.mirror], b.states[:, KINECT_V2.mirror])
    assert estimate_clock_offset(a, flipped).offset_s == pytest.approx(-0.05, abs=0.003)


def test_offset_outside_search_range_is_not_converged():
    a, b = _two_cameras(3, 0.3, np.eye(4))
    result = estimate_clock_offset(a, b, max_offset_s=0.1)
    assert not result.converged


def test_static_person_raises():
    a, b = _two_cameras(5, 0.0, np.eye(4), moving=False)
    with pytest.raises(CalibrationError, match="static"):
        estimate_clock_offset(a, b)


def _wobble(stream: SkeletonStream, rng: np.random.Generator, rms_m: float = 0.003) -> SkeletonStream:
    """The stream with a slow error of every joint (a tracker's wobble, half-second correlation)."""
    from scipy.ndimage import gaussian_filter1d

    w = gaussian_filter1d(rng.normal(size=stream.positions.shape), 15.0, axis=0)
    return dataclasses.replace(stream, positions=stream.positions + w * rms_m / w.std())


def test_a_still_person_whose_tracker_wobbles_is_static():
    """Slow tracker error moves inter-joint distances by millimetres with little frame-to-frame noise;
    the static check does not take it for motion."""
    a, b = _two_cameras(5, 0.0, np.eye(4), moving=False, noise_m=0.001, outlier_fraction=0.0)
    rng = np.random.default_rng(7)
    with pytest.raises(CalibrationError, match="static"):
        estimate_clock_offset(_wobble(a, rng), _wobble(b, rng))


def test_a_static_verdict_says_when_few_joints_were_tracked():
    """A still person whose tracker reports most joints below confidence 2: the error says how few
    were used, since that, not stillness alone, may be why no motion was seen."""
    a, b = _two_cameras(5, 0.0, np.eye(4), moving=False, noise_m=0.001, outlier_fraction=0.0)
    rng = np.random.default_rng(7)
    a, b = _wobble(a, rng), _wobble(b, rng)
    inferred = np.where(np.arange(a.topology.n_joints) % 4 == 0, a.states, np.minimum(a.states, 1))
    a = SkeletonStream(a.topology, a.timestamps, a.positions, inferred)
    with pytest.raises(CalibrationError, match=r"static in camera a: .* only 2\d % of its joint samples are TRACKED"):
        estimate_clock_offset(a, b)
    with pytest.raises(CalibrationError, match="static in camera a") as exc:
        estimate_clock_offset(_wobble(_two_cameras(5, 0.0, np.eye(4), moving=False, noise_m=0.001,
                                                   outlier_fraction=0.0)[0], rng), b)
    assert "only" not in str(exc.value)


def test_no_time_overlap_raises():
    a, b = _two_cameras(5, 100.0, np.eye(4))
    with pytest.raises(CalibrationError, match="overlap"):
        estimate_clock_offset(a, b)


def test_bad_arguments():
    a, b = _two_cameras(2, 0.0, np.eye(4), duration_s=3.0)
    with pytest.raises(BadInputError):
        estimate_clock_offset(a, b, max_offset_s=0.0)
    with pytest.raises(BadInputError):
        estimate_clock_offset(a, b, max_offset_s=0.2, grid_step_s=0.15)
    with pytest.raises(BadInputError):
        ClockOffset(0.0, np.zeros(3), np.zeros(4), 1.0, True, 1)


def _offset(peak_lag: float, peak: float, at_zero: float, converged: bool = True) -> ClockOffset:
    lags = np.linspace(-2.5, 2.5, 501)
    score = np.full(lags.shape, at_zero)
    score[np.argmin(np.abs(lags - peak_lag))] = peak
    return ClockOffset(peak_lag, lags, score, peak, converged, 32)


def test_a_wide_peak_counts_only_when_it_clearly_beats_the_clocks_as_given(monkeypatch):
    """fma_2cam seed 19's slow salute scored 0.81 at the true lag (0) and 0.94 at a false one 0.63 s
    away: taken, it put a camera 0.63 s off and the calibration 5 deg wrong."""
    edge = _offset(0.2, 0.812, 0.806, converged=False)
    edge = dataclasses.replace(edge, lags_s=np.linspace(-0.2, 0.2, 81), score=np.full(81, 0.806))
    wide = {"flat": _offset(0.63, 0.943, 0.806), "clear": _offset(1.6, 0.9, 0.3)}
    for kind, expected in (("flat", 0.2), ("clear", 1.6)):
        monkeypatch.setattr(clock_offset, "estimate_clock_offset",
                            lambda a, b, *, max_offset_s, names, k=kind: edge if max_offset_s < 1 else wide[k])
        est = clock_offset.estimate_clock_offset_widening(None, None, 0.2)
        assert est.offset_s == expected and est.widened == (kind == "clear")
    # a first search that fails inside its range (the best lag off its edge) is widened as well
    inside = dataclasses.replace(edge, offset_s=-0.05, peak_score=-0.37)
    monkeypatch.setattr(clock_offset, "estimate_clock_offset",
                        lambda a, b, *, max_offset_s, names: inside if max_offset_s < 1 else wide["clear"])
    assert clock_offset.estimate_clock_offset_widening(None, None, 0.2).widened
    assert wide["flat"].gain_over_zero() == pytest.approx(0.137)
    assert not clock_offset.contradicts(wide["flat"]) and clock_offset.contradicts(wide["clear"])
    assert not clock_offset.contradicts(_offset(0.1, 0.95, 0.3))  # within the tolerance
    # a patient's session: lag 0 unscored (its tracked samples overlap little), a peak 3.16 s away
    assert not clock_offset.contradicts(_offset(3.16, 0.707, np.nan))
