"""The Fugl-Meyer analysis command on a tiny generated cohort."""

import csv
import json

import pytest

from fusion.errors import RecordingError
from scenarios.cli import main
from scenarios.clinical.cohort import generate_cohort
from scenarios.clinical.fma_study import SETUPS, analyse
from scenarios.sweep import SweepOptions
from tests.scenarios.clinical.test_cohort import tiny_config


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    out = tmp_path_factory.mktemp("cohort") / "c"
    generate_cohort(tiny_config(), out, sweep=SweepOptions(workers=0, progress=False))
    return out


def test_analysis_produces_every_table(dataset, tmp_path):
    assert main(["fma", str(dataset), "--out", str(tmp_path / "rep")]) == 0
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


def test_analysis_is_reproducible(dataset):
    a, b = analyse(dataset, seed=3), analyse(dataset, seed=3)
    assert a["patient_vs_healthy"] == b["patient_vs_healthy"]


def test_missing_manifest(tmp_path):
    with pytest.raises(RecordingError, match="manifest.json"):
        analyse(tmp_path)


def test_dataset_without_truth(dataset, tmp_path):
    import shutil

    copy = tmp_path / "real"
    shutil.copytree(dataset, copy)
    manifest = json.loads((copy / "manifest.json").read_text())
    for subject in manifest["subjects"]:
        subject.pop("truth")
        for block in subject["blocks"]:
            block.pop("truth")
    (copy / "manifest.json").write_text(json.dumps(manifest))
    result = analyse(copy)
    assert "segmentation_error_frames" not in result and result["samples"] > 0
