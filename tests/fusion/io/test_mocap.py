"""Landmark trajectories, C3D / TRC / BVH readers (files written here from known points) and marker maps."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings

from fusion.calibration import Calibration
from fusion.camera import Intrinsics
from fusion.errors import BadInputError, RecordingError, UnknownNameError
from fusion.io.export import export_c3d, export_trc
from fusion.io.marker_map import (
    BUILTIN_MAPS,
    MarkerMap,
    apply_marker_map,
    load_marker_map,
)
from fusion.io.mocap import (
    LandmarkTrajectory,
    trajectory_from_recording,
    trajectory_from_stream,
)
from fusion.io.mocap_files import MarkerData, read_bvh, read_c3d, read_trc
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, TrackingState
from fusion.transforms import apply
from tests.strategies import transforms


def _stream(n: int = 6, seed: int = 0) -> SkeletonStream:
    rng = np.random.default_rng(seed)
    pos = rng.uniform(-1.0, 2.0, (n, KINECT_V2.n_joints, 3))
    states = np.full(pos.shape[:2], TrackingState.TRACKED, dtype=np.int8)
    pos[2, 3] = np.nan
    states[2, 3] = TrackingState.NOT_TRACKED
    states[1, 4] = TrackingState.INFERRED
    return SkeletonStream(KINECT_V2, np.arange(n) / 30.0, pos, states)


@settings(max_examples=20)
@given(T=transforms())
def test_stream_maps_to_world_with_confidences(T):
    s = _stream()
    traj = trajectory_from_stream(s, T, inferred_weight=0.25)
    np.testing.assert_allclose(traj.positions, apply(T, s.positions), atol=1e-12)
    assert traj.confidence[2, 3] == 0 and np.isnan(traj.positions[2, 3]).all()
    assert traj.confidence[1, 4] == 0.25 and traj.confidence[0, 0] == 1.0
    assert traj.positions.shape == (6, 25, 3) and traj.confidence.shape == (6, 25)


def test_trajectory_rejects_bad_input():
    s = _stream()
    with pytest.raises(BadInputError):
        trajectory_from_stream(s, inferred_weight=1.5)
    with pytest.raises(BadInputError):
        LandmarkTrajectory(KINECT_V2, np.zeros(3), np.zeros((3, 25, 3)), np.ones((3, 25)))  # times not increasing
    with pytest.raises(BadInputError):
        LandmarkTrajectory(KINECT_V2, np.arange(3.0), np.zeros((3, 25, 3)), np.full((3, 25), 2.0))
    with pytest.raises(BadInputError):
        LandmarkTrajectory(KINECT_V2, np.arange(3.0), np.zeros((3, 24, 3)), np.ones((3, 24)))


def test_window_selects_frames_and_rejects_empty():
    traj = trajectory_from_stream(_stream())
    assert traj.window(1 / 30 - 1e-9, 3 / 30 + 1e-9).n_frames == 3
    with pytest.raises(BadInputError, match="spans"):
        traj.window(5.0, 6.0)


def test_recording_camera_needs_its_calibration_and_fused_does_not():
    s = _stream()
    rec = Recording((CameraRecording("cam1", Intrinsics(), s), CameraRecording("cam2", Intrinsics(), s)))
    with pytest.raises(BadInputError, match="calib"):
        trajectory_from_recording(rec, camera="cam1")
    T = np.eye(4)
    T[:3, 3] = (1.0, 2.0, 3.0)
    calib = Calibration({"cam1": T}, {"cam1": Intrinsics()}, {"cam1": 0.0}, "cam1")
    traj = trajectory_from_recording(rec, calibration=calib)
    np.testing.assert_allclose(traj.positions, s.positions + (1.0, 2.0, 3.0))
    with pytest.raises(UnknownNameError, match="cam1"):
        trajectory_from_recording(rec, camera="cam2", calibration=calib)
    fused = Recording((CameraRecording("fused", Intrinsics(), s),))
    np.testing.assert_array_equal(trajectory_from_recording(fused).positions, s.positions)


@pytest.mark.parametrize("up", ["y", "z"])
@pytest.mark.parametrize("units", ["m", "mm"])
def test_trc_round_trip(tmp_path, up, units):
    s = _stream()
    path = export_trc(s, tmp_path / "clip.trc", units=units, up_axis=up)
    m = read_trc(path, up_axis=up)
    assert m.names == KINECT_V2.joints
    np.testing.assert_allclose(m.times, s.timestamps, atol=1e-6)
    np.testing.assert_allclose(m.positions, s.positions, atol=2e-6, equal_nan=True)


def test_c3d_round_trip(tmp_path):
    s = _stream()
    m = read_c3d(export_c3d(s, tmp_path / "clip.c3d"))
    np.testing.assert_allclose(m.positions, s.positions, atol=1e-6, equal_nan=True)
    assert np.isnan(m.positions[2, 3]).all()


def test_readers_reject_bad_files(tmp_path):
    bad = tmp_path / "bad.trc"
    bad.write_text("hello\n")
    with pytest.raises(RecordingError, match="PathFileType"):
        read_trc(bad)
    with pytest.raises(RecordingError):
        read_c3d(bad)
    with pytest.raises(RecordingError):
        read_bvh(bad)
    with pytest.raises(BadInputError, match="unit"):
        read_trc(export_trc(_stream(), tmp_path / "ok.trc"), units="furlong")


_BVH = """HIERARCHY
ROOT Hips
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT Spine
  {
    OFFSET 0 10 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT Neck
    {
      OFFSET 0 20 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      End Site
      {
        OFFSET 0 10 0
      }
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.04
0 90 0 0 0 0 0 0 0 0 0 0
5 90 0 0 0 0 90 0 0 0 0 0
"""


def test_bvh_world_positions_against_hand_computed(tmp_path):
    path = tmp_path / "clip.bvh"
    path.write_text(_BVH)
    m = read_bvh(path)  # y up, centimetres
    assert m.names == ("Hips", "Spine", "Neck")
    np.testing.assert_allclose(m.times, [0.0, 0.04])
    # frame 0: a vertical chain; y-up (0, 90, 0) cm is z-up (0, 0, 0.9) m
    np.testing.assert_allclose(m.positions[0], [[0, 0, 0.9], [0, 0, 1.0], [0, 0, 1.2]], atol=1e-9)
    # frame 1: root moved 5 cm along X, Spine turned 90 deg about Z: Neck's +Y offset becomes -X
    np.testing.assert_allclose(m.positions[1], [[0.05, 0, 0.9], [0.05, 0, 1.0], [-0.15, 0, 1.0]], atol=1e-6)


def _markers(names, pos) -> MarkerData:
    return MarkerData(tuple(names), np.arange(len(pos)) / 30.0, np.asarray(pos, float), "test")


def test_marker_map_weights_and_gaps():
    mm = BUILTIN_MAPS["body25"]
    names = mm.markers
    rng = np.random.default_rng(3)
    pos = rng.normal(size=(4, len(names), 3))
    pos[1, names.index("LEar")] = np.nan
    traj = apply_marker_map(_markers(names, pos), mm)
    head = KINECT_V2.index("Head")
    np.testing.assert_allclose(traj.positions[0, head],
                               0.5 * (pos[0, names.index("LEar")] + pos[0, names.index("REar")]))
    assert traj.confidence[1, head] == 0 and traj.confidence[0, head] == 1
    assert np.isnan(traj.positions[:, KINECT_V2.index("HandTipLeft")]).all()


def test_marker_map_errors_name_what_is_wrong(tmp_path):
    with pytest.raises(UnknownNameError, match="LShoulder"):
        apply_marker_map(_markers(["LShoulder"], np.zeros((2, 1, 3))), BUILTIN_MAPS["body25"])
    with pytest.raises(UnknownNameError, match="ShoulderLeft"):
        MarkerMap(KINECT_V2, (("Shoulder_L", (("A", 1.0),)),))
    partial = dict(BUILTIN_MAPS["kinect_v2"].landmarks)
    del partial["ElbowRight"]
    with pytest.raises(BadInputError, match="right arm.*ElbowRight"):
        MarkerMap(KINECT_V2, tuple(partial.items()))
    with pytest.raises(BadInputError, match="sum to 1"):
        MarkerMap(KINECT_V2, (("SpineBase", (("A", 0.4),)),))
    with pytest.raises(BadInputError, match="body25"):
        load_marker_map("no_such_map")


def test_user_map_from_toml(tmp_path):
    lines = ['topology = "kinect_v2"', "[landmarks]"]
    lines += [f'{j} = "{j}"' for j in KINECT_V2.joints if j != "SpineBase"]
    lines += ['SpineBase = { HipLeft = 0.5, HipRight = 0.5 }']
    path = tmp_path / "map.toml"
    path.write_text("\n".join(lines) + "\n")
    mm = load_marker_map(path)
    s = _stream()
    traj = apply_marker_map(_markers(KINECT_V2.joints, s.positions), mm)
    sb = KINECT_V2.index("SpineBase")
    np.testing.assert_allclose(traj.positions[:, sb], 0.5 * (s.positions[:, 12] + s.positions[:, 16]))
