"""Fused skeletons scored against ground truth: per-joint position error and clinical joint angles."""

from __future__ import annotations

import numpy as np

from fusion.arrays import unit
from fusion.calibrate.floor import GaugeMode, align_gauge
from fusion.facing import trunk_frame
from fusion.merge.metrics import Stats
from fusion.topology import Landmark, Topology
from fusion.transforms import apply
from sim.truth import GroundTruth


def arm_angles_deg(positions: np.ndarray, topology: Topology) -> dict[str, np.ndarray]:
    """Shoulder flexion, shoulder abduction and elbow flexion [deg] per frame and side, (T,) each.

    Trunk frame from :func:`fusion.facing.trunk_frame` (up from the pelvis to the spine-shoulder,
    left from the right to the left shoulder, forward = left x up). Flexion is the upper arm's angle from hanging down within the sagittal plane
    (forward positive), abduction within the frontal plane (outward positive); elbow flexion is 180
    degrees minus the shoulder-elbow-wrist angle.
    """
    P = positions

    def j(lm: Landmark) -> np.ndarray:
        return P[:, topology.index(lm)]

    left, up, forward = trunk_frame(P, topology)
    out = {}
    for side, sign, (sh, el, wr) in (
        ("left", 1.0, (Landmark.SHOULDER_LEFT, Landmark.ELBOW_LEFT, Landmark.WRIST_LEFT)),
        ("right", -1.0, (Landmark.SHOULDER_RIGHT, Landmark.ELBOW_RIGHT, Landmark.WRIST_RIGHT)),
    ):
        upper = j(el) - j(sh)
        lower = j(wr) - j(el)
        down = -np.einsum("tk,tk->t", upper, up)
        out[f"shoulder_flexion_{side}"] = np.degrees(np.arctan2(np.einsum("tk,tk->t", upper, forward), down))
        out[f"shoulder_abduction_{side}"] = np.degrees(np.arctan2(sign * np.einsum("tk,tk->t", upper, left), down))
        cos = np.einsum("tk,tk->t", unit(upper), unit(lower))
        out[f"elbow_flexion_{side}"] = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    return out


def skeleton_errors(positions_world: np.ndarray, T_world_cam_est: dict[str, np.ndarray], truth: GroundTruth,
                    reference: str, topology: Topology, *, gauge: GaugeMode = GaugeMode.FLOOR
                    ) -> dict[str, dict[str, float]]:
    """Errors of a fused skeleton on the reference camera's frames against the true joints.

    The estimated world is brought onto the true one by the gauge transform of the camera poses
    first (see :mod:`scenarios.evaluate`): FLOOR when the calibration found the floor (depth),
    RIGID when it could not (skeleton-only sessions have no floor).

    Returns
    -------
    dict
        ``joint_error_mm`` (all joints and frames) and per clinical angle ``<angle>_error_deg``,
        each as rmse / mean / median / std / max.
    """
    T_true_est, _ = align_gauge(T_world_cam_est, truth.T_world_cam(), mode=gauge)
    est = apply(T_true_est, positions_world)
    true = truth.camera(reference).joints_world
    if est.shape != true.shape:
        raise ValueError(f"fused skeleton {est.shape} does not match the reference camera's truth {true.shape}")
    out = {"joint_error_mm": Stats.of(np.linalg.norm(est - true, axis=-1).ravel() * 1e3).as_dict()}
    a_est, a_true = arm_angles_deg(est, topology), arm_angles_deg(true, topology)
    for name in a_est:
        out[f"{name}_error_deg"] = Stats.of(np.abs(a_est[name] - a_true[name])).as_dict()
    return out
