"""``mocap-bench demo``: every stage on the default scenario, ending in a report with pictures (the
stages through :mod:`scenarios.api`, as a script would run them)."""

from __future__ import annotations

from pathlib import Path

from fusion.io.atomic import write_text_atomic
from fusion.io.calibration_file import save_calibration
from fusion.merge.fuse import Fit, FuseOptions, camera_views, fuse_views
from fusion.merge.methods import MergeMethod
from scenarios import api
from scenarios.config import load_scenario
from scenarios.evaluate import evaluate_to_disk, truth_free_table
from scenarios.fusing import fuse_to_disk
from scenarios.runner import load_run, simulate_to_disk
from scenarios.show import show_run
from scenarios.skeleton_eval import skeleton_errors


def _clinical_cells(err: dict[str, dict[str, float]]) -> str:
    """Table cells: mean joint error and the raised-arm median angle errors of :func:`skeleton_errors`."""
    angles = ("elbow_flexion", "ht_elevation", "ht_plane_of_elevation")
    return " | ".join([f"{err['joint_error_mm']['mean']:.1f}"] + [f"{err[f'{a}_raised_error_deg']['median']:.1f}" for a in angles])


def run_demo(out: Path, *, scenario: str = "fma_2cam", seed: int | None = None,
             duration_s: float | None = None) -> Path:
    """Simulate, draw, calibrate from the body, fuse, score against truth; write ``out/README.md``.

    Files: ``out/run`` (recording + truth), ``out/pictures``, ``out/calibration.toml``,
    ``out/evaluation`` (result.json, arrays.npz, report.md), ``out/fused`` (fused skeleton recording,
    merged point cloud). An existing demo output is replaced.
    """
    out = Path(out)
    sc = load_scenario(scenario)
    stages = 5
    print(f"[1/{stages}] simulating {sc.name}: {sc.description}", flush=True)
    run = simulate_to_disk(sc, out / "run", seed=seed, duration_s=duration_s, overwrite=True)
    recording, truth = load_run(run)
    print(f"[2/{stages}] drawing the rig and each camera's view", flush=True)
    pictures = show_run(recording, truth, out / "pictures")
    print(f"[3/{stages}] calibrating the cameras from the body (skeleton RANSAC + ICP, pose graph)", flush=True)
    run_calib = api.calibrate(recording, seed=recording.metadata["seed"])
    calibration, rig = run_calib.calibration, run_calib.rig
    save_calibration(calibration, out / "calibration.toml")
    print(f"[4/{stages}] scoring the calibration against the truth", flush=True)
    result = evaluate_to_disk(calibration, truth, out / "evaluation", config={"run": str(run)}, overwrite=True)
    print(f"[5/{stages}] fusing the cameras (every merging method) and scoring the fused skeleton", flush=True)
    fused = fuse_to_disk(recording, calibration, out / "fused", FuseOptions(fit=Fit.KINEMATIC), overwrite=True)
    views = camera_views(recording, calibration)
    kin = fuse_views(views, FuseOptions(fit=Fit.KINEMATIC))
    err = skeleton_errors(kin.positions, calibration.T_world_cam, truth, calibration.reference, views.topology)
    fusion_rows = [f"| kinematic fit | {_clinical_cells(err)} |"]
    for method in MergeMethod:
        merged = fuse_views(views, FuseOptions(method=method))
        err = skeleton_errors(merged.positions, calibration.T_world_cam, truth, calibration.reference, views.topology)
        fusion_rows.append(f"| {method.value} | {_clinical_cells(err)} |")
    for name in views.names:
        one = fuse_views(views.subset([name]), FuseOptions(method=MergeMethod.AVERAGE))
        err = skeleton_errors(one.positions, calibration.T_world_cam, truth, calibration.reference, views.topology)
        fusion_rows.append(f"| {name} alone | {_clinical_cells(err)} |")

    lines = [f"# mocap-bench demo: {sc.name}", "", sc.description, "",
             f"Seed {recording.metadata['seed']}, {recording.metadata['duration_s']:.1f} s of session.", "",
             "## Recording", "",
             "| camera | skeleton frames | depth frames | tracked joints | inferred joints | flipped frames (truth) |",
             "| --- | --- | --- | --- | --- | --- |"]
    for cam, ct in zip(recording.cameras, truth.cameras):
        st = cam.skeleton.states
        lines.append(f"| {cam.name} | {cam.skeleton.n_frames} | {0 if cam.depth is None else cam.depth.n_frames} | "
                     f"{(st == 2).mean():.1%} | {(st == 1).mean():.1%} | {ct.flipped.mean():.1%} |")
    lines += ["", "## Calibration from the body", "",
              "Errors of each camera's pose against the truth, relative to the reference camera "
              "(full report: [evaluation/report.md](evaluation/report.md), file: [calibration.toml](calibration.toml)).", "",
              "| camera | rotation error [deg] | translation error [mm] | body points RMSE [mm] |", "| --- | --- | --- | --- |"]
    for name, c in result["cameras"].items():
        lines.append(f"| {name} | {c['rotation_error_deg']:.3f} | {c['translation_error_mm']:.1f} | "
                     f"{c['rmse_points_mm']:.1f} |")
    lines += ["", truth_free_table(calibration), ""]
    lines += [f"- {n}" for n in rig.notes]
    rel = fused["reliability"]
    lines += ["", "## Fusion", "",
              f"Fused skeleton (kinematic fit) and its joint angles (angles.csv, angles.mot) in [fused/](fused/): "
              f"{fused['frames']} frames, high confidence "
              f"{rel['high']:.1%}, back pose {rel['back_pose']:.1%}; merged body cloud "
              f"`fused/cloud.ply` ({fused['cloud'].get('points', 0)} points). Errors against the truth:", "",
              "Angle errors are median absolute errors of the ISB angles while an arm is raised (true "
              "elevation >= 30 deg), both arms pooled.", "",
              "| merge | mean joint error [mm] | elbow flexion error [deg] | elevation error [deg] | "
              "plane of elevation error [deg] |", "| --- | --- | --- | --- | --- |"]
    lines += fusion_rows
    lines += ["", "## Pictures", ""] + [f"![{p.stem}](pictures/{p.name})" for p in pictures]
    write_text_atomic(out / "README.md", "\n".join(lines) + "\n")
    print(f"report: {out / 'README.md'}")
    return out / "README.md"
