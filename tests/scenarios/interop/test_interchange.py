"""Real formats at the command line: write a simulated session, import it again, calibrate it."""

import json

import numpy as np
import pytest

from fusion.io.formats import FileFormat
from fusion.io.recording_files import load_recording
from scenarios.cli import main
from scenarios.config import scenario_from_dict
from scenarios.interop.interchange import round_trip_study
from scenarios.runner import simulate_to_disk
from scenarios.sweep import SweepOptions


def _scenario(topology="kinect_v2", seed=6):
    return scenario_from_dict({
        "scenario": {"name": "t", "seed": seed}, "subject": {"topology": topology},
        "rig": {"angles_deg": [45.0, -45.0], "radius_m": 2.0}, "sensors": {"depth_rate_hz": 0.0},
        "session": {"segment": [{"kind": "idle", "duration_s": 1.0}, {"kind": "calibration_turn", "duration_s": 12.0},
                                {"kind": "hand_lift", "side": "left", "repetitions": 1}]},
    })


@pytest.mark.parametrize("fmt", [f for f in FileFormat if f.writable])
def test_round_trip_keeps_the_calibration_errors(fmt):
    (row,) = round_trip_study(_scenario(), [fmt], [2], sweep=SweepOptions(workers=0, progress=False))
    for key in ("rotation_error_deg", "translation_error_mm"):
        assert row["imported"][key] == pytest.approx(row["native"][key], rel=0.05, abs=0.05)


def test_cli_write_import_calibrate_evaluate_without_truth(tmp_path, capsys):
    run = simulate_to_disk(_scenario(), tmp_path / "run", progress=False)
    assert main(["write", "ntu", str(run), "--out", str(tmp_path / "ntu")]) == 0
    files = sorted(str(p) for p in (tmp_path / "ntu").iterdir())
    assert len(files) == 2 and all(f.endswith(".skeleton") for f in files)
    assert main(["import", "ntu", *files, "--out", str(tmp_path / "imported")]) == 0
    rec = load_recording(tmp_path / "imported")
    assert rec.camera_names == ("cam1", "cam2") and rec.metadata
    # every session of a rig under the same names; one name per camera or nothing is written
    assert main(["import", "ntu", *files, "--names", "east", "west", "--out", str(tmp_path / "named")]) == 0
    named = load_recording(tmp_path / "named")
    assert named.camera_names == ("east", "west")
    np.testing.assert_array_equal(named.camera("west").skeleton.positions, rec.camera("cam2").skeleton.positions)
    assert main(["import", "ntu", *files, "--names", "east", "--out", str(tmp_path / "one")]) == 2
    assert "1 camera name(s) ['east'] for 2 camera(s)" in capsys.readouterr().err
    assert not (tmp_path / "one").exists()
    assert main(["calibrate", str(tmp_path / "imported"), "--out", str(tmp_path / "c.toml"), "--refine", "none"]) == 0
    assert main(["calibrate", str(run), "--out", str(tmp_path / "native.toml"), "--refine", "none"]) == 0
    assert main(["evaluate", str(tmp_path / "imported"), "--calib", str(tmp_path / "c.toml"), "--compare",
                 str(tmp_path / "native.toml"), "--out", str(tmp_path / "ev")]) == 0
    result = json.loads((tmp_path / "ev" / "result.json").read_text())
    assert "cameras" not in result  # no truth: no truth-based errors
    assert set(result["truth_free"]["bone_length_std_mm"]) and result["truth_free"]["session_to_session_rmse_mm"] < 30
    assert main(["fuse", str(tmp_path / "imported"), "--calib", str(tmp_path / "c.toml"), "--out",
                 str(tmp_path / "fused")]) == 0
    assert load_recording(tmp_path / "fused" / "recording").camera("fused").skeleton.n_frames == rec.cameras[0].skeleton.n_frames


def test_cli_import_errors(tmp_path, capsys):
    bad = tmp_path / "S001C001P001R001A001.skeleton"
    bad.write_text("3\n1\n")
    assert main(["import", "ntu", str(bad), "--out", str(tmp_path / "x")]) == 2
    assert str(bad) in capsys.readouterr().err
    run = simulate_to_disk(_scenario(), tmp_path / "run", progress=False)
    assert main(["write", "k4abt-json", str(run), "--out", str(tmp_path / "j")]) == 2
    assert "k4abt" in capsys.readouterr().err
