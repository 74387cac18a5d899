"""Exports: C3D (read back with ezc3d), TRC and CSV (parsed here), camera TOML (projection oracle), CLI."""

from __future__ import annotations

import tomllib

import ezc3d
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fusion.calibration import Calibration
from fusion.camera import AxisConvention, Intrinsics
from fusion.errors import BadInputError
from fusion.io.calibration_file import save_calibration
from fusion.io.export import (
    KinectImage,
    export_c3d,
    export_camera_toml,
    export_csv,
    export_trc,
    resample_uniform,
)
from fusion.io.recording_files import save_recording
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, TrackingState
from fusion.transforms import apply, invert, make_transform
from scenarios.cli import main

J = KINECT_V2.n_joints


def _stream(timestamps, *, seed: int = 0, missing=((3, 4), (7, 0))) -> SkeletonStream:
    """Random positions [m] in a 0.6 m box 1 m above the floor of a z-up world (a person's size), joints absent at the (frame, joint) pairs ``missing``."""
    rng = np.random.default_rng(seed)
    T = len(timestamps)
    pos = rng.uniform([-0.3, -0.3, 0.7], [0.3, 0.3, 1.3], size=(T, J, 3))
    states = np.full((T, J), TrackingState.TRACKED, dtype=np.int8)
    for f, j in missing:
        pos[f, j] = np.nan
        states[f, j] = TrackingState.NOT_TRACKED
    if T > 1:
        states[1, 2] = TrackingState.INFERRED
    return SkeletonStream(KINECT_V2, np.asarray(timestamps, dtype=float), pos, states)


def _linear_stream(timestamps) -> SkeletonStream:
    """Every joint moves along x at 1 m/s: x = t, y = joint index, z = 1."""
    ts = np.asarray(timestamps, dtype=float)
    pos = np.zeros((ts.size, J, 3))
    pos[..., 0] = ts[:, None]
    pos[..., 1] = np.arange(J)
    pos[..., 2] = 1.0
    return SkeletonStream(KINECT_V2, ts, pos, np.full((ts.size, J), TrackingState.TRACKED, dtype=np.int8))


UNIFORM = 10.0 + np.arange(12) / 30.0


# ---------------------------------------------------------------------------- resampling


def test_resample_keeps_uniform_frames():
    stream = _stream(UNIFORM)
    times, pos = resample_uniform(stream, 30.0)
    np.testing.assert_allclose(times, stream.timestamps, atol=1e-12)
    np.testing.assert_array_equal(np.isnan(pos), np.isnan(stream.positions))
    np.testing.assert_allclose(pos, stream.positions, atol=1e-12)


def test_resample_interpolates_within_two_frames_else_gap():
    ts = np.array([0, 1, 2, 4, 5, 8, 9]) / 10.0  # one frame dropped after 0.2, two after 0.5
    times, pos = resample_uniform(_linear_stream(ts + 0.003), 10.0)
    np.testing.assert_allclose(times, np.arange(10) / 10.0 + 0.003)
    x = pos[:, 0, 0]
    np.testing.assert_allclose(x[[0, 1, 2, 3, 4, 5, 8, 9]], times[[0, 1, 2, 3, 4, 5, 8, 9]], atol=1e-12)
    assert np.isnan(x[[6, 7]]).all()


def test_resample_jitter_is_linear_interpolation():
    rng = np.random.default_rng(1)
    ts = np.arange(30) / 30.0 + rng.uniform(-2e-3, 2e-3, 30)
    times, pos = resample_uniform(_linear_stream(ts), 30.0)
    np.testing.assert_allclose(pos[:, :, 0], np.repeat(times[:, None], J, axis=1), atol=1e-12)
    np.testing.assert_allclose(pos[:, :, 1], np.repeat(np.arange(J)[None], times.size, axis=0))


# ---------------------------------------------------------------------------- C3D


def test_c3d_round_trip(tmp_path):
    stream = _stream(UNIFORM)
    path = export_c3d(stream, tmp_path / "out" / "s.c3d")
    c3d = ezc3d.c3d(str(path))
    point = c3d["parameters"]["POINT"]
    assert list(point["LABELS"]["value"]) == list(KINECT_V2.joints)
    assert point["UNITS"]["value"] == ["mm"]
    assert point["RATE"]["value"][0] == pytest.approx(30.0)
    pts = c3d["data"]["points"][:3].transpose(2, 1, 0)  # (T, J, 3)
    expected = stream.positions * 1000.0
    np.testing.assert_array_equal(np.isnan(pts), np.isnan(expected))
    np.testing.assert_allclose(pts, expected, atol=1e-3, equal_nan=True)
    residuals = c3d["data"]["meta_points"]["residuals"][0].T  # (T, J)
    np.testing.assert_array_equal(residuals < 0, np.isnan(stream.positions[..., 0]))
    assert list(tmp_path.joinpath("out").iterdir()) == [path]  # no temporary file left


def test_c3d_metres_and_resampled_rate(tmp_path):
    ts = np.array([0, 1, 2, 4, 5]) / 50.0
    path = export_c3d(_linear_stream(ts), tmp_path / "s.c3d", units="m")
    c3d = ezc3d.c3d(str(path))
    assert c3d["parameters"]["POINT"]["UNITS"]["value"] == ["m"]
    assert c3d["parameters"]["POINT"]["RATE"]["value"][0] == pytest.approx(50.0)
    x = c3d["data"]["points"][0, 5, :]
    np.testing.assert_allclose(x, np.arange(6) / 50.0, atol=1e-6)


# ---------------------------------------------------------------------------- TRC


def _read_trc(path):
    lines = path.read_text().split("\n")
    header = dict(zip(lines[1].split("\t"), lines[2].split("\t")))
    names = [n for n in lines[3].split("\t")[2:] if n]
    rows = [line.split("\t") for line in lines[5:] if line]
    frames = np.array([int(r[0]) for r in rows])
    times = np.array([float(r[1]) for r in rows])
    values = np.array([[float(v) if v else np.nan for v in r[2:]] for r in rows]).reshape(len(rows), -1, 3)
    return lines, header, names, frames, times, values


def test_trc_header_and_values_y_up(tmp_path):
    stream = _stream(UNIFORM)
    path = export_trc(stream, tmp_path / "s.trc")
    lines, header, names, frames, times, values = _read_trc(path)
    assert lines[0].split("\t") == ["PathFileType", "4", "(X/Y/Z)", "s.trc"]
    assert header == {"DataRate": "30", "CameraRate": "30", "NumFrames": "12", "NumMarkers": str(J),
                      "Units": "m", "OrigDataRate": "30", "OrigDataStartFrame": "1", "OrigNumFrames": "12"}
    assert lines[3].split("\t")[:2] == ["Frame#", "Time"]
    assert lines[4].split("\t")[2:5] == ["X1", "Y1", "Z1"] and len(lines[4].split("\t")) == 2 + 3 * J
    assert names == list(KINECT_V2.joints)
    np.testing.assert_array_equal(frames, np.arange(1, 13))
    np.testing.assert_allclose(times, UNIFORM, atol=1e-6)
    p = stream.positions
    expected = np.stack([p[..., 0], p[..., 2], -p[..., 1]], axis=-1)  # x forward, y up, z right
    np.testing.assert_allclose(values, expected, atol=1e-6)
    assert np.isnan(values[3, 4]).all() and np.isnan(values[7, 0]).all()


def test_trc_millimetres_z_up(tmp_path):
    stream = _stream(UNIFORM)
    path = export_trc(stream, tmp_path / "s.trc", units="mm", up_axis="z", rate_hz=30.0)
    _, header, _, _, _, values = _read_trc(path)
    assert header["Units"] == "mm"
    np.testing.assert_allclose(values, stream.positions * 1000.0, atol=1e-3)


# ---------------------------------------------------------------------------- CSV


def test_csv_round_trip(tmp_path):
    stream = _stream(UNIFORM + np.r_[0, np.cumsum(np.full(11, 1e-4))])  # non-uniform: written as is
    path = export_csv(stream, tmp_path / "s.csv")
    header = path.read_text().split("\n")[0].split(",")
    assert header[:5] == ["time_s", "SpineBase_x_m", "SpineBase_y_m", "SpineBase_z_m", "SpineBase_state"]
    assert len(header) == 1 + 4 * J
    data = np.genfromtxt(path, delimiter=",", skip_header=1)
    assert data.shape == (12, 1 + 4 * J)
    np.testing.assert_array_equal(data[:, 0], stream.timestamps)
    per_joint = data[:, 1:].reshape(12, J, 4)
    np.testing.assert_array_equal(per_joint[..., :3], stream.positions)  # NaN equal to NaN
    np.testing.assert_array_equal(per_joint[..., 3], stream.states)


# ---------------------------------------------------------------------------- errors


def test_bad_input(tmp_path):
    empty = SkeletonStream(KINECT_V2, np.zeros(0), np.zeros((0, J, 3)), np.zeros((0, J), dtype=np.int8))
    for export in (export_c3d, export_trc, export_csv):
        with pytest.raises(BadInputError, match="empty"):
            export(empty, tmp_path / "x")
    single = _stream([0.0], missing=())
    with pytest.raises(BadInputError, match="at least 2 frames"):
        export_trc(single, tmp_path / "x.trc")
    export_trc(single, tmp_path / "x.trc", rate_hz=30.0)  # fine with an explicit rate
    with pytest.raises(BadInputError, match="rate_hz"):
        export_c3d(_stream(UNIFORM), tmp_path / "x.c3d", rate_hz=float("nan"))
    with pytest.raises(BadInputError, match="give at most"):  # not terabytes of interpolated frames
        export_c3d(_stream(UNIFORM), tmp_path / "x.c3d", rate_hz=1e12)
    with pytest.raises(ValueError):
        export_trc(_stream(UNIFORM), tmp_path / "x.trc", units="cm")
    with pytest.raises(BadInputError, match="NaN or infinite"):  # streams cannot hold such timestamps
        _stream([0.0, np.nan], missing=())
    assert not any(p.name.startswith(".") for p in tmp_path.iterdir())


# ---------------------------------------------------------------------------- camera TOML


def _calibration(seed: int) -> Calibration:
    rng = np.random.default_rng(seed)
    kinect = Intrinsics()
    azure = Intrinsics(width=640, height=576, fx=504.2, fy=504.5, cx=321.4, cy=330.2, axes=AxisConvention.OPENCV)
    T = {}
    for name in ("k1", "az"):
        R = Rotation.from_rotvec(rng.normal(size=3)).as_matrix()
        T[name] = make_transform(R, rng.uniform(-3, 3, 3))
    return Calibration(T, {"k1": kinect, "az": azure}, {"k1": 0.0, "az": 0.01}, "k1")


def _world_points_in_front(calibration: Calibration, name: str, rng: np.random.Generator) -> np.ndarray:
    intr = calibration.intrinsics[name]
    uv = rng.uniform([0, 0], [intr.width, intr.height], size=(20, 2))
    p_cam = intr.backproject(uv, rng.uniform(0.5, 4.0, 20))
    return apply(calibration.pose(name), p_cam)


def _project_toml(table: dict, p_world: np.ndarray) -> np.ndarray:
    K, t = np.array(table["matrix"]), np.array(table["translation"])
    R = Rotation.from_rotvec(table["rotation"]).as_matrix()
    x = (K @ (p_world @ R.T + t).T).T
    return x[:, :2] / x[:, 2:]


@given(seed=st.integers(0, 2**32 - 1))
def test_camera_toml_projection_matches_intrinsics(tmp_path_factory, seed):
    calibration = _calibration(seed)
    path = export_camera_toml(calibration, tmp_path_factory.mktemp("cam") / "calib.toml", kinect_image="as_recorded")
    doc = tomllib.loads(path.read_text())
    assert set(doc) == {"cam_1", "cam_2", "metadata"}
    assert doc["metadata"]["units"] == "m"
    rng = np.random.default_rng(seed)
    for key, name in (("cam_1", "k1"), ("cam_2", "az")):
        table = doc[key]
        intr = calibration.intrinsics[name]
        assert table["name"] == name and table["size"] == [intr.width, intr.height]
        assert table["distortions"] == [0.0] * 5
        p_world = _world_points_in_front(calibration, name, rng)
        uv, _ = intr.project(apply(invert(calibration.pose(name)), p_world))
        np.testing.assert_allclose(_project_toml(table, p_world), uv, atol=1e-6)


def test_camera_toml_opencv_axes_and_unmirrored_kinect_by_default(tmp_path):
    calibration = _calibration(3)
    doc = tomllib.loads(export_camera_toml(calibration, tmp_path / "c.toml").read_text())
    rng = np.random.default_rng(3)
    k1, az = doc["cam_1"], doc["cam_2"]
    assert k1["matrix"][0][0] > 0 and az["matrix"] == [[504.2, 0, 321.4], [0, 504.5, 330.2], [0, 0, 1]]
    intr = calibration.intrinsics["k1"]
    p_world = _world_points_in_front(calibration, "k1", rng)
    p_cam = apply(invert(calibration.pose("k1")), p_world)
    uv, _ = intr.project(p_cam)
    np.testing.assert_allclose(_project_toml(k1, p_world), np.c_[intr.width - 1 - uv[:, 0], uv[:, 1]], atol=1e-6)
    # OpenCV camera axes: the Kinect's +y (up) is the OpenCV camera's -y, +z stays forward.
    R = Rotation.from_rotvec(k1["rotation"]).as_matrix()
    p_cv = p_world @ R.T + np.array(k1["translation"])
    np.testing.assert_allclose(p_cv, p_cam * [-1, -1, 1], atol=1e-9)
    assert KinectImage(doc["metadata"]["kinect_image"]) is KinectImage.UNMIRRORED


# ---------------------------------------------------------------------------- CLI


@pytest.fixture
def fused_dir(tmp_path):
    recording = Recording((CameraRecording("fused", Intrinsics(), skeleton=_stream(UNIFORM)),))
    save_recording(recording, tmp_path / "fused" / "recording")
    return tmp_path / "fused"


@pytest.mark.parametrize("fmt", ["c3d", "trc", "csv"])
def test_cli_export_skeleton(fused_dir, tmp_path, fmt, capsys):
    out = tmp_path / f"fused.{fmt}"
    assert main(["export", str(fused_dir), "--format", fmt, "--out", str(out)]) == 0
    assert out.is_file() and out.stat().st_size > 0
    assert main(["export", str(fused_dir / "recording"), "--format", fmt, "--out", str(out),
                 "--camera", "fused"]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert main(["export", str(fused_dir / "recording"), "--format", fmt, "--out", str(out),
                 "--camera", "fused", "--overwrite"]) == 0
    assert "wrote" in capsys.readouterr().out


def test_cli_export_camera_toml(tmp_path):
    calib = save_calibration(_calibration(0), tmp_path / "calib.toml")
    out = tmp_path / "cams.toml"
    assert main(["export", str(calib), "--format", "camera-toml", "--out", str(out)]) == 0
    assert set(tomllib.loads(out.read_text())) == {"cam_1", "cam_2", "metadata"}


def test_cli_export_wrong_input(fused_dir, tmp_path, capsys):
    out = tmp_path / "x"
    assert main(["export", str(tmp_path / "missing"), "--format", "c3d", "--out", str(out)]) == 2
    assert "mocap-bench export: error:" in capsys.readouterr().err
    assert main(["export", str(fused_dir), "--format", "camera-toml", "--out", str(out)]) == 2
    assert "calibration" in capsys.readouterr().err
    assert main(["export", str(fused_dir), "--format", "trc", "--out", str(out), "--camera", "cam9"]) == 2
    assert "unknown camera 'cam9'; available: fused" in capsys.readouterr().err
    assert not out.exists()
