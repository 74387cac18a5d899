"""Analyses of one cohort dataset beyond the paper's label, side by side with it.

Given the result of :func:`scenarios.clinical.fma_study.analyse` and the dataset's ``manifest.json``,
:func:`cohort_metrics` returns flat named numbers (one cohort seed), every one computed from the
repetition samples with leave-one-subject-out validation:

- ``paper/...``: the paper's label (patient or healthy, both sides labelled by the subject),
  accuracy and balanced accuracy per movement, data variant, camera set-up and classifier;
- ``side/affected/...``: per-side labels, the patients' affected arm against healthy arms (the
  patients' other arm left out); ``side/unaffected/...`` the patients' other arm against healthy
  arms (how visible the ipsilesional deficits are);
- ``severity/...``: FMA-UE regression from the affected arm's repetitions (patients only): MAE
  (points), Pearson correlation, and the MAE of predicting the mean of the other subjects;
- ``item/...``: item scores (salute class 0/1/2, hand lift 0/1/2) of every side: accuracy,
  balanced accuracy, macro-F1 and per-class recall; confusion matrices in the details;
- ``ranking/...``: the share of speed, acceleration and time-length features among the ten best
  ranked features, and their share among all features (the chance level);
- ``trunk/...``: mean trunk displacement and trunk tilt range of patients minus healthy subjects.

Labels come from the manifest (``group``, ``affected_side``, ``fma_ue``, ``item_scores``), which a
real dataset provides as well; nothing here reads the simulation's truth.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from fma.classify import ClassifierKind, class_metrics, evaluate_classifiers
from fma.features import FEATURE_NAMES, TIME_LENGTH
from fma.severity import regress_severity
from fusion.errors import BadInputError, RecordingError

ANALYSIS_SETUP = "fused"
"""Camera set-up of the per-side, severity and item-score analyses (this system's merge)."""
TOP_K = 10
"""Ranked features counted by the ``ranking`` metrics."""
MOVEMENT_KEYS = ("hand_lift", "salute", "both")


def is_speed_or_time(name: str) -> bool:
    """True for the time length and every speed or acceleration statistic."""
    return name == TIME_LENGTH or " speed " in f" {name} " or " acceleration " in f" {name} "


def read_manifest(root: Path) -> dict[str, Any]:
    """The parsed ``manifest.json`` of a cohort directory."""
    path = Path(root) / "manifest.json"
    if not path.is_file():
        raise RecordingError(f"{root} has no manifest.json; create the dataset with `mocap-bench cohort`")
    return json.loads(path.read_text(encoding="utf-8"))


def _balanced(confusion: np.ndarray) -> float:
    cm = np.asarray(confusion, dtype=float)
    rows = cm.sum(axis=1)
    return float(np.mean(np.diag(cm)[rows > 0] / rows[rows > 0]))


def _rows(samples: list[Any], movement: str) -> list[Any]:
    return [s for s in samples if s.setup == ANALYSIS_SETUP and (movement == "both" or s.movement == movement)]


def _classify(rows: list[Any], labels: np.ndarray, seed: int) -> dict[ClassifierKind, Any] | None:
    if len(rows) < 4 or np.unique(labels).size < 2 or len({s.subject for s in rows}) < 3:
        return None
    X = np.stack([s.features for s in rows])
    return evaluate_classifiers(X, labels, np.array([s.subject for s in rows]), rng=np.random.default_rng(seed))


def cohort_metrics(result: dict[str, Any], manifest: dict[str, Any], *, seed: int = 0
                   ) -> tuple[dict[str, float], dict[str, Any]]:
    """Flat metrics of one dataset and details (confusion matrices, severity predictions).

    Parameters
    ----------
    result : dict
        What :func:`scenarios.clinical.fma_study.analyse` returned (needs its ``_samples``).
    manifest : dict
        The dataset's parsed ``manifest.json``.
    seed : int
        Seed of the classifiers and the regressor.

    Returns
    -------
    (dict, dict)
        Metric name -> value (accuracies and recalls as fractions, MAE in FMA-UE points, trunk
        differences in metres and degrees), and plain-data details for the report.
    """
    if "_samples" not in result or "patient_vs_healthy" not in result:
        raise BadInputError("result must be the dict returned by scenarios.clinical.fma_study.analyse")
    subjects = {s["id"]: s for s in manifest.get("subjects", [])}
    samples = result["_samples"]
    metrics: dict[str, float] = {}
    details: dict[str, Any] = {"item_confusion": {}, "severity": {}}
    for key, per_kind in result["patient_vs_healthy"].items():
        for kind, res in per_kind.items():
            metrics[f"paper/{key}/{kind}/accuracy"] = res["accuracy"]
            metrics[f"paper/{key}/{kind}/balanced_accuracy"] = _balanced(res["confusion"])

    for movement in MOVEMENT_KEYS:
        rows = _rows(samples, movement)
        for which in ("affected", "unaffected"):
            keep = [s for s in rows if s.group == "healthy"
                    or (s.side == subjects[s.subject]["affected_side"]) == (which == "affected")]
            labels = np.array([s.group != "healthy" for s in keep], dtype=int)
            res = _classify(keep, labels, seed)
            for kind, r in (res or {}).items():
                metrics[f"side/{which}/{movement}/{kind.value}/accuracy"] = r.accuracy
                metrics[f"side/{which}/{movement}/{kind.value}/balanced_accuracy"] = class_metrics(
                    labels, r.predictions).balanced_accuracy

        affected = [s for s in rows if s.group != "healthy" and s.side == subjects[s.subject]["affected_side"]
                    and subjects[s.subject].get("fma_ue") is not None]
        if len({s.subject for s in affected}) >= 3:
            sev = regress_severity(np.stack([s.features for s in affected]),
                                   np.array([subjects[s.subject]["fma_ue"] for s in affected], dtype=float),
                                   np.array([s.subject for s in affected]), rng=np.random.default_rng(seed))
            metrics[f"severity/{movement}/mae"] = sev.mae
            metrics[f"severity/{movement}/correlation"] = sev.correlation
            metrics[f"severity/{movement}/baseline_mae"] = sev.baseline_mae
            details["severity"][movement] = {"subjects": sev.subjects.tolist(), "truth": sev.truth.tolist(),
                                             "predicted": sev.predicted.tolist()}

        if movement != "both":
            labels = np.array([s.item_score for s in rows], dtype=int)
            res = _classify(rows, labels, seed)
            for kind, r in (res or {}).items():
                m = class_metrics(labels, r.predictions, classes=np.array([0, 1, 2]))
                base = f"item/{movement}/{kind.value}"
                metrics[f"{base}/accuracy"] = r.accuracy
                metrics[f"{base}/balanced_accuracy"] = m.balanced_accuracy
                metrics[f"{base}/macro_f1"] = m.macro_f1
                for c, rec in zip(m.classes.tolist(), m.recall.tolist()):
                    metrics[f"{base}/recall_{c}"] = rec
                details["item_confusion"][f"{movement}/{kind.value}"] = m.confusion.tolist()

    share_all = float(np.mean([is_speed_or_time(n) for n in FEATURE_NAMES]))
    for key, ranking in result.get("ranking", {}).items():
        top = [name for name, _ in ranking[:TOP_K]]
        metrics[f"ranking/{key}/speed_time_share"] = float(np.mean([is_speed_or_time(n) for n in top]))
        metrics[f"ranking/{key}/chance_share"] = share_all
    for movement, rows in result.get("t_tests", {}).items():
        for r in rows:
            short = "displacement" if r["name"].startswith("Trunk displacement") else (
                "tilt" if r["name"].startswith("Trunk tilt") else None)
            if short is not None:
                metrics[f"trunk/{movement}/{short}_difference"] = r["mean_a"] - r["mean_b"]
    return metrics, details
