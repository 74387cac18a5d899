"""Calibration study over seeds: the paper's Table 1 shape and the ring loop-closure figure.

For every seed the scenario is simulated, the camera pairs are measured once (skeleton RANSAC and
ICP) and the rig is assembled four ways: skeleton-only or ICP-refined, chained or pose graph. Each
variant is scored against the truth; consecutive seeds are separate sessions of the same rig, so
the RMSE between their calibrations is the session-to-session measure.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from fusion.calibrate.floor import GaugeMode
from fusion.calibrate.options import CalibrationOptions, RigMethod
from fusion.calibrate.pipeline import assemble_rig, measure_pairs
from fusion.calibrate.results import calibration_from_rig
from fusion.calibration import Calibration
from fusion.errors import BadInputError, CalibrationError
from fusion.io.atomic import atomic_directory
from fusion.merge.fuse import Fit, FuseOptions, camera_views, fuse_views
from fusion.recording import Recording
from fusion.transforms import apply, invert
from scenarios.config import load_scenario
from scenarios.evaluate import score_calibration, session_to_session_rmse_mm
from scenarios.show import plt, save_figure
from scenarios.skeleton_eval import skeleton_errors
from scenarios.sweep import SweepOptions, run_sweep
from sim.truth import GroundTruth

ANGLES = ("elbow_flexion", "ht_elevation")
"""Clinical angles whose error (kinematic fusion with each calibration, arm raised) the study reports."""

VARIANTS = tuple((refined, rig) for refined in (False, True) for rig in (RigMethod.CHAIN, RigMethod.GRAPH))


def variant_name(refined: bool, rig: RigMethod) -> str:
    """Label of one variant, e.g. ``icp+graph``."""
    return f"{'icp' if refined else 'skeleton'}+{rig.value}"


def algorithm_label(spec: str) -> str:
    """Variant label of a user's calibration ``MODULE:FUNCTION``: ``algorithm:FUNCTION``."""
    return f"algorithm:{spec.rpartition(':')[2]}"


def _scores(calibration: Calibration, recording: Recording, truth: GroundTruth, gauge: GaugeMode) -> dict[str, Any]:
    """One calibration's errors against the truth, and the arm-raised angle errors of the kinematic
    fusion with it (the world brought onto the truth by ``gauge``)."""
    scores = score_calibration(calibration.T_world_cam, truth, calibration.reference)
    views = camera_views(recording, calibration)
    angles = skeleton_errors(fuse_views(views, FuseOptions(fit=Fit.KINEMATIC)).positions, calibration.T_world_cam,
                             truth, calibration.reference, views.topology, gauge=gauge)
    T_ref_world = invert(calibration.T_world_cam[calibration.reference])
    return {
        "T_ref_cam": {n: (T_ref_world @ T).tolist() for n, T in calibration.T_world_cam.items()},
        "rotation_error_deg": {c.name: c.rotation_error_deg for c in scores.cameras},
        "translation_error_mm": {c.name: c.translation_error_mm for c in scores.cameras},
        "rmse_points_mm": {c.name: c.rmse_points_mm for c in scores.cameras},
    } | {f"{a}_deg": angles[f"{a}_raised_error_deg"]["median"] for a in ANGLES}


def _one_seed(scenario_name: str, seed: int, duration_s: float | None, algorithm: str | None = None) -> dict[str, Any]:
    """Simulate, calibrate and score one session (and a user's calibration, ``MODULE:FUNCTION``);
    returns plain numbers (picklable)."""
    from scenarios.api import load_algorithm, run_calibration_algorithm
    from scenarios.runner import simulate

    scenario = load_scenario(scenario_name).replace(seed=seed)
    if duration_s is not None:
        scenario = scenario.replace(duration_s=duration_s)
    recording, truth = simulate(scenario, progress=False)
    rng = np.random.default_rng(seed)
    out: dict[str, Any] = {"seed": seed, "variants": {}}
    try:
        measured = measure_pairs(recording, CalibrationOptions(), rng=rng)
        for refined, rig in VARIANTS:
            calib = assemble_rig(recording, measured, rig=rig, refined=refined, rng=np.random.default_rng(seed))
            out["variants"][variant_name(refined, rig)] = _scores(calibration_from_rig(calib), recording, truth,
                                                                  GaugeMode.FLOOR) | {
                "loop_closure_mm": None if calib.loop is None else calib.loop.mean_mm}
    except CalibrationError as exc:  # a session the body cannot calibrate is a result of the study
        return {"seed": seed, "variants": {}, "failed": str(exc)}
    if algorithm is not None:
        mine = run_calibration_algorithm(load_algorithm(algorithm), recording, rng=np.random.default_rng(seed),
                                         name=algorithm)
        out["variants"][algorithm_label(algorithm)] = _scores(mine, recording, truth, GaugeMode.RIGID) | {
            "loop_closure_mm": None}
    out["reference"] = measured.reference
    T_ref_world = invert(truth.camera(measured.reference).T_world_cam)
    out["body_ref_cam"] = apply(T_ref_world, truth.joints_world.reshape(-1, 3)[::97]).tolist()
    return out


def _percentiles(values: list[float]) -> tuple[float, float]:
    v = np.asarray(values, dtype=float)
    return float(np.median(v)), float(np.percentile(v, 90))


def summarise(runs: list[dict[str, Any]]) -> dict[str, Any]:
    """Median and 90th percentile of each variant's errors over the calibrated seeds and cameras,
    session-to-session RMSE over consecutive calibrated seeds, and loop closure per seed.

    Raises
    ------
    CalibrationError
        No seed could be calibrated.
    """
    failed = [r for r in runs if "failed" in r]
    runs = [r for r in runs if "failed" not in r]
    if not runs:
        raise CalibrationError(f"no seed could be calibrated, e.g. seed {failed[0]['seed']}: {failed[0]['failed']}")
    summary: dict[str, Any] = {}
    for name in runs[0]["variants"]:
        rot, trans, pts, loops, s2s = [], [], [], [], []
        for run in runs:
            v = run["variants"][name]
            others = [c for c in v["rotation_error_deg"] if c != run["reference"]]
            rot += [v["rotation_error_deg"][c] for c in others]
            trans += [v["translation_error_mm"][c] for c in others]
            pts += [v["rmse_points_mm"][c] for c in others]
            if v["loop_closure_mm"] is not None:
                loops.append(v["loop_closure_mm"])
        for a, b in zip(runs, runs[1:]):
            Ta = {n: np.array(T) for n, T in a["variants"][name]["T_ref_cam"].items()}
            Tb = {n: np.array(T) for n, T in b["variants"][name]["T_ref_cam"].items()}
            s2s.append(session_to_session_rmse_mm(Ta, Tb, np.asarray(a["body_ref_cam"])))
        summary[name] = {
            "rotation_error_deg": _percentiles(rot),
            "translation_error_mm": _percentiles(trans),
            "rmse_points_mm": _percentiles(pts),
            "session_to_session_rmse_mm": _percentiles(s2s) if s2s else None,
            "loop_closure_mm": _percentiles(loops) if loops else None,
            "loop_closure_per_seed_mm": loops,
        } | {f"{a}_deg": _percentiles([run["variants"][name][f"{a}_deg"] for run in runs]) for a in ANGLES}
    return summary


def run_study(scenario_name: str, seeds: list[int], *, duration_s: float | None = None,
              sweep: SweepOptions = SweepOptions(), algorithm: str | None = None) -> list[dict[str, Any]]:
    """Run :func:`_one_seed` for every seed as a Dask sweep (see :mod:`scenarios.sweep`); runs in seed order.

    ``algorithm``: a user's calibration ``MODULE:FUNCTION`` (see :mod:`scenarios.api`) scored beside
    the built-in variants on the same sessions.
    """
    from scenarios.api import load_algorithm

    if len(seeds) < 1:
        raise BadInputError("the study needs at least one seed")
    if algorithm is not None:
        load_algorithm(algorithm)  # a wrong spec fails here, before any session is simulated
    return run_sweep(_one_seed, [(scenario_name, int(s), duration_s, algorithm) for s in seeds], options=sweep,
                     desc=f"study {scenario_name}")


def table1(summary: dict[str, Any], scenario_name: str, n_seeds: int, failed: dict[int, str] | None = None) -> str:
    """Markdown in the shape of the paper's Table 1, with errors against truth instead of a checkerboard;
    ``failed``: seed -> why the body could not calibrate it (listed under the table)."""
    failed = failed or {}
    lines = [
        f"# Calibration study: {scenario_name}, {n_seeds} seeds",
        "",
        "Errors of every non-reference camera against the simulation's truth (`T_ref_cam`, gauge-free), "
        "as median / 90th percentile over seeds and cameras. Session-to-session: RMSE between the "
        "calibrations of consecutive seeds (separate sessions of the same rig) over body points. The "
        "paper (real Kinect v2, two cameras): body vs checkerboard 0.79 deg, 25 mm; session-to-session "
        "14.4 mm (body) and 9.2 mm (checkerboard); six-camera ring loop closure 31.1 mm skeleton-only, "
        "19.6 mm with ICP. Elbow flexion and elevation: median absolute error of the ISB angles "
        "(fusion.merge.angles) while an arm is raised, kinematic fusion with each calibration, median / 90th "
        "percentile over seeds. A user's calibration (`algorithm:` rows) is scored the same way, its angles "
        "after a rigid alignment of its world to the true one (it need not find the floor).",
        "",
        "| variant | rotation [deg] | translation [mm] | points RMSE [mm] | session-to-session [mm] | loop closure [mm] "
        "| elbow flexion [deg] | elevation [deg] |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]

    def cell(pair: tuple[float, float] | None, fmt: str) -> str:
        return "n/a" if pair is None else f"{pair[0]:{fmt}} / {pair[1]:{fmt}}"

    for name, s in summary.items():
        lines.append(f"| {name} | {cell(s['rotation_error_deg'], '.2f')} | {cell(s['translation_error_mm'], '.1f')} | "
                     f"{cell(s['rmse_points_mm'], '.1f')} | {cell(s['session_to_session_rmse_mm'], '.1f')} | "
                     f"{cell(s['loop_closure_mm'], '.1f')} | {cell(s['elbow_flexion_deg'], '.1f')} | "
                     f"{cell(s['ht_elevation_deg'], '.1f')} |")
    if failed:
        lines += ["", f"Calibrated {n_seeds - len(failed)} of {n_seeds} seeds; the table is over those. Not calibrated:"]
        lines += [f"- seed {seed}: {why}" for seed, why in failed.items()]
    return "\n".join(lines) + "\n"


def plot_study(runs: list[dict[str, Any]], summary: dict[str, Any], path: Path) -> None:
    """Per-variant error distributions of calibrated ``runs``, and the loop closure per seed when the rig is a ring."""
    has_loop = any(s["loop_closure_per_seed_mm"] for s in summary.values())
    fig, axes = plt.subplots(1, 3 if has_loop else 2, figsize=(14 if has_loop else 10, 4.2))
    names = list(summary)
    for ax, key, unit in ((axes[0], "rotation_error_deg", "deg"), (axes[1], "translation_error_mm", "mm")):
        data = [[v for run in runs for c, v in run["variants"][n][key].items() if c != run["reference"]] for n in names]
        ax.boxplot(data, showfliers=True)
        ax.set_xticks(range(1, len(names) + 1), names, rotation=20)
        ax.set_ylabel(f"{key.split('_')[0]} error [{unit}]")
        ax.set_yscale("log")
        ax.grid(alpha=0.3)
    if has_loop:
        ax = axes[2]
        for refined_name in ("skeleton+chain", "icp+chain"):
            loops = summary[refined_name]["loop_closure_per_seed_mm"]
            ax.plot(range(len(loops)), loops, "o-", label=refined_name.split("+")[0])
        ax.axhline(31.1, color="grey", ls="--", lw=0.8, label="paper, skeleton (31.1 mm)")
        ax.axhline(19.6, color="grey", ls=":", lw=0.8, label="paper, ICP (19.6 mm)")
        ax.set_xlabel("seed index")
        ax.set_ylabel("ring loop closure [mm]")
        ax.set_yscale("log")
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    fig.suptitle("Calibration errors against truth over seeds")
    save_figure(fig, path)


def write_study(out_dir: Path, scenario_name: str, runs: list[dict[str, Any]], *, overwrite: bool = False) -> dict:
    """Write ``study.json``, ``table1.md`` and ``study.png`` atomically; returns the summary."""
    summary = summarise(runs)
    failed = {r["seed"]: r["failed"] for r in runs if "failed" in r}
    calibrated = [r for r in runs if "failed" not in r]
    with atomic_directory(out_dir, overwrite=overwrite) as tmp:
        doc = {"scenario": scenario_name, "seeds": [r["seed"] for r in runs], "summary": summary,
               "failed": {str(k): v for k, v in failed.items()},
               "runs": [{k: v for k, v in r.items() if k != "body_ref_cam"} for r in calibrated]}
        (tmp / "study.json").write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n", encoding="utf-8")
        (tmp / "table1.md").write_text(table1(summary, scenario_name, len(runs), failed), encoding="utf-8")
        plot_study(calibrated, summary, tmp / "study.png")
    return summary
