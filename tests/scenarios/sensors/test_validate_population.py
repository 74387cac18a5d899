"""``mocap-bench sensor-validate`` end to end on four short simulated sessions of two people."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from scenarios.cli import main

SESSIONS = (("A", 1), ("A", 2), ("B", 3), ("B", 4))
"""(person, seed) of each recording; 8 s is about the shortest the body calibration takes."""


@pytest.fixture(scope="module")
def recordings(tmp_path_factory) -> list[str]:
    d = tmp_path_factory.mktemp("validate")
    out = []
    for who, seed in SESSIONS:
        path = d / f"{who}_{seed}"
        assert main(["simulate", "azure_2cam_45", "--seed", str(seed), "--duration", "8", "--out", str(path)]) == 0
        out.append(str(path))
    return out


@pytest.fixture(scope="module")
def validated(recordings, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("validated") / "v"
    assert main(["sensor-validate", *recordings, "--persons", "A", "A", "B", "B", "--draws", "2", "--iterations", "1",
                 "--speeds", "0.4", "--structure", "limb-sharing", "hidden-offsets", "--jobs", "1", "--out", str(out)]) == 0
    return out


def test_sensor_validate_writes_the_report(validated) -> None:
    for plot in ("validate.png", "ranks.png"):
        assert (validated / plot).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    report = (validated / "report.md").read_text()
    assert "Leave-one-person-out" in report and "sensor-validate" in report and "| **all** | 4 |" in report
    results = json.loads((validated / "results.json").read_text())
    assert results["draws"] == 2 and results["band_percentiles"] == [5.0, 95.0]
    folds = results["folds"]
    assert [f["left_out"] for f in folds] == ["A", "B"]
    assert [[s["session"] for s in f["sessions"]] for f in folds] == [["A_1", "A_2"], ["B_3", "B_4"]]
    for which in ("population", "typical"):
        counts = results["passing"][which]
        assert set(counts) == {"A", "B", "all"}
        for passing, compared in counts.values():
            assert 0 <= passing <= compared and compared > 0
        assert counts["all"] == [counts["A"][0] + counts["B"][0], counts["A"][1] + counts["B"][1]]
        for f in folds:  # the counts are those of the rows
            rows = [r for s in f["sessions"] for r in s[which] if r["passed"] is not None]
            assert counts[f["left_out"]] == [sum(r["passed"] for r in rows), len(rows)]
    for which in ("population", "typical"):  # the calibration table holds the rows' ranks and pass counts
        table = results["calibration"][which]
        rows = [r for f in folds for s in f["sessions"] for r in s[which] if r["passed"] is not None]
        assert sum(c["rows"] for c in table.values()) == len(rows)
        assert sum(c["passing"] for c in table.values()) == results["passing"][which]["all"][0]
        assert sum(c["below_all"] for c in table.values()) == sum(r["below"] == 0 for r in rows)
        assert sum(c["above_all"] for c in table.values()) == sum(r["below"] == r["n_draws"] for r in rows)
        for c in table.values():
            assert 0 <= c["expected_passing"] <= c["rows"] and c["expected_tail"] == pytest.approx(c["rows"] / 3)
        for r in rows:
            assert 0 <= r["below"] <= r["n_draws"] <= 2 and r["draws_passing"] in (0.0, 0.5, 1.0)
    assert "Is the population calibrated?" in report
    assert [f["speed_ref_m_s"] for f in folds] == [0.4, 0.4]  # the one reference speed given
    assert all(0.0 <= f["view_limb_correlation"] <= 0.95 and 0.0 <= f["hidden_offset_share"] <= 1.0
               for f in folds)  # fitted (--structure)
    assert "view bias limb correlation" in report and "hidden offset share" in report
    for f in folds:  # each fold is fitted on one person: no between-person part
        assert set(f["population"]) == {"noise", "bias", "bone", "confidence"}
        for spread in f["population"].values():
            assert spread["person_sd"] == 0.0 and spread["person_df"] is None and spread["session_sd"] >= 0
        assert f["labs"] == {}  # simulated recordings name no lab


def test_sensor_validate_refuses_a_single_draw(recordings, tmp_path, capsys) -> None:
    out = tmp_path / "v"
    code = main(["sensor-validate", recordings[0], recordings[2], "--draws", "1", "--iterations", "1", "--jobs", "1",
                 "--out", str(out)])
    assert code == 2 and "draws must be a whole number >= 2" in capsys.readouterr().err
    assert not (out / "results.json").exists()


def test_sensor_validate_refuses_a_wrong_count_of_persons(recordings, tmp_path, capsys) -> None:
    code = main(["sensor-validate", *recordings, "--persons", "A", "A", "B", "--out", str(tmp_path / "v")])
    assert code == 2 and "give one --persons label per recording (4), got 3" in capsys.readouterr().err


def test_sensor_validate_takes_one_lab_per_recording(recordings, tmp_path, capsys) -> None:
    code = main(["sensor-validate", *recordings, "--persons", "A", "A", "B", "B", "--labs", "x", "y", "--out",
                 str(tmp_path / "v")])
    assert code == 2 and "give one --labs label per recording (4), or 'recorded'; got 2" in capsys.readouterr().err
    assert not (tmp_path / "v").exists()
    # simulated recordings name no lab: asked for their own, the command says no lab level can be fitted
    code = main(["sensor-validate", *recordings, "--labs", "recorded", "--draws", "1", "--out", str(tmp_path / "v")])
    out = capsys.readouterr()
    assert code == 2 and "the recordings name 0 lab(s); a lab level needs two or more" in out.out
