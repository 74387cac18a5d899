"""What ``mocap-bench plan`` writes: the ranked list, pictures, rig files and a Markdown report.

Output directory::

    plan.json          the room, the screen, every searched layout and the final sessions
    report.md          ranked layouts with scores and 90 % intervals, best per camera count vs references
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
from scenarios.plan.objectives import OBJECTIVES, rig_config
from scenarios.plan.search import LayoutResult, PlanResult
from scenarios.runner import scenario_to_dict
from scenarios.show import plt, save_figure

_UNITS = {"joint_error_mm": "mm", "angle_error_deg": "deg", "back_pose_pct": "%", "not_high_confidence_pct": "%",
          "arm_occluded_pct": "%", "calibration_rotation_deg": "deg", "calibration_translation_mm": "mm",
          "cameras": ""}


def _drop_none(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _drop_none(v) for k, v in value.items() if v is not None}
    if isinstance(value, list):
        return [_drop_none(v) for v in value]
    return value


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
              f"{layout.score:.1f}.\n# Cameras in the simulation's world frame (subject at the origin facing +x).\n")
    return header + tomli_w.dumps(_drop_none(doc))


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
        lines.append(f"| {r.name} | {cams} | {_cell(r, None, '.1f')} | "
                     + " | ".join(_cell(r, k, ".1f") for k in OBJECTIVES[:-1]) + f" | {r.failed}/{len(r.sessions)} |")
    return lines


def report_markdown(result: PlanResult, *, top: int = 10) -> str:
    """The plan as Markdown (scores: mean [90 % t-interval] over seeds; lower is better)."""
    room, s = result.room, result.screen
    weights = ", ".join(f"{k} {v:g}" for k, v in dataclasses.asdict(room.objective).items() if v)
    lines = [f"# Camera plan: {room.room.name}", "", room.room.description, "",
             f"Cameras: {room.cameras.min} to {room.cameras.max}. Score = weighted sum of the objectives "
             f"({weights}); a failed session (calibration impossible) scores 1000. Values are means with a "
             "90 % t-interval over the seeds.", "",
             f"Screen: {int(s.kept.sum())} of {s.kept.size} candidate places see at least "
             f"{room.search.min_visible:.0%} of the key joints over {s.poses} instants of the arm movements "
             f"(median share {np.median(s.visible):.2f}).", "",
             f"## Best layout per camera count and references ({room.search.final_seeds} fresh seeds each)", ""]
    lines += _table(list(result.finals) + list(result.references))
    lines += ["", f"## Search: {len(result.trials)} layouts, {room.search.seeds} seeds each (top {top})", ""]
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
    room = result.room
    outline = np.asarray(room.room.outline_m)
    ax.fill(outline[:, 0], outline[:, 1], color="#fafafa", ec="#37474f", lw=2)
    for box in room.obstacles:
        ax.add_patch(plt.Rectangle(box.min_m[:2], box.max_m[0] - box.min_m[0], box.max_m[1] - box.min_m[1],
                                   color="#8d6e63", alpha=0.6))
        ax.annotate(box.name, ((box.min_m[0] + box.max_m[0]) / 2, (box.min_m[1] + box.max_m[1]) / 2), ha="center",
                    fontsize=7)
    for z in room.forbidden:
        ax.add_patch(plt.Rectangle(z.min_m, z.max_m[0] - z.min_m[0], z.max_m[1] - z.min_m[1], fill=False,
                                   hatch="//", ec="#c62828"))
    s = result.screen
    ax.scatter(s.places_room[~s.kept, 0], s.places_room[~s.kept, 1], s=6, c="#bdbdbd", marker="x")
    ax.scatter(s.places_room[s.kept, 0], s.places_room[s.kept, 1], s=6, c=s.visible[s.kept], cmap="viridis",
               vmin=0, vmax=1)
    c = np.asarray(room.subject.position_m)
    ax.add_patch(plt.Circle(c, room.subject.radius_m, color="#c62828", alpha=0.35))
    f = np.radians(room.subject.facing_deg)
    ax.arrow(c[0], c[1], 0.5 * np.cos(f), 0.5 * np.sin(f), width=0.03, color="#c62828")


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
    shown = list(result.finals) + list(result.references)
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
        "references": [r.to_dict() for r in result.references]}
    with atomic_directory(out_dir, overwrite=overwrite) as tmp:
        (tmp / "plan.json").write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
        (tmp / "report.md").write_text(report_markdown(result), encoding="utf-8")
        plot_pareto(result, tmp / "pareto.png")
        plot_top_views(result, tmp / "top_views.png")
        best = min(result.finals, key=lambda r: (r.score, r.name))
        (tmp / "rig_best.toml").write_text(rig_toml(result, best), encoding="utf-8")
        for r in result.finals:
            (tmp / f"rig_{len(r.layout)}cam.toml").write_text(rig_toml(result, r), encoding="utf-8")
        names = sorted(p.name for p in tmp.iterdir())
    return names
