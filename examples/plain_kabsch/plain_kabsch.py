"""A textbook calibration, written against the mocap-bench API only: each camera's skeleton joints
matched in time with the reference camera's, then one least-squares rigid fit (Kabsch) over every
joint both cameras report as tracked. No outlier rejection, no clock estimation, no back-facing check.

``calibrate(recording, rng=rng)`` is the interface ``--algorithm`` and the property tests call.
"""

from __future__ import annotations

import numpy as np

from scenarios.api import Recording

TRACKED = 2
"""Tracking state of a joint the sensor measured (1: inferred, 0: not tracked)."""


def kabsch(p_a: np.ndarray, p_b: np.ndarray) -> np.ndarray:
    """(4, 4) ``T_a_b`` minimising ``sum |p_a - T_a_b p_b|^2`` over matched (N, 3) points [m]."""
    ca, cb = p_a.mean(axis=0), p_b.mean(axis=0)
    u, _, vt = np.linalg.svd((p_b - cb).T @ (p_a - ca))
    d = np.sign(np.linalg.det(vt.T @ u.T))
    R = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, ca - R @ cb
    return T


def matched_joints(ref, cam, max_gap_s: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """Joints tracked by both streams at frames less than ``max_gap_s`` apart: two (N, 3) arrays [m]."""
    k = np.clip(np.searchsorted(ref.timestamps, cam.timestamps), 1, len(ref.timestamps) - 1)
    k -= (cam.timestamps - ref.timestamps[k - 1]) < (ref.timestamps[k] - cam.timestamps)
    close = np.abs(ref.timestamps[k] - cam.timestamps) < max_gap_s
    both = (ref.states[k] == TRACKED) & (cam.states == TRACKED) & close[:, None]
    return ref.positions[k][both], cam.positions[both]


def calibrate(recording: Recording, *, rng: np.random.Generator) -> dict[str, np.ndarray]:
    """``T_world_cam`` per camera, the world being the first camera's frame (``rng`` is not needed)."""
    ref = recording.cameras[0].skeleton
    poses = {recording.cameras[0].name: np.eye(4)}
    for cam in recording.cameras[1:]:
        p_ref, p_cam = matched_joints(ref, cam.skeleton)
        if len(p_ref) < 3:
            raise ValueError(f"{cam.name} shares fewer than 3 tracked joints with {recording.cameras[0].name}")
        poses[cam.name] = kabsch(p_ref, p_cam)
    return poses
