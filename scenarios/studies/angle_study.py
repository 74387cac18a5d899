"""``mocap-bench angle-study``: clinical angle and joint errors of the kinematic fusion against
Avg(Frontal) over seeds and camera subsets, with the tracker's static biases on or off.

Per seed the scenario is simulated once, without depth frames, and fused with the true camera poses
(so calibration error does not enter); per camera subset both fusions are scored against the truth
(:func:`scenarios.skeleton_eval.skeleton_errors`): mean joint error, and the median absolute errors of
the ISB elbow flexion and humerothoracic elevation while an arm is raised. Switching the static
biases off (``TrackerBias.OFF``: the body-model and view-dependent bias ranges and the hip offsets of
:class:`sim.tracker_noise.TrackerNoise` set to zero; jitter, outliers, inferred offsets and flips kept),
or one part of them (:class:`TrackerBias`), shows how much of the error each causes. With limb axes
the sessions are simulated with depth frames (at least :data:`LIMB_AXIS_DEPTH_HZ`) and both fusions are
scored once more on the views corrected from the depth clouds (``+axes`` rows; :mod:`fusion.merge.limb_axes`:
limb axes, the shoulders' and hips' centres, the hands).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np

from fusion.calibration import Calibration
from fusion.errors import BadInputError
from fusion.merge.fuse import Fit, FuseOptions, camera_views, fuse_views
from fusion.merge.limb_axes import limb_axes as fit_limb_axes
from fusion.merge.methods import MergeMethod
from fusion.merge.metrics import Stats
from fusion.recording import Recording
from scenarios.api import load_algorithm, run_fusion_algorithm, true_calibration
from scenarios.config import Scenario
from scenarios.runner import build_simulation
from scenarios.skeleton_eval import skeleton_errors
from scenarios.studies.calib_study import algorithm_label
from sim.session import simulate_session
from sim.tracker_bias import TrackerBias, tracker_with
from sim.truth import GroundTruth

FUSIONS = {"avg_frontal": FuseOptions(method=MergeMethod.AVG_FRONTAL), "kinematic": FuseOptions(fit=Fit.KINEMATIC)}

LIMB_AXIS_DEPTH_HZ = 10.0
"""Depth frame rate [Hz] of the sessions scored with limb axes (the scenario's, when higher)."""


def _row(scenario: Scenario, names: list[str] | None, label: str, err: dict[str, dict[str, float]]) -> dict[str, Any]:
    return {"seed": scenario.seed, "cameras": "all" if names is None else "+".join(names), "fusion": label,
            "joint_error_mm": err["joint_error_mm"]["mean"],
            "elbow_flexion_deg": err["elbow_flexion_raised_error_deg"]["median"],
            "ht_elevation_deg": err["ht_elevation_raised_error_deg"]["median"]}


def _algorithm_errors(fn: Callable[..., Any], spec: str, recording: Recording, calibration: Calibration,
                      truth: GroundTruth, names: list[str] | None) -> dict[str, dict[str, float]]:
    """A user's fusion of the named cameras (all when None), scored on the frames of the first of them."""
    names = list(recording.camera_names) if names is None else names
    positions = run_fusion_algorithm(fn, recording, calibration, cameras=names, name=spec)
    return skeleton_errors(positions, calibration.T_world_cam, truth, names[0], recording.topology)


def _one_seed(scenario: Scenario, subsets: list[list[str] | None], bias: TrackerBias,
              algorithm: str | None = None, limb_axes: bool = False) -> list[dict[str, Any]]:
    sim = build_simulation(scenario)
    tracker = tracker_with(sim.sensors.tracker, bias)
    depth_hz = max(sim.sensors.depth_rate_hz, LIMB_AXIS_DEPTH_HZ) if limb_axes else 0.0
    sim = dataclasses.replace(sim, sensors=dataclasses.replace(sim.sensors, tracker=tracker, depth_rate_hz=depth_hz))
    recording, truth = simulate_session(sim.humanoid, sim.motion, sim.rig, sim.sensors, seed=sim.session_seed,
                                        person_seed=sim.person_seed, duration_s=scenario.duration_s or sim.motion.duration,
                                        metadata={"scenario": scenario.name, "seed": scenario.seed})
    calibration = true_calibration(recording, truth)
    views = camera_views(recording, calibration)
    fn = None if algorithm is None else load_algorithm(algorithm)
    rows = []
    for names in subsets:
        sub = views if names is None else views.subset(names)
        variants = {"": None}
        if limb_axes:
            variants["+axes"] = fit_limb_axes(sub, recording, calibration)
        for suffix, axes in variants.items():
            for label, options in FUSIONS.items():
                err = skeleton_errors(fuse_views(sub, options, axes).positions, calibration.T_world_cam, truth,
                                      calibration.reference, views.topology)
                rows.append(_row(scenario, names, label + suffix, err))
        if fn is not None:
            rows.append(_row(scenario, names, algorithm_label(algorithm),
                             _algorithm_errors(fn, algorithm, recording, calibration, truth, names)))
    return rows


def angle_study(scenario: Scenario, seeds: list[int], *, subsets: list[list[str] | None] | None = None,
                bias: TrackerBias = TrackerBias.ON, progress: Callable[[int], None] | None = None,
                algorithm: str | None = None, limb_axes: bool = False) -> dict[str, Any]:
    """Run the study (see the module docstring).

    Parameters
    ----------
    scenario : the scenario (its seed is replaced by each of ``seeds``).
    seeds : at least one seed.
    subsets : camera subsets (None = all cameras); default all cameras only.
    bias : the tracker's static biases on or off.
    progress : called with 1 after each seed.
    algorithm : a user's fusion ``MODULE:FUNCTION`` (see :mod:`scenarios.api`), scored beside the
        built-in fusions on the same sessions and true camera poses (rows ``algorithm:FUNCTION``).
    limb_axes : also score both fusions on the views corrected by the limb axes (module docstring).

    Returns
    -------
    dict
        ``rows`` (one per seed, subset and fusion) and ``summary`` per subset and fusion: mean over
        seeds of the joint error, its reduction against Avg(Frontal) [%], and mean / median over seeds of
        the two angle errors.
    """
    if not seeds:
        raise BadInputError("the angle study needs at least one seed")
    if algorithm is not None:
        load_algorithm(algorithm)  # a wrong spec fails here, before any session is simulated
    subsets = subsets or [None]
    rows = []
    for seed in seeds:
        rows += _one_seed(scenario.replace(seed=seed), subsets, bias, algorithm, limb_axes)
        if progress:
            progress(1)
    summary = {}
    for cams in dict.fromkeys(r["cameras"] for r in rows):
        base = np.array([r["joint_error_mm"] for r in rows if r["cameras"] == cams and r["fusion"] == "avg_frontal"])
        for label in dict.fromkeys(r["fusion"] for r in rows if r["cameras"] == cams):
            sel = [r for r in rows if r["cameras"] == cams and r["fusion"] == label]
            joint = np.array([r["joint_error_mm"] for r in sel])
            summary[f"{cams} {label}"] = {
                "joint_error_mm": float(joint.mean()),
                "joint_error_reduction_pct": Stats.of(100.0 * (1.0 - joint / base)).as_dict(),
                "elbow_flexion_deg": Stats.of(np.array([r["elbow_flexion_deg"] for r in sel])).as_dict(),
                "ht_elevation_deg": Stats.of(np.array([r["ht_elevation_deg"] for r in sel])).as_dict(),
            }
    return {"scenario": scenario.name, "seeds": seeds, "tracker_bias": bias.value, "limb_axes": limb_axes,
            "rows": rows, "summary": summary}


def angle_study_markdown(result: dict[str, Any]) -> str:
    """The study's summary and per-seed rows as Markdown."""
    lines = [f"# Angle study: {result['scenario']}, seeds {result['seeds'][0]}-{result['seeds'][-1]}, "
             f"tracker static biases {result['tracker_bias']}", "",
             "True camera poses. Joint error: mean over joints and frames, then over seeds; reduction against "
             "Avg(Frontal) per seed, mean +- standard deviation over seeds. Angles: median absolute error while an arm is raised, "
             "then mean / median over seeds."
             + (" Rows `+axes`: the same fusion after the joints were corrected from the depth clouds (depth at 10 Hz "
                "or the scenario's rate): the limb joints onto the limb axes, the shoulders and hips to where those "
                "axes meet in the trunk, the hands to the cloud's hand." if result.get("limb_axes") else ""), "",
             "| cameras + fusion | joint error [mm] | reduction [%] | elbow flexion [deg] | elevation [deg] |",
             "| --- | --- | --- | --- | --- |"]
    for key, s in result["summary"].items():
        r = s["joint_error_reduction_pct"]
        lines.append(f"| {key} | {s['joint_error_mm']:.1f} | {r['mean']:.1f} +- {r['std']:.1f} | "
                     f"{s['elbow_flexion_deg']['mean']:.1f} / {s['elbow_flexion_deg']['median']:.1f} | "
                     f"{s['ht_elevation_deg']['mean']:.1f} / {s['ht_elevation_deg']['median']:.1f} |")
    lines += ["", "| seed | cameras | fusion | joint error [mm] | elbow flexion [deg] | elevation [deg] |",
              "| --- | --- | --- | --- | --- | --- |"]
    lines += [f"| {r['seed']} | {r['cameras']} | {r['fusion']} | {r['joint_error_mm']:.1f} | "
              f"{r['elbow_flexion_deg']:.1f} | {r['ht_elevation_deg']:.1f} |" for r in result["rows"]]
    return "\n".join(lines) + "\n"
