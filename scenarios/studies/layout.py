"""``mocap-bench layout``: compare camera layouts and merging methods (the paper's Tables 2 and 3).

One session of a ring scenario is simulated and calibrated (from the body, or with the true poses);
then every configuration (subset of ring cameras) is fused on its own, as if only those cameras had
been installed: back-facing flags are cross-checked among the configuration's cameras only.

- Table 2, per configuration: % of merged joints in a back pose and % with high confidence (the
  paper's columns), plus the truth: % of frames in which every camera of the configuration truly
  sees the subject's back, and the mean per-joint error of the Avg(Frontal) merge.
- Table 3, per merging method and configuration: standard deviation over time of three bone lengths,
  % of the joints seen (Tracked) by held-out cameras within 5 and 7 cm of the merged joint (the
  paper's columns; with all cameras, each camera is held out in turn), plus the truth: mean per-joint
  error and clinical angle errors (ISB angles of :mod:`fusion.merge.angles`, median absolute error
  while an arm is raised).
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from fusion.calibrate.options import CalibrationOptions, RigMethod
from fusion.calibrate.pipeline import calibrate_rig
from fusion.calibrate.results import calibration_from_rig
from fusion.calibration import Calibration
from fusion.errors import BadInputError, ScenarioError
from fusion.io.atomic import atomic_directory
from fusion.merge.backfacing import cross_check_back_facing
from fusion.merge.filters import TemporalFilter
from fusion.merge.fuse import (
    Fit,
    FuseOptions,
    camera_views,
    fuse_views,
    reliability_fractions,
)
from fusion.merge.methods import MergeMethod
from fusion.merge.metrics import bone_length_std, held_out_support
from fusion.merge.views import CameraViews
from fusion.recording import Recording
from scenarios.api import load_algorithm, run_fusion_algorithm, true_calibration
from scenarios.config import SKELETON_RATE_HZ, PoseSource, Scenario, camera_positions
from scenarios.show import plt, save_figure
from scenarios.skeleton_eval import skeleton_errors
from scenarios.studies.calib_study import algorithm_label
from scenarios.sweep import SweepOptions, run_sweep
from sim.truth import GroundTruth

TABLE2_CONFIGS = ((1,), (1, 2), (1, 3), (1, 2, 3), (1, 3, 5), (1, 2, 3, 4), (1, 2, 3, 4, 5), (1, 2, 3, 4, 5, 6))
TABLE3_CONFIGS = ((1, 2, 3), (1, 3, 5), (1, 2, 3, 4, 5, 6))


@dataclasses.dataclass(frozen=True)
class Variant:
    """A merging set-up compared in Table 3: one of the paper's methods, or one beyond the paper."""

    label: str
    options: FuseOptions
    algorithm: str | None = None
    """A user's fusion ``MODULE:FUNCTION`` (:mod:`scenarios.api`) used instead of ``options``."""


VARIANTS = tuple(Variant(m.value, FuseOptions(method=m)) for m in MergeMethod) + (
    Variant("avg_frontal+kalman", FuseOptions(method=MergeMethod.AVG_FRONTAL, temporal=TemporalFilter.KALMAN)),
    Variant("avg_frontal+kalman+bones", FuseOptions(method=MergeMethod.AVG_FRONTAL, temporal=TemporalFilter.KALMAN,
                                                    bone_lengths=True)),
    Variant("frontality+kalman+bones", FuseOptions(method=MergeMethod.FRONTALITY, temporal=TemporalFilter.KALMAN,
                                                   bone_lengths=True)),
    Variant("kinematic", FuseOptions(fit=Fit.KINEMATIC)),
)


def _names(config: tuple[int, ...]) -> list[str]:
    return [f"cam{k}" for k in config]


def _config_label(config: tuple[int, ...]) -> str:
    return "[" + ",".join(map(str, config)) + "]"


def _subset(views: CameraViews, names: list[str]) -> CameraViews:
    sub = views.subset(names)
    return dataclasses.replace(sub, back_facing=cross_check_back_facing(sub))


def _true_back_fraction(truth: GroundTruth, views: CameraViews, names: list[str]) -> float:
    """% of reference frames in which every camera of the configuration truly sees the subject's back."""
    ref_times = truth.cameras[0].true_times
    flips = []
    for n in names:
        ct = truth.camera(n)
        k = np.clip(np.searchsorted(ct.true_times, ref_times), 0, ct.true_times.size - 1)
        flips.append(ct.flipped[k])
    return float(np.all(flips, axis=0).mean() * 100) if views.times.size else float("nan")


def _held_out(merged_positions: np.ndarray, views: CameraViews, held: list[str]) -> dict[float, float]:
    sub = views.subset(held)
    return held_out_support(merged_positions, sub.positions, sub.states, exclude_frames=sub.back_facing)


def _positions(views: CameraViews, names: list[str], variant: Variant, recording: Recording | None,
               calibration: Calibration) -> np.ndarray:
    """(T, J, 3) fused positions [m] of the named cameras on the views' frames. A user's fusion returns
    them on its first camera's frames: each views frame takes the nearest of those within half a frame."""
    if variant.algorithm is None:
        return fuse_views(_subset(views, names), variant.options).positions
    positions = run_fusion_algorithm(load_algorithm(variant.algorithm), recording, calibration, cameras=names,
                                     name=variant.algorithm)
    t = recording.camera(names[0]).skeleton.timestamps - calibration.clock_offset_s[names[0]]
    k = np.clip(np.searchsorted(t, views.times), 1, max(t.size - 1, 1))
    k = np.where(np.abs(t[k - 1] - views.times) < np.abs(t[k] - views.times), k - 1, k)
    near = np.abs(t[k] - views.times) <= 0.5 / SKELETON_RATE_HZ
    return np.where(near[:, None, None], positions[k], np.nan)


def _table3_row(views: CameraViews, names: list[str], variant: Variant, truth: GroundTruth,
                calibration: Calibration, recording: Recording | None = None) -> dict[str, Any]:
    all_names = list(views.names)
    if len(names) == len(all_names):  # leave one out in turn
        folds = [([n for n in names if n != h], [h]) for h in names]
    else:
        folds = [(names, [n for n in all_names if n not in names])]
    support = {0.05: [], 0.07: []}
    for used, held in folds:
        for d, v in _held_out(_positions(views, used, variant, recording, calibration), views, held).items():
            support[d].append(v)
    merged = _positions(views, names, variant, recording, calibration)
    bones = bone_length_std(merged, views.topology)
    errors = skeleton_errors(merged, calibration.T_world_cam, truth, calibration.reference, views.topology)
    return {
        "bone_std_mm": {k: v * 1e3 for k, v in bones.items()},
        "support_5cm": float(np.mean(support[0.05])), "support_7cm": float(np.mean(support[0.07])),
        "joint_error_mm": errors["joint_error_mm"]["mean"],
        "elevation_error_deg": errors["ht_elevation_raised_error_deg"]["median"],
        "plane_of_elevation_error_deg": errors["ht_plane_of_elevation_raised_error_deg"]["median"],
        "elbow_flexion_error_deg": errors["elbow_flexion_raised_error_deg"]["median"],
    }


def _table2_row(views: CameraViews, config: tuple[int, ...], truth: GroundTruth, calibration: Calibration
                ) -> dict[str, Any]:
    names = _names(config)
    merged = fuse_views(_subset(views, names), FuseOptions(method=MergeMethod.AVG_FRONTAL))
    rel = reliability_fractions(merged)
    err = skeleton_errors(merged.positions, calibration.T_world_cam, truth, calibration.reference, views.topology)
    return {"config": _config_label(config), "back_pose_pct": rel["back_pose"] * 100,
            "high_confidence_pct": rel["high"] * 100, "true_back_pct": _true_back_fraction(truth, views, names),
            "joint_error_mm": err["joint_error_mm"]["mean"]}


def _table3_cell(views: CameraViews, config: tuple[int, ...], variant: Variant, truth: GroundTruth,
                 calibration: Calibration, recording: Recording | None) -> dict[str, Any]:
    return ({"config": _config_label(config), "method": variant.label}
            | _table3_row(views, _names(config), variant, truth, calibration, recording))


def layout_study(scenario: Scenario, *, poses: PoseSource | str = PoseSource.BODY, sweep: SweepOptions = SweepOptions(),
                 progress: Callable[[str], None] | None = None, algorithm: str | None = None) -> dict[str, Any]:
    """Simulate ``scenario`` once and fill Tables 2 and 3 (see the module docstring).

    Parameters
    ----------
    scenario : a ring scenario; configurations naming cameras the ring lacks are left out.
    poses : PoseSource
        Calibrate from the body, or fuse with the true camera poses and clock offsets.
    sweep : where the table rows run (one Dask task per row, :mod:`scenarios.sweep`); the result
        does not depend on it.
    progress : called with a short message after the simulation and the calibration.
    algorithm : a user's fusion ``MODULE:FUNCTION`` (see :mod:`scenarios.api`): an extra Table 3 method,
        ``algorithm:FUNCTION``, given each configuration's cameras (its output, on its first camera's
        frames, is matched to the reference frames by nearest time).
    """
    from scenarios.runner import simulate

    tell = progress or (lambda msg: None)
    ring = {name for name, _ in camera_positions(scenario.rig)}
    if not any(set(_names(config)) <= ring for config in TABLE3_CONFIGS):
        raise ScenarioError(f"layout compares configurations of at least three ring cameras (cam1, cam2, cam3 ...); "
                            f"scenario {scenario.name} has {', '.join(sorted(ring))}: use a ring such as ring6")
    try:
        poses = PoseSource(poses)
    except ValueError:
        raise BadInputError(f"poses must be one of {[p.value for p in PoseSource]}, got {poses!r}") from None
    variants = VARIANTS
    if algorithm is not None:
        load_algorithm(algorithm)  # a wrong spec fails here, before the session is simulated
        variants += (Variant(algorithm_label(algorithm), FuseOptions(), algorithm),)
    recording, truth = simulate(scenario, progress=False)
    tell("simulated")
    if poses is PoseSource.BODY:
        rig = calibrate_rig(recording, CalibrationOptions(rig=RigMethod.CHAIN), rng=np.random.default_rng(scenario.seed))
        calibration = calibration_from_rig(rig)
    else:
        calibration = true_calibration(recording, truth)
    tell("calibrated")
    views = camera_views(recording, calibration, cross_check=False)
    present = set(views.names)
    configs2 = [c for c in TABLE2_CONFIGS if set(_names(c)) <= present]
    cells3 = [(c, v) for c in TABLE3_CONFIGS if set(_names(c)) <= present for v in variants]
    skeletons = None if algorithm is None else dataclasses.replace(  # what a user's fusion gets, without depth
        recording, cameras=tuple(dataclasses.replace(c, depth=None) for c in recording.cameras))
    table2 = run_sweep(_table2_row, [(views, c, truth, calibration) for c in configs2], options=sweep,
                       desc="table 2")
    table3 = run_sweep(_table3_cell, [(views, c, v, truth, calibration, skeletons if v.algorithm else None)
                                      for c, v in cells3], options=sweep,
                       desc="table 3")
    single = {}
    for n in views.names:
        e = skeleton_errors(fuse_views(views.subset([n]), FuseOptions(method=MergeMethod.AVERAGE)).positions,
                            calibration.T_world_cam, truth, calibration.reference, views.topology)
        single[n] = e["joint_error_mm"]["mean"]
    return {"scenario": scenario.name, "seed": scenario.seed, "poses": poses.value, "table2": table2, "table3": table3,
            "single_camera_joint_error_mm": single,
            "camera_positions": {n: truth.camera(n).T_world_cam[:3, 3].tolist() for n in views.names},
            "camera_axes": {n: truth.camera(n).T_world_cam[:3, 2].tolist() for n in views.names}}


def tables_markdown(result: dict[str, Any]) -> str:
    """Tables 2 and 3 as Markdown."""
    lines = [f"# Camera layouts and merging methods: {result['scenario']}, seed {result['seed']}, "
             f"poses from {result['poses']}", "",
             "## Table 2: camera configurations (Avg(Frontal) merge)", "",
             "| configuration | back pose [%] | high confidence [%] | truth: all cameras see the back [%] | "
             "truth: mean joint error [mm] |", "| --- | --- | --- | --- | --- |"]
    for r in result["table2"]:
        lines.append(f"| {r['config']} | {r['back_pose_pct']:.1f} | {r['high_confidence_pct']:.2f} | "
                     f"{r['true_back_pct']:.1f} | {r['joint_error_mm']:.1f} |")
    lines += ["", "## Table 3: merging methods", "",
              "Bone-length standard deviation over time [mm] (spine-shoulder to shoulder, shoulder to elbow, "
              "elbow to wrist), % of held-out cameras' Tracked joints within 5 / 7 cm, and truth columns: mean joint "
              "error, and median absolute errors of the humerothoracic elevation and plane of elevation and of the "
              "elbow flexion while an arm is raised (ISB angles, fusion.merge.angles).", "",
              "| configuration | method | SS-S | S-E | E-W | within 5 cm [%] | within 7 cm [%] | truth: joint error [mm] | "
              "truth: elevation [deg] | truth: plane of elevation [deg] | truth: elbow flexion [deg] |",
              "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in result["table3"]:
        b = list(r["bone_std_mm"].values())
        lines.append(f"| {r['config']} | {r['method']} | {b[0]:.1f} | {b[1]:.1f} | {b[2]:.1f} | {r['support_5cm']:.1f} | "
                     f"{r['support_7cm']:.1f} | {r['joint_error_mm']:.1f} | {r['elevation_error_deg']:.1f} | "
                     f"{r['plane_of_elevation_error_deg']:.1f} | {r['elbow_flexion_error_deg']:.1f} |")
    best = min(result["single_camera_joint_error_mm"].items(), key=lambda kv: kv[1])
    lines += ["", f"Best single camera: {best[0]}, mean joint error {best[1]:.1f} mm (Average of one camera).", ""]
    return "\n".join(lines)


def plot_tables(result: dict[str, Any], path: Path) -> None:
    """Bar charts of Table 2 and of Table 3's joint error per method and configuration."""
    fig, axes = plt.subplots(1, 2, figsize=(15, 4.8))
    t2 = result["table2"]
    x = np.arange(len(t2))
    ax = axes[0]
    ax.bar(x - 0.2, [r["back_pose_pct"] for r in t2], 0.4, label="back pose [%]")
    ax.bar(x + 0.2, [100 - r["high_confidence_pct"] for r in t2], 0.4, label="not high confidence [%]")
    ax.set_xticks(x, [r["config"] for r in t2], rotation=20)
    ax.set_title("Table 2: camera configurations")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    ax = axes[1]
    configs = sorted({r["config"] for r in result["table3"]}, key=len)
    methods = list(dict.fromkeys(r["method"] for r in result["table3"]))
    width = 0.8 / len(configs)
    for i, c in enumerate(configs):
        vals = [next(r["joint_error_mm"] for r in result["table3"] if r["config"] == c and r["method"] == m)
                for m in methods]
        ax.bar(np.arange(len(methods)) + (i - (len(configs) - 1) / 2) * width, vals, width, label=c)
    ax.set_xticks(np.arange(len(methods)), methods, rotation=30, ha="right", fontsize=8)
    ax.set_ylabel("mean joint error against truth [mm]")
    ax.set_title("Table 3: merging methods")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3, axis="y")
    save_figure(fig, path)


def plot_layouts(result: dict[str, Any], path: Path, *, fov_deg: float = 70.6, reach_m: float = 4.5) -> None:
    """Top view of every Table 2 configuration: cameras, their horizontal fields of view, the subject."""
    configs = [r["config"] for r in result["table2"]]
    cols = 4
    rows = int(np.ceil(len(configs) / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.6 * cols, 3.6 * rows), squeeze=False)
    for ax, label in zip(axes.ravel(), configs):
        numbers = [int(k) for k in label.strip("[]").split(",")]
        for n, pos in result["camera_positions"].items():
            used = int(n[3:]) in numbers
            ax.plot(pos[0], pos[1], "s", color="#37474f" if used else "#cfd8dc", ms=7)
            ax.annotate(n[3:], pos[:2], textcoords="offset points", xytext=(4, 4), fontsize=8)
            if used:
                axis = result["camera_axes"][n]
                heading = np.arctan2(axis[1], axis[0])
                half = np.radians(fov_deg / 2)
                a = np.linspace(heading - half, heading + half, 20)
                wedge = np.vstack([pos[:2], np.column_stack([pos[0] + reach_m * np.cos(a), pos[1] + reach_m * np.sin(a)]),
                                   pos[:2]])
                ax.fill(wedge[:, 0], wedge[:, 1], color="#90caf9", alpha=0.25)
        ax.add_patch(plt.Circle((0, 0), 0.25, color="#c62828", alpha=0.6))
        ax.set_title(label, fontsize=10)
        ax.set_aspect("equal")
        ax.set_xlim(-2.6, 2.6)
        ax.set_ylim(-2.6, 2.6)
        ax.set_xticks([])
        ax.set_yticks([])
    for ax in axes.ravel()[len(configs):]:
        ax.axis("off")
    fig.suptitle("Layouts: cameras used (dark) and their fields of view; subject in red")
    save_figure(fig, path)


def write_layout_report(result: dict[str, Any], out_dir: Path, *, overwrite: bool = False) -> None:
    """Write ``layout.json``, ``tables.md``, ``tables.png`` and ``layouts.png`` atomically."""
    with atomic_directory(out_dir, overwrite=overwrite) as tmp:
        (tmp / "layout.json").write_text(json.dumps(result, indent=1, sort_keys=True) + "\n", encoding="utf-8")
        (tmp / "tables.md").write_text(tables_markdown(result), encoding="utf-8")
        plot_tables(result, tmp / "tables.png")
        plot_layouts(result, tmp / "layouts.png")
