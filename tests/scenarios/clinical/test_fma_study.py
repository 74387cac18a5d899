"""The Fugl-Meyer analysis command on a tiny generated cohort."""

import csv
import json

import pytest

from fusion.errors import RecordingError
from scenarios.cli import main
from scenarios.clinical.fma_study import SETUPS, analyse


@pytest.fixture(scope="module")
def dataset(tiny_cohort):
    return tiny_cohort.out_dir


@pytest.fixture(scope="module")
def report_dir(dataset, tmp_path_factory, small_forests_module):
    out = tmp_path_factory.mktemp("fma") / "rep"
    assert main(["fma", str(dataset), "--out", str(out)]) == 0
    return out


def test_analysis_produces_every_table(report_dir):
    tmp_path = report_dir.parent
    report = (tmp_path / "rep" / "report.md").read_text()
    for heading in ("Table 5", "Table 6", "Table 7", "Feature ranking", "Compensation t-tests", "item score"):
        assert heading in report
    results = json.loads((tmp_path / "rep" / "results.json").read_text())
    assert results["subjects"] == 4 and results["samples"] > 0
    assert results["segmentation_error_frames"]["start_frames"]["median"] < 15
    with open(tmp_path / "rep" / "features.csv") as f:
        rows = list(csv.DictReader(f))
    assert {r["setup"] for r in rows} == set(SETUPS)
    assert len(rows[0]) == 7 + 170
    assert (tmp_path / "rep" / "segmentation.png").stat().st_size > 0


def test_report_has_person_level_tests_chance_and_warnings(report_dir):
    report = (report_dir / "report.md").read_text()
    assert "pseudo-replicated; the paper's" in report and "Person level" in report
    assert "mixed-model p" in report and "Hedges' g" in report
    assert "| chance |" in report
    assert "**Warning:**" in report and "fewer than 5 subjects per class" in report  # 2 + 2 subjects
    results = json.loads((report_dir / "results.json").read_text())
    assert set(results["person_t_tests"]) == set(results["t_tests"])  # old keys kept, new ones added
    row = results["person_t_tests"]["hand_lift"][0]
    assert row["n_persons_a"] + row["n_persons_b"] == results["subjects"]
    entry = next(iter(results["patient_vs_healthy"].values()))
    assert {"accuracy", "confusion", "classes", "chance"} <= set(entry["svm"])
    assert 0.5 <= entry["svm"]["chance"] <= 1.0 and results["warnings"]
    assert all(", chance " in line for line in report.splitlines() if line.startswith("- ") and "classes [" in line)


def test_missing_manifest(tmp_path):
    with pytest.raises(RecordingError, match="manifest.json"):
        analyse(tmp_path)


def test_dataset_without_truth_gives_the_commands_results_again(dataset, report_dir, tmp_path, small_forests_module):
    """Without the simulation's truth the analysis runs, reports no segmentation error, and with the same
    seed (the command's default, 0) classifies as the command did: reproducible, and blind to the truth."""
    import shutil

    copy = tmp_path / "real"
    shutil.copytree(dataset, copy)
    manifest = json.loads((copy / "manifest.json").read_text())
    for subject in manifest["subjects"]:
        subject.pop("truth")
        for block in subject["blocks"]:
            block.pop("truth")
    (copy / "manifest.json").write_text(json.dumps(manifest))
    result = analyse(copy, seed=0)
    assert "segmentation_error_frames" not in result and result["samples"] > 0
    written = json.loads((report_dir / "results.json").read_text())["patient_vs_healthy"]
    assert json.loads(json.dumps(result["patient_vs_healthy"], default=float)) == written
