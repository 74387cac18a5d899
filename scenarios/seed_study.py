"""The Fugl-Meyer analyses over several cohort seeds, with intervals (``mocap-bench patient-study``).

For every seed the cohort is generated anew (:func:`scenarios.cohort.generate_cohort`), analysed
as in the paper (:func:`scenarios.fma_study.analyse`) and beyond it
(:func:`scenarios.patient_analyses.cohort_metrics`). Each metric is then summarised over the
seeds by its mean and a 95 % Student-t interval (:func:`fma.statistics.mean_interval`), and the
paper's orderings are measured as per-seed differences (:data:`ORDERINGS`), so an ordering holds
when its whole interval lies above zero.

The cohorts go to ``<datasets>/seed-<n>/`` (a cohort already there is reused); the report
directory holds ``report.md``, ``results.json`` (per-seed metrics, intervals, details),
``intervals.png`` and ``item_confusion.png``.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fma.statistics import Interval, mean_interval
from fusion.errors import BadInputError
from fusion.io.atomic import atomic_directory
from scenarios.cohort import Cohort, generate_cohort
from scenarios.fma_study import analyse
from scenarios.patient_analyses import cohort_metrics, read_manifest
from scenarios.plots import plt, save_figure
from scenarios.sweep import SweepOptions

RF = "random_forest"
ORDERINGS: tuple[tuple[str, str, str, str], ...] = (
    ("salute above hand lift", f"paper/salute/raw/fused/{RF}/accuracy", f"paper/hand_lift/raw/fused/{RF}/accuracy",
     "affected-arm peak elevation and synergy (hand lift scores 1 earlier), rise time of both movements"),
    ("two cameras above one", f"paper/both/raw/averaging/{RF}/accuracy", f"paper/both/raw/single/{RF}/accuracy",
     "none of the patient model: tracker noise and occlusion of one camera against two"),
    ("per-side above asymmetry", f"paper/both/raw/fused/{RF}/accuracy", f"paper/both/asymmetry/fused/{RF}/accuracy",
     "ipsilesional slowing (response-time ratio x severity): both sides slow makes the asymmetry smaller"),
    ("speed and time features on top (salute)", "ranking/salute/forest_importance/speed_time_share",
     "ranking/salute/forest_importance/chance_share", "rise time, movement units, initiation delay"),
    ("speed and time features on top (hand lift)", "ranking/hand_lift/forest_importance/speed_time_share",
     "ranking/hand_lift/forest_importance/chance_share", "rise time, movement units, initiation delay"),
    ("more trunk motion in patients (salute)", "trunk/salute/displacement_difference", None,
     "trunk_forward, trunk_lateral, trunk_rotation anchors (fma.md), scaled by severity"),
    ("more trunk motion in patients (hand lift)", "trunk/hand_lift/displacement_difference", None,
     "trunk_forward, trunk_lateral, trunk_rotation anchors (fma.md), scaled by severity"),
)
"""(claim, metric A, metric B or None for A > 0, model parameter behind it)."""


@dataclass(frozen=True)
class SeedStudyResult:
    """Per-seed metrics and their intervals.

    Attributes
    ----------
    cohort : str
        Cohort name.
    seeds : tuple of int
    subjects : tuple of int
        Usable subjects analysed per seed.
    per_seed : tuple of dict
        Metric name -> value, one dict per seed.
    intervals : dict
        Metric name -> :class:`fma.statistics.Interval` over the seeds.
    orderings : dict
        Claim -> Interval of metric A - metric B (or A) over the seeds.
    details : tuple of dict
        Per seed: summed item-score confusion matrices and severity predictions.
    """

    cohort: str
    seeds: tuple[int, ...]
    subjects: tuple[int, ...]
    per_seed: tuple[dict[str, float], ...]
    intervals: dict[str, Interval]
    orderings: dict[str, Interval]
    details: tuple[dict[str, Any], ...]


def summarise(cohort: str, seeds: Sequence[int], subjects: Sequence[int], per_seed: Sequence[dict[str, float]],
              details: Sequence[dict[str, Any]]) -> SeedStudyResult:
    """Intervals of every metric and of every ordering over the seeds (NaN / missing values left out)."""
    if not per_seed or len(per_seed) != len(seeds):
        raise BadInputError(f"need one metrics dict per seed, got {len(per_seed)} for {len(seeds)} seeds")
    names = sorted({k for m in per_seed for k in m})
    intervals = {k: mean_interval([m.get(k, np.nan) for m in per_seed]) for k in names}
    orderings = {}
    for claim, a, b, _ in ORDERINGS:
        diffs = [m.get(a, np.nan) - (m.get(b, np.nan) if b else 0.0) for m in per_seed]
        orderings[claim] = mean_interval(diffs)
    return SeedStudyResult(cohort, tuple(int(s) for s in seeds), tuple(int(n) for n in subjects),
                           tuple(per_seed), intervals, orderings, tuple(details))


def run_seed_study(cohort: Cohort, seeds: Sequence[int], datasets: str | Path, *,
                   sweep: SweepOptions = SweepOptions(progress=False),
                   analysis_seed: int = 0, progress: Callable[[str], None] | None = None) -> SeedStudyResult:
    """Generate (or reuse) and analyse ``cohort`` once per seed in ``datasets / "seed-<n>"``.

    Parameters
    ----------
    cohort : Cohort
        Its ``study.seed`` is replaced by each of ``seeds``.
    seeds : sequence of int
        At least two distinct seeds >= 0 (five or more for useful intervals).
    datasets : directory of the cohorts, created if needed.
    sweep : where each cohort's subjects run (:class:`scenarios.sweep.SweepOptions`).
    analysis_seed : seed of camera picks, classifiers and regressors.
    progress : called with a short message after each step.
    """
    seeds = [int(s) for s in seeds]
    if len(seeds) < 2 or len(set(seeds)) != len(seeds) or min(seeds) < 0:
        raise BadInputError(f"seeds must be at least two distinct integers >= 0, got {seeds}")
    tell = progress or (lambda msg: None)
    root = Path(datasets)
    per_seed, subjects, details = [], [], []
    for seed in seeds:
        c = dataclasses.replace(cohort, study=dataclasses.replace(cohort.study, seed=seed))
        data = root / f"seed-{seed}"
        if not (data / "manifest.json").is_file():
            generate_cohort(c, data, sweep=sweep)
        tell(f"seed {seed}: cohort generated")
        result = analyse(data, seed=analysis_seed)
        metrics, det = cohort_metrics(result, read_manifest(data), seed=analysis_seed)
        per_seed.append(metrics)
        subjects.append(result["subjects"])
        details.append(det)
        tell(f"seed {seed}: analysed")
    return summarise(cohort.study.name, seeds, subjects, per_seed, details)


def _fmt(iv: Interval, percent: bool) -> str:
    if iv.n == 0:
        return "n/a"
    if percent:
        return f"{iv.mean:.1%} [{iv.low:.1%}, {iv.high:.1%}]"
    return f"{iv.mean:.3g} [{iv.low:.3g}, {iv.high:.3g}]"


def _table(result: SeedStudyResult, rows: list[tuple[str, str]], percent: bool = True) -> list[str]:
    lines = ["| quantity | mean [95 % interval] |", "| --- | --- |"]
    for label, key in rows:
        if key in result.intervals:
            lines.append(f"| {label} | {_fmt(result.intervals[key], percent)} |")
    return lines + [""]


def report_markdown(result: SeedStudyResult) -> str:
    """Orderings, paper label, per-side labels, severity and item scores, each with intervals."""
    n = len(result.seeds)
    lines = [f"# Fugl-Meyer analyses over {n} cohort seeds: {result.cohort}", "",
             f"Seeds {', '.join(map(str, result.seeds))}; usable subjects per seed: "
             f"{', '.join(map(str, result.subjects))}. Every number: mean over the seeds and a 95 % "
             "Student-t interval; leave-one-subject-out throughout; fused skeleton unless a set-up is named.", "",
             "## The paper's orderings, measured", "",
             "| claim | difference (A - B) [95 % interval] | holds | model parameter behind it |",
             "| --- | --- | --- | --- |"]
    for claim, _, _, driver in ORDERINGS:
        iv = result.orderings[claim]
        verdict = "n/a" if iv.n == 0 else "yes" if iv.low > 0 else "no" if iv.high < 0 else "not resolved"
        lines.append(f"| {claim} | {_fmt(iv, False)} | {verdict} | {driver} |")
    lines += [""]
    for title, label_key in (("Paper's label (subject group, both sides), random forest", "paper"),):
        lines += [f"## {title}", ""]
        rows = []
        for mv in ("salute", "hand_lift", "both"):
            for variant, setup in (("raw", "fused"), ("raw", "averaging"), ("raw", "single"), ("asymmetry", "fused")):
                for metric in ("accuracy", "balanced_accuracy"):
                    rows.append((f"{mv} {variant} {setup} {metric}", f"{label_key}/{mv}/{variant}/{setup}/{RF}/{metric}"))
        lines += _table(result, rows)
    lines += ["## Per-side labels, random forest", ""]
    lines += _table(result, [(f"{which} arm vs healthy, {mv}, {metric}", f"side/{which}/{mv}/{RF}/{metric}")
                             for which in ("affected", "unaffected") for mv in ("salute", "hand_lift", "both")
                             for metric in ("accuracy", "balanced_accuracy")])
    lines += ["## Severity regression (FMA-UE points, patients' affected arm)", ""]
    lines += _table(result, [(f"{mv} {m}", f"severity/{mv}/{m}") for mv in ("salute", "hand_lift", "both")
                             for m in ("mae", "baseline_mae", "correlation")], percent=False)
    lines += ["## Item scores (0/1/2 per side), random forest", ""]
    lines += _table(result, [(f"{mv} {m}", f"item/{mv}/{RF}/{m}") for mv in ("salute", "hand_lift")
                             for m in ("accuracy", "balanced_accuracy", "macro_f1", "recall_0", "recall_1", "recall_2")])
    confusion = _summed_confusion(result)
    for key, cm in confusion.items():
        lines += [f"Confusion matrix summed over the seeds, {key} (rows true 0/1/2, columns predicted):", "",
                  "| true \\ predicted | 0 | 1 | 2 |", "| --- | --- | --- | --- |"]
        lines += [f"| {i} | " + " | ".join(str(v) for v in row) + " |" for i, row in enumerate(cm.tolist())] + [""]
    return "\n".join(lines) + "\n"


def _summed_confusion(result: SeedStudyResult) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for det in result.details:
        for key, cm in det.get("item_confusion", {}).items():
            if key.endswith(RF):
                out[key] = out.get(key, np.zeros((3, 3), dtype=int)) + np.asarray(cm, dtype=int)
    return out


def _plots(result: SeedStudyResult, out: Path) -> None:
    keys = [(claim, result.orderings[claim]) for claim, *_ in ORDERINGS if result.orderings[claim].n]
    if keys:
        fig, ax = plt.subplots(figsize=(8, 0.5 * len(keys) + 1.5))
        for i, (claim, iv) in enumerate(keys):
            ax.errorbar(iv.mean, i, xerr=[[iv.mean - iv.low], [iv.high - iv.mean]], fmt="o", capsize=4,
                        color="#2e7d32" if iv.low > 0 else "#c62828" if iv.high < 0 else "#616161")
        ax.axvline(0.0, color="black", lw=0.8)
        ax.set_yticks(range(len(keys)), [k for k, _ in keys], fontsize=8)
        ax.invert_yaxis()
        ax.set_xlabel("difference A - B (accuracy or feature share; trunk: metres), 95 % interval")
        ax.set_title(f"The paper's orderings over {len(result.seeds)} cohort seeds")
        save_figure(fig, out / "intervals.png")
    confusion = _summed_confusion(result)
    if confusion:
        fig, axes = plt.subplots(1, len(confusion), figsize=(4.2 * len(confusion), 3.8))
        for ax, (key, cm) in zip(np.atleast_1d(axes), confusion.items()):
            ax.imshow(cm, cmap="Blues")
            for (i, j), v in np.ndenumerate(cm):
                ax.text(j, i, str(v), ha="center", va="center")
            ax.set_xticks(range(3), ["0", "1", "2"])
            ax.set_yticks(range(3), ["0", "1", "2"])
            ax.set_xlabel("predicted item score")
            ax.set_ylabel("true item score")
            ax.set_title(key.replace("_", " "))
        fig.suptitle("Item scores, summed over the seeds (leave one subject out)")
        save_figure(fig, out / "item_confusion.png")


def write_report(result: SeedStudyResult, out_dir: str | Path, *, overwrite: bool = False) -> None:
    """``report.md``, ``results.json``, ``intervals.png`` and ``item_confusion.png``, written atomically."""
    doc = {"cohort": result.cohort, "seeds": list(result.seeds), "subjects": list(result.subjects),
           "per_seed": list(result.per_seed),
           "intervals": {k: dataclasses.asdict(v) for k, v in result.intervals.items()},
           "orderings": {k: dataclasses.asdict(v) for k, v in result.orderings.items()},
           "details": list(result.details)}
    with atomic_directory(out_dir, overwrite=overwrite) as tmp:
        (tmp / "results.json").write_text(json.dumps(doc, indent=1, default=float) + "\n", encoding="utf-8")
        (tmp / "report.md").write_text(report_markdown(result), encoding="utf-8")
        _plots(result, tmp)
