"""``fuse`` refuses a session in which a camera moved, saying which and when; ``--no-move-check`` fuses it
anyway and records the move in ``fused.json``."""

from __future__ import annotations

import dataclasses
import json

import numpy as np

from fusion.io.calibration_file import save_calibration
from fusion.io.recording_files import save_recording
from fusion.transforms import from_rotvec
from scenarios import api
from scenarios.cli import main


def test_a_camera_turned_halfway_is_refused_unless_asked(tmp_path, capsys):
    session = api.simulate(api.scenario("fma_2cam", seed=3, duration_s=12))
    cam2 = session.recording.camera("cam2").skeleton
    late = cam2.timestamps >= cam2.timestamps[0] + 6.0
    turned = cam2.positions.copy()
    turned[late] = turned[late] @ from_rotvec(np.array([0.0, np.radians(8.0), 0.0]), np.zeros(3))[:3, :3].T
    cameras = tuple(dataclasses.replace(c, skeleton=dataclasses.replace(cam2, positions=turned)) if c.name == "cam2"
                    else c for c in session.recording.cameras)
    rec = save_recording(dataclasses.replace(session.recording, cameras=cameras), tmp_path / "rec")
    calib = save_calibration(api.true_calibration(session.recording, session.truth), tmp_path / "calib.toml")

    assert main(["fuse", str(rec), "--calib", str(calib), "--out", str(tmp_path / "refused")]) == 2
    err = capsys.readouterr().err
    assert "cam1 and cam2 disagree by" in err and "one of them moved" in err and "--no-move-check" in err
    assert not (tmp_path / "refused").exists()

    assert main(["fuse", str(rec), "--calib", str(calib), "--no-move-check", "--out", str(tmp_path / "fused")]) == 0
    moves = json.loads((tmp_path / "fused" / "fused.json").read_text())["camera_disagreement_mm"]
    start, end = moves["cam2"]["moved_s"]
    assert 4.0 < start < 8.0 and end > 9.0 and moves["cam2"]["max_window"] > 150.0
