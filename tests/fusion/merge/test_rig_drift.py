"""A camera that moves during a session is found, when and by how much; steady rigs are not flagged."""

from __future__ import annotations

import numpy as np
import pytest

from fusion.errors import BadInputError
from fusion.merge.rig_drift import rig_drift
from fusion.merge.views import CameraViews
from fusion.topology import KINECT_V2, TrackingState


def _views(n_cameras: int, *, moved: dict[int, tuple[float, np.ndarray]] | None = None, seconds: float = 30.0,
           noise_m: float = 0.02, seed: int = 0) -> CameraViews:
    """Cameras seeing one wandering body with ``noise_m`` each; ``moved``: camera -> (from time [s], shift [m])."""
    rng = np.random.default_rng(seed)
    times = np.arange(0.0, seconds, 1 / 30)
    J = KINECT_V2.n_joints
    body = rng.normal(0.0, 0.3, (J, 3)) + [0.0, 0.0, 1.0]
    walk = np.cumsum(rng.normal(0.0, 0.002, (times.size, 1, 3)), axis=0)
    pos = body + walk + rng.normal(0.0, noise_m, (n_cameras, times.size, J, 3))
    for c, (t_from, shift) in (moved or {}).items():
        pos[c, times >= t_from] += shift
    states = np.full(pos.shape[:3], TrackingState.TRACKED, dtype=np.int8)
    centres = np.array([[2.0 * np.cos(a), 2.0 * np.sin(a), 1.0] for a in np.linspace(0, np.pi, n_cameras)])
    return CameraViews(tuple(f"cam{k + 1}" for k in range(n_cameras)), KINECT_V2, times, pos, states, centres,
                       np.zeros(pos.shape[:2], dtype=bool))


def test_a_steady_rig_is_not_flagged():
    drift = rig_drift(_views(3))
    assert drift.moved == () and drift.describe() == ""
    assert all(0.01 < c.baseline_m < 0.05 for c in drift.cameras)


def test_a_camera_moved_halfway_is_found_with_its_time_and_size():
    drift = rig_drift(_views(3, moved={1: (15.0, np.array([0.3, 0.0, 0.0]))}))
    assert [c.name for c in drift.moved] == ["cam2"]
    start, end = drift.moved[0].moved
    assert start == pytest.approx(15.0, abs=0.1) and end == pytest.approx(30.0, abs=5.0)
    assert drift.moved[0].during_move_m(drift.window_starts_s) == pytest.approx(0.3, abs=0.05)
    assert "cam2 disagrees with the other cameras by" in drift.describe()


def test_two_cameras_cannot_say_which_moved_but_say_that_one_did():
    drift = rig_drift(_views(2, moved={1: (10.0, np.array([0.0, 0.2, 0.1]))}))
    assert {c.name for c in drift.moved} == {"cam1", "cam2"}
    assert "cam1 and cam2 disagree by" in drift.describe() and "one of them moved" in drift.describe()


def test_a_short_glitch_is_not_a_move():
    drift = rig_drift(_views(3, moved={0: (29.0, np.array([0.5, 0.0, 0.0]))}))
    assert drift.moved == ()


def test_bad_arguments():
    with pytest.raises(BadInputError, match="at least two"):
        rig_drift(_views(2).subset(["cam1"]))
    with pytest.raises(BadInputError, match="window_s"):
        rig_drift(_views(2), window_s=0.0)
