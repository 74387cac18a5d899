import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fma.measurements import Side
from fma.segmentation import RepetitionSegment, segment_repetitions
from fusion.errors import BadInputError
from fusion.topology import K4ABT, KINECT_V2, Landmark

FPS = 30.0


def min_jerk(tau: np.ndarray) -> np.ndarray:
    tau = np.clip(tau, 0.0, 1.0)
    return 10 * tau**3 - 15 * tau**4 + 6 * tau**5


def trajectory(topology, side, rises, holds, rests, *, noise_m, seed, amplitude=0.6):
    """Hand/wrist/elbow of ``side`` rise and fall with minimum-jerk profiles; returns truth frames."""
    rng = np.random.default_rng(seed)
    starts, ends, t0 = [], [], rests[0]
    for rise, hold, rest in zip(rises, holds, rests[1:]):
        starts.append(t0)
        ends.append(t0 + 2 * rise + hold)
        t0 = ends[-1] + rest
    times = np.arange(0.0, t0, 1 / FPS)
    z = 0.8 + sum(
        amplitude * (min_jerk((times - s) / r) - min_jerk((times - s - r - h) / r))
        for s, r, h in zip(starts, rises, holds)
    )
    pos = np.zeros((times.size, topology.n_joints, 3)) + np.array([0.0, 0.0, 1.0])
    s = side.value.upper()
    for lm, dz in ((f"HAND_{s}", 0.0), (f"WRIST_{s}", 0.05), (f"ELBOW_{s}", 0.3)):
        j = topology.index(Landmark[lm])
        pos[:, j, 0] = 0.3 * (z - 0.8)
        pos[:, j, 2] = z + dz * (1 - (z - 0.8) / amplitude)
    pos += rng.normal(0.0, noise_m, pos.shape)
    truth = np.round(np.array([starts, ends]) * FPS).astype(int)
    return times, pos, truth


@given(seed=st.integers(0, 2**32 - 1), n_reps=st.integers(1, 4), side=st.sampled_from(list(Side)))
def test_recovers_starts_and_ends_within_three_frames(seed, n_reps, side):
    rng = np.random.default_rng(seed)
    rises = rng.uniform(0.8, 2.0, n_reps)
    holds = rng.uniform(0.0, 0.8, n_reps)
    rests = rng.uniform(0.8, 2.0, n_reps + 1)
    times, pos, truth = trajectory(KINECT_V2, side, rises, holds, rests, noise_m=0.002, seed=seed)
    segs = segment_repetitions(times, pos, KINECT_V2, side)
    assert len(segs) == n_reps
    found = np.array([[s.start_index for s in segs], [s.end_index for s in segs]])
    np.testing.assert_array_less(np.abs(found - truth), 3.5)
    for s in segs:
        assert s.start_index <= s.peak_index <= s.end_index
        assert s.t_start == times[s.start_index] and s.t_end == times[s.end_index]


def test_other_side_and_still_hand_give_no_repetitions():
    times, pos, _ = trajectory(KINECT_V2, Side.LEFT, [1.0, 1.0], [0.3, 0.3], [1, 1, 1], noise_m=0.003, seed=1)
    assert segment_repetitions(times, pos, KINECT_V2, "right") == []
    assert len(segment_repetitions(times, pos, KINECT_V2, "left")) == 2


def test_robust_to_nan_gaps_and_k4abt():
    times, pos, truth = trajectory(K4ABT, Side.RIGHT, [1.2, 1.5, 1.0], [0.5, 0.2, 0.0], [1, 1, 1, 1],
                                   noise_m=0.003, seed=2)
    hand, wrist = K4ABT.index(Landmark.HAND_RIGHT), K4ABT.index(Landmark.WRIST_RIGHT)
    pos[50:58, hand] = np.nan  # wrist stands in
    pos[100:104, [hand, wrist]] = np.nan  # interpolated
    segs = segment_repetitions(times, pos, K4ABT, Side.RIGHT)
    found = np.array([[s.start_index for s in segs], [s.end_index for s in segs]])
    assert found.shape == truth.shape
    np.testing.assert_array_less(np.abs(found - truth), 3.5)


def test_short_twitches_are_ignored():
    times, pos, _ = trajectory(KINECT_V2, Side.LEFT, [0.1, 1.2], [0.0, 0.3], [1, 1, 1], noise_m=0.002, seed=3)
    segs = segment_repetitions(times, pos, KINECT_V2, Side.LEFT, min_duration_s=0.5)
    assert len(segs) == 1


def test_bad_input():
    times, pos, _ = trajectory(KINECT_V2, Side.LEFT, [1.0], [0.3], [1, 1], noise_m=0.0, seed=0)
    with pytest.raises(BadInputError):
        segment_repetitions(times, pos[:, :5], KINECT_V2, Side.LEFT)
    with pytest.raises(BadInputError):
        segment_repetitions(times[::-1], pos, KINECT_V2, Side.LEFT)
    with pytest.raises(BadInputError):
        segment_repetitions(times, pos, KINECT_V2, "up")
    with pytest.raises(BadInputError):
        segment_repetitions(times, pos, KINECT_V2, Side.LEFT, enter_fraction=0.1, exit_fraction=0.2)
    with pytest.raises(BadInputError):
        RepetitionSegment(5, 3, 8, 0.0, 1.0)
    assert segment_repetitions(times, np.full_like(pos, np.nan), KINECT_V2, Side.LEFT) == []
