"""Exports loaded in the tools they are for, with a known pose whose axes must come out right:
OpenSim (TRC), ezc3d (C3D), aniposelib (camera TOML, bundle adjustment), and camera TOMLs read back."""

from __future__ import annotations

import tomllib

import ezc3d
import numpy as np
import pytest
import tomli_w

from fusion.calibration import Calibration
from fusion.camera import AxisConvention, Intrinsics
from fusion.errors import RecordingError
from fusion.io.camera_toml import load_calibration_for, load_camera_toml
from fusion.io.export import export_c3d, export_camera_toml, export_trc
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, Landmark
from fusion.transforms import apply, invert
from scenarios.cli import main
from sim.rig import look_at
from tests.fusion.skeleton_fakes import REST_POSE

HEAD, FOOT = KINECT_V2.index(Landmark.HEAD), KINECT_V2.index(Landmark.FOOT_LEFT)
T = 30
KINECT_CAM = REST_POSE + [0.0, -1.0, 2.5]  # a person 2.5 m in front of a Kinect v2 (+y up), feet 1 m below it
OPENCV_CAM = KINECT_CAM * [-1.0, -1.0, 1.0]  # the same seen by an OpenCV-axes camera (+y down)
WORLD = REST_POSE[:, [2, 0, 1]]  # body frame (left, up, forward) -> world (x forward, y left, z up)


def _stream(points: np.ndarray) -> SkeletonStream:
    pos = np.repeat(points[None], T, axis=0)
    return SkeletonStream(KINECT_V2, np.arange(T) / 30.0, pos, np.full(pos.shape[:2], 2, dtype=np.int8))


FRAMES = [(WORLD, None), (KINECT_CAM, AxisConvention.KINECT_V2), (OPENCV_CAM, AxisConvention.OPENCV)]


@pytest.mark.parametrize("points, axes", FRAMES)
def test_trc_opens_in_opensim_y_up(tmp_path, points, axes):
    osim = pytest.importorskip("opensim")
    path = export_trc(_stream(points), tmp_path / "s.trc", camera_axes=axes)
    table = osim.TimeSeriesTableVec3(str(path))
    assert table.getNumRows() == T and list(table.getColumnLabels()) == list(KINECT_V2.joints)
    assert table.getTableMetaDataAsString("Units") == "m"
    row = table.getRowAtIndex(3)
    head, foot = np.array(row[HEAD].to_numpy()), np.array(row[FOOT].to_numpy())
    height = REST_POSE[HEAD, 1] - REST_POSE[FOOT, 1]
    assert head[1] - foot[1] == pytest.approx(height, abs=1e-6)  # Y up, by the person's height


def test_trc_missing_markers_open_in_opensim(tmp_path):
    osim = pytest.importorskip("opensim")
    s = _stream(WORLD)
    pos, st = s.positions.copy(), s.states.copy()
    pos[5:, -1], st[5:, -1] = np.nan, 0  # the last marker missing: trailing fields
    path = export_trc(SkeletonStream(KINECT_V2, s.timestamps, pos, st), tmp_path / "gap.trc")
    row = osim.TimeSeriesTableVec3(str(path)).getRowAtIndex(7)
    assert np.isnan(row[KINECT_V2.n_joints - 1].to_numpy()).all()


@pytest.mark.parametrize("points, axes", FRAMES)
def test_c3d_opens_in_ezc3d_z_up(tmp_path, points, axes):
    path = export_c3d(_stream(points), tmp_path / "s.c3d", camera_axes=axes)
    c3d = ezc3d.c3d(str(path))
    xyz = c3d["data"]["points"][:3].transpose(2, 1, 0)  # (frames, markers, 3) mm
    assert c3d["parameters"]["POINT"]["UNITS"]["value"] == ["mm"]
    height_mm = 1000 * (REST_POSE[HEAD, 1] - REST_POSE[FOOT, 1])
    np.testing.assert_allclose(xyz[:, HEAD, 2] - xyz[:, FOOT, 2], height_mm, atol=1e-3)


def test_cli_export_of_a_camera_frame_is_not_rotated_twice(tmp_path):
    rec = Recording((CameraRecording("cam1", Intrinsics(), _stream(KINECT_CAM)),))
    from fusion.io.recording_files import save_recording

    save_recording(rec, tmp_path / "rec")
    for extra, axis in (((), 1), (("--up-axis", "z", "--units", "mm", "--rate", "15"), 2)):
        out = tmp_path / f"cam{axis}.trc"
        assert main(["export", str(tmp_path / "rec"), "--camera", "cam1", "--format", "trc", "--out", str(out),
                     *extra]) == 0
        rows = [ln.split("\t") for ln in out.read_text().splitlines()[5:]]
        values = np.array([[float(v) for v in r[2:]] for r in rows]).reshape(len(rows), -1, 3)
        assert np.all(values[:, HEAD, axis] > values[:, FOOT, axis])
    assert len(rows) == 15  # 1 s of frames at --rate 15


def _rig() -> Calibration:
    """A Kinect v2 and an Azure-style camera 2.5 m from the origin, 1 m up, looking at the person."""
    kinect = Intrinsics()
    azure = Intrinsics(width=640, height=576, fx=504.0, fy=504.0, cx=320.0, cy=288.0, axes=AxisConvention.OPENCV)
    T_k = look_at([2.5, 0.5, 1.0], [0.0, 0.0, 1.0])
    T_a = look_at([1.0, -2.3, 1.1], [0.0, 0.0, 1.0]) @ np.diag([-1.0, -1.0, 1.0, 1.0])  # OpenCV axes
    return Calibration({"k": T_k, "a": T_a}, {"k": kinect, "a": azure}, {"k": 0.0, "a": 0.0}, "k")


def _recording(cal: Calibration) -> Recording:
    return Recording(tuple(CameraRecording(n, cal.intrinsics[n], _stream(KINECT_CAM)) for n in cal.camera_names))


@pytest.mark.parametrize("image", ["unmirrored", "as_recorded"])
def test_camera_toml_reads_back_as_the_same_rig(tmp_path, image):
    cal = _rig()
    path = export_camera_toml(cal, tmp_path / "c.toml", kinect_image=image)
    back = load_calibration_for(_recording(cal), path)
    for n in cal.camera_names:
        np.testing.assert_allclose(back.pose(n), cal.pose(n), atol=1e-9)
        assert back.intrinsics[n] == cal.intrinsics[n]
    doc = tomllib.loads(path.read_text())
    doc["metadata"]["units"] = "mm"
    for key in ("cam_1", "cam_2"):
        doc[key]["translation"] = [1000 * v for v in doc[key]["translation"]]
    (tmp_path / "mm.toml").write_text(tomli_w.dumps(doc))
    np.testing.assert_allclose(load_camera_toml(tmp_path / "mm.toml", cal.intrinsics).pose("k"), cal.pose("k"),
                               atol=1e-9)
    del doc["metadata"]["units"]
    (tmp_path / "mm.toml").write_text(tomli_w.dumps(doc))
    with pytest.raises(RecordingError, match='not in metres; set units = "mm"'):
        load_camera_toml(tmp_path / "mm.toml", cal.intrinsics)
    with pytest.raises(RecordingError, match="not in the recording"):
        load_camera_toml(path, {"k": cal.intrinsics["k"]})


def test_aniposelib_projects_and_triangulates_like_the_rig(tmp_path):
    """Default export (fx > 0): aniposelib projects like our intrinsics (of the unmirrored Kinect image)
    and triangulates the points back. Its bundle adjustment (numba-compiled, ~15 s) is checked by
    ``mocap-bench hostile`` (case "camera TOML: aniposelib bundle adjustment converges")."""
    anipose = pytest.importorskip("aniposelib.cameras")
    cal = _rig()
    path = export_camera_toml(cal, tmp_path / "c.toml")
    group = anipose.CameraGroup.load(str(path))
    rng = np.random.default_rng(4)
    p_world = rng.uniform([-0.4, -0.4, 0.2], [0.4, 0.4, 1.8], size=(30, 3))
    uv = []
    for n in cal.camera_names:
        intr = cal.intrinsics[n]
        px, _ = intr.project(apply(invert(cal.pose(n)), p_world))
        if intr.axes is AxisConvention.KINECT_V2:
            px[:, 0] = intr.width - 1 - px[:, 0]  # the unmirrored image the file describes
        uv.append(px)
    uv = np.array(uv)
    np.testing.assert_allclose(group.project(p_world), uv, atol=1e-6)
    np.testing.assert_allclose(group.triangulate(uv), p_world, atol=1e-6)
