"""``fuse`` refuses a calibration whose clock offsets the recording's motion contradicts (another session's,
a reset clock), naming the camera and by how much; ``--no-clock-check`` fuses anyway; a fitting calibration
passes and its residuals are recorded in ``fused.json``."""

from __future__ import annotations

import dataclasses
import json
import re

import pytest

from fusion.io.calibration_file import save_calibration
from fusion.io.recording_files import save_recording
from scenarios import api
from scenarios.cli import main


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    d = tmp_path_factory.mktemp("clock")
    s = api.simulate(api.scenario("fma_2cam", seed=2, duration_s=16))
    true = api.true_calibration(s.recording, s.truth)
    wrong = dataclasses.replace(true, clock_offset_s=true.clock_offset_s | {"cam2": true.clock_offset_s["cam2"] + 1.5})
    return (save_recording(s.recording, d / "rec"), save_calibration(true, d / "true.toml"),
            save_calibration(wrong, d / "wrong.toml"))


def test_offsets_that_do_not_fit_the_recording_are_refused_unless_asked(session, tmp_path, capsys):
    rec, _, wrong = session
    assert main(["fuse", str(rec), "--calib", str(wrong), "--out", str(tmp_path / "refused")]) == 2
    err = capsys.readouterr().err
    assert "clock offsets do not fit" in err and "--no-clock-check" in err
    assert re.search(r"cam2 -1\.(4[5-9]|5[0-5]) s", err)
    assert not (tmp_path / "refused").exists()
    assert main(["fuse", str(rec), "--calib", str(wrong), "--no-clock-check", "--out", str(tmp_path / "f")]) == 0
    residual = json.loads((tmp_path / "f" / "fused.json").read_text())["clock_residual_s"]["cam2"]
    assert residual == pytest.approx(-1.5, abs=0.05)


def test_fitting_offsets_pass_with_a_residual_near_zero(session, tmp_path):
    rec, true, _ = session
    assert main(["fuse", str(rec), "--calib", str(true), "--out", str(tmp_path / "f")]) == 0
    residual = json.loads((tmp_path / "f" / "fused.json").read_text())["clock_residual_s"]["cam2"]
    assert residual is not None and abs(residual) < 0.05
