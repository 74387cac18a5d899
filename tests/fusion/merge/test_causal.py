"""Causal fusion: the frame-by-frame back-facing detector against the offline detector on the
stream so far, and the causal fusion against the offline fuse when their flags agree."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fusion.errors import BadInputError
from fusion.facing import detect_back_facing
from fusion.merge.causal import (
    CausalBackFacing,
    causal_back_facing,
    check_causal,
    fuse_causal,
)
from fusion.merge.filters import TemporalFilter
from fusion.merge.fuse import FuseOptions, camera_views, fuse_views
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2
from tests.fusion.live.fakes import session


def _turning_stream(seed, n=90):
    """A stream whose limbs swap sides now and then (a tracker seeing the back), with a tracking gap."""
    recording, _ = session(rng=np.random.default_rng(seed), n_cameras=1, seconds=n / 30)
    s = recording.cameras[0].skeleton
    rng = np.random.default_rng(seed + 1)
    P, S = s.positions.copy(), s.states.copy()
    swapped = np.cumsum(rng.random(s.n_frames) < 0.05) % 2 == 1
    mirror = np.array(KINECT_V2.mirror)
    P[swapped], S[swapped] = P[swapped][:, mirror], S[swapped][:, mirror]
    gap = slice(n // 2, n // 2 + 12)
    P[gap], S[gap] = np.nan, 0
    return SkeletonStream(KINECT_V2, s.timestamps, P, S)


@settings(max_examples=8)
@given(seed=st.integers(0, 2**31))
def test_each_flag_is_the_offline_flag_of_the_stream_so_far(seed):
    stream = _turning_stream(seed)
    flags = causal_back_facing(stream)
    assert flags.shape == (stream.n_frames,) and flags.dtype == bool
    for t in range(0, stream.n_frames, 7):
        assert flags[t] == detect_back_facing(stream.subset(slice(0, t + 1))).flipped[t]
    assert flags[-1] == detect_back_facing(stream).flipped[-1]


def test_the_detector_takes_frames_in_time_order_only():
    stream = _turning_stream(1, n=5)
    detector = CausalBackFacing(KINECT_V2)
    detector.step(stream.timestamps[1], stream.positions[1], stream.states[1])
    with pytest.raises(BadInputError):
        detector.step(stream.timestamps[0], stream.positions[0], stream.states[0])
    with pytest.raises(BadInputError):
        CausalBackFacing(KINECT_V2, max_gap_s=0.0)


def test_causal_fusion_is_the_offline_fusion_where_the_flags_agree():
    recording, calibration = session(rng=np.random.default_rng(5), n_cameras=3, seconds=2.0)
    options = FuseOptions(temporal=TemporalFilter.ONE_EURO)
    flags_agree = all(np.array_equal(causal_back_facing(c.skeleton), detect_back_facing(c.skeleton).flipped)
                      for c in recording.cameras)
    assert flags_agree
    causal = fuse_causal(recording, calibration, options)
    offline = fuse_views(camera_views(recording, calibration), options)
    assert causal.positions.shape == (recording.camera("cam1").skeleton.n_frames, 25, 3)
    assert np.array_equal(causal.positions, offline.positions, equal_nan=True)
    assert np.array_equal(causal.reliability, offline.reliability)


def test_filters_that_use_the_future_are_not_causal():
    check_causal(FuseOptions(temporal=TemporalFilter.ONE_EURO))
    for options in (FuseOptions(temporal=TemporalFilter.KALMAN), FuseOptions(bone_lengths=True)):
        with pytest.raises(BadInputError):
            check_causal(options)
