import csv
import json
import re
from pathlib import Path

import ezc3d
import numpy as np
import pytest

from fusion.errors import BadInputError, RecordingError
from scenarios.cli import main
from scenarios.clinical.cohort import generate_cohort
from scenarios.clinical.cohort_export import export_cohort
from scenarios.clinical.dataset_files import MANIFEST_CSV_COLUMNS
from scenarios.clinical.vocabulary import (
    PARTICIPANT_COLUMNS,
    PROFILE_UNITS,
    Item,
    item_raw,
    item_score,
    participant_row,
)
from scenarios.sweep import SweepOptions
from sim.truth import load_truth
from tests.scenarios.clinical.test_cohort import tiny_config

DOCS = Path(__file__).parents[3] / "docs"


@pytest.fixture(scope="module", name="work")
def tiny_work_folder(tmp_path_factory):
    """A folder holding ``out/cohort``: one healthy and one mild subject, skeleton-only calibration."""
    work = tmp_path_factory.mktemp("work")
    generate_cohort(tiny_config(healthy=1, mild=1, moderate_severe=0), work / "out" / "cohort",
                    sweep=SweepOptions(workers=0, progress=False), commit="abc1234")
    return work


def _manifest(work):
    return json.loads((work / "out" / "cohort" / "manifest.json").read_text())


def _tsv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f, delimiter="\t"))


def test_participants_and_sidecar_follow_the_vocabulary(work):
    root, manifest = work / "out" / "cohort", _manifest(work)
    rows = _tsv(root / "participants.tsv")
    assert list(rows[0]) == [c.name for c in PARTICIPANT_COLUMNS]
    sidecar = json.loads((root / "participants.json").read_text())
    assert set(sidecar) == set(rows[0]) and all("Description" in v for v in sidecar.values())
    assert sidecar["height_m"]["Units"] == "m" and set(sidecar["group"]["Levels"]) == {
        "healthy", "mild", "moderate_severe"}
    for row, s in zip(rows, manifest["subjects"]):
        assert row["participant_id"] == s["id"] and row["group"] == s["group"]
        assert row["affected_side"] == (s["affected_side"] or "n/a") and row["affected_side"] in ("left", "right", "n/a")
        for side in ("left", "right"):
            raw = sum(s["item_scores"][side][k] for k in ("shoulder_retraction", "shoulder_elevation",
                                                          "shoulder_abduction", "shoulder_external_rotation",
                                                          "elbow_flexion", "forearm_supination"))
            assert int(row[f"salute_{side}_raw"]) == raw == s["item_scores"][side]["salute"]
            assert int(row[f"salute_{side}_score"]) == (2 if raw == 12 else 0 if raw <= 4 else 1)
            assert row[f"hand_lift_{side}_score"] == row[f"hand_lift_{side}_raw"] == str(s["item_scores"][side]["hand_lift"])
        assert float(row["height_m"]) == pytest.approx(s["anthropometry"]["height_m"], abs=1e-4)
        assert row["seed"] == "7"


def test_manifest_csv_scores_are_the_vocabularys_and_carry_units(work):
    root, manifest = work / "out" / "cohort", _manifest(work)
    with open(root / "manifest.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == list(MANIFEST_CSV_COLUMNS)
    by_id = {s["id"]: s for s in manifest["subjects"]}
    for row in rows:
        scores = by_id[row["subject"]]["item_scores"][row["side"]]
        item = Item(row["movement"])
        assert int(row["item_raw"]) == item_raw(item, scores)
        assert int(row["item_score"]) == item_score(item, item_raw(item, scores)) in (0, 1, 2)
        assert float(row["true_t_start_s"]) < float(row["true_t_end_s"])


def test_manifest_truth_profile_names_sides_and_units(work):
    for s in _manifest(work)["subjects"]:
        assert s["truth"]["profile"]["affected_side"] == s["affected_side"]
        assert s["truth"]["profile_units"] == {k: u.value for k, u in PROFILE_UNITS.items()}
        assert set(PROFILE_UNITS) == set(s["truth"]["profile"]["salute_left"])


def test_datasheet_says_how_the_data_were_made(work):
    text = (work / "out" / "cohort" / "datasheet.md").read_text()
    for needle in ("mocap-bench 0.1.0", "abc1234", "Seed: 7", "`ranges`", "Sensor profile: `kinect_v2`",
                   "Intended uses and limits", "Not modelled", "participants.tsv", "`salute_left_score`"):
        assert needle in text


def test_export_cohort_csv_c3d_trc_with_labels_and_truth(work, tmp_path):
    root, manifest = work / "out" / "cohort", _manifest(work)
    assert main(["export", "--cohort", str(root), "--format", "csv", "--out", str(tmp_path / "csv"), "--truth"]) == 0
    assert main(["export", "--cohort", str(root), "--format", "c3d", "--out", str(tmp_path / "c3d"), "--truth"]) == 0
    assert main(["export", "--cohort", str(root), "--format", "trc", "--out", str(tmp_path / "trc")]) == 0
    assert sorted(p.name for p in (tmp_path / "trc").iterdir()) == [
        "participants.json", "participants.tsv", "sub-01_fused.trc", "sub-02_fused.trc"]
    for s in manifest["subjects"]:
        expected = participant_row(s, manifest["seed"])
        with open(tmp_path / "csv" / f"{s['id']}_fused.csv", newline="") as f:
            first = next(csv.DictReader(f))
        assert {k: first[k] for k in expected} == expected
        for stream in ("fused", "truth"):
            c3d = ezc3d.c3d(str(tmp_path / "c3d" / f"{s['id']}_{stream}.c3d"))
            got = {k: v["value"][0] for k, v in c3d["parameters"]["MOCAP_BENCH"].items() if k != "__METADATA__"}
            assert got == expected
        lines = (tmp_path / "trc" / f"{s['id']}_fused.trc").read_text().split("\n")
        assert dict(f.split("=", 1) for f in lines[0].split("\t")[4:]) == expected
    truth = load_truth(root / manifest["subjects"][0]["files"]["truth"])
    with open(tmp_path / "csv" / "sub-01_truth.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == truth.times.size
    assert float(rows[5]["HandRight_z_m"]) == truth.joints_world[5, 11, 2]


def test_export_cohort_bids_has_the_required_files_and_fields(work, tmp_path):
    out = tmp_path / "bids"
    assert main(["export", "--cohort", str(work / "out" / "cohort"), "--format", "bids", "--out", str(out),
                 "--truth"]) == 0
    description = json.loads((out / "dataset_description.json").read_text())
    assert {"Name", "BIDSVersion"} <= set(description) and description["BIDSVersion"].startswith("1.")
    assert (out / "README.md").read_text().startswith("# Datasheet")
    motion = sorted(out.glob("sub-*/motion/*_motion.tsv"))
    assert [p.name for p in motion] == [f"sub-0{i}_task-fma_tracksys-{t}_motion.tsv" for i in (1, 2)
                                        for t in ("fused", "truth")]
    for path in motion:
        stem = str(path)[: -len("_motion.tsv")]
        meta = json.loads(Path(stem + "_motion.json").read_text())
        assert meta["TaskName"] == "fma" and meta["SamplingFrequency"] > 0
        channels = _tsv(stem + "_channels.tsv")
        assert list(channels[0])[:5] == ["name", "component", "type", "tracked_point", "units"]
        assert {c["type"] for c in channels} == {"LATENCY", "POS", "JNTANG"}
        assert {c["units"] for c in channels} == {"s", "m", "deg"}
        data = np.genfromtxt(path, delimiter="\t", missing_values="n/a")
        assert data.shape[1] == len(channels) == meta["MotionChannelCount"]
        assert np.allclose(np.diff(data[:, 0]), 1.0 / meta["SamplingFrequency"])
        elbow = [i for i, c in enumerate(channels) if c["name"] == "elbow_flexion_right"]
        assert elbow and np.nanmax(data[:, elbow[0]]) <= 180.0 and np.isfinite(data[:, elbow[0]]).any()
    events = _tsv(out / "sub-01" / "motion" / "sub-01_task-fma_events.tsv")
    assert [(e["trial_type"], e["side"]) for e in events] == [("salute", "right"), ("hand_lift", "right")]


def test_bids_export_against_the_specification(work, tmp_path):
    validator = pytest.importorskip("bids_validator")
    schema = pytest.importorskip("bidsschematools.schema").load_schema()
    out = export_cohort(work / "out" / "cohort", "bids", tmp_path / "bids", truth=True, progress=False).out_dir
    check = validator.BIDSValidator()
    files = [p for p in out.rglob("*") if p.is_file()]
    bad = [str(p.relative_to(out)) for p in files if not check.is_bids("/" + str(p.relative_to(out)))]
    assert bad == []
    sidecars = schema.rules.sidecars.motion
    required = {k for group in sidecars.values() for k, level in group["fields"].items()
                if (level if isinstance(level, str) else level["level"]) == "required"}
    assert required == {"TaskName", "SamplingFrequency"}
    columns = schema.rules.tabular_data.motion.motionChannels["columns"]
    needed = {re.sub("__.*", "", k) for k, level in columns.items() if level == "required"}
    for path in out.rglob("*_motion.json"):
        assert required <= set(json.loads(path.read_text()))
    for path in out.rglob("*_channels.tsv"):
        assert needed <= set(_tsv(path)[0])


def test_export_cohort_bad_input(work, tmp_path):
    root = work / "out" / "cohort"
    with pytest.raises(RecordingError, match="no manifest.json"):
        export_cohort(tmp_path, "csv", tmp_path / "x", progress=False)
    with pytest.raises(BadInputError, match="not camera-toml"):
        export_cohort(root, "camera-toml", tmp_path / "x", progress=False)
    with pytest.raises(ValueError):
        export_cohort(root, "xlsx", tmp_path / "x", progress=False)
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "keep.txt").write_text("mine")
    with pytest.raises(BadInputError, match="not empty"):
        export_cohort(root, "csv", tmp_path / "full", progress=False)
    assert [p.name for p in (tmp_path / "full").iterdir()] == ["keep.txt"]
    export_cohort(root, "csv", tmp_path / "full", overwrite=True, progress=False)
    assert not (tmp_path / "full" / "keep.txt").exists()


def test_export_cohort_command_line_errors(work, tmp_path, capsys):
    root = str(work / "out" / "cohort")
    cases = [
        (["export", "--cohort", str(tmp_path), "--format", "csv", "--out", str(tmp_path / "a")], "no manifest.json"),
        (["export", "--cohort", root, "--format", "csv", "--out", str(tmp_path / "a"), "--rate", "60"], "drop --rate"),
        (["export", "--cohort", root, "--format", "camera-toml", "--out", str(tmp_path / "a")], "not camera-toml"),
        (["export", "x", "--format", "bids", "--out", str(tmp_path / "a.tsv")], "add --cohort"),
        (["export", "--format", "csv", "--out", str(tmp_path / "a.csv")], "or --cohort DIR"),
    ]
    for argv, message in cases:
        assert main(argv) == 2
        assert message in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["export", "--cohort", root, "--format", "xlsx", "--out", str(tmp_path / "a")])
    assert exc.value.code == 2 and "invalid choice" in capsys.readouterr().err
    assert main(["export", "--cohort", root, "--format", "csv", "--out", str(tmp_path / "b")]) == 0
    assert main(["export", "--cohort", root, "--format", "csv", "--out", str(tmp_path / "b")]) == 2
    assert "not empty" in capsys.readouterr().err


def test_the_documented_loading_example_reads_the_manifests_labels(work, monkeypatch):
    pytest.importorskip("pandas")
    text = (DOCS / "workflows" / "synthetic-datasets.md").read_text()
    section = text[text.index("## 4. Export"):text.index("## Measured")]
    commands = re.findall(r"^mocap-bench (export --cohort .*?)(?:\s+#.*)?$", section, flags=re.M)[:2]
    assert commands == ["export --cohort out/cohort --format csv --out out/cohort_csv --truth",
                        "export --cohort out/cohort --format c3d --out out/cohort_c3d"]
    monkeypatch.chdir(work)
    assert main(["export", "--cohort", "out/cohort", "--format", "csv", "--out", "out/cohort_csv", "--truth",
                 "--overwrite"]) == 0
    assert main(["export", "--cohort", "out/cohort", "--format", "c3d", "--out", "out/cohort_c3d", "--overwrite"]) == 0
    (code,) = re.findall(r"```python\n(.*?)```", section, flags=re.S)
    namespace: dict = {}
    exec(compile(code, "synthetic-datasets.md", "exec"), namespace)
    subjects = _manifest(work)["subjects"]
    participants = namespace["participants"]
    assert list(participants["participant_id"]) == [s["id"] for s in subjects]
    assert list(participants["group"]) == [s["group"] for s in subjects]
    assert [None if isinstance(v, float) else v for v in participants["affected_side"]] == [
        s["affected_side"] for s in subjects]
    assert list(participants["salute_right_score"]) == [
        item_score(Item.SALUTE, item_raw(Item.SALUTE, s["item_scores"]["right"])) for s in subjects]
    first = subjects[0]
    assert namespace["labels"]["participant_id"] == first["id"] and namespace["labels"]["group"] == first["group"]
    assert set(namespace["frames"]["group"]) == {first["group"]}
    assert namespace["points"].shape[:2] == (3, len(namespace["markers"]))
    assert len(namespace["truth"]) == load_truth(work / "out" / "cohort" / first["files"]["truth"]).times.size
