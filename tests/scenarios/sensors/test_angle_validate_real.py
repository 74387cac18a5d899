"""angle-validate on real UI-PRMD episodes (skipped without the samples): one episode's real and
simulated sides, the command's outputs, its refusal to write into a non-empty folder, and an
unreadable episode left out."""

from __future__ import annotations

import gzip
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from scenarios.cli import main
from scenarios.sensors.angle_validate import STATISTICS, find_episodes, validate_episode

SAMPLES = Path(__file__).resolve().parents[3].parent / "shared" / "samples" / "ui_prmd"

real = pytest.mark.skipif(not SAMPLES.is_dir(), reason="UI-PRMD samples not present")


@real
def test_validate_episode_on_a_real_abduction():
    episodes = find_episodes(SAMPLES, ["s02"], ["m07"], limit=1)
    assert [e.name for e in episodes] == ["m07_s02_e01"]
    result = validate_episode(episodes[0], seeds=(0,))
    assert result.problem == ""
    assert result.real.errors is not None and result.real.alignment.ok and result.real.alignment.side == "right"
    assert len(result.sims) == 1 and result.sims[0].errors is not None
    for side in (result.real, result.sims[0]):
        values = [side.value(s) for s in STATISTICS]
        assert np.all(np.isfinite(values)), values
        assert side.value("elevation_trace_rmse_deg") >= 0
        assert np.nanmax(side.truth_elevation_deg) > 90.0  # an abduction above the shoulder


@real
def test_angle_validate_command_writes_its_report(tmp_path, capsys):
    out = tmp_path / "av"
    argv = ["angle-validate", str(SAMPLES), "--subjects", "s02", "--movements", "m07", "--limit", "1",
            "--seeds", "1", "--jobs", "1", "--out", str(out)]
    assert main(argv) == 0
    assert "1 episodes" in capsys.readouterr().out
    assert {"report.md", "results.json", "traces.png"} <= {p.name for p in out.iterdir()}
    doc = json.loads((out / "results.json").read_text())
    row = doc["movements"]["m07"]["peak_elevation_error_deg"]
    assert {"real_mean", "real_sd", "sim_mean", "sim_sd"} <= set(row)
    assert np.isfinite(row["real_mean"]) and np.isfinite(row["sim_mean"])
    assert "angle-validate" in (out / "report.md").read_text()

    assert main(argv) == 2
    err = capsys.readouterr().err
    assert str(out) in err and "--overwrite" in err
    assert main(argv + ["--overwrite"]) == 0


@real
def test_an_unreadable_episode_is_left_out_and_listed(tmp_path, capsys):
    """One cut-short Kinect file of three episodes: the run (with the arm bias fitted) goes on with the
    others and names the one left out; with none readable it stops."""
    root = tmp_path / "UI-PRMD" / "Segmented Movements"
    for name in ("m07_s02_e01", "m07_s02_e02", "m07_s03_e01"):
        for system, kind in (("Kinect", "Positions"), ("Kinect", "Angles"), ("Vicon", "Positions")):
            src = SAMPLES / "Segmented Movements" / system / kind / f"{name}_{kind.lower()}.txt.gz"
            (root / system / kind).mkdir(parents=True, exist_ok=True)
            shutil.copy(src, root / system / kind / src.name)
    broken = root / "Kinect" / "Positions" / "m07_s02_e02_positions.txt.gz"
    broken.write_bytes(gzip.compress(b"\n".join(gzip.decompress(broken.read_bytes()).splitlines()[:5]) + b"\n"))
    out = tmp_path / "av"
    assert main(["angle-validate", str(root.parent), "--seeds", "1", "--jobs", "1", "--fit", "arm",
                 "--out", str(out)]) == 0
    said = capsys.readouterr().out
    assert "left out m07_s02_e02: " in said and "2 episodes (1 left out, unreadable)" in said
    doc = json.loads((out / "results.json").read_text())
    assert list(doc["left_out"]) == ["m07_s02_e02"] and "cut short" in doc["left_out"]["m07_s02_e02"]
    assert [e["episode"] for e in doc["episodes"]] == ["m07_s02_e01", "m07_s03_e01"]
    assert "## Episodes left out: their files could not be read" in (out / "report.md").read_text()
    (root / "Kinect" / "Positions" / "m07_s02_e01_positions.txt.gz").write_bytes(b"not gzip")
    (root / "Vicon" / "Positions" / "m07_s03_e01_positions.txt.gz").write_bytes(b"")
    assert main(["angle-validate", str(root.parent), "--seeds", "1", "--jobs", "1",
                 "--out", str(tmp_path / "none")]) == 2
    assert "no readable episode" in capsys.readouterr().err
