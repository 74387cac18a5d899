import csv
import dataclasses
import json
import math
import tomllib

import numpy as np
import pytest

import scenarios.clinical.cohort as cohort_module
from fusion.errors import BadInputError, CalibrationError, ScenarioError
from fusion.io.calibration_file import load_calibration
from fusion.io.recording_files import load_recording
from scenarios.cli import main
from scenarios.clinical.cohort import generate_cohort, subject_plan
from scenarios.clinical.cohort_file import (
    COHORT_DIR,
    GroupCounts,
    cohort_from_dict,
    load_cohort,
)
from scenarios.sweep import SweepOptions
from sim.patient_motion import (
    Group,
    Movement,
    MovementProfile,
    Side,
    SubjectProfile,
    sample_profile,
)
from sim.scoring import ItemScores, hand_lift_score, item_scores
from sim.truth import load_truth

IN_PROCESS = SweepOptions(workers=0, progress=False)

TINY = """
[cohort]
name = "tiny"
seed = 7

[groups]
healthy = 2
mild = 1
moderate_severe = 1

[protocol]
idle_s = 1.0
calibration_turn_s = 8.0
repetitions = [1, 1]
rest_s = 0.5
movements = ["salute", "hand_lift"]
sides = ["right"]

[rig]
angles_deg = [45.0, -45.0]
target_height_m = 0.9

[processing]
refine = "none"  # skeleton-only calibration keeps the test fast; ICP is tested in tests/fusion
"""


def tiny_config(**groups):
    cohort = cohort_from_dict(tomllib.loads(TINY))
    return dataclasses.replace(cohort, groups=GroupCounts(**groups)) if groups else cohort


# --- scoring ----------------------------------------------------------------------------------------


def _lift(**changes):
    return dataclasses.replace(MovementProfile.healthy(Movement.HAND_LIFT), **changes)


def test_healthy_profiles_earn_full_scores():
    for seed in range(200):
        profile = sample_profile(Group.HEALTHY, rng=np.random.default_rng(seed))
        for side in Side:
            scores = item_scores(profile, side)
            assert (scores.salute, scores.hand_lift, scores.total) == (12, 2, 14)
    assert item_scores(SubjectProfile.healthy(), Side.LEFT).total == 14


def test_patients_score_lower_on_the_affected_side_only():
    totals = {Group.MILD: [], Group.MODERATE_SEVERE: []}
    for seed in range(100):
        for group in totals:
            profile = sample_profile(group, rng=np.random.default_rng(seed))
            unaffected = Side.LEFT if profile.affected_side is Side.RIGHT else Side.RIGHT
            assert item_scores(profile, unaffected).total == 14
            totals[group].append(item_scores(profile, profile.affected_side))
    severe = totals[Group.MODERATE_SEVERE]
    assert all(s.hand_lift == 0 and s.salute < 12 for s in severe)  # synergy from the start
    assert np.mean([s.total for s in totals[Group.MILD]]) > np.mean([s.total for s in severe])
    assert {s.hand_lift for s in totals[Group.MILD]} >= {1}


@pytest.mark.parametrize(("changes", "expected"), [
    ({}, 2),
    ({"peak_elevation": math.radians(80)}, 1),  # incomplete range
    ({"peak_elevation": math.radians(40)}, 0),  # cannot be performed
    ({"synergy_onset": math.radians(50), "synergy_elbow_flexion": math.radians(20)}, 1),  # appears late
    ({"synergy_onset": 0.0, "synergy_abduction": math.radians(30)}, 0),  # immediate
    ({"synergy_onset": math.radians(100), "synergy_elbow_flexion": math.radians(40)}, 2),  # onset never reached
])
def test_hand_lift_rules(changes, expected):
    assert hand_lift_score(_lift(**changes)) == expected


def test_salute_components_follow_the_reached_fraction():
    def scores(peak_deg):
        salute = dataclasses.replace(MovementProfile.healthy(Movement.SALUTE), peak_elevation=math.radians(peak_deg))
        profile = dataclasses.replace(SubjectProfile.healthy(), salute_right=salute)
        return item_scores(profile, Side.RIGHT)

    assert (scores(90).salute, scores(85).salute, scores(85).shoulder_abduction) == (12, 11, 1)
    assert (scores(60).salute, scores(20).salute) == (6, 0)


def test_scoring_bad_input():
    with pytest.raises(BadInputError, match="side"):
        item_scores(SubjectProfile.healthy(), "left")
    with pytest.raises(BadInputError, match="SubjectProfile"):
        item_scores(MovementProfile.healthy(Movement.SALUTE), Side.LEFT)
    with pytest.raises(BadInputError, match="hand_lift"):
        ItemScores(Side.LEFT, 2, 2, 2, 2, 2, 2, hand_lift=3)


# --- configuration ----------------------------------------------------------------------------------


def test_builtin_paper_cohort():
    cohort = load_cohort("cohort_paper")
    g = cohort.groups
    assert (g.healthy, g.mild + g.moderate_severe) == (10, 12)
    assert cohort.rig.angles_deg == [45.0, -45.0] and cohort.rig.radius_m == 2.0
    assert cohort.protocol.repetitions == [3, 5] and set(cohort.protocol.sides) == {"left", "right"}
    assert load_cohort(COHORT_DIR / "cohort_paper.toml") == cohort


@pytest.mark.parametrize(("text", "message"), [
    (TINY.replace("rest_s = 0.5", "rest_s = 0.5\nrests = 2"), "unknown key 'rests' in \\[protocol\\]"),
    (TINY + "\n[extra]\n", "unknown table \\[extra\\]"),
    (TINY.replace("[1, 1]", "[3, 2]"), "protocol.repetitions"),
    (TINY.replace('"right"]', '"up"]'), "protocol.sides"),
    (TINY.replace("healthy = 2", 'healthy = "two"'), "groups.healthy: expected int"),
    (TINY.replace("[45.0, -45.0]", "[45.0]"), "at least two cameras"),
    (TINY.replace("calibration_turn_s = 8.0", "calibration_turn_s = 2.0"), "calibration_turn_s"),
    (TINY.replace('[cohort]\nname = "tiny"', "[cohort]"), "missing required key\\(s\\): name"),
])
def test_bad_cohort_files_are_rejected_clearly(text, message):
    with pytest.raises(ScenarioError, match=message):
        cohort_from_dict(tomllib.loads(text))


def test_unknown_cohort_name(tmp_path):
    with pytest.raises(ScenarioError, match="cohort_paper"):
        load_cohort("no_such_cohort")
    assert main(["cohort", str(tmp_path / "missing.toml"), "--out", str(tmp_path / "o")]) == 2


def test_subject_plan_is_seeded_and_shuffled():
    cohort = tiny_config()
    a, b = subject_plan(cohort), subject_plan(cohort)
    assert [(i, g) for i, g, _ in a] == [(i, g) for i, g, _ in b]
    assert all(sa.generate_state(4).tolist() == sb.generate_state(4).tolist() for (_, _, sa), (_, _, sb) in zip(a, b))
    other = subject_plan(dataclasses.replace(cohort, study=dataclasses.replace(cohort.study, seed=8)))
    assert a[0][2].generate_state(4).tolist() != other[0][2].generate_state(4).tolist()
    assert sorted(g.value for _, g, _ in a) == ["healthy", "healthy", "mild", "moderate_severe"]


# --- generation -------------------------------------------------------------------------------------


def test_manifest_labels_and_files(tiny_cohort):
    out, manifest = tiny_cohort.out_dir, tiny_cohort.manifest
    assert json.loads((out / "manifest.json").read_text()) == manifest
    assert manifest["format"] == "mocap-bench-cohort" and manifest["seed"] == 7
    subjects = manifest["subjects"]
    assert [s["id"] for s in subjects] == ["sub-01", "sub-02", "sub-03", "sub-04"]
    assert tiny_cohort.failed == ()
    for s in subjects:
        assert (s["affected_side"] is None) == (s["group"] == "healthy")
        assert set(s["item_scores"]) == {"left", "right"}
        assert [(b["movement"], b["side"], b["repetitions"]) for b in s["blocks"]] == [
            ("salute", "right", 1), ("hand_lift", "right", 1)]
        truth = load_truth(out / s["files"]["truth"])
        recording = load_recording(out / s["files"]["recording"])
        assert [c.name for c in recording.cameras] == [c.name for c in truth.cameras]
        for block in s["blocks"]:
            (rep,) = block["truth"]["repetitions"]
            assert block["t_start"] <= rep["t_start"] < rep["t_peak"] < rep["t_end"] <= block["t_end"]
            assert any(r["movement"] == block["movement"] and math.isclose(r["t_start"], rep["t_start"])
                       for r in truth.repetitions)
        load_calibration(out / s["files"]["calibration"])
        fused = load_recording(out / s["files"]["fused"])
        assert [c.name for c in fused.cameras] == ["fused"]
        assert s["truth"]["profile"]["group"] == s["group"]
    rows = list(csv.DictReader((out / "manifest.csv").open()))
    assert len(rows) == 4 * 2
    assert {r["movement"] for r in rows} == {"salute", "hand_lift"} and all(r["fused"] for r in rows)


def test_patients_score_below_healthy(tiny_cohort):
    def worst(s):
        return min(v["total"] for v in s["item_scores"].values())

    subjects = tiny_cohort.manifest["subjects"]
    healthy = [worst(s) for s in subjects if s["group"] == "healthy"]
    patients = [worst(s) for s in subjects if s["group"] != "healthy"]
    assert healthy == [14, 14] and max(patients) < 14


def test_a_subject_is_reproducible_from_the_cohort_seed(tiny_cohort, tmp_path):
    cohort = tiny_config()
    subject_id, group, seed = subject_plan(cohort)[0]
    entry = cohort_module._simulate_subject(cohort, subject_id, group, seed, tmp_path)
    assert json.loads(json.dumps(entry)) == tiny_cohort.manifest["subjects"][0]
    run = "subjects/sub-01/run/recording/recording.json"
    assert (tmp_path / run).read_bytes() == (tiny_cohort.out_dir / run).read_bytes()


def test_failed_calibration_is_recorded_not_fatal(tmp_path, monkeypatch):
    def fail(*args, **kwargs):
        raise CalibrationError("no camera pair saw enough of the body")

    monkeypatch.setattr(cohort_module, "calibrate_rig", fail)
    cohort = tiny_config(healthy=1, mild=0, moderate_severe=0)
    cohort = dataclasses.replace(cohort, protocol=dataclasses.replace(cohort.protocol, movements=["hand_lift"]))
    result = generate_cohort(cohort, tmp_path / "c", sweep=IN_PROCESS)
    (s,) = result.manifest["subjects"]
    assert result.failed == ("sub-01",) and "no camera pair" in s["error"]
    assert s["files"]["calibration"] is None and (result.out_dir / s["files"]["recording"]).is_dir()
    with pytest.raises(BadInputError, match="not empty"):
        generate_cohort(cohort, tmp_path / "c", sweep=IN_PROCESS)
    with pytest.raises(BadInputError, match="workers"):
        generate_cohort(cohort, tmp_path / "d", sweep=SweepOptions(workers=-1))
