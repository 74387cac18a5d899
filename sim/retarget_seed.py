"""Starting points of the per-frame fit in :mod:`sim.retarget`: the first frame's stance, and arm
poses seeded from the targets where a warm start is stuck at the gimbal-locked shoulder.

The unknowns are the coordinates of :mod:`sim.coordinates` followed by the pelvis height.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from fusion.topology import Landmark, Topology
from sim.coordinates import COORDINATES, INDEX

K = len(COORDINATES)


def initial_guess(target: np.ndarray, weight: np.ndarray, topology: Topology) -> np.ndarray:
    """Neutral stance at the pelvis target, facing where the hips (or shoulders) face."""
    x = np.zeros(K + 1)
    present = weight > 0
    for left, right in ((Landmark.HIP_LEFT, Landmark.HIP_RIGHT), (Landmark.SHOULDER_LEFT, Landmark.SHOULDER_RIGHT)):
        i, j = topology.index(left), topology.index(right)
        if present[i] and present[j]:
            lx, ly = (target[i] - target[j])[:2]
            x[INDEX["root_yaw"]] = np.arctan2(-lx, ly)
            break
    pelvis = topology.index(Landmark.PELVIS)
    centre = target[pelvis] if present[pelvis] else np.nanmean(target[present], axis=0)
    x[INDEX["root_x"]], x[INDEX["root_y"]], x[K] = centre
    return x


_SEED_BELOW = np.radians(25.0)
"""Below this shoulder elevation the plane of elevation is re-seeded from the target (gimbal lock)."""


def trunk_frame(target: np.ndarray, weight: np.ndarray,
                topology: Topology) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Forward, left and up unit vectors of the target trunk (pelvis to spine-shoulder up, shoulder
    line left), or None if those landmarks are absent or degenerate."""
    idx = [topology.index(j) for j in (Landmark.PELVIS, Landmark.SPINE_SHOULDER, Landmark.SHOULDER_LEFT,
                                       Landmark.SHOULDER_RIGHT)]
    if not np.all(weight[idx] > 0):
        return None
    pelvis, spine, ls, rs = target[idx]
    up = spine - pelvis
    left = ls - rs
    left = left - (left @ up) / max(up @ up, 1e-12) * up
    if np.linalg.norm(up) < 1e-6 or np.linalg.norm(left) < 1e-6:
        return None
    up, left = up / np.linalg.norm(up), left / np.linalg.norm(left)
    return np.cross(left, up), left, up


def seed_shoulder_planes(x: np.ndarray, target: np.ndarray, weight: np.ndarray, topology: Topology) -> np.ndarray:
    """Set the plane of elevation of a nearly hanging arm to the plane its target upper arm lies in.

    At ``sh_elevation`` near 0 the Y-X-Y shoulder is gimbal-locked: the landmark error does not
    depend on ``sh_plane``, so a warm start cannot find the plane the arm is about to rise in. The
    plane is taken from the target elbow relative to the target shoulder in the frame of the target
    shoulder line (0 = outwards, pi/2 = forwards); ``sh_rotation`` turns with it to keep the twist.
    """
    frame = trunk_frame(target, weight, topology)
    if frame is None:
        return x
    forward, left, up = frame
    x = x.copy()
    for side, sign, shoulder, elbow in (("l", 1.0, Landmark.SHOULDER_LEFT, Landmark.ELBOW_LEFT),
                                        ("r", -1.0, Landmark.SHOULDER_RIGHT, Landmark.ELBOW_RIGHT)):
        s, e = topology.index(shoulder), topology.index(elbow)
        if not (weight[s] > 0 and weight[e] > 0) or x[INDEX[f"sh_elevation_{side}"]] > _SEED_BELOW:
            continue
        d = target[e] - target[s]
        norm = np.linalg.norm(d)
        if norm < 1e-6 or _angle(d, -up) < np.radians(5.0):
            continue  # target arm hangs too: its plane is undefined as well
        plane = np.arctan2(d @ forward, sign * (d @ left))
        x[INDEX[f"sh_rotation_{side}"]] += plane - x[INDEX[f"sh_plane_{side}"]]
        x[INDEX[f"sh_plane_{side}"]] = plane
    return x


_TWISTS = np.linspace(-np.pi, np.pi, 12, endpoint=False)


def _angle(u: np.ndarray, v: np.ndarray) -> float:
    """Angle between two vectors, radians."""
    c = u @ v / max(np.linalg.norm(u) * np.linalg.norm(v), 1e-12)
    return float(np.arccos(np.clip(c, -1.0, 1.0)))


def restart_guess(x: np.ndarray, target: np.ndarray, weight: np.ndarray, topology: Topology,
                  cost: Callable[[np.ndarray], float], lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Arms re-seeded from the targets: plane (as :func:`seed_shoulder_planes`, at any elevation),
    elevation from the vertical, elbow flexion from the bone angle, and the axial twist of the 12
    candidates that brings the arm's sites closest."""
    x = x.copy()
    x[INDEX["sh_elevation_l"]] = x[INDEX["sh_elevation_r"]] = 0.0
    x = seed_shoulder_planes(x, target, weight, topology)
    for side, (shoulder, elbow, wrist) in (
        ("l", (Landmark.SHOULDER_LEFT, Landmark.ELBOW_LEFT, Landmark.WRIST_LEFT)),
        ("r", (Landmark.SHOULDER_RIGHT, Landmark.ELBOW_RIGHT, Landmark.WRIST_RIGHT)),
    ):
        s, e, w = (topology.index(j) for j in (shoulder, elbow, wrist))
        if not (weight[s] > 0 and weight[e] > 0):
            continue
        upper_arm = target[e] - target[s]
        frame = trunk_frame(target, weight, topology)
        x[INDEX[f"sh_elevation_{side}"]] = _angle(upper_arm, -frame[2] if frame else np.array([0.0, 0.0, -1.0]))
        if weight[w] > 0:
            x[INDEX[f"elbow_flexion_{side}"]] = _angle(upper_arm, target[w] - target[e])
        plane = x[INDEX[f"sh_plane_{side}"]]
        costs = []
        for twist in _TWISTS:
            x[INDEX[f"sh_rotation_{side}"]] = plane + twist
            costs.append(cost(x))
        x[INDEX[f"sh_rotation_{side}"]] = plane + _TWISTS[int(np.argmin(costs))]
    return np.clip(x, lower, upper)
