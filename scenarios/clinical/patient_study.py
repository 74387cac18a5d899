"""The Fugl-Meyer analyses over several cohort seeds, with intervals (``mocap-bench patient-study``).

For every seed the cohort is generated anew (:func:`scenarios.clinical.cohort.generate_cohort`), analysed
as in the paper (:func:`scenarios.clinical.fma_study.analyse`) and beyond it
(:func:`scenarios.clinical.analyses.cohort_metrics`). Each metric is then summarised over the
seeds by its mean and a 95 % Student-t interval (:func:`fma.statistics.mean_interval`), and the
paper's orderings are measured as per-seed differences (:data:`ORDERINGS`), so an ordering holds
when its whole interval lies above zero.

The cohorts go to ``<datasets>/seed-<n>/`` (a cohort already there is reused); the report
directory holds ``report.md``, ``results.json`` (per-seed metrics, intervals, details),
``intervals.png`` and ``item_confusion.png``.

With parts of the patient model switched off (``[patients] ablate``) and the report of the same seeds
without them as a baseline, :func:`compare_with_baseline` gives each ordering's and each headline
metric's change, ablated minus baseline, as paired per-seed differences: the same subjects differ only
in the ablated part, so what the part drives shows as an interval away from zero.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from joblib import parallel_config

from fma.statistics import Interval, mean_interval
from fusion.errors import BadInputError
from fusion.io.atomic import atomic_directory
from scenarios.clinical.analyses import cohort_metrics, read_manifest
from scenarios.clinical.cohort import generate_cohort, plain
from scenarios.clinical.cohort_file import Cohort
from scenarios.clinical.fma_study import analyse
from scenarios.show import plt, save_figure
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
     "ranking/salute/forest_importance/chance_share",
     "affected-arm rise time and movement units; ipsilesional slowing and initiation pause"),
    ("speed and time features on top (hand lift)", "ranking/hand_lift/forest_importance/speed_time_share",
     "ranking/hand_lift/forest_importance/chance_share",
     "affected-arm rise time and movement units; ipsilesional slowing and initiation pause"),
    ("more trunk motion in patients (salute)", "trunk/salute/displacement_difference", None,
     "trunk_forward, trunk_lateral, trunk_rotation anchors (fma.md), scaled by severity"),
    ("more trunk motion in patients (hand lift)", "trunk/hand_lift/displacement_difference", None,
     "trunk_forward, trunk_lateral, trunk_rotation anchors (fma.md), scaled by severity"),
)
"""(claim, metric A, metric B or None for A > 0, model parameter behind it)."""

HEADLINE_METRICS: tuple[tuple[str, str], ...] = (
    ("paper's label, both movements, fused, accuracy", f"paper/both/raw/fused/{RF}/accuracy"),
    ("affected arm vs healthy, both, balanced accuracy", f"side/affected/both/{RF}/balanced_accuracy"),
    ("unaffected arm vs healthy, both, balanced accuracy", f"side/unaffected/both/{RF}/balanced_accuracy"),
    ("FMA-UE MAE, both movements [points]", "severity/both/mae"),
    ("salute item macro-F1", f"item/salute/{RF}/macro_f1"),
    ("hand lift item macro-F1", f"item/hand_lift/{RF}/macro_f1"),
)
"""(label, metric) compared with the baseline of an ablation besides the orderings."""


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
    ablated : tuple of str
        Parts of the patient model switched off (``[patients] ablate``), empty for the full model.
    baseline : dict
        Set by :func:`compare_with_baseline`: ``path`` of the baseline report, ``seeds`` compared and
        ``changes`` (claim or metric label -> Interval of ablated minus baseline); empty otherwise.
    """

    cohort: str
    seeds: tuple[int, ...]
    subjects: tuple[int, ...]
    per_seed: tuple[dict[str, float], ...]
    intervals: dict[str, Interval]
    orderings: dict[str, Interval]
    details: tuple[dict[str, Any], ...]
    ablated: tuple[str, ...] = ()
    baseline: dict[str, Any] = dataclasses.field(default_factory=dict)


def _ordering_value(metrics: dict[str, float], a: str, b: str | None) -> float:
    return metrics.get(a, np.nan) - (metrics.get(b, np.nan) if b else 0.0)


def summarise(cohort: str, seeds: Sequence[int], subjects: Sequence[int], per_seed: Sequence[dict[str, float]],
              details: Sequence[dict[str, Any]], ablated: Sequence[str] = ()) -> SeedStudyResult:
    """Intervals of every metric and of every ordering over the seeds (NaN / missing values left out)."""
    if not per_seed or len(per_seed) != len(seeds):
        raise BadInputError(f"need one metrics dict per seed, got {len(per_seed)} for {len(seeds)} seeds")
    names = sorted({k for m in per_seed for k in m})
    intervals = {k: mean_interval([m.get(k, np.nan) for m in per_seed]) for k in names}
    orderings = {}
    for claim, a, b, _ in ORDERINGS:
        orderings[claim] = mean_interval([_ordering_value(m, a, b) for m in per_seed])
    return SeedStudyResult(cohort, tuple(int(s) for s in seeds), tuple(int(n) for n in subjects),
                           tuple(per_seed), intervals, orderings, tuple(details), tuple(ablated))


def compare_with_baseline(result: SeedStudyResult, baseline_dir: str | Path) -> SeedStudyResult:
    """``result`` with its paired changes against the report in ``baseline_dir`` (its ``results.json``).

    Per seed present in both, each ordering's value and each :data:`HEADLINE_METRICS` value of
    ``result`` minus the baseline's; summarised by mean and 95 % t-interval over those seeds.

    Raises
    ------
    BadInputError
        No readable ``results.json`` in ``baseline_dir``, or fewer than two seeds in common.
    """
    path = Path(baseline_dir) / "results.json"
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
        base = {int(seed): metrics for seed, metrics in zip(doc["seeds"], doc["per_seed"], strict=True)}
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise BadInputError(f"{path}: not a patient-study results file ({exc}); give the report directory "
                            "of a patient-study run of the same cohort without the ablation") from None
    common = [i for i, seed in enumerate(result.seeds) if seed in base]
    if len(common) < 2:
        raise BadInputError(f"{path} shares {len(common)} seed(s) with this study ({list(result.seeds)} against "
                            f"{sorted(base)}); run both over the same seeds (at least two)")
    pairs = [(result.per_seed[i], base[result.seeds[i]]) for i in common]
    changes = {claim: mean_interval([_ordering_value(m, a, b) - _ordering_value(ref, a, b) for m, ref in pairs])
               for claim, a, b, _ in ORDERINGS}
    changes.update({label: mean_interval([m.get(key, np.nan) - ref.get(key, np.nan) for m, ref in pairs])
                    for label, key in HEADLINE_METRICS})
    info = {"path": str(baseline_dir), "seeds": [result.seeds[i] for i in common], "changes": changes}
    return dataclasses.replace(result, baseline=info)


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
    sweep : where each cohort's subjects run (:class:`scenarios.sweep.SweepOptions`); its worker count
        (one per core when None) also sets the processes of the analysis.
    analysis_seed : seed of camera picks, classifiers and regressors.
    progress : called with a short message after each step.
    """
    seeds = [int(s) for s in seeds]
    if len(seeds) < 2 or len(set(seeds)) != len(seeds) or min(seeds) < 0:
        raise BadInputError(f"seeds must be at least two distinct integers >= 0, got {seeds}")
    tell = progress or (lambda msg: None)
    root = Path(datasets)
    jobs = -1 if sweep.workers is None else max(sweep.workers, 1)  # analysis processes, like the sweep's
    per_seed, subjects, details = [], [], []
    for seed in seeds:
        c = dataclasses.replace(cohort, study=dataclasses.replace(cohort.study, seed=seed))
        data = root / f"seed-{seed}"
        if (data / "manifest.json").is_file():
            _check_reused(c, data)
        else:
            generate_cohort(c, data, sweep=sweep)
        tell(f"seed {seed}: cohort generated")
        result = analyse(data, seed=analysis_seed, jobs=jobs)
        with parallel_config(n_jobs=jobs):
            metrics, det = cohort_metrics(result, read_manifest(data), seed=analysis_seed)
        per_seed.append(metrics)
        subjects.append(result["subjects"])
        details.append(det)
        tell(f"seed {seed}: analysed")
    return summarise(cohort.study.name, seeds, subjects, per_seed, details,
                     ablated=[p.value for p in cohort.patients.ablate])


def _flat(value: Any, prefix: str = "") -> dict[str, Any]:
    if isinstance(value, dict):
        return {k: v for key, item in value.items() for k, v in _flat(item, f"{prefix}{key}.").items()}
    return {prefix.rstrip("."): value}


def _check_reused(cohort: Cohort, data: Path) -> None:
    """Refuse to reuse a cohort in ``data`` generated with another configuration than ``cohort``.

    A key the stored configuration lacks (written by an older version) is accepted when the
    requested value is that key's default.
    """
    wanted = _flat(json.loads(json.dumps(plain(cohort))))
    stored = _flat(read_manifest(data).get("cohort", {}))
    defaults = _flat(json.loads(json.dumps(plain(Cohort(study=cohort.study)))))
    differ = [k for k, v in wanted.items() if stored.get(k, defaults.get(k)) != v]
    if differ:
        raise BadInputError(f"{data} holds a cohort generated with other settings ({', '.join(differ[:4])} differ); "
                            "give another --datasets directory or remove that one")


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
    if result.ablated:
        lines += [f"Patient model parts switched off: {', '.join(result.ablated)}.", ""]
    if result.baseline:
        b = result.baseline
        lines += ["## Change against the full model (ablated minus baseline, paired by seed)", "",
                  (f"Baseline: `{b['path']}`, seeds {', '.join(map(str, b['seeds']))}. Orderings in their own "
                   "units (accuracy or feature share; trunk: metres); an interval away from zero shows what the "
                   "switched-off part drives."), "",
                  "| claim or metric | change [95 % interval] |", "| --- | --- |"]
        lines += [f"| {label} | {_fmt(iv, False)} |" for label, iv in b["changes"].items()] + [""]
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
           "details": list(result.details), "ablated": list(result.ablated),
           "baseline": {**result.baseline, "changes": {k: dataclasses.asdict(v) for k, v in
                                                       result.baseline.get("changes", {}).items()}}}
    with atomic_directory(out_dir, overwrite=overwrite) as tmp:
        (tmp / "results.json").write_text(json.dumps(doc, indent=1, default=float) + "\n", encoding="utf-8")
        (tmp / "report.md").write_text(report_markdown(result), encoding="utf-8")
        _plots(result, tmp)
