"""Reports of a sensor fit and of a sim-to-real comparison: Markdown tables and PNG plots."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from fusion.io.atomic import write_text_atomic
from fusion.merge.block_bootstrap import Interval
from fusion.merge.sensor_stats import BONES, STAT_GROUPS, SensorStats
from scenarios.sensors.fit import FitResult
from scenarios.sensors.fit_population import PopulationFit
from scenarios.sensors.fit_replica import ReplicaFit
from scenarios.sensors.population_report import population_lines
from scenarios.sensors.replica_case import ReplicaCase
from scenarios.sensors.sim_to_real import (
    BAND,
    POINTS_TOLERANCE,
    RATIO_TOLERANCE,
    BandRow,
    Row,
    SimToReal,
    SimToRealBand,
    compare_stats,
)
from scenarios.show import plt, save_figure
from sim.tracker_noise import TrackerNoise

_SPECTRUM_GROUPS = ("head", "spine", "wrist")


def _iv(iv: Interval | None, scale: float = 1.0, digits: int = 1) -> str:
    if iv is None or not np.isfinite(iv.value):
        return "-"
    return f"{iv.value * scale:.{digits}f} [{iv.low * scale:.{digits}f}, {iv.high * scale:.{digits}f}]"


def _num(value: float, scale: float = 1.0, digits: int = 1) -> str:
    """``value * scale`` with ``digits`` decimals, or '-' where it is not measured (NaN)."""
    return f"{value * scale:.{digits}f}" if np.isfinite(value) else "-"


def stats_table(stats: Mapping[str, SensorStats]) -> str:
    """Markdown table: one column per recording, each statistic with its 95 % bootstrap interval."""
    names = list(stats)
    lines = ["| statistic | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]

    def row(label: str, cells: Sequence[str]) -> None:
        lines.append(f"| {label} | " + " | ".join(cells) + " |")

    S = [stats[n] for n in names]
    for g in STAT_GROUPS:
        row(f"{g} jitter [mm]", [_iv(s.jitter_mm.get(g)) for s in S])
    for g in _SPECTRUM_GROUPS:
        row(f"{g} jitter lag-1 autocorrelation", [f"{s.jitter_acf[g][1]:.2f}" for s in S])
    for g in STAT_GROUPS:
        row(f"{g} spikes over 5 cm [%]", [_iv(s.spikes.get(g), 100, 2) for s in S])
    for g in STAT_GROUPS:
        row(f"{g} spike length, median [mm]", [_iv(s.spike_mm.get(g)) for s in S])
    for b in BONES:
        row(f"{b} length std [mm]", [_iv(s.bone_std_mm[b]) for s in S])
    for b in BONES:
        row(f"{b} length jitter [mm]", [_iv(s.bone_jitter_mm.get(b)) for s in S])
    row("elbows' and wrists' steps along their bones [%]",
        [_num(s.bone_step_share, 100, 0) for s in S])
    for g in (*STAT_GROUPS, "all"):
        row(f"{g} at confidence 2 [%]", [_iv(s.confidence2.get(g), 100) for s in S])
    for g in (*STAT_GROUPS, "all"):
        row(f"{g} cross-camera residual [mm]", [_iv(s.residual_mm.get(g)) for s in S])
    row("steady / fluctuating residual, all groups [mm]",
        [f"{np.nanmedian(list(s.residual_static_mm.values())):.1f} / {np.nanmedian(list(s.residual_fluct_mm.values())):.1f}"
         if s.residual_static_mm else "-" for s in S])
    row("share beyond 5 cm [%]", [_iv(s.beyond_5cm, 100) for s in S])
    row("limb cosine of the steady residuals", [_num(s.residual_limb_cosine, digits=2) for s in S])
    row("elbows' and wrists' steady residual along their bones [%]",
        [_num(s.residual_bone_share, 100, 0) for s in S])
    row("other cameras' size against the reference / spread over the bones [%]",
        [f"{_num(s.camera_scale, 100)} / {_num(s.bone_ratio_spread, 100)}" if np.isfinite(s.camera_scale) else "-"
         for s in S])
    row("trunk's turn against the whole body [deg]",
        [_num(float(np.linalg.norm(s.trunk_turn_deg[0])), digits=2) if len(s.trunk_turn_deg) else "-" for s in S])
    row("elbows and wrists beyond 8 cm, Tracked in both [%]",
        [_num(s.residual_tail, 100) for s in S])
    row("dropped frames [%]", [f"{100 * s.dropped_frames:.2f}" for s in S])
    row("frames", [str(s.n_frames) for s in S])
    return "\n".join(lines) + "\n"


def _plot_stats(stats: Mapping[str, SensorStats], path: Path, title: str) -> None:
    """Four panels: jitter autocorrelation, residual CDFs, bone-length spread, confidence shares."""
    fig, ax = plt.subplots(2, 2, figsize=(12, 8))
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, (name, s) in enumerate(stats.items()):
        c = colours[k % len(colours)]
        for m, g in enumerate(_SPECTRUM_GROUPS):
            acf = s.jitter_acf[g]
            freqs = np.linspace(0, s.frame_rate_hz / 2, 64)
            lags = np.arange(acf.size)
            psd = acf[0] + 2 * np.sum(acf[1:, None] * np.cos(2 * np.pi * np.outer(lags[1:], freqs) / s.frame_rate_hz), 0)
            ax[0, 0].plot(freqs, np.maximum(psd, 1e-3) * s.jitter_mm[g].value ** 2, color=c,
                          ls=("-", "--", ":")[m], label=f"{name} {g}")
        for m, g in enumerate(("spine", "elbow", "wrist")):
            v = np.sort(s.residual_samples_mm[s.residual_groups == g])
            if v.size:
                ax[0, 1].plot(v, np.arange(1, v.size + 1) / v.size, color=c, ls=("-", "--", ":")[m], label=f"{name} {g}")
        bones = list(BONES)
        x = np.arange(len(bones)) + 0.8 * k / max(1, len(stats))
        ax[1, 0].bar(x, [s.bone_std_mm[b].value for b in bones], width=0.8 / max(1, len(stats)), color=c, label=name,
                     yerr=[[max(0.0, s.bone_std_mm[b].value - s.bone_std_mm[b].low) for b in bones],
                           [max(0.0, s.bone_std_mm[b].high - s.bone_std_mm[b].value) for b in bones]])
        groups = [*STAT_GROUPS, "all"]
        x = np.arange(len(groups)) + 0.8 * k / max(1, len(stats))
        ax[1, 1].bar(x, [100 * s.confidence2[g].value if g in s.confidence2 else np.nan for g in groups], width=0.8 / max(1, len(stats)), color=c,
                     label=name)
    ax[0, 0].set(title="second-difference spectrum (from its autocorrelation)", xlabel="frequency [Hz]",
                 ylabel="power [mm^2, relative]", yscale="log")
    ax[0, 1].set(title="cross-camera residual CDF", xlabel="residual [mm]", ylabel="share", xlim=(0, 150))
    ax[1, 0].set(title="bone-length std over time", ylabel="mm", xticks=np.arange(len(BONES)) + 0.3,
                 xticklabels=list(BONES))
    ax[1, 1].set(title="samples at confidence 2", ylabel="%", xticks=np.arange(len(STAT_GROUPS) + 1) + 0.3,
                 xticklabels=[*STAT_GROUPS, "all"])
    ax[1, 1].tick_params(axis="x", rotation=45)
    for a in ax.ravel():
        if a.get_legend_handles_labels()[0]:
            a.legend(fontsize=7)
    fig.suptitle(title)
    save_figure(fig, path)


def error_growth(tracker: TrackerNoise) -> str:
    """How a tracker's errors grow with the motion, in words: its speed dependence and activity factor."""
    speed, a = tracker.speed_ref_m_s, tracker.activity_exponent
    own = ", ".join(f"{g.value} {n.activity_exponent:+.2f}" for g, n in tracker.groups.items() if n.activity_exponent)
    return (f"speed dependence {f'1 + |v| / {speed:g} m/s' if speed > 0 else 'none'}, activity factor "
            f"{f'(A / {tracker.activity_ref_m_s:.3f} m/s) ^ {a:.2f}' if a != 0 else 'none'}"
            + (f" (the jitter's own exponent per group: {own})" if own else ""))


def body_scale_words(tracker: TrackerNoise) -> str:
    """The tracker's body scale (:mod:`sim.tracker_bones`) and its optional parts (view bias shared along
    the limbs, guessed offsets of hidden joints reported confident, noise along the bones), in words."""
    shared = (f"; view bias shared along the limbs, correlation {tracker.view_limb_correlation:.2f}"
              if tracker.view_limb_correlation else "") + (
        f"; hidden joints reported confident with a guessed offset in {100 * tracker.hidden_offset_share:.0f} % of "
        "their frames" if tracker.hidden_offset_share else "") + (
        f"; limb joints' view bias {np.exp(tracker.view_bone_alignment):.2f} times as large along their bones as across"
        if tracker.view_bone_alignment else "") + (
        f"; limb joints' jitter, slow error and outliers {np.exp(tracker.noise_bone_alignment):.2f} times as large along "
        "their bones as across" if tracker.noise_bone_alignment else "")
    if tracker.body_scale_sd == 0:
        return "no body scale (the bones vary each on its own)" + shared
    return (f"body scale {100 * tracker.body_scale_sd:.1f} % (time constant {tracker.body_scale_tau_s:.2f} s, "
            f"{100 * tracker.body_scale_shared:.0f} % shared by the cameras)" + shared)


def write_fit_report(result: FitResult, out_dir: str | Path, replica: ReplicaFit | None = None,
                     cases: Sequence[ReplicaCase] = (), population: PopulationFit | None = None) -> list[Path]:
    """``fit.md`` (statistics per recording, fitted values, notes; with ``replica``, the refinement on
    the recordings' replicas ``cases``; with ``population``, its families) and ``fit.png`` in ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    p = replica.profile if replica is not None else result.profile
    lines = [f"# Sensor fit: {p.name} ({p.topology.name})", "", "Statistics of each recording (95 % moving-block "
             "bootstrap intervals):", "", stats_table(result.stats), "## Fitted values", "",
             "| joint group | white jitter [mm] | slow wobble [mm] | bias [mm] | outlier rate [%] | "
             "low confidence, visible / hidden [%] | bone rigidity |", "|---|---|---|---|---|---|---|"]
    for g, n in p.tracker.groups.items():
        lines.append(f"| {g.value} | {1e3 * n.jitter_m:.2f} | {1e3 * n.wobble_m:.2f} | {1e3 * n.bias_m[0]:.1f}-"
                     f"{1e3 * n.bias_m[1]:.1f} | {100 * n.outlier_rate:.2f} | {100 * n.low_confidence[0]:.0f}-"
                     f"{100 * n.low_confidence[1]:.0f} / {100 * n.hidden_low_confidence:.0f} | {n.bone_rigidity:.2f} |")
    lines += ["", f"Wobble time constant {p.tracker.wobble_tau_s:.2f} s, {error_growth(p.tracker)}, "
              f"{body_scale_words(p.tracker)}, clock jitter "
              f"{1e6 * p.clock.jitter_sigma_s:.1f} us, dropped frames {100 * p.clock.drop_probability:.2f} %.", ""]
    lines += [f"- {n}" for n in result.notes] + ["", "![statistics](fit.png)", ""]
    if replica is not None:
        lines += ["## Refined on the replicas", "", ("Loss (per acceptance statistic the median recording's squared "
                  "log-ratio, times the number of recordings, summed) after refinement, per reference speed of the "
                  "speed dependence:"), "",
                  "| reference speed [m/s] | loss |", "|---|---|"]
        lines += [f"| {'none' if s == 0 else f'{s:g}'} | {v:.2f} |" for s, v in replica.losses.items()]
        lines += ["", "Each fitting recording against its replica re-tracked with the refined profile:", "",
                  comparison_table({c.name: compare_stats(c.real, sim) for c, sim in zip(cases, replica.sims)}), ""]
    if population is not None:
        lines += population_lines(population)
    write_text_atomic(out / "fit.md", "\n".join(lines))
    _plot_stats(result.stats, out / "fit.png", f"truth-free statistics, {p.name}")
    return [out / "fit.md", out / "fit.png"]


def comparison_table(rows_by_recording: Mapping[str, Sequence[Row]]) -> str:
    """Markdown table: per recording and statistic, real, simulated, ratio and verdict."""
    lines = ["| recording | statistic | real | simulated | sim / real | verdict |", "|---|---|---|---|---|---|"]
    for name, rows in rows_by_recording.items():
        for r in rows:
            if r.by_points:
                real, sim, ratio = f"{100 * r.real:.1f} %", f"{100 * r.sim:.1f} %", f"{100 * (r.sim - r.real):+.1f} pt"
            else:
                real, sim, ratio = f"{r.real:.3g}", f"{r.sim:.3g}", f"{r.ratio:.2f}"
            if not (np.isfinite(r.real) and np.isfinite(r.sim)):  # not measured on one side
                real, sim, ratio = real if np.isfinite(r.real) else "-", sim if np.isfinite(r.sim) else "-", "-"
            verdict = "-" if r.passed is None else ("pass" if r.passed else "FAIL")
            lines.append(f"| {name} | {r.statistic} | {real} | {sim} | {ratio} | {verdict} |")
    return "\n".join(lines) + "\n"


def write_sim_to_real(result: SimToReal, name: str, out_dir: str | Path) -> list[Path]:
    """``sim_to_real.md``, ``sim_to_real.json`` and ``sim_to_real.png`` in ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    verdict = "every statistic within tolerance" if result.passed else "some statistics outside tolerance"
    text = "\n".join([
        f"# Sim-to-real: {name}", "",
        f"Simulated scenario `{result.scenario.name}` with sensor profile "
        f"`{result.scenario.sensors.profile or 'the topology default'}`. Verdict: {verdict} (ratios within "
        "+-25 %, shares within 10 points).", "", comparison_table({name: result.rows}),
        "## All statistics", "", stats_table({"real": result.real, "simulated": result.sim}),
        "![real and simulated](sim_to_real.png)", ""])
    write_text_atomic(out / "sim_to_real.md", text)
    doc = {"recording": name, "scenario": result.scenario.name, "profile": result.scenario.sensors.profile,
           "passed": result.passed, "rows": [r.__dict__ for r in result.rows]}
    write_text_atomic(out / "sim_to_real.json", json.dumps(doc, indent=2) + "\n")
    _plot_stats({"real": result.real, "simulated": result.sim}, out / "sim_to_real.png", f"sim-to-real, {name}")
    return [out / "sim_to_real.md", out / "sim_to_real.json", out / "sim_to_real.png"]


_VERDICT_COLOURS = {"inside band": "tab:green", "near median": "tab:orange", "outside": "tab:red"}


def _band_cells(r: BandRow) -> tuple[str, str, str]:
    """Real value, median and band of a row as table cells (shares in per cent)."""
    if r.verdict == "missing":
        real = "-" if not np.isfinite(r.real) else f"{100 * r.real:.1f} %" if r.by_points else f"{r.real:.3g}"
        return real, "-", "-"
    if r.by_points:
        return f"{100 * r.real:.1f} %", f"{100 * r.median:.1f} %", f"{100 * r.low:.1f}-{100 * r.high:.1f} %"
    return f"{r.real:.3g}", f"{r.median:.3g}", f"{r.low:.3g}-{r.high:.3g}"


def band_table(rows: Sequence[BandRow]) -> str:
    """Markdown table: per statistic the real value, the draws' median and band, and the verdict."""
    lines = [f"| statistic | real | simulated median | {BAND[0]:g}-{BAND[1]:g} % band | verdict |",
             "|---|---|---|---|---|"]
    for r in rows:
        real, median, band = _band_cells(r)
        lines.append(f"| {r.statistic} | {real} | {median} | {band} | {r.verdict} |")
    return "\n".join(lines) + "\n"


def band_summary(result: SimToRealBand) -> str:
    """One line: how many statistics pass of how many compared, over how many draws."""
    k, n = result.counts
    return (f"{k} of {n} statistics pass (inside the {BAND[0]:g}-{BAND[1]:g} % band of {len(result.draws)} "
            "draws or near their median)")


def json_safe(value):
    """``value`` with NaN and infinite floats as None (valid JSON)."""
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return float(value) if np.isfinite(value) else None
    return value


def band_json(result: SimToRealBand, name: str) -> dict:
    """Machine-readable sim-to-real with draws: per statistic real, median, band, verdict and the value
    of every draw, the seeds and the profile."""
    k, n = result.counts
    rows = [{"statistic": r.statistic, "real": r.real, "median": r.median, "low": r.low, "high": r.high,
             "by_points": r.by_points, "verdict": r.verdict, "passed": r.passed, "below": r.below,
             "draws_passing": r.draws_passing, "draws": values}
            for r, values in zip(result.rows, result.values())]
    return json_safe({"recording": name, "scenario": result.scenario.name, "profile": result.profile,
                       "profile_source": result.scenario.sensors.profile, "has_population": result.has_population,
                       "population": result.population, "draws": len(result.draws), "seeds": list(result.seeds),
                       "band_percentiles": list(BAND), "ratio_tolerance": RATIO_TOLERANCE,
                       "points_tolerance": POINTS_TOLERANCE, "passing": k, "compared": n, "passed": result.passed,
                       "rows": rows})


def _plot_band(result: SimToRealBand, path: Path, title: str) -> None:
    """Per statistic the draws (dots), their band (bar) and the real value (marker coloured by its
    verdict): ratio statistics divided by the draws' median on one axis, the confidence share in per
    cent on a panel of its own."""
    values = result.values()
    ratio = [k for k, r in enumerate(result.rows) if not r.by_points]
    points = [k for k, r in enumerate(result.rows) if r.by_points]
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.8), width_ratios=[max(1, len(ratio)), max(1, 1.6 * len(points))],
                             squeeze=False)
    n = len(result.draws)
    offsets = np.linspace(-0.12, 0.12, n) if n > 1 else np.zeros(1)  # the draws side by side
    for ax, keys, scale in ((axes[0, 0], ratio, None), (axes[0, 1], points, 100.0)):
        legend = True
        for x, k in enumerate(keys):
            r = result.rows[k]
            if r.verdict == "missing" or (scale is None and not r.median):
                continue
            divisor = r.median if scale is None else 1 / scale
            v = np.asarray(values[k], dtype=np.float64) / divisor
            ax.plot([x, x], [r.low / divisor, r.high / divisor], color="0.75", lw=10, solid_capstyle="butt",
                    zorder=1, label=f"{BAND[0]:g}-{BAND[1]:g} % band of the draws" if legend else None)
            ax.plot(x + offsets, v, "o", ms=3.5, color="tab:blue", alpha=0.8, zorder=2,
                    label="draws" if legend else None)
            ax.plot(x, r.real / divisor, "D", ms=8, mec="black", color=_VERDICT_COLOURS[r.verdict], zorder=3,
                    label="real" if legend else None)
            legend = False
        ax.set_xticks(range(len(keys)), [result.rows[k].statistic.split(" [")[0] for k in keys], rotation=35,
                      ha="right", fontsize=8)
        ax.set_xlim(-0.6, max(len(keys), 1) - 0.4)
        ax.grid(axis="y", alpha=0.3)
    ax = axes[0, 0]
    ax.axhline(1.0, color="0.4", lw=0.8)
    # near the median: median / real within +-tolerance, i.e. real / median in [1 / (1 + t), 1 / (1 - t)]
    ax.axhspan(1 / (1 + RATIO_TOLERANCE), 1 / (1 - RATIO_TOLERANCE), color="tab:green", alpha=0.07,
               label=f"near the median (median / real within +-{100 * RATIO_TOLERANCE:.0f} %)")
    ax.set_ylabel("value / median of the draws")
    ax.legend(fontsize=7, loc="best")
    ax = axes[0, 1]
    for x, k in enumerate(points):
        r = result.rows[k]
        if r.verdict != "missing":
            ax.axhspan(100 * (r.median - POINTS_TOLERANCE), 100 * (r.median + POINTS_TOLERANCE), color="tab:green",
                       alpha=0.07)
    ax.set_ylabel(f"share [%] (green: median +-{100 * POINTS_TOLERANCE:.0f} points)")
    fig.suptitle(f"{title}: real marker green inside the band, orange near the median, red outside", fontsize=9)
    save_figure(fig, path)


def write_sim_to_real_band(result: SimToRealBand, name: str, out_dir: str | Path,
                           command: str | None = None) -> list[Path]:
    """``report.md``, ``results.json`` and ``band.png`` of a sim-to-real with several draws in ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    report, results, plot = out / "report.md", out / "results.json", out / "band.png"
    source = result.scenario.sensors.profile
    lines = [f"# Sim-to-real with {len(result.draws)} draws: {name}", ""]
    if command:
        lines += [f"Command: `{command}`", ""]
    shown = f" (`{source}`)" if source is not None and source != result.profile else ""
    lines += [(f"Simulated scenario `{result.scenario.name}` {len(result.draws)} times (seeds "
               f"{result.seeds[0]}-{result.seeds[-1]}) with sensor profile `{result.profile}`{shown}; "
               f"{result.population}."), "",
              (f"A statistic passes *inside band* (within the {BAND[0]:g}-{BAND[1]:g} % percentiles of the draws) "
               f"or *near median* (the draws' median within +-{100 * RATIO_TOLERANCE:.0f} % of the real value, the "
               f"confidence share within {100 * POINTS_TOLERANCE:.0f} points of it)."), "",
              band_table(result.rows), f"**{band_summary(result)}.**", "",
              "Every draw (seed: value per statistic):", "",
              "| seed | " + " | ".join(r.statistic for r in result.rows) + " |",
              "|---|" + "---|" * len(result.rows)]
    values = result.values()
    for d, seed in enumerate(result.seeds):
        cells = [("-" if not np.isfinite(values[k][d]) else
                  f"{100 * values[k][d]:.1f} %" if r.by_points else f"{values[k][d]:.3g}")
                 for k, r in enumerate(result.rows)]
        lines.append(f"| {seed} | " + " | ".join(cells) + " |")
    lines += ["", "![real against the draws' band](band.png)", "", "## All statistics", "",
              "The real session and each draw (seed) on every statistic, the judged ones above among them.", "",
              stats_table({"real": result.real, **{f"seed {s}": d for s, d in zip(result.seeds, result.draws)}})]
    write_text_atomic(report, "\n".join(lines))
    write_text_atomic(results, json.dumps(band_json(result, name), indent=2) + "\n")
    _plot_band(result, plot, f"sim-to-real, {name}")
    return [report, results, plot]
