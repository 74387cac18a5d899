"""The live engine against the offline causal fusion, and its handling of late, duplicate,
missing and silent cameras."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fusion.errors import BadInputError
from fusion.live.engine import EngineOptions, LiveFusion
from fusion.live.protocol import CameraFrame
from fusion.merge.causal import fuse_causal
from fusion.merge.filters import TemporalFilter
from fusion.merge.fuse import FuseOptions
from fusion.merge.methods import MergeMethod
from tests.fusion.live.fakes import arrivals, session

WAIT_ALL = dict(deadline_s=np.inf, silent_after_s=np.inf)


def _frame(recording, name, k, *, shift=0.0):
    s = recording.camera(name).skeleton
    return CameraFrame(name, k, s.timestamps[k] + shift, s.topology, s.positions[k], s.states[k])


def _run(recording, calibration, options, order):
    engine = LiveFusion(calibration, recording.topology, options)
    out = []
    for arrival, (name, k) in order:
        out += engine.push(_frame(recording, name, k), arrival)
    for name in engine.cameras:
        out += engine.bye(name, 1e9)
    return engine, out


@settings(max_examples=6)
@given(seed=st.integers(0, 2**32 - 1), method=st.sampled_from(list(MergeMethod)),
       temporal=st.sampled_from([TemporalFilter.NONE, TemporalFilter.ONE_EURO]),
       lag=st.floats(0.0, 0.3), relabel=st.booleans())
def test_live_fusion_equals_the_offline_causal_fusion_frame_for_frame(seed, method, temporal, lag, relabel):
    rng = np.random.default_rng(seed)
    recording, calibration = session(rng=rng, n_cameras=3, seconds=1.5)
    fuse = FuseOptions(method=method, temporal=temporal, relabel_back_facing=relabel)
    order = arrivals(recording, delays={"cam2": lag, "cam3": lag / 2})  # cameras arrive interleaved, late
    engine, out = _run(recording, calibration, EngineOptions(fuse=fuse, **WAIT_ALL), order)
    offline = fuse_causal(recording, calibration, fuse)
    stream = offline.to_stream(recording.topology)
    assert [f.time for f in out] == list(offline.times)
    assert sum(not f.complete for f in out) <= 2  # only at the end, past another camera's last frame
    P = np.array([f.positions for f in out])
    assert np.array_equal(np.isnan(P), np.isnan(stream.positions))
    assert np.nanmax(np.abs(P - stream.positions)) <= 1e-9
    assert np.array_equal(np.array([f.states for f in out]), stream.states)
    assert np.array_equal(np.array([f.reliability for f in out]), offline.reliability)


def test_late_and_duplicate_frames_are_counted_and_dropped():
    recording, calibration = session(rng=np.random.default_rng(2), n_cameras=2, seconds=1.0)
    engine = LiveFusion(calibration, recording.topology, EngineOptions(**WAIT_ALL))
    engine.push(_frame(recording, "cam2", 5), 0.0)
    assert engine.push(_frame(recording, "cam2", 3), 0.0) == []  # older than the newest: late
    engine.push(_frame(recording, "cam2", 5), 0.0)  # again: duplicate
    status = engine.camera_status(0.0)["cam2"]
    assert (status["frames"], status["late"], status["duplicates"]) == (1, 1, 1)


def test_frames_beyond_max_held_are_forgotten_and_counted():
    recording, calibration = session(rng=np.random.default_rng(2), n_cameras=2, seconds=1.0)
    engine = LiveFusion(calibration, recording.topology, EngineOptions(**WAIT_ALL, max_held=4))
    for k in range(6):  # cam2 runs ahead; no reference frame yet
        engine.push(_frame(recording, "cam2", k), 0.0)
    status = engine.camera_status(0.0)["cam2"]
    assert (status["frames"], status["forgotten"]) == (6, 2)


def test_an_instant_waits_for_every_camera_until_its_deadline():
    recording, calibration = session(rng=np.random.default_rng(3), n_cameras=3, seconds=1.0, max_offset_s=0.0)
    engine = LiveFusion(calibration, recording.topology, EngineOptions(deadline_s=0.05, silent_after_s=10.0))
    assert engine.push(_frame(recording, "cam1", 0), 0.0) == []  # opens an instant, others awaited
    t = recording.camera("cam1").skeleton.timestamps[0]
    later = [k for k, ts in enumerate(recording.camera("cam2").skeleton.timestamps) if ts >= t][0]
    assert engine.push(_frame(recording, "cam2", later), 0.01) == []  # cam3 still missing
    assert engine.poll(0.04) == []
    (frame,) = engine.poll(0.06)  # deadline passed: merged without cam3
    assert not frame.complete and frame.cameras == ("cam1", "cam2") and frame.time == t
    assert engine.counts["incomplete"] == 1


def test_a_silent_camera_is_not_awaited_and_a_silent_reference_hands_over():
    recording, calibration = session(rng=np.random.default_rng(4), n_cameras=2, seconds=2.0, max_offset_s=0.0)
    engine = LiveFusion(calibration, recording.topology, EngineOptions(deadline_s=10.0, silent_after_s=0.5))
    out = []
    for arrival, (name, k) in arrivals(recording):
        if name == "cam1" and arrival > 1.0:
            continue  # the reference stops sending after 1 s
        out += engine.push(_frame(recording, name, k), arrival)
    times = np.array([f.time for f in out])
    assert np.all(np.diff(times) > 0)
    assert times[-1] > 1.8  # the stream went on with cam2's frames as instants
    assert engine.timebase(2.0) == "cam2" and engine.camera_status(2.0)["cam1"]["silent"]
    assert out[-1].cameras == ("cam2",)


def test_frames_of_unknown_cameras_are_counted():
    recording, calibration = session(rng=np.random.default_rng(5), n_cameras=2, seconds=0.5)
    engine = LiveFusion(calibration, recording.topology, EngineOptions())
    f = _frame(recording, "cam1", 0)
    engine.push(CameraFrame("camX", 0, 0.0, f.topology, f.positions, f.states), 0.0)
    assert engine.counts["unknown_camera"] == 1


def test_options_that_need_the_future_are_refused():
    for fuse in (FuseOptions(temporal=TemporalFilter.KALMAN), FuseOptions(bone_lengths=True)):
        with pytest.raises(BadInputError):
            EngineOptions(fuse=fuse)
    with pytest.raises(BadInputError):
        EngineOptions(deadline_s=0.0)
    with pytest.raises(BadInputError):
        LiveFusion("calib.toml", None)


def test_frames_of_cameras_the_calibration_lacks_are_counted_by_name():
    recording, calibration = session(rng=np.random.default_rng(2), n_cameras=2, seconds=1.0)
    engine = LiveFusion(calibration, recording.topology, EngineOptions(**WAIT_ALL))
    s = recording.camera("cam2").skeleton
    for k in range(3):
        assert engine.push(CameraFrame("stranger", k, s.timestamps[k], s.topology, s.positions[k], s.states[k]), 0.0) == []
    assert engine.counts["unknown_camera"] == 3 and engine.unknown_cameras == {"stranger": 3}


def _pushed(recording, calibration, frames):
    """Push ``(arrival, CameraFrame)`` pairs, then byes; returns the engine and the fused frames."""
    engine = LiveFusion(calibration, recording.topology, EngineOptions(**WAIT_ALL))
    out = []
    for arrival, frame in frames:
        out += engine.push(frame, arrival)
    for name in engine.cameras:
        out += engine.bye(name, 1e9)
    return engine, out


def _clean_and(recording, change):
    """Every frame in arrival order, with ``change(name, k, frame)`` returning the frames to send instead."""
    return [(a, f) for a, (name, k) in arrivals(recording) for f in change(name, k, _frame(recording, name, k))]


def _same_output(a, b):
    P, Q = np.array([f.positions for f in a]), np.array([f.positions for f in b])
    return [f.time for f in a] == [f.time for f in b] and np.array_equal(P, Q, equal_nan=True)


def test_frames_in_millimetres_are_refused_and_the_rest_fuses_as_without_them():
    recording, calibration = session(rng=np.random.default_rng(21), n_cameras=2, seconds=1.0)
    _, clean = _pushed(recording, calibration, _clean_and(recording, lambda n, k, f: [f]))

    def mm(name, k, f):  # every fifth frame of cam2 sent again in millimetres, then the real one
        bad = CameraFrame(name, k, f.timestamp - 1e-4, f.topology, f.positions * 1000, f.states)
        return [bad, f] if name == "cam2" and k % 5 == 0 and k > 0 else [f]

    engine, out = _pushed(recording, calibration, _clean_and(recording, mm))
    n_bad = sum(1 for k in range(1, recording.camera("cam2").skeleton.n_frames) if k % 5 == 0)
    assert engine.counts["units"] == n_bad > 0
    assert engine.camera_status(0.0)["cam2"]["rejected_units"] == n_bad
    assert _same_output(out, clean)


def test_one_stray_timestamp_is_refused_and_does_not_lock_its_camera():
    recording, calibration = session(rng=np.random.default_rng(22), n_cameras=2, seconds=1.5)
    _, clean = _pushed(recording, calibration, _clean_and(recording, lambda n, k, f: [f]))

    def stray(name, k, f):  # an epoch-nanosecond timestamp in the middle of cam2's stream
        if name == "cam2" and k == 10:
            return [CameraFrame(name, k, 1.7e18, f.topology, f.positions, f.states), f]
        return [f]

    engine, out = _pushed(recording, calibration, _clean_and(recording, stray))
    assert engine.counts["clock"] == 1 and engine.camera_status(0.0)["cam2"]["clock_steps"] == 0
    assert _same_output(out, clean)  # before, cam2's every later frame was "late" behind the stray one


def test_a_clock_that_steps_for_good_is_followed_after_a_few_frames():
    recording, calibration = session(rng=np.random.default_rng(23), n_cameras=2, seconds=1.5)

    def step(name, k, f):  # cam2's clock jumps 60 s ahead from frame 20 on, e.g. a camera restarted
        shift = 60.0 if name == "cam2" and k >= 20 else 0.0
        return [CameraFrame(name, k, f.timestamp + shift, f.topology, f.positions, f.states)]

    engine, out = _pushed(recording, calibration, _clean_and(recording, step))
    status = engine.camera_status(0.0)["cam2"]
    assert status["clock_steps"] == 1 and engine.counts["clock"] == 0
    assert status["frames"] == recording.camera("cam2").skeleton.n_frames  # the step's frames were kept
    assert len(out) == recording.camera("cam1").skeleton.n_frames


def test_timestamps_in_milliseconds_are_refused_as_clock_errors():
    recording, calibration = session(rng=np.random.default_rng(24), n_cameras=2, seconds=1.0)

    def ms(name, k, f):
        t = f.timestamp * 1000 if name == "cam2" else f.timestamp
        return [CameraFrame(name, k, t, f.topology, f.positions, f.states)]

    engine, out = _pushed(recording, calibration, _clean_and(recording, ms))
    n = recording.camera("cam2").skeleton.n_frames
    assert engine.camera_status(0.0)["cam2"]["frames"] <= 1
    assert engine.counts["clock"] >= n - 1 - 2  # all but the first (and up to two held as a candidate step)
    assert len(out) == recording.camera("cam1").skeleton.n_frames  # cam1 still fuses
