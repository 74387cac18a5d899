"""Joint confidences estimated from consistency for streams that carry none."""

import numpy as np
import pytest
from hypothesis import given, settings

from fusion.calibrate.reliability import estimate_states, has_confidences
from fusion.errors import BadInputError
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, TrackingState
from tests.fusion.skeleton_fakes import Motion, observe
from tests.strategies import seeds


def _tracked_only(rng, n=150):
    """A moving person seen with 5 mm jitter, every present joint Tracked (no confidences)."""
    times = np.arange(n) / 30.0
    stream = observe(Motion.random(rng=rng).joints(times), np.eye(4), times, rng=rng, inferred_fraction=0.0,
                     missing_fraction=0.0)
    return stream


def test_a_jump_and_a_stretched_bone_are_marked_inferred():
    rng = np.random.default_rng(3)
    stream = _tracked_only(rng)
    assert not has_confidences(stream)
    P = np.array(stream.positions)
    hand = KINECT_V2.index("HandRight")
    P[60, hand] += [0.25, 0.0, 0.0]  # one-frame jump
    P[100:103, 0] += [0.0, 0.3, 0.0]  # three frames with the first joint far off: bones through it stretch
    bad = SkeletonStream(stream.topology, stream.timestamps, P, stream.states)
    out = estimate_states(bad)
    assert out.states[60, hand] == TrackingState.INFERRED
    assert np.all(out.states[100:103, 0] == TrackingState.INFERRED)
    assert has_confidences(out)
    np.testing.assert_array_equal(out.positions, bad.positions)
    assert out.states.shape == bad.states.shape


@settings(max_examples=10, deadline=None)
@given(seeds)
def test_consistent_joints_stay_tracked(seed):
    stream = _tracked_only(np.random.default_rng(seed))
    out = estimate_states(stream)
    kept = np.mean(out.states[stream.states == TrackingState.TRACKED] == TrackingState.TRACKED)
    assert kept > 0.9  # measured 91-97 % kept on these synthetic motions (seeds 0-4)
    assert np.all(out.states <= stream.states)  # never upgrades


def test_streams_with_confidences_are_recognised():
    rng = np.random.default_rng(0)
    times = np.arange(60) / 30.0
    stream = observe(Motion.random(rng=rng).joints(times), np.eye(4), times, rng=rng, inferred_fraction=0.1)
    assert has_confidences(stream)


def test_bad_inputs():
    stream = _tracked_only(np.random.default_rng(1), 20)
    with pytest.raises(BadInputError):
        estimate_states(stream, k_sigma=0.0)
    with pytest.raises(BadInputError):
        estimate_states(stream, half_window=0)
