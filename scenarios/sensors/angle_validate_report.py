"""The report of ``mocap-bench angle-validate``: ``report.md``, ``results.json`` and ``traces.png``."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from fusion.io.atomic import write_text_atomic
from scenarios.sensors.angle_clocks import RATE_RATIOS, ClockRatios
from scenarios.sensors.angle_validate import (
    STATISTICS,
    EpisodeResult,
    summarise,
)
from scenarios.sensors.fit_report import json_safe
from sim.tracker_arm_bias import ARM_JOINTS

MOVEMENT_NAMES = {"m07": "shoulder abduction", "m08": "shoulder extension",
                  "m09": "shoulder internal-external rotation", "m10": "shoulder scaption"}

_LABELS = {"peak_elevation_error_deg": "peak elevation error", "elbow_flexion_error_deg": "elbow flexion at peak, error",
           "plane_of_elevation_error_deg": "plane of elevation at peak, error",
           "elevation_trace_rmse_deg": "elevation trace RMSE",
           "peak_elevation_thorax_part_deg": "peak elevation error: the thorax axis's part"}

JUDGED = ("peak_elevation_error_deg", "elbow_flexion_error_deg", "elevation_trace_rmse_deg")
"""The statistics the agreement count is over (the plane of elevation is reported, not judged)."""


def agreement(summary: dict) -> tuple[int, int]:
    """(rows agreeing, rows judged) over the movements and :data:`JUDGED` statistics."""
    rows = [summary["movements"][m][s]["agrees"] for m in summary["movements"] for s in JUDGED]
    rows = [r for r in rows if r is not None]
    return sum(rows), len(rows)


def expected_agreement(summary: dict) -> float:
    """Rows a simulation with exactly the right mean errors would agree in on as many new people, on
    average: the sum of the judged rows' ``agree_chance`` (NaN when any is unknown)."""
    return float(sum(summary["movements"][m][s]["agree_chance"] for m in summary["movements"] for s in JUDGED
                     if summary["movements"][m][s]["agrees"] is not None))


def _cell(mean: float, sd: float, n: int) -> str:
    return f"{mean:+.1f} ({sd:.1f}, n={n})" if n else "-"


def _chance(row: dict, statistic: str) -> str:
    if statistic not in JUDGED or not np.isfinite(row["agree_chance"]):
        return "-"
    return f"{100 * row['agree_chance']:.0f} %"


def _interval(bounds: Sequence[float]) -> str:
    return f"[{bounds[0]:+.1f}, {bounds[1]:+.1f}]" if np.all(np.isfinite(bounds)) else "-"


def report_markdown(results: Sequence[EpisodeResult], summary: dict, command: str, profile: str,
                    clock_ratios: ClockRatios) -> str:
    """The report: per movement a table of real and simulated errors, and the episodes left out."""
    k, n = agreement(summary)
    subjects = sorted({r.episode.subject for r in results})
    lines = ["# Clinical angles against an optical reference: the real Kinect and its simulation", "",
             f"Command: `{command}`", "",
             f"Subjects {', '.join(subjects)}; {len(results)} episodes; sensor profile `{profile}`. Errors are "
             "signed, camera minus truth, in degrees: the real Kinect against the joint centres from the "
             "Plug-in-Gait markers, the simulated Kinect against the humanoid the optical episode was "
             "retargeted onto (mean, sd over episodes; the simulated values pool every seed). A row agrees when "
             "the simulated mean is within max(3 deg, 30 %) of the real one (RMSE: within +-30 %). The brackets "
             "are 95 % t-intervals of the mean over people (each person's mean; real: one per subject, simulated: "
             "one per subject and seed): how far the mean may move with other people, real or simulated.", "",
             f"**Agreeing rows: {k}/{n}** (peak elevation, elbow flexion and trace RMSE of each movement; the "
             "plane of elevation and the thorax axis's part of the peak elevation error, the Kinect's elevation "
             "at its peak minus its elevation with its pelvis and spine joints moved onto the truth's, are shown, "
             "not judged).", "",
             f"*A correct simulation agrees* (last column): the chance that a simulation whose mean errors were "
             f"exactly right would agree on {len(subjects)} new people, given how much the difference real - "
             "simulated of each person's mean varies between these people (Student-t, people - 1 degrees of "
             f"freedom). Summed over the judged rows: **{expected_agreement(summary):.1f} of {n}**, what "
             "these people's spread allows on average (NaN under three subjects: too few to go by).", "",
             "Clock ratio (optical / Kinect) per subject and movement, the median best over its first episodes "
             "(borrowed: the movement's arm hardly rises, so it takes the median of the subject's other movements; "
             f"at the search's end: the ratio may lie beyond the candidates {RATE_RATIOS[0]:g}-{RATE_RATIOS[-1]:g}):",
             "", *(f"- {line}" for line in clock_ratios.text().splitlines()), ""]
    for m, table in summary["movements"].items():
        lines += [f"## {m}: {MOVEMENT_NAMES.get(m, m)}", "",
                  "| statistic | real mean (sd, n) | real, over people | simulated mean (sd, n) | simulated, over people "
                  "| agrees | a correct simulation agrees |", "|---|---|---|---|---|---|---|"]
        for stat in STATISTICS:
            v = table[stat]
            verdict = "-" if v["agrees"] is None else ("yes" if v["agrees"] else "**no**")
            lines.append(f"| {_LABELS[stat]} | {_cell(v['real_mean'], v['real_sd'], v['real_n'])} | "
                         f"{_interval(v['real_interval'])} | {_cell(v['sim_mean'], v['sim_sd'], v['sim_n'])} | "
                         f"{_interval(v['sim_interval'])} | {verdict} | {_chance(v, stat)} |")
        lines.append("")
    lines += ["## How much the arm joints' errors move", "",
              "RMS frame-to-frame change of the error (camera minus truth) of the moving arm's joints, median over "
              "the episodes [mm]: the tracker's noise as the truth sees it (a steady offset does not count).", "",
              "| movement | " + " | ".join(f"{j}: real / simulated" for j in ARM_JOINTS)
              + " |", "|---|" + "---|" * 3]
    for m, table in summary["movements"].items():
        change = table["arm_change_mm"]
        lines.append(f"| {m} | " + " | ".join(f"{r:.1f} / {s:.1f}" for r, s in zip(change["real"], change["sim"])) + " |")
    lines.append("")
    problems = [r for r in results if r.problem]
    if problems:
        lines += ["## Episodes with a side missing", ""] + [f"- {r.episode.name}: {r.problem}" for r in problems] + [""]
    lines += ["`traces.png`: the moving arm's elevation of one typical episode per movement (median real trace RMSE), real Kinect and reference "
              "above, simulated Kinect and the humanoid's truth below.", ""]
    return "\n".join(lines)


def plot_traces(results: Sequence[EpisodeResult], path: Path) -> Path | None:
    """One column per movement (its episode with both sides and the median real trace RMSE): the elevation traces, real above,
    simulated below. None when no episode has both."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    chosen = {}
    for m in sorted({r.episode.movement for r in results}):
        both = [r for r in results if r.episode.movement == m and r.sims and r.real.errors is not None]
        if both:  # the episode whose real trace RMSE is the median: a typical one, not the first
            both.sort(key=lambda r: (not np.isfinite(r.real.value("elevation_trace_rmse_deg")),
                                     r.real.value("elevation_trace_rmse_deg")))
            finite = [r for r in both if np.isfinite(r.real.value("elevation_trace_rmse_deg"))] or both
            chosen[m] = finite[len(finite) // 2]
    if not chosen:
        return None
    fig, axes = plt.subplots(2, len(chosen), figsize=(3.6 * len(chosen), 5.2), squeeze=False, sharey=True)
    for col, (m, r) in enumerate(sorted(chosen.items())):
        for row, (side, who) in enumerate(((r.real, "real Kinect"), (r.sims[0], "simulated Kinect"))):
            ax = axes[row, col]
            t = side.times - side.times[0]
            ax.plot(t, side.truth_elevation_deg, color="black", lw=1.5,
                    label="optical reference" if row == 0 else "humanoid truth")
            ax.plot(t, side.elevation_deg, color="tab:red" if row == 0 else "tab:blue", lw=1.2, label=who)
            ax.set_title(f"{r.episode.name} ({r.real.alignment.side} arm)" if row == 0 else "", fontsize=9)
            ax.set_xlabel("time [s]" if row == 1 else "")
            ax.grid(alpha=0.3)
            if col == 0:
                ax.set_ylabel("humerothoracic elevation [deg]")
            ax.legend(fontsize=7, loc="lower center")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def write_report(results: Sequence[EpisodeResult], out: Path, command: str, profile: str,
                 clock_ratios: ClockRatios, left_out: dict[str, str] | None = None) -> list[Path]:
    """Write ``report.md``, ``results.json`` (:func:`~scenarios.sensors.angle_validate.summarise`) and
    ``traces.png`` into ``out``; ``left_out``: episodes whose files could not be read (name -> why),
    listed in both. Returns the paths written."""
    out.mkdir(parents=True, exist_ok=True)
    summary = summarise(results)
    k, n = agreement(summary)
    doc = {"command": command, "profile": profile, "clock_ratios": clock_ratios.as_dict(), "agreeing_rows": k, "judged_rows": n,
           "expected_agreeing_rows": expected_agreement(summary), **summary, "left_out": left_out or {}}
    paths = [out / "results.json", out / "report.md"]
    lines = [f"- {name}: {why}" for name, why in (left_out or {}).items()]
    unread = ["", "## Episodes left out: their files could not be read", "", *lines] if lines else []
    write_text_atomic(paths[0], json.dumps(json_safe(doc), indent=1, allow_nan=False) + "\n")
    write_text_atomic(paths[1], report_markdown(results, summary, command, profile, clock_ratios).rstrip("\n")
                      + "\n".join(["", *unread]) + "\n")
    png = plot_traces(results, out / "traces.png")
    return paths + ([png] if png is not None else [])
