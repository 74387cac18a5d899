"""Every command is run by a test: smoke runs of the commands no other test runs, and a scan that
finds, for each command of the parser, a test calling it."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from scenarios.cli import commands, main

TESTS = Path(__file__).resolve().parents[2]




def test_every_command_is_run_by_a_test():
    text = "\n".join(p.read_text(encoding="utf-8") for p in TESTS.rglob("test_*.py"))
    called = set(re.findall(r'main\(\s*\[\s*"([a-z0-9-]+)"', text))
    missing = [c for c in commands() if c not in called]
    assert not missing, f"commands no test runs: {missing}"


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    """A short simulated two-camera session and its calibration from the body (skeletons only)."""
    d = tmp_path_factory.mktemp("smoke")
    assert main(["simulate", "fma_2cam", "--duration", "6", "--out", str(d / "run")]) == 0
    assert main(["calibrate", str(d / "run"), "--refine", "none", "--out", str(d / "calib.toml")]) == 0
    return d


def test_angle_figure(tmp_path):
    assert main(["angle-figure", "--out", str(tmp_path / "frames.png")]) == 0
    assert (tmp_path / "frames.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_angle_study(tmp_path):
    out = tmp_path / "study"
    assert main(["angle-study", "fma_2cam", "--seeds", "1", "--duration", "4", "--out", str(out)]) == 0
    result = json.loads((out / "angle_study.json").read_text())
    assert result and "elbow" in (out / "angle_study.md").read_text()


def test_roundtrip(tmp_path):
    out = tmp_path / "rt"
    assert main(["roundtrip", "fma_2cam", "--formats", "csv", "--camera-counts", "2", "--duration", "6", "--workers", "0",
                 "--out", str(out)]) == 0
    rows = json.loads((out / "roundtrip.json").read_text())
    assert len(rows) == 1 and rows[0]["format"] == "csv"


def test_replica(session, tmp_path):
    out = tmp_path / "replica.toml"
    assert main(["replica", str(session / "run"), "--calib", str(session / "calib.toml"), "--out", str(out)]) == 0
    assert out.is_file() and out.with_suffix(".motion.npz").is_file()
    assert main(["simulate", str(out), "--duration", "2", "--out", str(tmp_path / "sim")]) == 0


def test_replica_keeps_existing_files_unless_overwrite(session, tmp_path, capsys):
    out, motion = tmp_path / "replica.toml", tmp_path / "replica.motion.npz"
    argv = ["replica", str(session / "run"), "--calib", str(session / "calib.toml"), "--out", str(out)]
    for existing in (out, motion):  # either output already there stops the command
        existing.write_text("keep")
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert str(existing) in err and "choose another path or pass --overwrite" in err
        assert existing.read_text() == "keep" and len(list(tmp_path.iterdir())) == 1
        existing.unlink()
    out.write_text("keep")
    assert main([*argv, "--overwrite"]) == 0
    assert out.read_text() != "keep" and motion.is_file()


def test_demo(tmp_path):
    out = tmp_path / "demo"
    assert main(["demo", "--duration", "6", "--out", str(out)]) == 0
    assert (out / "README.md").is_file() and (out / "evaluation" / "report.md").is_file()


def test_bench(tmp_path):
    out = tmp_path / "B.md"
    assert main(["bench", "--only", "depth_frame", "--out", str(out)]) == 0
    rows = json.loads(out.with_suffix(".json").read_text())
    assert [r["name"] for r in rows] == ["depth_frame"] and "depth_frame" in out.read_text()


def test_live_load(tmp_path):
    out = tmp_path / "load.json"
    assert main(["live-load", "fma_2cam", "--duration", "6", "--stream-s", "6", "--speed", "4", "--out", str(out)]) == 0
    report = json.loads(out.read_text())
    assert report["frames_sent"] > 0 and report["fused_received"] > 0


def test_hostile_command_reports_and_fails_on_a_bad_outcome(tmp_path, monkeypatch):
    """The command's plumbing (report, counts, exit status) on two cases instead of the whole suite."""
    from scenarios.hostile import command_cases, reader_cases
    from scenarios.hostile.suite import Case, Expect

    cases = [Case("version", "smoke", lambda d: (["--version"], None), Expect.RESULT, quick=True),
             Case("accepted", "smoke", lambda d: (["--version"], None), Expect.ERROR, quick=True)]
    monkeypatch.setattr(reader_cases, "build_base", lambda work, seed: None)
    monkeypatch.setattr(command_cases, "all_cases", lambda base, mutants, rng: cases)
    out = tmp_path / "hostile.md"
    try:
        code = main(["hostile", "--quick", "--out", str(out)])
    except SystemExit as stop:
        code = stop.code
    assert code == 1
    report = out.read_text()
    assert "version" in report and "silent wrong result" in report
