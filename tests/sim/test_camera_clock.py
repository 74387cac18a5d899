"""Camera clock model: frame times, timestamps, drops, offsets and drift."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fusion.errors import BadInputError
from sim.camera_clock import ClockModel, ClockSamples, sample_clock
from tests.strategies import seeds


def test_timestamps_increase_at_nominal_rate():
    c = sample_clock(60.0, ClockModel(), rng=np.random.default_rng(1))
    assert isinstance(c, ClockSamples)
    assert c.true_times.shape == c.camera_timestamps.shape == c.frame_index.shape == (c.n_frames,)
    assert np.all(np.diff(c.camera_timestamps) > 0) and np.all(np.diff(c.true_times) > 0)
    assert np.median(np.diff(c.camera_timestamps)) == pytest.approx(1 / 30, abs=1e-3)
    assert 0 <= c.true_times[0] < 1 / 30 * (c.frame_index[0] + 1) and c.true_times[-1] < 60.0
    assert 1750 <= c.n_frames <= 1800


def test_drop_rate_near_requested():
    c = sample_clock(1000.0, ClockModel(drop_probability=0.01), rng=np.random.default_rng(2))
    n_captured = c.frame_index[-1] + 1
    drop_rate = 1 - c.n_frames / n_captured
    assert drop_rate == pytest.approx(0.01, abs=0.002)
    gaps = np.diff(c.frame_index)
    assert np.all(gaps >= 1) and np.sum(gaps - 1) == n_captured - c.n_frames - c.frame_index[0]


def test_phase_and_offset_differ_between_cameras():
    a, b = (sample_clock(5.0, ClockModel(), rng=np.random.default_rng(s)) for s in (3, 4))
    assert a.phase_s != b.phase_s and a.offset_s != b.offset_s
    assert 0 <= a.phase_s < 1 / 30 and 0 <= b.phase_s < 1 / 30
    offsets = [sample_clock(1.0, ClockModel(), rng=np.random.default_rng(s)).offset_s for s in range(400)]
    assert np.std(offsets) == pytest.approx(0.005, rel=0.15)


def test_ideal_clock_is_exact():
    model = ClockModel(offset_sigma_s=0.0, jitter_sigma_s=0.0, drop_probability=0.0, phase_s=0.01)
    c = sample_clock(2.0, model, rng=np.random.default_rng(0))
    np.testing.assert_allclose(c.true_times, 0.01 + np.arange(60) / 30, atol=1e-12)
    np.testing.assert_array_equal(c.camera_timestamps, c.true_times)
    np.testing.assert_array_equal(c.frame_index, np.arange(60))


def test_jitter_offset_and_drift():
    model = ClockModel(jitter_sigma_s=0.001, drift_ppm=100.0, offset_s=0.2, drop_probability=0.0)
    c = sample_clock(600.0, model, rng=np.random.default_rng(5))
    residual = c.camera_timestamps - (1 + 1e-4) * c.true_times - 0.2
    assert np.std(residual) == pytest.approx(0.001, rel=0.05) and abs(np.mean(residual)) < 1e-4
    # the camera believes it runs at exactly 30 Hz
    slope = np.polyfit(c.frame_index, c.camera_timestamps, 1)[0]
    assert slope == pytest.approx(1 / 30, rel=1e-6)
    assert np.polyfit(c.frame_index, c.true_times, 1)[0] == pytest.approx(1 / 30 / (1 + 1e-4), rel=1e-7)


def test_deterministic_given_rng():
    a, b, c = (sample_clock(10.0, ClockModel(), rng=np.random.default_rng(s)) for s in (7, 7, 8))
    for name in ("true_times", "camera_timestamps", "frame_index"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert not np.array_equal(a.camera_timestamps, c.camera_timestamps[: a.n_frames])


@given(seed=seeds, rate=st.floats(5.0, 60.0), drop=st.floats(0.0, 0.5), drift=st.floats(-200.0, 200.0))
def test_strictly_increasing_property(seed, rate, drop, drift):
    model = ClockModel(rate_hz=rate, jitter_sigma_s=0.1 / rate, drop_probability=drop, drift_ppm=drift)
    c = sample_clock(3.0, model, rng=np.random.default_rng(seed))
    assert np.all(np.diff(c.camera_timestamps) > 0)
    assert np.all((c.true_times >= 0) & (c.true_times < 3.0))


@pytest.mark.parametrize(
    "changes",
    [
        {"rate_hz": 0.0},
        {"rate_hz": float("nan")},
        {"offset_sigma_s": -1.0},
        {"jitter_sigma_s": 0.01},
        {"drop_probability": 1.0},
        {"phase_s": 0.04},
        {"drift_ppm": 1e5},
    ],
)
def test_bad_model(changes):
    with pytest.raises(BadInputError):
        dataclasses.replace(ClockModel(), **changes)


@pytest.mark.parametrize("duration", [0.0, -1.0, float("inf")])
def test_bad_duration(duration):
    with pytest.raises(BadInputError):
        sample_clock(duration, ClockModel(), rng=np.random.default_rng(0))


def test_bad_samples():
    with pytest.raises(BadInputError, match="strictly increasing"):
        ClockSamples(np.array([0.0, 1.0]), np.array([1.0, 1.0]), np.array([0, 1]), 0.0, 0.0)
    with pytest.raises(BadInputError, match="1-D"):
        ClockSamples(np.zeros(2), np.zeros(3), np.zeros(2), 0.0, 0.0)
