"""Pooling sessions of one fixed rig onto one time line."""

import numpy as np
import pytest

from fusion.calibrate.sessions import SESSION_GAP_S, pool_sessions
from fusion.camera import KINECT_V2_DEPTH
from fusion.errors import BadInputError
from fusion.recording import CameraRecording, Recording
from tests.fusion.skeleton_fakes import Motion, observe


def _session(rng, start_s, names=("cam1", "cam2"), n=40):
    times = start_s + np.arange(n) / 30.0
    joints = Motion.random(rng=rng).joints(times)
    cams = tuple(CameraRecording(name, KINECT_V2_DEPTH, observe(joints, np.eye(4), times, rng=rng)) for name in names)
    return Recording(cams)


def test_sessions_are_laid_end_to_end_with_clocks_corrected():
    rng = np.random.default_rng(0)
    s1, s2 = _session(rng, 100.0), _session(rng, 5.0, n=30)
    pooled = pool_sessions([s1, s2], [{"cam1": 0.0, "cam2": 0.02}, {"cam1": 0.0, "cam2": -0.01}])
    assert [c.name for c in pooled.cameras] == ["cam1", "cam2"]
    cam2 = pooled.camera("cam2").skeleton
    assert cam2.n_frames == 70
    np.testing.assert_array_equal(cam2.positions[:40], s1.camera("cam2").skeleton.positions)
    shift1 = pooled.metadata["sessions"][0]["time_shift_s"]
    # camera 2's clock offset removed: its frames land where camera 1's do
    np.testing.assert_allclose(cam2.timestamps[:40], pooled.camera("cam1").skeleton.timestamps[:40] - 0.02, atol=1e-9)
    np.testing.assert_allclose(cam2.timestamps[40:], pooled.camera("cam1").skeleton.timestamps[40:] + 0.01, atol=1e-9)
    gap = pooled.camera("cam1").skeleton.timestamps[40] - pooled.camera("cam1").skeleton.timestamps[39]
    assert gap >= SESSION_GAP_S
    assert shift1 == pytest.approx(-100.0 + 0.02)  # first session starts at 0 (its earliest corrected frame)


def test_sessions_of_different_rigs_are_refused():
    rng = np.random.default_rng(1)
    with pytest.raises(BadInputError, match="same camera names"):
        pool_sessions([_session(rng, 0.0), _session(rng, 0.0, names=("cam1", "cam3"))], [{}, {}])
    with pytest.raises(BadInputError):
        pool_sessions([_session(rng, 0.0)], [])
    with pytest.raises(BadInputError):
        pool_sessions([], [])
