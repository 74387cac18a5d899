"""Truth-free tracker statistics: oracles on synthetic streams with known noise."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fusion.camera import KINECT_V2_DEPTH
from fusion.errors import BadInputError
from fusion.merge.block_bootstrap import bootstrap, mean_of_each, median_of_each
from fusion.merge.sensor_stats import (
    N_LAGS,
    autocorrelation,
    cross_camera_residuals,
    second_differences,
    sensor_stats,
)
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, Landmark
from fusion.transforms import make_transform


def _recording(sigma: float, T: int, *, seed: int, shift: np.ndarray | None = None) -> Recording:
    rng = np.random.default_rng(seed)
    base = rng.uniform(-0.5, 0.5, size=(KINECT_V2.n_joints, 3)) + [0, 0, 2.5]
    ts = np.arange(T) / 30.0
    cams = []
    for c in range(2):
        pos = base + sigma * rng.standard_normal((T, KINECT_V2.n_joints, 3))
        if c == 1 and shift is not None:
            pos = pos - shift
        states = np.full((T, KINECT_V2.n_joints), 2, dtype=np.int8)
        states[: T // 4, KINECT_V2.index(Landmark.WRIST_LEFT)] = 1
        cams.append(CameraRecording(f"c{c}", KINECT_V2_DEPTH, SkeletonStream(KINECT_V2, ts, pos, states)))
    return Recording(tuple(cams), {})


def test_white_noise_oracle() -> None:
    sigma = 0.002
    st_ = sensor_stats(_recording(sigma, 600, seed=1), n_boot=20, rng=np.random.default_rng(0))
    # second difference of white noise: per-axis std sqrt(6) sigma; median norm of a 3-D Gaussian 1.538 s
    expect = 1.538 * np.sqrt(6) * sigma * 1e3
    assert st_.jitter_mm["head"].value == pytest.approx(expect, rel=0.15)
    assert st_.jitter_mm["head"].low <= st_.jitter_mm["head"].value <= st_.jitter_mm["head"].high
    assert st_.jitter_acf["spine"][1] == pytest.approx(-2 / 3, abs=0.06)
    assert st_.confidence2["wrist"].value == pytest.approx(1 - 0.25 / 2, abs=0.01)
    assert st_.residual_mm == {} and st_.beyond_5cm is None and st_.dropped_frames == 0.0


def test_residuals_with_calibration() -> None:
    shift = np.array([0.1, 0.0, 0.0])
    rec = _recording(0.001, 300, seed=2, shift=shift)
    T = {"c0": np.eye(4), "c1": make_transform(np.eye(3), shift)}
    st_ = sensor_stats(rec, T, n_boot=10, rng=np.random.default_rng(0))
    # residual: difference of two white noises, per-axis std sqrt(2) sigma
    assert st_.residual_mm["all"].value == pytest.approx(1.538 * np.sqrt(2), rel=0.1)
    assert st_.beyond_5cm.value == 0.0
    assert st_.residual_samples_mm.shape == st_.residual_groups.shape
    wrong = sensor_stats(rec, {"c0": np.eye(4), "c1": np.eye(4)}, n_boot=0, rng=np.random.default_rng(0))
    assert wrong.residual_mm["all"].value == pytest.approx(100, rel=0.05)
    assert wrong.beyond_5cm.value == 1.0


def test_cross_camera_residuals_keep_only_confident_joints() -> None:
    rec = _recording(0.001, 40, seed=4)
    T = {"c0": np.eye(4), "c1": np.eye(4)}
    wrist = KINECT_V2.index(Landmark.WRIST_LEFT)
    (every,) = cross_camera_residuals(rec, T, "c0", 1 / 30)
    (confident,) = cross_camera_residuals(rec, T, "c0", 1 / 30, min_state=2)
    assert every.shape == (40, KINECT_V2.n_joints, 3) and np.isfinite(every).all()
    assert np.isnan(confident[:10, wrist]).all() and np.isfinite(confident[10:, wrist]).all()
    np.testing.assert_array_equal(confident[:, KINECT_V2.index(Landmark.HEAD)], every[:, KINECT_V2.index(Landmark.HEAD)])


def test_bad_input() -> None:
    rec = _recording(0.001, 30, seed=3)
    with pytest.raises(BadInputError, match="no pose for camera"):
        sensor_stats(rec, {"c0": np.eye(4)}, rng=np.random.default_rng(0))
    with pytest.raises(BadInputError, match="n_boot"):
        sensor_stats(rec, n_boot=-1, rng=np.random.default_rng(0))
    with pytest.raises(BadInputError, match="Recording"):
        sensor_stats("x", rng=np.random.default_rng(0))


def test_second_differences_skip_gaps() -> None:
    p = np.zeros((5, 1, 3))
    d2 = second_differences(p, np.array([0.0, 1.0, 2.0, 4.0, 5.0]))
    assert d2.shape == p.shape
    assert np.isfinite(d2[1]).all() and np.isnan(d2[2]).all() and np.isnan(d2[0]).all()


@pytest.mark.parametrize(("statistic", "efficiency", "within"),
                         [(mean_of_each, 1.0, 0.15), (median_of_each, np.sqrt(np.pi / 2), 0.35)])
def test_bootstrap_interval_has_the_sampling_width(statistic, efficiency, within) -> None:
    """Independent frames (blocks of one): the 95 % interval of the mean (median) of n normal values is
    about 2 x 1.96 sigma / sqrt(n) wide (times sqrt(pi / 2) for the median, whose bootstrap width also
    follows the sample's own density at its median: 0.75-1.05 of that over 20 seeds), and holds the value."""
    x = np.random.default_rng(4).standard_normal((2000, 1))
    x[::50] = np.nan  # absent frames are left out of each resample's statistic
    iv = bootstrap(x, statistic, block=1, n_boot=400, rng=np.random.default_rng(5))
    expected = 2 * 1.96 * efficiency / np.sqrt(iv.n)
    assert iv.n == 1960 and iv.low < iv.value < iv.high
    assert (1 - within) * expected < iv.high - iv.low < (1 + within) * expected


@given(st.integers(0, 2**31 - 1))
def test_bootstrap_interval_brackets_value(seed: int) -> None:
    x = np.random.default_rng(seed).standard_normal((60, 2))
    iv = bootstrap(x, mean_of_each, block=5, n_boot=30, rng=np.random.default_rng(seed))
    assert iv.low <= iv.high and iv.n == 120 and iv.value == pytest.approx(x.mean())
    acf = autocorrelation(x, N_LAGS)
    assert acf.shape == (N_LAGS + 1,) and acf[0] == pytest.approx(1.0)
