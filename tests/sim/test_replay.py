"""Fitted motion files and their replay as a timeline segment."""

from __future__ import annotations

import numpy as np
import pytest

from fusion.errors import BadInputError, RecordingError
from sim.anthropometry import Anthropometry
from sim.coordinates import COORDINATES, INDEX
from sim.motions import idle
from sim.replay import FittedMotion, load_motion, replay_motion, save_motion
from sim.timeline import compose

K = len(COORDINATES)


def _motion(n: int = 40) -> FittedMotion:
    t = 2.0 + np.arange(n) / 30.0
    q = 0.1 * np.random.default_rng(0).normal(size=(n, K))
    return FittedMotion(t, q, Anthropometry(height_m=1.6, forearm=1.1), "kinect_v2", ("A", "B"),
                        np.zeros((n, 2)), np.zeros(n), np.ones(n, bool), "test", {"failed_frames": []})


def test_save_and_load_round_trip(tmp_path):
    m = _motion()
    back = load_motion(save_motion(m, tmp_path / "m.npz"))
    np.testing.assert_array_equal(back.coords, m.coords)
    np.testing.assert_array_equal(back.times, m.times)
    assert back.anthropometry == m.anthropometry and back.joints == m.joints and back.source == "test"


def test_load_rejects_other_files(tmp_path):
    bad = tmp_path / "x.npz"
    np.savez(bad, meta=np.array('{"format": "other", "version": 1}'))
    with pytest.raises(RecordingError, match="mocap-bench-motion"):
        load_motion(bad)
    with pytest.raises(RecordingError, match="retarget"):
        load_motion(tmp_path / "missing.npz")


def test_fitted_motion_validates_shapes():
    m = _motion()
    with pytest.raises(BadInputError, match="coords"):
        FittedMotion(m.times, m.coords[:, :3], m.anthropometry, "kinect_v2", m.joints, m.errors, m.frame_rms,
                     m.converged)


def test_replay_interpolates_the_frames():
    m = _motion()
    r = replay_motion(m)
    assert r.duration == pytest.approx(m.duration)
    np.testing.assert_allclose(r.sample(m.times - m.times[0]), m.coords, atol=1e-12)
    mid = r.sample(np.array([0.5 / 30.0]))[0]
    np.testing.assert_allclose(mid, 0.5 * (m.coords[0] + m.coords[1]), atol=1e-12)


def test_replay_window_and_placement():
    m = _motion()
    r = replay_motion(m, start_s=2.0 + 10 / 30, end_s=2.0 + 20 / 30, position_m=(1.0, -1.0), facing_deg=90.0)
    q = r.sample(np.array([0.0, r.duration]))
    assert r.duration == pytest.approx(10 / 30)
    np.testing.assert_allclose(q[0, [INDEX["root_x"], INDEX["root_y"]]], [1.0, -1.0], atol=1e-12)
    assert q[0, INDEX["root_yaw"]] == pytest.approx(np.pi / 2)
    # the floor path turns with the facing: the step from frame 10 to 20 is rotated by the turn
    turn = np.pi / 2 - m.coords[10, INDEX["root_yaw"]]
    step = m.coords[20, [INDEX["root_x"], INDEX["root_y"]]] - m.coords[10, [INDEX["root_x"], INDEX["root_y"]]]
    c, s = np.cos(turn), np.sin(turn)
    np.testing.assert_allclose(q[1, :2] - q[0, :2], [c * step[0] - s * step[1], s * step[0] + c * step[1]],
                               atol=1e-12)
    np.testing.assert_allclose(q[:, 3:], m.coords[[10, 20], 3:], atol=1e-12)  # joint angles untouched
    with pytest.raises(BadInputError, match="fewer than two"):
        replay_motion(m, start_s=100.0)


def test_replay_composes_with_scripted_segments():
    m = _motion()
    total = compose([replay_motion(m), idle(2.0, rng=np.random.default_rng(0))])
    assert total.duration == pytest.approx(m.duration + 2.0)
    assert np.isfinite(total.sample(np.linspace(0, total.duration, 50))).all()
