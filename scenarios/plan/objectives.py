"""Objectives of one camera layout in one simulated session (one seed), all "lower is better".

The room's protocol is simulated with the layout's cameras, calibrated from the body (skeleton
RANSAC, pose graph, no ICP refinement) and fused (Avg(Frontal)); the result is scored against the
simulation's truth (after the floor gauge when the room simulates depth frames, else the rigid
gauge: without depth the calibration has no floor):

- ``joint_error_mm``: mean fused joint error against the true joints [mm].
- ``angle_error_deg``: mean error of the six clinical arm angles (shoulder flexion, abduction and
  elbow flexion, both sides) [deg].
- ``back_pose_pct``: merged joints in a back pose [%]; ``not_high_confidence_pct``: merged joints
  without high confidence [%] (the paper's Table 2 columns).
- ``arm_occluded_pct``: joint-instants of the moving arm (elbow, wrist, hand) during the protocol's
  repetitions that no camera has in direct line of sight [%] (truth).
- ``calibration_rotation_deg``, ``calibration_translation_mm``: median error of the body-based
  calibration of the non-reference cameras against the true poses.
- ``cameras``: the number of cameras (cost).

Besides the objectives, each session records the clinical detail the install sheet reports
(:data:`CLINICAL`): the mean error of each clinical angle, both sides pooled (humerothoracic
elevation and plane of elevation, elbow flexion, trunk flexion and lateral lean) [deg] and the
mean position error of each joint group (both sides pooled) [mm], after the same gauge.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from fusion.calibrate.floor import GaugeMode, align_gauge
from fusion.calibrate.options import CalibrationOptions, Refinement, RigMethod
from fusion.calibrate.pipeline import calibrate_rig
from fusion.calibrate.results import calibration_from_rig
from fusion.errors import BenchError
from fusion.merge.fuse import (
    FuseOptions,
    camera_views,
    fuse_views,
    reliability_fractions,
)
from fusion.topology import Landmark, Topology
from fusion.transforms import apply
from scenarios.config import CameraConfig, RigConfig
from scenarios.evaluate import score_calibration
from scenarios.plan.room import Room
from scenarios.skeleton_eval import skeleton_errors
from sim.truth import GroundTruth

OBJECTIVES = ("joint_error_mm", "angle_error_deg", "back_pose_pct", "not_high_confidence_pct", "arm_occluded_pct",
              "calibration_rotation_deg", "calibration_translation_mm", "cameras")

Layout = tuple[tuple[float, float, float, float], ...]
"""Cameras as (x, y, z, aim height) in the room frame [m]; each looks at the subject's centre at the aim height."""

CLINICAL_ANGLES = {"ht_elevation_error_deg": ("ht_elevation_left", "ht_elevation_right"),
                   "ht_plane_of_elevation_error_deg": ("ht_plane_of_elevation_left", "ht_plane_of_elevation_right"),
                   "elbow_flexion_error_deg": ("elbow_flexion_left", "elbow_flexion_right"),
                   "trunk_flexion_error_deg": ("trunk_flexion",),
                   "trunk_lateral_lean_error_deg": ("trunk_lateral_lean",)}
"""Session key -> the angles of :func:`fusion.merge.angles.angle_names` it pools (mean over frames and sides)."""

JOINT_GROUPS = {"trunk_error_mm": (Landmark.SPINE_MID, Landmark.SPINE_SHOULDER),
                "shoulder_error_mm": (Landmark.SHOULDER_LEFT, Landmark.SHOULDER_RIGHT),
                "elbow_error_mm": (Landmark.ELBOW_LEFT, Landmark.ELBOW_RIGHT),
                "wrist_error_mm": (Landmark.WRIST_LEFT, Landmark.WRIST_RIGHT),
                "hand_error_mm": (Landmark.HAND_LEFT, Landmark.HAND_RIGHT)}
"""Session key -> the joints whose mean position error it holds."""

CLINICAL = (*CLINICAL_ANGLES, *JOINT_GROUPS)
"""Per-angle and per-joint keys of a session (not scored; see the module docstring)."""

_ARM = {"left": (Landmark.ELBOW_LEFT, Landmark.WRIST_LEFT, Landmark.HAND_LEFT),
        "right": (Landmark.ELBOW_RIGHT, Landmark.WRIST_RIGHT, Landmark.HAND_RIGHT)}


def rig_config(room: Room, layout: Layout) -> RigConfig:
    """The layout as explicit scenario cameras in the simulation's world frame (subject at the origin)."""
    T = room.T_world_room
    cams = []
    for k, (x, y, z, aim) in enumerate(layout):
        p = apply(T, np.array([[x, y, z]]))[0]
        cams.append(CameraConfig(f"cam{k + 1}", [float(v) for v in p], [0.0, 0.0, float(aim)]))
    return RigConfig(camera=cams)


def arm_occluded_pct(truth: GroundTruth, topology: Topology) -> float:
    """% of moving-arm joint-instants during repetitions that no camera sees directly (NaN without repetitions)."""
    ref_times = truth.cameras[0].true_times
    hidden, total = 0, 0
    for rep in truth.repetitions:
        if rep["side"] not in _ARM:
            continue
        joints = [topology.index(lm) for lm in _ARM[rep["side"]]]
        frames = (ref_times >= rep["t_start"]) & (ref_times <= rep["t_end"])
        seen = np.zeros((int(frames.sum()), len(joints)), dtype=bool)
        for cam in truth.cameras:
            k = np.clip(np.searchsorted(cam.true_times, ref_times[frames]), 0, cam.true_times.size - 1)
            seen |= cam.visible[k][:, joints]
        hidden += int((~seen).sum())
        total += seen.size
    return float(hidden / total * 100) if total else float("nan")


def evaluate_layout(room: Room, layout: Layout, seed: int) -> dict[str, Any]:
    """Simulate, calibrate, fuse and score one layout with one seed.

    Returns
    -------
    dict
        ``seed``, ``error`` (None, or why calibration or fusion failed) and every name of
        :data:`OBJECTIVES` (NaN when it could not be measured).
    """
    from scenarios.runner import simulate

    scenario = dataclasses.replace(room.scenario(f"{room.room.name}-plan", seed), rig=rig_config(room, layout))
    recording, truth = simulate(scenario, progress=False)
    out: dict[str, Any] = {name: float("nan") for name in (*OBJECTIVES, *CLINICAL)}
    out.update(seed=seed, error=None, cameras=float(len(layout)), arm_occluded_pct=arm_occluded_pct(truth, recording.topology))
    try:
        rig = calibrate_rig(recording, CalibrationOptions(refine=Refinement.NONE, rig=RigMethod.GRAPH),
                            rng=np.random.default_rng(seed))
        calibration = calibration_from_rig(rig)
        merged = fuse_views(camera_views(recording, calibration), FuseOptions())
    except BenchError as exc:
        out["error"] = f"{type(exc).__name__}: {exc}"
        return out
    scores = score_calibration(calibration.T_world_cam, truth, calibration.reference).summary()
    rel = reliability_fractions(merged)
    gauge = GaugeMode.FLOOR if room.sensors.depth_rate_hz > 0 else GaugeMode.RIGID  # no depth, no floor
    errors = skeleton_errors(merged.positions, calibration.T_world_cam, truth, calibration.reference,
                             recording.topology, gauge=gauge)
    angles = [v["mean"] for k, v in errors.items() if k.endswith("_error_deg")]
    out.update(_clinical(errors, merged.positions, calibration.T_world_cam, truth, calibration.reference,
                         recording.topology, gauge))
    out.update(joint_error_mm=errors["joint_error_mm"]["mean"], angle_error_deg=float(np.mean(angles)),
               back_pose_pct=rel["back_pose"] * 100, not_high_confidence_pct=(1 - rel["high"]) * 100,
               calibration_rotation_deg=scores["rotation_error_deg"]["median"],
               calibration_translation_mm=scores["translation_error_mm"]["median"])
    return out


def _clinical(errors: dict[str, dict[str, float]], positions_world: np.ndarray,
              T_world_cam_est: dict[str, np.ndarray], truth: GroundTruth, reference: str, topology: Topology,
              gauge: GaugeMode) -> dict[str, float]:
    """The :data:`CLINICAL` values of one session from ``skeleton_errors``' output and the fused joints (T, J, 3)."""
    out = {key: float(np.nanmean([errors[f"{a}_error_deg"]["mean"] for a in names]))
           for key, names in CLINICAL_ANGLES.items()}
    T_true_est, _ = align_gauge(T_world_cam_est, truth.T_world_cam(), mode=gauge)
    error_mm = np.linalg.norm(apply(T_true_est, positions_world) - truth.camera(reference).joints_world, axis=-1) * 1e3
    for key, landmarks in JOINT_GROUPS.items():
        out[key] = float(np.nanmean(error_mm[:, [topology.index(lm) for lm in landmarks]]))
    return out


FAILURE_PENALTY = 1000.0
"""Score added per failed session (calibration or fusion impossible): a layout that fails loses."""


def score(room: Room, result: dict[str, Any]) -> float:
    """Weighted sum of one session's objectives (weights from ``[objective]``); lower is better."""
    if result["error"] is not None:
        return FAILURE_PENALTY
    weights = dataclasses.asdict(room.objective)
    return float(sum(w * result[k] for k, w in weights.items() if w and np.isfinite(result[k])))
