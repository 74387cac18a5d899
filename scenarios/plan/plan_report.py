"""What ``mocap-bench plan`` writes: the ranked list, pictures, rig files and a Markdown report.

Output directory::

    plan.json          the room, the screen, every searched layout and the final sessions
    report.md          warnings, sensor, best per camera count and the user's layouts vs references,
                       per-angle errors, other sensors, the ablation, the ranked search (90 % bootstrap intervals)
    install.md         an install sheet per recommended layout (best first): mounts, positions, pan / tilt /
                       roll, distance and bearing to the patient, expected error per clinical angle and joint
    install_<k>.png    the k-th layout's top view and side elevation to scale (and install_<k>.pdf)
    pareto.png         fused joint error against moving-arm occlusion and back pose, Pareto front marked
    top_views.png      the room from above: obstacles, forbidden zones, candidate places, cameras, fields of view
    rig_best.toml      the best layout as a scenario (the protocol, the subject, explicit cameras)
    rig_<n>cam.toml    the best layout with n cameras, for every n planned
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from fusion.camera import KINECT_V2_DEPTH
from fusion.io.atomic import atomic_directory
from fusion.transforms import apply
from scenarios.config import scenario_to_dict
from scenarios.plan.install_sheet import (
    draw_room,
    error_table,
    install_markdown,
    plot_install,
)
from scenarios.plan.objectives import OBJECTIVES, rig_config
from scenarios.plan.rules import MIN_SEPARATION_M, MIN_VIEW_ANGLE_DEG
from scenarios.plan.search import LayoutResult, PlanResult
from scenarios.show import plt, save_figure
from scenarios.toml_tables import without_none

_UNITS = {"joint_error_mm": "mm", "angle_error_deg": "deg", "back_pose_pct": "%", "not_high_confidence_pct": "%",
          "arm_occluded_pct": "%", "calibration_rotation_deg": "deg", "calibration_translation_mm": "mm",
          "cameras": ""}


def rig_toml(result: PlanResult, layout: LayoutResult) -> str:
    """A scenario TOML (``simulate`` input) of the room's protocol with ``layout``'s cameras."""
    room = result.room
    scenario = dataclasses.replace(room.scenario(f"{room.room.name}-{len(layout.layout)}cam", room.room.seed),
                                   rig=rig_config(room, layout.layout),
                                   description=f"planned for {room.room.name}: {layout.name}")
    doc = scenario_to_dict(scenario)
    top = {k: doc.pop(k) for k in ("name", "description", "seed", "duration_s")}
    doc = {"scenario": top, **doc, "session": {"segment": doc.pop("session")}}
    header = (f"# Planned by `mocap-bench plan` for room {room.room.name!r}: {layout.name}, mean score "
              f"{layout.score:.1f}.\n# Cameras in the simulation's world frame (subject at the origin facing +x); "
              "in the room frame:\n")
    world = apply(room.T_world_room, np.array([c[:3] for c in layout.layout]))
    header += "".join(f"#   cam{k + 1}: room ({x:.2f}, {y:.2f}, {z:.2f}) m = world ({u:.2f}, {v:.2f}, {w:.2f}) m, "
                      f"aim height {c[3]:.2f} m\n" for k, (c, (x, y, z), (u, v, w))
                      in enumerate(zip(layout.layout, (c[:3] for c in layout.layout), world)))
    return header + tomli_w.dumps(without_none(doc))


def _cell(r: LayoutResult, key: str | None, fmt: str) -> str:
    mean, lo, hi = r.interval(key)
    if not np.isfinite(mean):
        return "n/a"
    return f"{mean:{fmt}}" if not np.isfinite(lo) else f"{mean:{fmt}} [{lo:{fmt}}, {hi:{fmt}}]"


def _table(rows: list[LayoutResult]) -> list[str]:
    head = "| layout | cameras (x, y, z, aim) [m] | score | " + " | ".join(
        f"{k} [{_UNITS[k]}]" if _UNITS[k] else k for k in OBJECTIVES[:-1]) + " | failed |"
    lines = [head, "| " + " | ".join(["---"] * (len(OBJECTIVES) + 3)) + " |"]
    for r in rows:
        cams = "; ".join("(" + ", ".join(f"{v:.2f}" for v in c) + ")" for c in r.layout)
        name = r.name + "".join(f" ({t})" for t in (r.sensor, r.note) if t)
        lines.append(f"| {name} | {cams} | {_cell(r, None, '.1f')} | "
                     + " | ".join(_cell(r, k, ".1f") for k in OBJECTIVES[:-1]) + f" | {r.failed}/{len(r.sessions)} |")
    return lines


def ablation_lines(result: PlanResult) -> list[str]:
    """What dominates the best layout's expected error: each ablation row against the best layout."""
    if not result.ablation or not result.recommended:
        return []
    base = result.recommended[0]
    j0, a0 = base.interval("joint_error_mm")[0], base.interval("angle_error_deg")[0]
    lines = [f"## What dominates the expected error ({base.name}, {base.sensor})", ""]
    drops = []
    for r in result.ablation:
        j, a = r.interval("joint_error_mm")[0], r.interval("angle_error_deg")[0]
        drops.append(((j0 - j) / j0 if j0 > 0 else float("nan"), r.note))
        lines.append(f"- {r.note}: fused joint error {j0:.0f} -> {j:.0f} mm, mean angle error {a0:.1f} -> {a:.1f} deg.")
    finite = [d for d in drops if np.isfinite(d[0])]
    if finite:
        share, label = max(finite)
        lines += ["", f"Largest effect: **{label}** ({share:.0%} of the joint error goes away); "
                  + ("that source dominates the expected error." if share > 0.25 else
                     "no single switch removes more than a quarter: the error is shared between sources "
                     "(and the calibration from the body).")]
    return lines + ["", *error_table([base, *result.ablation]), ""]


def report_markdown(result: PlanResult, *, top: int = 10) -> str:
    """The plan as Markdown (values: mean [90 % bootstrap interval] over seeds; lower is better)."""
    room, s = result.room, result.screen
    weights = ", ".join(f"{k} {v:g}" for k, v in dataclasses.asdict(room.objective).items() if v)
    default = "" if room.sensors.profile else " (the default of the room's subject topology; choose with --sensor)"
    lines = [f"# Camera plan: {room.room.name}", "", room.room.description, ""]
    lines += [f"> **Warning:** {w}" for w in result.warnings] + ([""] if result.warnings else [])
    lines += [f"Sensor: **{room.sensor_name}**{default}. Cameras: {room.cameras.min} to {room.cameras.max}. "
              f"Score = weighted sum of the objectives ({weights}); a failed session (calibration impossible) "
              "scores 1000. Values are means with a 90 % bootstrap interval over the seeds (never outside the "
              "measured range). Degenerate layouts (two cameras closer than "
              f"{MIN_SEPARATION_M} m, or less than {MIN_VIEW_ANGLE_DEG:g} deg apart as seen from the patient) are "
              "not searched.", "",
              f"Screen: {int(s.kept.sum())} of {s.kept.size} candidate places see at least "
              f"{room.search.min_visible:.0%} of the key joints over {s.poses} instants of the arm movements "
              f"(median share {np.median(s.visible):.2f}).", "",
              f"## Recommended and own layouts, references ({room.search.final_seeds} fresh seeds each, the same "
              "for all)", ""]
    finals = [*result.recommended, *result.references]
    lines += _table(finals)
    lines += ["", "## Expected error per clinical angle and joint", "", *error_table(finals), ""]
    if result.sensors:
        lines += ["## Other sensors", "", *_table(list(result.sensors)), ""]
    lines += ablation_lines(result)
    if result.trials:
        lines += [f"## Search: {len(result.trials)} layouts, {room.search.seeds} seeds each (top {top})", "",
                  f"{result.refused} further proposals were refused before simulation (degenerate, or two cameras "
                  "at one place).", ""]
        lines += _table(result.ranked[:top])
    return "\n".join(lines) + "\n"


def pareto_front(points: np.ndarray) -> np.ndarray:
    """(N,) bool: rows of ``points`` (N, M) that no other row beats in every column (lower is better)."""
    p = np.asarray(points, dtype=float)
    front = np.ones(p.shape[0], dtype=bool)
    for i in range(p.shape[0]):
        others = np.all(p <= p[i], axis=1) & np.any(p < p[i], axis=1)
        front[i] = not others.any()
    return front & np.all(np.isfinite(p), axis=1)


def plot_pareto(result: PlanResult, path: Path) -> None:
    """Fused joint error against moving-arm occlusion and against back pose, per camera count."""
    rows = [r for r in result.trials if r.failed == 0]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    for ax, key in zip(axes, ("arm_occluded_pct", "back_pose_pct")):
        pts = np.array([[r.interval(key)[0], r.interval("joint_error_mm")[0]] for r in rows]).reshape(-1, 2)
        counts = np.array([len(r.layout) for r in rows])
        front = pareto_front(pts) if pts.size else np.zeros(0, bool)
        for n in sorted(set(counts.tolist())):
            sel = counts == n
            ax.scatter(pts[sel, 0], pts[sel, 1], s=22, label=f"{n} cameras")
        order = np.argsort(pts[front, 0])
        ax.plot(pts[front, 0][order], pts[front, 1][order], "k--", lw=1, label="Pareto front")
        for r in result.references:
            ax.scatter(r.interval(key)[0], r.interval("joint_error_mm")[0], marker="*", s=160, c="#c62828",
                       label=f"{r.name} (final seeds)")
        ax.set_xlabel(f"{key} [%]")
        ax.set_ylabel("fused joint error [mm]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"{result.room.room.name}: searched layouts (mean over seeds; lower-left is better)")
    save_figure(fig, path)


def _draw_room(ax: Any, result: PlanResult) -> None:
    draw_room(ax, result.room)
    s = result.screen
    ax.scatter(s.places_room[~s.kept, 0], s.places_room[~s.kept, 1], s=6, c="#bdbdbd", marker="x")
    ax.scatter(s.places_room[s.kept, 0], s.places_room[s.kept, 1], s=6, c=s.visible[s.kept], cmap="viridis",
               vmin=0, vmax=1)


def _draw_cameras(ax: Any, result: PlanResult, layout: LayoutResult) -> None:
    k = KINECT_V2_DEPTH
    half = np.arctan(k.width / 2 / k.fx)
    c = np.asarray(result.room.subject.position_m)
    for i, (x, y, z, _) in enumerate(layout.layout):
        heading = np.arctan2(c[1] - y, c[0] - x)
        a = np.linspace(heading - half, heading + half, 20)
        wedge = np.vstack([[x, y], np.column_stack([x + k.max_depth_m * np.cos(a), y + k.max_depth_m * np.sin(a)]),
                           [x, y]])
        ax.fill(wedge[:, 0], wedge[:, 1], color="#90caf9", alpha=0.2)
        ax.plot(x, y, "s", color="#1a237e", ms=7)
        ax.annotate(f"{i + 1} ({z:.1f} m)", (x, y), textcoords="offset points", xytext=(4, 4), fontsize=7)


def plot_top_views(result: PlanResult, path: Path) -> None:
    """The room from above with the best layout per camera count and each reference layout."""
    shown = [*result.recommended, *result.references]
    cols = min(3, len(shown))
    rows = int(np.ceil(len(shown) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(5.2 * cols, 4.6 * rows), squeeze=False)
    outline = np.asarray(result.room.room.outline_m)
    lo, hi = outline.min(axis=0) - 0.3, outline.max(axis=0) + 0.3
    for ax, layout in zip(axes.ravel(), shown):
        _draw_room(ax, result)
        _draw_cameras(ax, result, layout)
        ax.set_title(f"{layout.name}\nscore {_cell(layout, None, '.1f')}", fontsize=9)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal")
    for ax in axes.ravel()[len(shown):]:
        ax.axis("off")
    fig.suptitle("Top views: obstacles (brown), forbidden zones (hatched), candidate places (by share of key joints "
                 "seen; x dropped), subject (red), cameras with their fields of view", fontsize=9)
    save_figure(fig, path)


def write_plan(result: PlanResult, out_dir: Path, *, overwrite: bool = False) -> list[str]:
    """Write the files listed in the module docstring atomically; returns their names."""
    doc = {"room": scenario_to_dict(result.room), "screen": {
        "places_room": result.screen.places_room.tolist(), "mount": result.screen.mount.tolist(),
        "visible": result.screen.visible.tolist(), "kept": result.screen.kept.tolist(), "poses": result.screen.poses},
        "trials": [r.to_dict() for r in result.trials], "finals": [r.to_dict() for r in result.finals],
        "references": [r.to_dict() for r in result.references], "evaluated": [r.to_dict() for r in result.evaluated],
        "sensors": [r.to_dict() for r in result.sensors], "ablation": [r.to_dict() for r in result.ablation],
        "sensor": result.room.sensor_name, "warnings": list(result.warnings)}
    with atomic_directory(out_dir, overwrite=overwrite) as tmp:
        (tmp / "plan.json").write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
        (tmp / "report.md").write_text(report_markdown(result), encoding="utf-8")
        if result.trials:
            plot_pareto(result, tmp / "pareto.png")
        plot_top_views(result, tmp / "top_views.png")
        if result.finals:
            best = min(result.finals, key=lambda r: (r.score, r.name))
            (tmp / "rig_best.toml").write_text(rig_toml(result, best), encoding="utf-8")
        for r in result.finals:
            (tmp / f"rig_{len(r.layout)}cam.toml").write_text(rig_toml(result, r), encoding="utf-8")
        sheet = [f"# Install sheets: {result.room.room.name}", "", "Best layout first. Room frame: metres, x and y "
                 "as the room's outline is drawn, heights above the floor. Pan: direction of the optical axis, "
                 "counter-clockwise from +x; tilt: above the horizontal (negative: down); roll: about the optical "
                 "axis (0: level); bearing: where the camera stands as seen from the patient, counter-clockwise "
                 "from the patient's facing (+90: on the patient's left).", ""]
        for k, r in enumerate(result.recommended, start=1):
            plot_install(result.room, r, tmp / f"install_{k}.png", pdf=tmp / f"install_{k}.pdf")
            sheet += install_markdown(result.room, r, f"install_{k}.png")
        (tmp / "install.md").write_text("\n".join(sheet), encoding="utf-8")
        names = sorted(p.name for p in tmp.iterdir())
    return names
