"""``--algorithm``: a user's calibration in calib-study and a user's fusion in angle-study, scored
beside the built-in methods on the same sessions; a wrong spec fails before any simulation."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from scenarios.cli import main

EXAMPLE = Path(__file__).resolve().parents[3] / "examples" / "plain_kabsch"


def test_calib_study_scores_a_users_calibration(tmp_path):
    out = tmp_path / "study"
    assert main(["calib-study", "fma_2cam", "--seeds", "2", "--duration", "12", "--workers", "0",
                 "--algorithm", f"{EXAMPLE / 'plain_kabsch.py'}:calibrate", "--out", str(out)]) == 0
    doc = json.loads((out / "study.json").read_text())
    mine = doc["summary"]["algorithm:calibrate"]
    assert mine["session_to_session_rmse_mm"] is not None and mine["loop_closure_mm"] is None
    assert 0.0 < mine["rotation_error_deg"][0] < 10.0
    assert "| algorithm:calibrate |" in (out / "table1.md").read_text()


def test_angle_study_scores_a_users_fusion(tmp_path):
    out = tmp_path / "angles"
    assert main(["angle-study", "fma_2cam", "--seeds", "1", "--duration", "12", "--cameras", "all", "cam2",
                 "--algorithm", f"{EXAMPLE / 'average_fusion.py'}:fuse", "--out", str(out)]) == 0
    result = json.loads((out / "angle_study.json").read_text())
    rows = {(r["cameras"], r["fusion"]): r for r in result["rows"]}
    assert {("all", "algorithm:fuse"), ("cam2", "algorithm:fuse")} <= set(rows)
    # one camera: the plain average is that camera's tracked joints, as Avg(Frontal) with one camera
    assert rows[("cam2", "algorithm:fuse")]["joint_error_mm"] == pytest.approx(
        rows[("cam2", "avg_frontal")]["joint_error_mm"], rel=0.35)


def test_a_wrong_algorithm_fails_before_simulating(tmp_path, capsys):
    assert main(["calib-study", "fma_2cam", "--seeds", "1", "--workers", "0", "--algorithm", "nope.mod:fn",
                 "--out", str(tmp_path / "x")]) == 2
    assert "cannot import nope.mod" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_layout_compares_a_users_fusion_in_table_3(tmp_path):
    out = tmp_path / "layout"
    assert main(["layout", "ring6", "--duration", "6", "--poses", "truth", "--workers", "0",
                 "--algorithm", f"{EXAMPLE / 'average_fusion.py'}:fuse", "--out", str(out)]) == 0
    rows = json.loads((out / "layout.json").read_text())["table3"]
    mine = [r for r in rows if r["method"] == "algorithm:fuse"]
    assert {r["config"] for r in mine} == {r["config"] for r in rows}
    assert all(np.isfinite(r["joint_error_mm"]) and r["joint_error_mm"] > 0 for r in mine)
