"""Plausibility checks: units of lengths and times, integer states, shared clocks, camera sets, usable streams."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fusion.errors import BadInputError, RecordingError
from fusion.io.plausibility import (
    check_camera_sets,
    check_clock_overlap,
    check_integer_states,
    check_stream_units,
    check_usable_streams,
    median_bone_length_m,
    median_distance_m,
    median_interval_s,
)
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, TrackingState
from tests.fusion.skeleton_fakes import REST_POSE


def _person(*, distance_m: float = 2.5, rate_hz: float = 30.0, n: int = 40, t0: float = 0.0) -> SkeletonStream:
    """The rest pose standing ``distance_m`` in front of a Kinect v2 camera, ``n`` frames at ``rate_hz``."""
    pos = np.repeat(REST_POSE[None] + [0.0, -1.0, distance_m], n, axis=0)
    states = np.full(pos.shape[:2], TrackingState.TRACKED, dtype=np.int8)
    return SkeletonStream(KINECT_V2, t0 + np.arange(n) / rate_hz, pos, states)


def _scaled(s: SkeletonStream, *, length: float = 1.0, time: float = 1.0) -> SkeletonStream:
    return SkeletonStream(s.topology, s.timestamps * time, s.positions * length, s.states)


def test_summaries_of_a_person():
    s = _person(distance_m=2.5)
    assert 0.1 < median_bone_length_m(s) < 0.3  # rest-pose bones: 0.07-0.43 m
    assert median_distance_m(s) == pytest.approx(np.linalg.norm(REST_POSE.mean(axis=0) + [0, -1, 2.5]))
    assert median_interval_s(s) == pytest.approx(1 / 30)
    one = s.subset(slice(0, 1))
    assert np.isnan(median_interval_s(one))
    empty = SkeletonStream(KINECT_V2, [0.0, 0.1], np.full((2, 25, 3), np.nan), np.zeros((2, 25), dtype=np.int8))
    assert np.isnan(median_bone_length_m(empty)) and np.isnan(median_distance_m(empty))
    check_stream_units(empty, "nothing tracked")  # nothing to judge: accepted


@given(distance=st.floats(0.5, 8.0), rate=st.floats(5.0, 120.0), t0=st.floats(-1e4, 1e9))
def test_plausible_streams_pass(distance, rate, t0):
    check_stream_units(_person(distance_m=distance, rate_hz=rate, t0=t0), "ok")


@given(distance=st.floats(0.5, 8.0), factor=st.sampled_from([1000.0, 1e-3, 25.4e-3 * 1e-3]))
def test_length_unit_mistakes_are_refused(distance, factor):
    with pytest.raises(RecordingError, match="look like.*--csv-unit"):
        check_stream_units(_scaled(_person(distance_m=distance), length=factor), "f.csv", length_hint="--csv-unit")


@given(rate=st.floats(5.0, 120.0), unit=st.sampled_from([(1e3, "milliseconds"), (1e6, "microseconds"),
                                                         (1e9, "nanoseconds")]))
def test_time_unit_mistakes_are_refused_and_named(rate, unit):
    factor, name = unit
    with pytest.raises(RecordingError, match=f"frame interval.*{name}"):
        check_stream_units(_scaled(_person(rate_hz=rate), time=factor), "f.csv")


def test_seconds_read_as_microseconds_are_refused():
    with pytest.raises(RecordingError, match="another unit than seconds"):
        check_stream_units(_scaled(_person(), time=1e-6), "f.json")


def test_a_distant_body_is_refused():
    with pytest.raises(RecordingError, match="from the camera"):
        check_stream_units(_person(distance_m=400.0), "cam")


def test_integer_states():
    check_integer_states(np.array([[0, 1, 2]], dtype=np.int8), "x")
    check_integer_states(np.array([[0.0, 2.0, 3.0]]), "x")  # whole floats keep their values
    for bad in (np.array([[1.7, 2.0]]), np.array([[np.nan]]), np.array([["2"]])):
        with pytest.raises(RecordingError, match="whole numbers"):
            check_integer_states(bad, "cam1")


@given(shift=st.floats(0.0, 0.5), span=st.floats(1.0, 100.0))
def test_clock_overlap(shift, span):
    check_clock_overlap({"a": (0.0, span), "b": (shift * span, (1 + shift) * span)}, "rec")  # half overlaps
    with pytest.raises(RecordingError, match="time base"):
        check_clock_overlap({"a": (0.0, span), "b": (0.6 * span, 1.6 * span)}, "rec")
    with pytest.raises(RecordingError, match="camera c's clock.*time base"):
        check_clock_overlap({"a": (0.0, span), "b": (0.0, span), "c": (1.7e9, 1.7e9 + span)}, "rec")
    check_clock_overlap({"only": (5.0, 5.0)}, "rec")


def test_camera_sets_both_ways():
    check_camera_sets(["cam1", "cam2"], ["cam2", "cam1"], "c.toml")
    with pytest.raises(BadInputError, match="lacks recording camera\\(s\\) cam2"):
        check_camera_sets(["cam1", "cam2"], ["cam1"], "c.toml")
    with pytest.raises(BadInputError, match="names camera\\(s\\) cam3 the recording does not have"):
        check_camera_sets(["cam1"], ["cam1", "cam3"], "c.toml")


def test_usable_streams():
    s = _person()
    check_usable_streams({"a": s, "b": s}, "rec")
    for bad, msg in ((None, "has no skeleton"), (s.subset(slice(0, 1)), "has 1 frame"),
                     (s.subset(slice(0, 0)), "has 0 frame"),
                     (SkeletonStream(KINECT_V2, [0.0, 0.1], np.full((2, 25, 3), np.nan),
                                     np.zeros((2, 25), dtype=np.int8)), "never tracked")):
        with pytest.raises(RecordingError, match=f"camera b {msg}"):
            check_usable_streams({"a": s, "b": bad}, "rec")


def test_coordinates_that_overflow_are_refused():
    s = _scaled(_person(), length=1e300)  # bone lengths overflow to inf: not a person, not silently NaN
    assert median_bone_length_m(s) == np.inf
    with pytest.raises(RecordingError, match="absurd values"):
        check_stream_units(s, "cam1")
