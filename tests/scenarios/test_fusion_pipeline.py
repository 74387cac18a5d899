"""Fusion of simulated sessions: back-facing cross-check, the fuse command, the layout tables."""

import dataclasses
import json

import numpy as np
import pytest
import tomli_w

from fusion.calibration import Calibration
from fusion.io.angle_tables import read_angles_csv, read_mot
from fusion.io.calibration_file import load_calibration, save_calibration
from fusion.io.recording_files import load_recording
from fusion.merge.angles import angle_names, joint_angles
from fusion.merge.backfacing import cross_check_back_facing
from fusion.merge.fuse import FuseOptions, camera_views, fuse_views
from fusion.merge.methods import MergeMethod
from scenarios.cli import main
from scenarios.config import scenario_from_dict
from scenarios.runner import simulate, simulate_to_disk
from scenarios.skeleton_eval import skeleton_errors
from scenarios.studies.layout import tables_markdown


def _ring(seed=4, duration=12.0, depth=0.0):
    return scenario_from_dict(_ring_doc(seed, duration, depth))


def _ring_doc(seed=4, duration=12.0, depth=0.0) -> dict:
    return {
        "scenario": {"name": "ring", "seed": seed, "duration_s": duration},
        "rig": {"n_cameras": 6, "radius_m": 2.0},
        "sensors": {"depth_rate_hz": depth},
        "session": {"segment": [{"kind": "idle", "duration_s": 1.0}, {"kind": "calibration_turn", "duration_s": 10.0},
                                {"kind": "hand_lift", "side": "right", "repetitions": 1}]},
    }


def _true_calibration(recording, truth):
    ref = truth.cameras[0]
    return Calibration(truth.T_world_cam(), {c.name: c.intrinsics for c in recording.cameras},
                       {c.name: c.clock_offset_s - ref.clock_offset_s for c in truth.cameras}, ref.name)


@pytest.fixture(scope="module")
def ring():
    recording, truth = simulate(_ring(), progress=False)
    return recording, truth, _true_calibration(recording, truth)


def test_cross_check_repairs_wrong_single_camera_flags(ring):
    recording, truth, calibration = ring
    views = camera_views(recording, calibration, cross_check=False)
    wrong = views.back_facing.copy()
    wrong[2] = ~wrong[2]  # one camera's detector got everything backwards
    repaired = cross_check_back_facing(dataclasses.replace(views, back_facing=wrong))
    agree = (repaired[2] == views.back_facing[2]).mean()
    assert agree > 0.95


def test_merging_beats_the_worst_camera_and_keeps_absent_joints_nan(ring):
    recording, truth, calibration = ring
    views = camera_views(recording, calibration)
    merged = fuse_views(views, FuseOptions(method=MergeMethod.AVG_FRONTAL))
    err = skeleton_errors(merged.positions, calibration.T_world_cam, truth, calibration.reference, views.topology)
    single = [skeleton_errors(fuse_views(views.subset([n]), FuseOptions(method=MergeMethod.AVERAGE)).positions,
                              calibration.T_world_cam, truth, calibration.reference, views.topology)
              ["joint_error_mm"]["mean"] for n in views.names]
    assert err["joint_error_mm"]["mean"] < max(single)
    assert np.array_equal(np.isnan(merged.positions).any(-1), merged.reliability == 0)


def test_joint_angles_on_a_known_pose(ring):
    _, truth, _ = ring
    angles = joint_angles(truth.joints_world[:1], ring[0].topology)
    # standing still at the start: arms hang, elbows nearly straight, trunk upright
    for side in ("left", "right"):
        assert angles[f"ht_elevation_{side}"][0] < 15
        assert np.isnan(angles[f"ht_plane_of_elevation_{side}"][0])
        assert angles[f"elbow_flexion_{side}"][0] < 25
    assert abs(angles["trunk_lateral_lean"][0]) < 5


def test_layout_tables_have_the_paper_shape(tmp_path):
    scenario = tmp_path / "ring.toml"
    scenario.write_text(tomli_w.dumps(_ring_doc(duration=8.0)))
    assert main(["layout", str(scenario), "--poses", "truth", "--workers", "0", "--out", str(tmp_path / "l")]) == 0
    result = json.loads((tmp_path / "l" / "layout.json").read_text())
    configs = [r["config"] for r in result["table2"]]
    assert configs[0] == "[1]" and configs[-1] == "[1,2,3,4,5,6]" and len(configs) == 8
    assert result["table2"][-1]["high_confidence_pct"] >= result["table2"][0]["high_confidence_pct"]
    methods = {r["method"] for r in result["table3"]}
    assert {m.value for m in MergeMethod} <= methods
    for r in result["table3"]:
        assert 0 <= r["support_5cm"] <= r["support_7cm"] <= 100
    assert "Table 2" in tables_markdown(result) and "Table 3" in tables_markdown(result)


def test_cli_fuse_writes_skeleton_and_cloud(tmp_path):
    run = simulate_to_disk(_ring(duration=6.0, depth=1.0), tmp_path / "run", progress=False)
    recording = load_recording(run / "recording")
    from sim.truth import load_truth

    save_calibration(_true_calibration(recording, load_truth(run / "truth")), tmp_path / "c.toml")
    assert main(["fuse", str(run), "--calib", str(tmp_path / "c.toml"), "--out", str(tmp_path / "fused"),
                 "--fit", "merge", "--method", "frontality", "--filter", "kalman", "--bone-lengths", "--mesh"]) == 0
    fused = load_recording(tmp_path / "fused" / "recording")
    assert fused.camera_names == ("fused",) and fused.metadata["frame"] == "world"
    summary = json.loads((tmp_path / "fused" / "fused.json").read_text())
    assert summary["method"] == "frontality" and summary["cloud"]["points"] > 1000
    assert (tmp_path / "fused" / "cloud.ply").stat().st_size > 0 and (tmp_path / "fused" / "mesh.glb").is_file()
    assert max(summary["bone_length_std_mm"].values()) < 1e-6
    assert load_calibration(tmp_path / "c.toml").reference == "cam1"
    times, names, degrees = read_angles_csv(tmp_path / "fused" / "angles.csv")
    assert names == angle_names() and np.array_equal(times, fused.cameras[0].skeleton.timestamps)
    mot_times, mot_names, mot_degrees = read_mot(tmp_path / "fused" / "angles.mot")
    assert mot_names == names and np.allclose(mot_degrees, degrees, atol=1e-6, equal_nan=True)

    assert main(["fuse", str(run), "--calib", str(tmp_path / "c.toml"), "--out", str(tmp_path / "kin"),
                 "--neutral", "0", "1.5"]) == 0
    summary = json.loads((tmp_path / "kin" / "fused.json").read_text())
    assert summary["fit"] == "kinematic" and summary["neutral_s"] == [0.0, 1.5]
    times, names, degrees = read_angles_csv(tmp_path / "kin" / "angles.csv")
    still = times <= 1.5
    trunk = degrees[:, names.index("trunk_flexion")]
    assert abs(np.median(trunk[still])) < 1e-9 and "trunk_flexion" in summary["angle_offsets_deg"]


def test_cli_fuse_with_limb_axes_reports_them(tmp_path):
    run = simulate_to_disk(_ring(duration=3.0, depth=5.0), tmp_path / "run", progress=False)
    from sim.truth import load_truth

    save_calibration(_true_calibration(load_recording(run / "recording"), load_truth(run / "truth")), tmp_path / "c.toml")
    assert main(["fuse", str(run), "--calib", str(tmp_path / "c.toml"), "--out", str(tmp_path / "axes"),
                 "--limb-axes"]) == 0
    summary = json.loads((tmp_path / "axes" / "fused.json").read_text())["limb_axes"]
    assert summary["instants"] >= 14 and set(summary["counted_share"]) == set(summary["radius_mm"])
    assert 55 < summary["radius_mm"]["HipLeft-KneeLeft"] < 80 and summary["counted_share"]["HipLeft-KneeLeft"] > 0.5
    assert set(summary["pivots"]) == {"ShoulderLeft", "ShoulderRight", "HipLeft", "HipRight"}
    assert all(p["point_mm"] is None and p["rms_mm"] is None for p in summary["pivots"].values())  # 15 instants: too few
    assert all(0 <= share <= 1 for share in summary["anchored_share"].values())
    assert load_recording(tmp_path / "axes" / "recording").metadata["limb_axes"] is True
    assert (tmp_path / "axes" / "limb_axes.png").stat().st_size > 10_000
    assert main(["fuse", str(run), "--calib", str(tmp_path / "c.toml"), "--out", str(tmp_path / "bare"),
                 "--limb-axes", "--limb-axes-without", "centres", "hands"]) == 0
    bare = json.loads((tmp_path / "bare" / "fused.json").read_text())["limb_axes"]
    assert bare["pivots"] == {} and bare["anchored_share"] == {}
    assert bare["counted_share"] == summary["counted_share"]
    assert main(["fuse", str(run), "--calib", str(tmp_path / "c.toml"), "--out", str(tmp_path / "none"),
                 "--limb-axes-without", "hands"]) != 0
    assert not (tmp_path / "none").exists()
