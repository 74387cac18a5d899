"""The Rerun viewer: what ``mocap-bench view`` writes, read back with the SDK's own RRD reader."""

import sys

import numpy as np
import pytest

from fusion.errors import BadInputError
from fusion.io.angle_tables import read_angles_csv
from fusion.io.calibration_file import save_calibration
from fusion.merge.angles import joint_angles
from fusion.merge.fuse import FuseOptions
from scenarios.cli import main
from scenarios.config import load_scenario
from scenarios.fusing import fuse_to_disk
from scenarios.interop.rerun_view import (
    SourceKind,
    Viewer,
    ViewOptions,
    detect_kind,
    true_time_calibration,
    view,
)
from scenarios.runner import load_run, simulate_to_disk

rr = pytest.importorskip("rerun")
chunk = pytest.importorskip("rerun.chunk")
pa = pytest.importorskip("pyarrow")


def _read(path):
    """Entity path (without the leading '/') -> list of record batches of the file."""
    out = {}
    for c in chunk.RrdReader(path).stream():
        out.setdefault(c.entity_path.lstrip("/"), []).append(c.to_record_batch())
    return out


def _column(batches, column):
    """(frames or None, times [s] or None, values) of a column over an entity's batches, by frame."""
    rows = []
    for b in batches:
        if column not in b.schema.names:
            continue
        n = b.num_rows
        frames = b.column("frame").to_pylist() if "frame" in b.schema.names else [None] * n
        times = (b.column("time").cast(pa.int64()).to_numpy() * 1e-9).tolist() if "time" in b.schema.names \
            else [None] * n
        rows += zip(frames, times, b.column(column).to_pylist())
    rows.sort(key=lambda r: (r[0] is None, r[0] or 0, r[1] or 0.0))
    return [r[0] for r in rows], [r[1] for r in rows], [r[2] for r in rows]


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return simulate_to_disk(load_scenario("fma_2cam"), tmp_path_factory.mktemp("view") / "run", duration_s=3.0,
                            progress=False)


def test_run_view_logs_rig_skeletons_depth_fusion_truth_angles_and_errors(run, tmp_path, capsys):
    out = tmp_path / "run.rrd"
    assert main(["view", str(run), "--save", str(out), "--depth-points", "500"]) == 0
    assert "true poses" in capsys.readouterr().out
    recording, truth = load_run(run)
    data = _read(out)
    assert len(chunk.RrdReader(out).blueprints()) == 1  # the default layout travels with the file
    for entity in ("world", "world/floor", "world/cameras/cam1", "world/cameras/cam1/image",
                   "world/cameras/cam2/skeleton/joints", "world/cameras/cam2/skeleton/bones",
                   "world/cameras/cam1/depth", "world/fused/joints", "world/fused/bones", "world/truth/joints",
                   "angles/fused/ht_elevation_left", "angles/truth/elbow_flexion_right", "errors/fused/HandLeft",
                   "info"):
        assert entity in data, entity
    z_up = rr.ViewCoordinates.RIGHT_HAND_Z_UP.as_arrow_array().to_pylist()
    assert _column(data["world"], "ViewCoordinates:xyz")[2] == [z_up]
    ((translation,),) = _column(data["world/cameras/cam2"], "Transform3D:translation")[2]
    np.testing.assert_allclose(translation, truth.camera("cam2").T_world_cam[:3, 3], atol=1e-6)

    cam = recording.camera("cam2")
    frames, times, positions = _column(data["world/cameras/cam2/skeleton/joints"], "Points3D:positions")
    _, _, ids = _column(data["world/cameras/cam2/skeleton/joints"], "Points3D:keypoint_ids")
    assert frames == list(range(cam.skeleton.n_frames))
    np.testing.assert_allclose(times, cam.skeleton.timestamps - truth.camera("cam2").clock_offset_s, atol=1e-6)
    k = 40
    np.testing.assert_allclose(positions[k], cam.skeleton.positions[k][ids[k]], atol=1e-6)
    assert ids[k] == np.flatnonzero(~np.isnan(cam.skeleton.positions[k]).any(axis=1)).tolist()

    _, _, clouds = _column(data["world/cameras/cam1/depth"], "Points3D:positions")
    assert len(clouds) == recording.camera("cam1").depth.n_frames and all(0 < len(c) <= 500 for c in clouds)

    ref = truth.cameras[0]
    frames, times, true_joints = _column(data["world/truth/joints"], "Points3D:positions")
    assert len(frames) == ref.joints_world.shape[0]
    np.testing.assert_allclose(true_joints[k], ref.joints_world[k], atol=1e-6)
    np.testing.assert_allclose(times, ref.true_times, atol=5e-3)  # timestamp - true offset = true time + jitter
    frames, _, angle = _column(data["angles/truth/ht_elevation_left"], "Scalars:scalars")
    expected = joint_angles(ref.joints_world, recording.topology)["ht_elevation_left"]
    np.testing.assert_allclose(np.ravel(angle), expected, atol=1e-9)
    _, _, fused = _column(data["world/fused/joints"], "Points3D:positions")
    _, _, fused_ids = _column(data["world/fused/joints"], "Points3D:keypoint_ids")
    _, _, error = _column(data["errors/fused/HandLeft"], "Scalars:scalars")
    hand = recording.topology.index("HandLeft")
    expected = np.linalg.norm(np.array(fused[k])[fused_ids[k].index(hand)] - ref.joints_world[k, hand]) * 1e3
    assert np.ravel(error)[k] == pytest.approx(expected, rel=1e-4)


def test_recording_with_and_without_a_calibration(run, tmp_path):
    recording, truth = load_run(run)
    calib = save_calibration(true_time_calibration(recording, truth), tmp_path / "c.toml")
    assert main(["view", str(run / "recording"), "--calib", str(calib), "--save", str(tmp_path / "a.rrd")]) == 0
    data = _read(tmp_path / "a.rrd")
    assert "world/fused/joints" in data and "world/truth/joints" not in data
    bare = view(run / "recording", save=tmp_path / "b.rrd", options=ViewOptions(depth_interval_s=10.0))
    assert bare.kind is SourceKind.RECORDING and bare.poses.startswith("none")
    assert "no calibration: no fused skeleton" in bare.notes and "world/fused/joints" not in bare.entities
    data = _read(tmp_path / "b.rrd")
    _, _, clouds = _column(data["world/cameras/cam1/depth"], "Points3D:positions")
    assert len(clouds) == 1  # one cloud per 10 s


def test_fused_output_shows_the_fused_skeleton_and_its_angles(run, tmp_path):
    recording, truth = load_run(run)
    calibration = true_time_calibration(recording, truth)
    fuse_to_disk(recording, calibration, tmp_path / "fused", FuseOptions())
    save_calibration(calibration, tmp_path / "c.toml")
    assert main(["view", str(tmp_path / "fused"), "--calib", str(tmp_path / "c.toml"),
                 "--save", str(tmp_path / "f.rrd")]) == 0
    data = _read(tmp_path / "f.rrd")
    assert {"world/cameras/cam1/image", "world/fused/joints", "angles/fused/elbow_flexion_left"} <= set(data)
    times, names, degrees = read_angles_csv(tmp_path / "fused" / "angles.csv")
    frames, logged_times, values = _column(data["angles/fused/elbow_flexion_left"], "Scalars:scalars")
    assert frames == list(range(times.size))
    np.testing.assert_allclose(logged_times, times, atol=1e-6)
    np.testing.assert_allclose(np.ravel(values), degrees[:, names.index("elbow_flexion_left")], equal_nan=True)


def _rig_file(path, name, score, cameras):
    lines = [f"# Planned by `mocap-bench plan` for room 'r': {name}, mean score {score}.",
             "[scenario]", f'name = "r-{len(cameras)}cam"', f'description = "planned for r: {name}"',
             "[[session.segment]]", 'kind = "idle"', "duration_s = 1.0"]
    for i, p in enumerate(cameras):
        lines += ["[[rig.camera]]", f'name = "cam{i + 1}"', f"position_m = {list(p)}", "target_m = [0.0, 0.0, 1.0]"]
    path.write_text("\n".join(lines) + "\n")


def test_plan_ranks_its_layouts(tmp_path):
    plan = tmp_path / "plan"
    plan.mkdir()
    (plan / "plan.json").write_text("{}")
    _rig_file(plan / "rig_2cam.toml", "best 2 cameras", 30.5, [(2.0, 1.0, 1.5), (2.0, -1.0, 1.5)])
    _rig_file(plan / "rig_3cam.toml", "best 3 cameras", 12.25, [(2.0, 0.0, 1.5), (0.0, 2.0, 1.5), (0.0, -2.0, 2.0)])
    assert detect_kind(plan) is SourceKind.PLAN
    assert main(["view", str(plan), "--save", str(tmp_path / "p.rrd")]) == 0
    data = _read(tmp_path / "p.rrd")
    ((table,),) = _column(data["plan"], "TextDocument:text")[2]
    assert table.index("best 3 cameras") < table.index("best 2 cameras") and "12.2" in table
    assert {"world/layouts/1_rig_3cam/cam3/image", "world/layouts/2_rig_2cam/cam2", "world/subject"} <= set(data)
    ((translation,),) = _column(data["world/layouts/1_rig_3cam/cam3"], "Transform3D:translation")[2]
    np.testing.assert_allclose(translation, [0.0, -2.0, 2.0], atol=1e-6)


def test_unknown_path_and_existing_output_are_clear_errors(run, tmp_path, capsys):
    out = tmp_path / "x.rrd"
    assert main(["view", str(tmp_path), "--save", str(out)]) == 2
    err = capsys.readouterr().err
    assert all(word in err for word in ("simulate", "import", "fuse", "plan")) and not out.exists()
    assert main(["view", str(tmp_path / "missing"), "--save", str(out)]) == 2
    assert "does not exist" in capsys.readouterr().err
    out.write_text("keep")
    assert main(["view", str(run), "--save", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err and out.read_text() == "keep"
    assert main(["view", str(run), "--save", str(out), "--viewer", "web"]) == 2
    assert main(["view", str(run), "--save", str(tmp_path / "y.rrd"), "--depth-points", "0"]) == 2
    assert "--depth-points" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["x.rrd"]  # no temporary file left


def test_missing_extra_says_what_to_install(run, tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "rerun", None)  # import rerun raises ImportError
    with pytest.raises(BadInputError, match=r"pip install 'mocap-bench\[view\]'"):
        view(run, save=tmp_path / "x.rrd")
    assert main(["view", str(run), "--save", str(tmp_path / "x.rrd")]) == 2
    assert "mocap-bench[view]" in capsys.readouterr().err


def test_without_save_the_viewer_is_spawned_or_served(run, monkeypatch):
    calls = []
    monkeypatch.setattr(rr.RecordingStream, "spawn", lambda self, **kw: calls.append("spawn"))
    monkeypatch.setattr(rr.RecordingStream, "serve_grpc", lambda self, **kw: calls.append("grpc") or "rerun+http://x")
    monkeypatch.setattr(rr, "serve_web_viewer", lambda **kw: calls.append(kw["connect_to"]))
    options = ViewOptions(depth_points=10)
    assert view(run, options=options).saved is None
    assert view(run, viewer=Viewer.WEB, options=options).kind is SourceKind.RUN
    assert calls == ["spawn", "grpc", "rerun+http://x"]


def test_a_viewer_that_cannot_start_is_a_clear_error(run, monkeypatch):
    def missing(self, **kw):
        raise RuntimeError("Failed to find Rerun Viewer executable in PATH.\nmore")

    monkeypatch.setattr(rr.RecordingStream, "spawn", missing)
    with pytest.raises(BadInputError, match="desktop viewer.*PATH.*--viewer web"):
        view(run)
