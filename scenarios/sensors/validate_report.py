"""The report of a leave-one-person-out validation: ``report.md``, ``results.json``, ``validate.png`` and
``ranks.png``."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from fusion.io.atomic import write_text_atomic
from scenarios.sensors.fit_report import json_safe
from scenarios.sensors.sim_to_real import BAND, POINTS_TOLERANCE, RATIO_TOLERANCE
from scenarios.sensors.validate_population import Fold, calibration_counts, pass_counts
from sim.sensor_population import Family


def _share(n: tuple[int, int]) -> str:
    return f"{n[0]}/{n[1]} ({100 * n[0] / n[1]:.0f} %)" if n[1] else "-"


def _statistics(folds: Sequence[Fold]) -> list[str]:
    return [r.statistic for r in folds[0].sessions[0].population]


def validation_markdown(folds: Sequence[Fold], draws: int, command: str) -> str:
    """The report: pass counts per left-out person with and without the population, the populations
    fitted, and every verdict."""
    pop, typ = pass_counts(folds, "population"), pass_counts(folds, "typical")
    lines = ["# Leave-one-person-out validation of a sensor population", "",
             f"Command: `{command}`", "",
             f"Each person's sessions are judged by a profile fitted on the other people only: {draws} "
             f"simulated sessions of each replica, each a person and session drawn from the fitted population; "
             f"a statistic passes inside the {BAND[0]:g}-{BAND[1]:g} % band of the draws or within "
             f"+-{100 * RATIO_TOLERANCE:.0f} % of their median (confidence share: {100 * POINTS_TOLERANCE:.0f} "
             "points). *Typical only*: the same with the typical tracker (no population; the band is the "
             "simulation's seed noise).", "",
             "| left-out person | sessions | population: passing | typical only: passing |", "|---|---|---|---|"]
    for f in folds:
        lines.append(f"| {f.person} | {len(f.sessions)} | {_share(pop[f.person])} | {_share(typ[f.person])} |")
    lines += [f"| **all** | {sum(len(f.sessions) for f in folds)} | **{_share(pop['all'])}** | {_share(typ['all'])} |",
              "", "## Per statistic (population)", "",
              "| statistic | " + " | ".join(f.person for f in folds) + " |", "|---|" + "---|" * len(folds)]
    for k, name in enumerate(_statistics(folds)):
        cells = []
        for f in folds:
            rows = [s.population[k] for s in f.sessions if s.population[k].passed is not None]
            cells.append(_share((sum(r.passed for r in rows), len(rows))))
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines += ["", "## Is the population calibrated? (the real session's rank among the draws)", "",
              "A population that predicted the left-out people exactly would make the real session one more "
              "draw: each of its ranks among the draws equally likely, the real value below every draw (or above "
              f"every one) in 1/{draws + 1} of the rows, and it would pass only as often as the draws pass "
              "when each is judged against the others (*calibrated: passing*; with one draw fewer, 1-3 points "
              "low). Below every draw and above every one far more often than expected: the population is too "
              "narrow or off-centre for that statistic; passing far below the calibrated rate: the same; near "
              "it: the verdict's own limit for a statistic that spread.", "",
              "| statistic | rows | passing | calibrated: passing | below every draw | above every draw | expected each |",
              "|---|---|---|---|---|---|---|"]
    for name, c in calibration_counts(folds, "population").items():
        lines.append(f"| {name} | {c.rows} | {c.passing} | {c.expected_passing:.1f} | {c.below_all} | "
                     f"{c.above_all} | {c.expected_tail:.1f} |")
    lines += ["", "## Populations fitted (log units; confidence on the arcsine-square-root scale, rad)", "",
              "| without | reference speed [m/s] | view bias limb correlation | hidden offset share | bone alignment: view / noise | camera scale sd / shared bone lengths | trunk turn sd [deg] | mean ("
              + ", ".join(fam.value for fam in Family) + ") | "
              + " | ".join(f"{fam.value}: new person scale (df) / session sd" for fam in Family) + " |",
              "|---|---|---|---|---|---|---|---|" + "---|" * len(Family)]
    for f in folds:
        cells = []
        for fam in Family:
            s = f.profile.population.spreads.get(fam) if f.profile.population else None
            cells.append("-" if s is None else f"{s.person_sd:.2f} ({s.person_df:g}) / {s.session_sd:.2f}")
        means = ", ".join("-" if f.profile.population is None or fam not in f.profile.population.spreads else
                          f"{f.profile.population.spreads[fam].mean:+.2f}" for fam in Family)
        tr = f.profile.tracker
        lines.append(f"| {f.person} | {tr.speed_ref_m_s:g} | {tr.view_limb_correlation:.2f} | {tr.hidden_offset_share:.2f} | "
                     f"{tr.view_bone_alignment:+.2f} / {tr.noise_bone_alignment:+.2f} | "
                     f"{tr.camera_scale_sd:.3f} / {tr.shared_bone_lengths:.2f} | {tr.trunk_turn_sd_deg:.2f} | {means} | " + " | ".join(cells) + " |")
    labs = [(f.person, lab, pop) for f in folds if f.profile.population for lab, pop in f.profile.population.labs.items()]
    if labs:
        lines += ["", "Each fold's labs (a left-out person of a lab the fold knows is drawn from it): mean, new person "
                  "scale (df) per family:", "", "| without | lab | " + " | ".join(fam.value for fam in Family) + " |",
                  "|---|---|" + "---|" * len(Family)]
        lines += [f"| {who} | {lab} | " + " | ".join(pop.spread(fam).text(2) if fam in pop.spreads else "-"
                                                   for fam in Family) + " |" for who, lab, pop in labs]
    lines += ["", "## Every verdict", "", "| session | statistic | real | median | band | verdict | typical only |",
              "|---|---|---|---|---|---|---|"]
    for f in folds:
        for s in f.sessions:
            for r, t in zip(s.population, s.typical):
                lines.append(f"| {s.session} | {r.statistic} | {r.real:.3g} | {r.median:.3g} | "
                             f"{r.low:.3g}-{r.high:.3g} | {r.verdict} | {t.verdict} |")
    return "\n".join(lines) + "\n"


def validation_json(folds: Sequence[Fold], draws: int) -> dict:
    """Machine-readable results: counts, populations and every row."""
    def rows(rs):
        return [{"statistic": r.statistic, "real": r.real, "median": r.median, "low": r.low, "high": r.high,
                 "verdict": r.verdict, "passed": r.passed, "below": r.below, "n_draws": r.n_draws,
                 "draws_passing": r.draws_passing} for r in rs]
    return {"draws": draws, "band_percentiles": list(BAND),
            "passing": {"population": pass_counts(folds, "population"), "typical": pass_counts(folds, "typical")},
            "calibration": {which: {name: vars(c) for name, c in calibration_counts(folds, which).items()}
                            for which in ("population", "typical")},
            "folds": [{"left_out": f.person, "speed_ref_m_s": f.profile.tracker.speed_ref_m_s,
                       "view_limb_correlation": f.profile.tracker.view_limb_correlation,
                       "hidden_offset_share": f.profile.tracker.hidden_offset_share,
                       "view_bone_alignment": f.profile.tracker.view_bone_alignment,
                       "noise_bone_alignment": f.profile.tracker.noise_bone_alignment,
                       "camera_scale_sd": f.profile.tracker.camera_scale_sd,
                       "shared_bone_lengths": f.profile.tracker.shared_bone_lengths,
                       "trunk_turn_sd_deg": f.profile.tracker.trunk_turn_sd_deg,
                       "population": {fam.value: vars(s) for fam, s in f.profile.population.spreads.items()}
                       if f.profile.population else None,
                       "labs": {lab: {fam.value: vars(s) for fam, s in pop.spreads.items()}
                                for lab, pop in f.profile.population.labs.items()} if f.profile.population else {},
                       "sessions": [{"session": s.session, "population": rows(s.population), "typical": rows(s.typical)}
                                    for s in f.sessions]} for f in folds]}


def _plot(folds: Sequence[Fold], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = _statistics(folds)
    fig, axes = plt.subplots(1, len(folds), figsize=(4 * len(folds), 4.2), sharey=True, squeeze=False)
    for ax, f in zip(axes[0], folds):
        for k in range(len(names)):
            for s in f.sessions:
                r = s.population[k]
                if r.passed is None or not r.median:
                    continue
                lo, hi, real = (1 + v - r.median if r.by_points else v / r.median for v in (r.low, r.high, r.real))
                ax.plot([k, k], [lo, hi], color="0.75", lw=4, solid_capstyle="butt", zorder=1)
                ax.plot(k, real, "o", ms=4, color="tab:green" if r.passed else "tab:red", zorder=2)
        ax.set_xticks(range(len(names)), [n.split(" [")[0] for n in names], rotation=60, ha="right", fontsize=7)
        ax.set_title(f"left out: {f.person}", fontsize=9)
        ax.axhline(1.0, color="0.5", lw=0.5)
    axes[0][0].set_ylabel("value / median of draws (shares: 1 + value - median)")
    fig.suptitle("Left-out sessions against the population's band (grey), pass green, miss red", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _rank_plot(folds: Sequence[Fold], draws: int, path: Path) -> None:
    """Per statistic, the histogram of the real sessions' ranks among the population's draws."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = _statistics(folds)
    fig, axes = plt.subplots(2, (len(names) + 1) // 2, figsize=(2.6 * ((len(names) + 1) // 2), 5.2), squeeze=False)
    for ax, (k, name) in zip(axes.flat, enumerate(names)):
        ranks = [s.population[k].below for f in folds for s in f.sessions
                 if s.population[k].passed is not None and s.population[k].n_draws == draws]
        counts = np.bincount(np.floor(np.asarray(ranks, dtype=float)).astype(int), minlength=draws + 1)[:draws + 1]
        ax.bar(range(draws + 1), counts, color="tab:blue", width=0.8)
        ax.axhline(len(ranks) / (draws + 1), color="0.3", lw=1, ls="--")
        ax.set_title(name.split(" [")[0], fontsize=8)
        ax.set_xticks(range(draws + 1))
        ax.tick_params(labelsize=7)
    for ax in axes.flat[len(names):]:
        ax.set_visible(False)
    fig.supxlabel(f"draws below the real session (of {draws})", fontsize=8)
    fig.suptitle("Rank of each left-out session among the population's draws; dashed: a calibrated population",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_validation(folds: Sequence[Fold], out: Path, draws: int, command: str) -> list[Path]:
    """Write ``report.md``, ``results.json``, ``validate.png`` and ``ranks.png`` into ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    report, results, plot, ranks = out / "report.md", out / "results.json", out / "validate.png", out / "ranks.png"
    write_text_atomic(report, validation_markdown(folds, draws, command))
    write_text_atomic(results, json.dumps(json_safe(validation_json(folds, draws)), indent=1) + "\n")
    _plot(folds, plot)
    _rank_plot(folds, draws, ranks)
    return [report, results, plot, ranks]
