"""Per-dataset analyses beyond the paper's label, and their summary over cohort seeds."""

import argparse
import dataclasses
import json

import numpy as np
import pytest

from fma.features import FEATURE_NAMES
from fusion.errors import BadInputError, RecordingError
from scenarios.cli import build_parser, main
from scenarios.clinical.analyses import cohort_metrics, is_speed_or_time, read_manifest
from scenarios.clinical.cohort import plain
from scenarios.clinical.fma_study import Sample
from scenarios.clinical.patient_study import (
    HEADLINE_METRICS,
    ORDERINGS,
    compare_with_baseline,
    report_markdown,
    run_seed_study,
    summarise,
    write_report,
)
from sim.patients import ModelPart, PatientModel
from tests.scenarios.clinical.test_cohort import tiny_config

F = len(FEATURE_NAMES)


def synthetic(seed, *, n_healthy=6, n_patients=6, reps=3):
    """Samples whose feature 0 is high on a patient's affected arm only, with a manifest to match.

    Feature 1 carries the FMA-UE score of the affected arm, feature 2 the item score of the side.
    """
    rng = np.random.default_rng(seed)
    samples, subjects = [], []
    for i in range(n_healthy + n_patients):
        sid = f"sub-{i:02d}"
        patient = i >= n_healthy
        affected = ("left", "right")[i % 2] if patient else None
        fma = float(20 + 4 * (i - n_healthy)) if patient else None
        scores = {}
        for side in ("left", "right"):
            hit = side == affected
            item = (1 if fma < 50 else 2) if hit else 2
            scores[side] = {"hand_lift": item, "salute": 12 if item == 2 else 6, "shoulder_retraction": item,
                            "shoulder_elevation": item, "shoulder_abduction": item,
                            "shoulder_external_rotation": item, "elbow_flexion": item, "forearm_supination": item}
            for movement in ("salute", "hand_lift"):
                for _ in range(reps):
                    f = rng.normal(size=F)
                    f[0] += 5.0 * hit
                    f[1] = (fma if hit else 66.0) / 10.0 + rng.normal(0, 0.05)
                    f[2] = item + rng.normal(0, 0.05)
                    samples.append(Sample(sid, "patient" if patient else "healthy", side, movement, "fused", "fused",
                                          item, f, np.zeros(3)))
        subjects.append({"id": sid, "group": "mild" if patient else "healthy", "affected_side": affected,
                         "fma_ue": fma, "item_scores": scores})
    result = {
        "_samples": samples,
        "patient_vs_healthy": {"salute/raw/fused": {"random_forest": {"accuracy": 0.8, "confusion": [[8, 2], [2, 8]]}}},
        "ranking": {"salute/forest_importance": [(FEATURE_NAMES[0], 0.5), ("Height(Hand) mean", 0.1)]},
        "t_tests": {"salute": [{"name": "Trunk displacement range (m)", "mean_a": 0.05, "mean_b": 0.02}]},
    }
    return result, {"subjects": subjects}


@pytest.fixture(scope="module")
def metrics(small_forests_module):
    return cohort_metrics(*synthetic(0), seed=1)


def test_per_side_labels_separate_the_affected_arm_only(metrics):
    m, _ = metrics
    assert m["side/affected/both/random_forest/balanced_accuracy"] > 0.9
    assert m["side/unaffected/both/random_forest/balanced_accuracy"] < 0.75  # no signal on the other arm
    assert m["paper/salute/raw/fused/random_forest/accuracy"] == 0.8
    assert m["paper/salute/raw/fused/random_forest/balanced_accuracy"] == pytest.approx(0.8)


def test_severity_and_item_scores(metrics):
    m, details = metrics
    assert m["severity/both/mae"] < m["severity/both/baseline_mae"] and m["severity/both/correlation"] > 0.8
    assert len(details["severity"]["both"]["truth"]) == 6
    assert m["item/salute/random_forest/macro_f1"] > 0.8 and np.isnan(m["item/salute/random_forest/recall_0"])
    cm = np.array(details["item_confusion"]["salute/random_forest"])
    assert cm.shape == (3, 3) and cm[0].sum() == 0 and cm.sum() == 12 * 2 * 3


def test_ranking_and_trunk(metrics):
    m, _ = metrics
    assert m["ranking/salute/forest_importance/speed_time_share"] == 0.5  # time length yes, Height mean no
    assert m["ranking/salute/forest_importance/chance_share"] == pytest.approx(105 / 170)
    assert m["trunk/salute/displacement_difference"] == pytest.approx(0.03)
    assert is_speed_or_time("Time length") and is_speed_or_time("Height(Hand) speed max")
    assert not is_speed_or_time("Height(Hand) variance")


def test_cohort_metrics_bad_input(tmp_path):
    with pytest.raises(BadInputError, match="analyse"):
        cohort_metrics({}, {"subjects": []})
    with pytest.raises(RecordingError, match="manifest.json"):
        read_manifest(tmp_path)


def test_summary_intervals_orderings_and_report(tmp_path, small_forests_module):
    per_seed, details = [], []
    for seed in range(3):
        m, d = cohort_metrics(*synthetic(seed, n_healthy=4, n_patients=4, reps=2), seed=0)
        per_seed.append(m)
        details.append(d)
    result = summarise("synthetic", [1, 2, 3], [8] * 3, per_seed, details)
    iv = result.intervals["paper/salute/raw/fused/random_forest/accuracy"]
    assert (iv.mean, iv.low, iv.high) == pytest.approx((0.8, 0.8, 0.8)) and iv.n == 3
    trunk = result.orderings["more trunk motion in patients (salute)"]
    assert trunk.mean == pytest.approx(0.03) and trunk.n == 3
    assert result.orderings["two cameras above one"].n == 0  # not in the synthetic result
    assert set(result.orderings) == {claim for claim, *_ in ORDERINGS}
    text = report_markdown(result)
    for heading in ("orderings", "Per-side labels", "Severity regression", "Item scores", "Confusion matrix"):
        assert heading in text
    write_report(result, tmp_path / "rep")
    doc = json.loads((tmp_path / "rep" / "results.json").read_text())
    assert doc["seeds"] == [1, 2, 3] and len(doc["per_seed"]) == 3
    assert (tmp_path / "rep" / "intervals.png").stat().st_size > 0
    assert (tmp_path / "rep" / "item_confusion.png").stat().st_size > 0
    with pytest.raises(BadInputError, match="one metrics dict per seed"):
        summarise("x", [1, 2], [1], per_seed[:1], details[:1])


def test_run_seed_study_bad_seeds(tmp_path):
    for seeds in ([1], [1, 1], [-1, 2]):
        with pytest.raises(BadInputError, match="seeds"):
            run_seed_study(tiny_config(), seeds, tmp_path)


def test_cli_rejects_bad_counts(tmp_path, capsys):
    assert main(["patient-study", "cohort_literature_quick", "--out", str(tmp_path / "r"), "--healthy", "-1"]) == 2
    assert "group counts" in capsys.readouterr().err


def test_ablation_is_compared_with_its_baseline_seed_by_seed(tmp_path):
    key = "trunk/hand_lift/displacement_difference"
    accuracy = HEADLINE_METRICS[0][1]

    def study(values, seeds, ablated=()):
        per_seed = [{key: v, accuracy: 0.5 + v} for v in values]
        return summarise("c", seeds, [8] * len(seeds), per_seed, [{}] * len(seeds), ablated=ablated)

    write_report(study([0.04, 0.03, 0.05], [1, 2, 3]), tmp_path / "base")
    ablated = study([0.01, 0.0, 0.03, 0.2], [1, 2, 3, 9], ablated=("trunk",))
    result = compare_with_baseline(ablated, tmp_path / "base")
    change = result.baseline["changes"]["more trunk motion in patients (hand lift)"]
    assert result.baseline["seeds"] == [1, 2, 3]  # seed 9 has no baseline
    assert (change.mean, change.n) == (pytest.approx(-0.08 / 3), 3) and change.high < 0
    assert result.baseline["changes"][HEADLINE_METRICS[0][0]].mean == pytest.approx(-0.08 / 3)
    text = report_markdown(result)
    assert "switched off: trunk" in text and "ablated minus baseline" in text
    write_report(result, tmp_path / "abl")
    doc = json.loads((tmp_path / "abl" / "results.json").read_text())
    assert doc["ablated"] == ["trunk"] and doc["baseline"]["changes"][HEADLINE_METRICS[0][0]]["n"] == 3
    with pytest.raises(BadInputError, match="results file"):
        compare_with_baseline(ablated, tmp_path / "nowhere")
    write_report(study([0.1, 0.2], [7, 8]), tmp_path / "other")
    with pytest.raises(BadInputError, match="same seeds"):
        compare_with_baseline(ablated, tmp_path / "other")


def test_a_cohort_generated_with_other_settings_is_not_reused(tmp_path):
    cohort = tiny_config()
    data = tmp_path / "seed-1"
    data.mkdir()
    stored = json.loads(json.dumps(plain(dataclasses.replace(cohort, study=dataclasses.replace(cohort.study, seed=1)))))
    del stored["patients"]["ablate"]  # written before the key existed: read as its default
    (data / "manifest.json").write_text(json.dumps({"format": "mocap-bench-cohort", "cohort": stored, "subjects": []}))
    ablated = dataclasses.replace(cohort, patients=dataclasses.replace(
        cohort.patients, model=PatientModel.LITERATURE, ablate=[ModelPart.TRUNK]))
    with pytest.raises(BadInputError, match="other settings.*patients"):
        run_seed_study(ablated, [1, 2], tmp_path)


def test_cli_ablate_choices_are_the_model_parts():
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    ablate = next(a for a in sub.choices["patient-study"]._actions if a.dest == "ablate")
    assert set(ablate.choices) == {p.value for p in ModelPart}
