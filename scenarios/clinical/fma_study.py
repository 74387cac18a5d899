"""``mocap-bench fma``: the paper's section 4 on a cohort dataset (``mocap-bench cohort``).

For every subject the calibrated cameras' skeletons are put on one time base in the world frame
(:func:`fusion.merge.fuse.camera_views`) and read through the paper's camera set-ups:

- ``single``: one camera per subject, picked at random (seeded);
- ``averaging``: the plain average of the cameras;
- ``best``: per movement block, the camera nearest to the moving hand;
- ``all``: every camera a separate sample;
- ``fused``: this system's Avg(Frontal) merge with back-facing relabelling.

Within each protocol block (movement and side, the time the clinician asked for it) repetitions are
segmented from the moving hand (:mod:`fma.segmentation`), the 13 measurements of Table 4 computed,
and the features of each repetition extracted (:mod:`fma.features`). Classifiers are scored with
leave-one-subject-out validation (:mod:`fma.classify`): patients against healthy subjects for the
hand lift, the salute and both (Tables 5-7 shape), with the raw, repetition-average and asymmetry
data variants; feature rankings (Tables 8-11); compensation t-tests (Tables 12-13); and, beyond the
paper, the item score (0/1/2) of each side. Truth is used only to score the segmentation, when the
manifest has it: a dataset of real recordings needs only a ``manifest.json`` with, per subject,
``id``, ``group``, ``item_scores`` (per side), ``blocks`` (``movement``, ``side``, ``t_start``,
``t_end`` on the reference camera's clock), ``files`` (``recording`` and ``calibration``, relative
paths) and ``error`` = null (layout in :mod:`scenarios.clinical.cohort`).

Item scores are the 0/1/2 labels of :mod:`scenarios.clinical.vocabulary` (the salute's from the
sum of its six components by the rule there), the same as in ``participants.tsv`` and ``manifest.csv``.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from joblib import parallel_config

from fma.classify import (
    ClassifierKind,
    RankingMethod,
    evaluate_classifiers,
    rank_features,
)
from fma.features import (
    FEATURE_NAMES,
    DataVariant,
    FeatureTable,
    apply_variant,
    segments_features,
)
from fma.measurements import MEASUREMENT_NAMES, compute_measurements, side_landmarks
from fma.segmentation import segment_repetitions
from fma.statistics import (
    COMPENSATION_NAMES,
    PersonTestResult,
    TTestResult,
    compensation_measures,
    person_level_tests,
    person_tests_markdown,
    t_tests_markdown,
    welch_t_tests,
)
from fusion.errors import BadInputError, RecordingError
from fusion.io.atomic import atomic_directory
from fusion.io.calibration_file import load_calibration
from fusion.io.recording_files import load_recording
from fusion.merge.fuse import FuseOptions, camera_views, fuse_views
from fusion.merge.methods import MergeMethod
from fusion.merge.views import CameraViews
from scenarios.clinical.fma_validity import chance_level, loso_warnings
from scenarios.clinical.manifest import MOVEMENTS, read_manifest
from scenarios.clinical.vocabulary import Item, item_raw, item_score
from scenarios.show import plt, save_figure

SETUPS = ("single", "averaging", "best", "all", "fused")
FRAME_S = 1.0 / 30.0


@dataclass
class Sample:
    """One repetition seen through one camera set-up."""

    subject: str
    group: str
    side: str
    movement: str
    setup: str
    camera: str
    item_score: int
    features: np.ndarray
    compensation: np.ndarray


def _item_label(subject: dict[str, Any], movement: str, side: str) -> int:
    item = Item(movement)
    return item_score(item, item_raw(item, subject["item_scores"][side]))


def _setup_positions(views: CameraViews, setup: str, rng: np.random.Generator
                     ) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """(camera label, (T, J, 3) world positions, (3,) camera centre) per sample stream of a set-up."""
    def one(name: str) -> tuple[str, np.ndarray, np.ndarray]:
        k = views.names.index(name)
        merged = fuse_views(views.subset([name]), FuseOptions(method=MergeMethod.AVERAGE))
        return name, merged.positions, views.centres[k]

    if setup == "single":
        return [one(views.names[int(rng.integers(views.n_cameras))])]
    if setup == "all":
        return [one(n) for n in views.names]
    method = MergeMethod.AVERAGE if setup == "averaging" else MergeMethod.AVG_FRONTAL
    merged = fuse_views(views, FuseOptions(method=method, relabel_back_facing=setup == "fused"))
    return [(setup, merged.positions, views.centres[0])]


def _best_camera(views: CameraViews, side: str, frames: np.ndarray) -> str:
    hand = views.topology.index(side_landmarks(side)["hand"])
    d = np.linalg.norm(views.positions[:, frames, hand] - views.centres[:, None], axis=-1)
    med = np.array([np.nanmedian(x) if np.isfinite(x).any() else np.inf for x in d])
    return views.names[int(np.argmin(med))]


def subject_samples(root: Path, subject: dict[str, Any], *, rng: np.random.Generator
                    ) -> tuple[list[Sample], list[dict[str, Any]], dict[str, Any]]:
    """Samples of one subject for every set-up, segmentation errors against the truth, and an
    example (times, Height(Hand), segments) for the plot."""
    files = subject["files"]
    recording = load_recording(root / files["recording"])
    calibration = load_calibration(root / files["calibration"])
    views = camera_views(recording, calibration)
    topo, times = views.topology, views.times
    samples, seg_errors, example = [], [], {}
    streams = {setup: _setup_positions(views, setup, rng) for setup in SETUPS if setup != "best"}
    for block in subject["blocks"]:
        movement, side = block["movement"], block["side"]
        frames = np.flatnonzero((times >= block["t_start"]) & (times < block["t_end"]))
        if frames.size < 10:
            continue
        best = _best_camera(views, side, frames)
        per_setup = dict(streams)
        per_setup["best"] = [s for s in streams["all"] if s[0] == best]
        for setup, entries in per_setup.items():
            for camera, positions, centre in entries:
                t, p = times[frames], positions[frames]
                segments = segment_repetitions(t, p, topo, side)
                if not segments:
                    continue
                meas = compute_measurements(p, topo, side, camera_position=centre)
                feats = segments_features(t, meas, segments)
                for seg, f in zip(segments, feats):
                    samples.append(Sample(subject["id"], subject["group"], side, movement, setup, camera,
                                          _item_label(subject, movement, side), f,
                                          compensation_measures(p, topo, side, seg)))
                if setup == "fused":
                    truth = block.get("truth", {}).get("repetitions", [])  # absent for real recordings
                    for seg in segments:
                        near = min(truth, key=lambda r: abs(r["t_start"] - seg.t_start), default=None)
                        if near is not None:
                            seg_errors.append({"start_frames": abs(seg.t_start - near["t_start"]) / FRAME_S,
                                               "end_frames": abs(seg.t_end - near["t_end"]) / FRAME_S})
                    if not example and movement == "hand_lift":
                        example = {"subject": subject["id"], "side": side, "times": t,
                                   "height": meas[:, MEASUREMENT_NAMES.index("Height(Hand)")],
                                   "segments": [(s.t_start, s.t_end) for s in segments],
                                   "truth": [(r["t_start"], r["t_end"]) for r in truth]}
    return samples, seg_errors, example


def _table(samples: list[Sample], movement: str, setup: str, label: str) -> FeatureTable | None:
    rows = [s for s in samples if s.setup == setup and (movement == "both" or s.movement == movement)]
    if not rows:
        return None
    y = np.array([(s.group != "healthy") if label == "patient" else s.item_score for s in rows], dtype=int)
    return FeatureTable(np.stack([s.features for s in rows]), FEATURE_NAMES, np.array([s.subject for s in rows]),
                        np.array([s.side for s in rows]), y)


def _classify(table: FeatureTable, seed: int) -> dict[str, Any]:
    """Per classifier: accuracy, confusion, classes and the chance level (majority class share, 0-1)."""
    results = evaluate_classifiers(table.X, table.labels, table.subjects, rng=np.random.default_rng(seed))
    chance = chance_level(table.labels)
    return {kind.value: {"accuracy": r.accuracy, "confusion": r.confusion.tolist(), "classes": r.classes.tolist(),
                         "chance": chance}
            for kind, r in results.items()}


def analyse(root: Path, *, seed: int = 0, jobs: int = -1,
            progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Run the whole analysis on a cohort directory; returns every table as plain data.

    ``jobs`` processes fit the leave-one-subject-out folds (-1: one per core); the results do not
    depend on it.

    Raises
    ------
    RecordingError
        No ``manifest.json``, or no subject with a calibration and recording.
    """
    with parallel_config(n_jobs=jobs):
        return _analyse(root, seed=seed, progress=progress)


def _analyse(root: Path, *, seed: int, progress: Callable[[str], None] | None) -> dict[str, Any]:
    tell = progress or (lambda msg: None)
    manifest = read_manifest(Path(root))
    rng = np.random.default_rng(seed)
    samples: list[Sample] = []
    seg_errors: list[dict[str, Any]] = []
    example: dict[str, Any] = {}
    usable = [s for s in manifest["subjects"] if s["error"] is None and s["files"]["calibration"]]
    if len(usable) < 2:
        raise RecordingError(f"{root}: fewer than two subjects with a calibration; nothing to compare")
    for subject in usable:
        s, e, ex = subject_samples(root, subject, rng=rng)
        samples += s
        seg_errors += e
        example = example or ex
        tell(f"subject {subject['id']}")
    out: dict[str, Any] = {"subjects": len(usable), "samples": len(samples), "skipped": [
        s["id"] for s in manifest["subjects"] if s not in usable]}
    if seg_errors:
        out["segmentation_error_frames"] = {k: {"median": float(np.median([e[k] for e in seg_errors])),
                                                "p90": float(np.percentile([e[k] for e in seg_errors], 90))}
                                            for k in ("start_frames", "end_frames")}
    accuracy: dict[str, Any] = {}
    warned: list[str] = []
    for movement in (*MOVEMENTS, "both"):
        for variant in DataVariant:
            for setup in SETUPS:
                table = _table(samples, movement, setup, "patient")
                if table is None:
                    continue
                try:
                    table = apply_variant(table, variant)
                except BadInputError:
                    continue  # e.g. asymmetry of a subject seen on one side only
                if len(set(table.labels.tolist())) < 2:
                    continue
                accuracy[f"{movement}/{variant.value}/{setup}"] = _classify(table, seed)
                warned += loso_warnings(table.labels, table.subjects, "patients vs healthy")
        tell(f"classified {movement}")
    out["patient_vs_healthy"] = accuracy
    out["item_score"] = {}
    for movement in MOVEMENTS:
        table = _table(samples, movement, "fused", "item")
        if table is not None and len(set(table.labels.tolist())) >= 2:
            out["item_score"][movement] = _classify(table, seed)
            warned += loso_warnings(table.labels, table.subjects, f"item score, {movement.replace('_', ' ')}")
    out["warnings"] = list(dict.fromkeys(warned))  # each distinct warning once, in order
    for message in out["warnings"]:
        logging.getLogger(__name__).warning("%s", message)
    out["ranking"] = {}
    for movement in MOVEMENTS:
        table = _table(samples, movement, "averaging", "patient")
        if table is None or len(set(table.labels.tolist())) < 2:
            continue
        for method in RankingMethod:
            r = rank_features(table.X, table.labels, list(table.feature_names), rng=np.random.default_rng(seed),
                              method=method)
            out["ranking"][f"{movement}/{method.value}"] = list(zip(r.names[:10], map(float, r.scores[:10])))
    out["t_tests"], out["person_t_tests"] = {}, {}
    for movement in MOVEMENTS:
        rows = [s for s in samples if s.setup == "fused" and s.movement == movement]
        if rows:
            values, in_a = np.stack([s.compensation for s in rows]), np.array([s.group != "healthy" for s in rows])
            res = welch_t_tests(values, in_a, list(COMPENSATION_NAMES))
            out["t_tests"][movement] = [r.__dict__ for r in res]
            person = person_level_tests(values, in_a, np.array([s.subject for s in rows]), list(COMPENSATION_NAMES),
                                        seed=seed)
            out["person_t_tests"][movement] = [r.__dict__ for r in person]
    out["_samples"] = samples
    out["_example"] = example
    return out


def _accuracy_table(acc: dict[str, Any], movement: str) -> list[str]:
    kinds = [k.value for k in ClassifierKind]
    lines = ["| data | camera set-up | chance | " + " | ".join(kinds) + " |",
             "| --- | --- | --- | " + " | ".join("---" for _ in kinds) + " |"]
    for key, res in acc.items():
        mv, variant, setup = key.split("/")
        if mv == movement:
            lines.append(f"| {variant} | {setup} | {_chance(res):.1%} | "
                         + " | ".join(f"{res[k]['accuracy']:.1%}" for k in kinds) + " |")
    return lines


def _chance(res: dict[str, Any]) -> float:
    """Chance level (0-1) of one classification entry; NaN in results written before it was recorded."""
    return float(next(iter(res.values())).get("chance", float("nan")))


def report_markdown(result: dict[str, Any]) -> str:
    """Tables 5-13 shaped Markdown (accuracies with chance levels and fold warnings, rankings, t-tests per
    repetition and per person, item scores, segmentation)."""
    lines = ["# Fugl-Meyer analysis", "",
             f"{result['subjects']} subjects, {result['samples']} repetition samples over all camera set-ups "
             f"(skipped: {', '.join(result['skipped']) or 'none'}). Leave-one-subject-out accuracy, patients vs healthy; "
             "chance: the majority class share of the evaluated samples (the accuracy of always guessing it).", ""]
    lines += [f"**Warning:** {w}" for w in result.get("warnings", [])] + ([""] if result.get("warnings") else [])
    if "segmentation_error_frames" in result:
        s = result["segmentation_error_frames"]
        lines += [f"Segmentation against the truth (fused skeleton): start error median {s['start_frames']['median']:.1f} "
                  f"frames (90th percentile {s['start_frames']['p90']:.1f}), end error median "
                  f"{s['end_frames']['median']:.1f} ({s['end_frames']['p90']:.1f}).", ""]
    for number, movement in (("5", "hand_lift"), ("6", "salute"), ("7", "both")):
        lines += [f"## Table {number}: {movement.replace('_', ' ')}", ""] + _accuracy_table(
            result["patient_vs_healthy"], movement) + [""]
    for key, ranking in result["ranking"].items():
        lines += [f"## Feature ranking: {key}", "", "| rank | feature | score |", "| --- | --- | --- |"]
        lines += [f"| {i + 1} | {name} | {score:.3f} |" for i, (name, score) in enumerate(ranking)] + [""]
    for movement, rows in result["t_tests"].items():
        lines += [f"## Compensation t-tests: {movement.replace('_', ' ')}", "",
                  ("Repetitions as samples (pseudo-replicated; the paper's): each repetition counts as an independent "
                   "sample, so n is the number of repetitions and p comes out too small."), "",
                  t_tests_markdown([TTestResult(**r) for r in rows]), ""]
        person = result.get("person_t_tests", {}).get(movement)
        if person:
            lines += [("Person level: Welch t-test on the per-person means (n = persons), linear mixed model "
                       "(value ~ group, random intercept per person; effect = patients minus healthy) and Hedges' g "
                       "of the person means with a 95 % bootstrap interval over persons."), "",
                      person_tests_markdown([PersonTestResult(**r) for r in person]), ""]
    lines += ["## Beyond the paper: item score (0/1/2) per side, fused skeleton", ""]
    for movement, res in result["item_score"].items():
        best = max(res.values(), key=lambda r: r["accuracy"])
        lines.append(f"- {movement.replace('_', ' ')}: " + ", ".join(f"{k} {v['accuracy']:.1%}" for k, v in res.items())
                     + f" (classes {best['classes']}, chance {_chance(res):.1%})")
    return "\n".join(lines) + "\n"


def features_csv(samples: list[Sample]) -> str:
    """The feature table: one row per repetition and camera set-up."""
    head = ["subject", "group", "side", "movement", "setup", "camera", "item_score"] + list(FEATURE_NAMES)
    rows = [",".join(head)]
    for s in samples:
        rows.append(",".join([s.subject, s.group, s.side, s.movement, s.setup, s.camera, str(s.item_score)]
                             + [repr(float(v)) for v in s.features]))
    return "\n".join(rows) + "\n"


def _plots(result: dict[str, Any], out: Path) -> None:
    acc = result["patient_vs_healthy"]
    key = next((k for k in ("salute/raw/fused", "salute/raw/averaging") if k in acc), next(iter(acc), None))
    if key is not None:
        fig, axes = plt.subplots(1, 3, figsize=(13, 3.8))
        fig.subplots_adjust(wspace=0.45)
        for ax, (kind, res) in zip(axes, acc[key].items()):
            cm = np.array(res["confusion"])
            ax.imshow(cm, cmap="Blues")
            for (i, j), v in np.ndenumerate(cm):
                ax.text(j, i, str(v), ha="center", va="center")
            ax.set_title(f"{kind}: {res['accuracy']:.0%}")
            ax.set_xticks(range(len(res["classes"])), ["healthy", "patient"][: len(res["classes"])])
            ax.set_yticks(range(len(res["classes"])), ["healthy", "patient"][: len(res["classes"])])
            ax.set_xlabel("predicted")
            ax.set_ylabel("true")
        fig.suptitle(f"Confusion matrices, {key} (leave one subject out)")
        save_figure(fig, out / "confusion.png")
    ranking = result["ranking"].get("salute/forest_importance") or next(iter(result["ranking"].values()), None)
    if ranking:
        fig, ax = plt.subplots(figsize=(8, 4.5))
        names, scores = zip(*ranking)
        ax.barh(range(len(names))[::-1], scores)
        ax.set_yticks(range(len(names))[::-1], names, fontsize=8)
        ax.set_xlabel("importance")
        ax.set_title("Top features")
        save_figure(fig, out / "features.png")
    ex = result["_example"]
    if ex:
        fig, ax = plt.subplots(figsize=(9, 3.8))
        ax.plot(ex["times"], ex["height"], color="#1565c0", label="Height(Hand) [m]")
        for i, (a, b) in enumerate(ex["segments"]):
            ax.axvspan(a, b, color="#a5d6a7", alpha=0.5, label="segmented" if i == 0 else None)
        for i, (a, b) in enumerate(ex["truth"]):
            ax.axvline(a, color="black", ls="--", lw=0.8, label="true start / end" if i == 0 else None)
            ax.axvline(b, color="black", ls="--", lw=0.8)
        ax.set_xlabel("time [s]")
        ax.set_title(f"Subject {ex['subject']}, {ex['side']} hand lift: segmentation")
        ax.legend(fontsize=8)
        save_figure(fig, out / "segmentation.png")


def write_report(result: dict[str, Any], out_dir: Path, *, overwrite: bool = False) -> None:
    """``report.md``, ``results.json``, ``features.csv`` and PNGs, written atomically."""
    plain = {k: v for k, v in result.items() if not k.startswith("_")}
    with atomic_directory(out_dir, overwrite=overwrite) as tmp:
        (tmp / "results.json").write_text(json.dumps(plain, indent=1, default=float) + "\n", encoding="utf-8")
        (tmp / "report.md").write_text(report_markdown(result), encoding="utf-8")
        (tmp / "features.csv").write_text(features_csv(result["_samples"]), encoding="utf-8")
        _plots(result, tmp)
