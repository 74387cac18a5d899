"""The device-swap report: ``report.md`` (the table of :class:`scenarios.sensors.device_swap.DeviceSwap`),
``results.json`` (every metric of every draw) and ``swap.png`` (each metric per seed, both profiles)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from fusion.io.atomic import write_text_atomic
from scenarios.sensors.device_swap import DeviceSwap, SwapRow
from scenarios.sensors.fit_report import json_safe
from scenarios.sensors.sim_to_real import BAND
from scenarios.show import plt, save_figure


def _num(v: float) -> str:
    return "-" if not np.isfinite(v) else f"{v:.3g}"


def _band(b: tuple[float, float, float]) -> str:
    return "-" if not np.isfinite(b[0]) else f"{b[0]:.3g} [{b[1]:.3g}, {b[2]:.3g}]"


def _signed(v: float) -> str:
    return "-" if not np.isfinite(v) else f"{v:+.3g}"


def swap_table(result: DeviceSwap) -> str:
    """The Markdown table: per metric the real value, each profile's median [band] and the median paired change."""
    lines = [f"| metric | kind | real session | {result.from_profile} | {result.to_profile} | change (paired median) |",
             "|---|---|---|---|---|---|"]
    lines += [f"| {r.metric} | {r.kind} | {_num(r.real)} | {_band(r.before)} | {_band(r.after)} | {_signed(r.change)} |"
              for r in result.rows]
    return "\n".join(lines) + "\n"


def swap_json(result: DeviceSwap, name: str) -> dict:
    """Machine-readable device swap: the rows and every draw's metrics, seeds and profiles."""
    rows = [{"metric": r.metric, "kind": r.kind, "real": r.real,
             "from": dict(zip(("median", "low", "high"), r.before)),
             "to": dict(zip(("median", "low", "high"), r.after)), "change": r.change} for r in result.rows]
    draws = [{"profile": d.profile, "seed": d.seed, "calibrated": d.stats is not None, "values": dict(d.values)}
             for d in result.draws]
    return json_safe({"recording": name, "scenario": result.scenario.name, "from_profile": result.from_profile,
                      "to_profile": result.to_profile, "seeds": list(result.seeds), "band_percentiles": list(BAND),
                      "rows": rows, "draws": draws})


def _plot(result: DeviceSwap, path: Path, title: str) -> None:
    rows: list[SwapRow] = list(result.rows)
    ncol = 4
    nrow = -(-len(rows) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(3.2 * ncol, 2.4 * nrow), squeeze=False)
    names = (result.from_profile, result.to_profile)
    for ax, r in zip(axes.ravel(), rows):
        for seed in result.seeds:
            y = [next((d.values.get(r.metric, np.nan) for d in result.draws if d.profile == n and d.seed == seed),
                      np.nan) for n in names]
            ax.plot([0, 1], y, "o-", color="tab:blue", alpha=0.6)
        if np.isfinite(r.real):
            ax.axhline(r.real, color="k", ls="--", lw=1, label="real")
        ax.set_xticks([0, 1], names, fontsize=7)
        ax.set_xlim(-0.4, 1.4)
        ax.set_title(r.metric, fontsize=7)
    for ax in axes.ravel()[len(rows):]:
        ax.axis("off")
    fig.suptitle(title)
    fig.tight_layout()
    save_figure(fig, path)


def write_device_swap(result: DeviceSwap, name: str, out_dir: str | Path, command: str | None = None) -> list[Path]:
    """``report.md``, ``results.json`` and ``swap.png`` of a device swap in ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    report, results, plot = out / "report.md", out / "results.json", out / "swap.png"
    lines = [f"# Device swap: {name}, {result.from_profile} -> {result.to_profile}", ""]
    if command:
        lines += [f"Command: `{command}`", ""]
    lines += [(f"The replica `{result.scenario.name}` simulated with each profile over the same seeds "
               f"{result.seeds[0]}-{result.seeds[-1]} ({len(result.seeds)} per profile): the same motion, rig and "
               "scenario seed, only the sensor models differ. Each value is the median over the seeds with the "
               f"{BAND[0]:g}-{BAND[1]:g} % band; *change* is the median over the seeds of the paired difference "
               f"({result.to_profile} - {result.from_profile}). Truth-free statistics as in sim-to-real (the real "
               "session's value beside them); calibration errors are the body calibration's (skeletons only) "
               "camera poses relative to the reference camera against the replica's true poses, mean over the "
               "other cameras; skeleton errors are the fused skeleton's against the replica's true joints."), ""]
    lines += [swap_table(result)]
    if result.failed:
        lines += ["Left out (cameras not calibrated from the body): "
                  + ", ".join(f"{p} seed {s}" for p, s in result.failed) + ".", ""]
    lines += ["![every metric per seed with both profiles](swap.png)", ""]
    write_text_atomic(report, "\n".join(lines))
    write_text_atomic(results, json.dumps(swap_json(result, name), indent=2) + "\n")
    _plot(result, plot, f"device swap, {name}")
    return [report, results, plot]
