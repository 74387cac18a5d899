"""Starting points of the per-frame fit in :mod:`sim.retarget`: the first frame's stance, and arm
poses solved in closed form from the targets where a warm start is stuck at the gimbal-locked
shoulder or in the wrong basin.

The unknowns are the coordinates of :mod:`sim.coordinates` followed by the pelvis height. The arm
poses are solved in the frame of the body the shoulder hinges ride on (the clavicle, see
:mod:`sim.humanoid_model`), taken from the humanoid at the current estimate: the shoulder is the
Y-X-Y sequence ``R = Rz(-sh_plane) Rx(sh_elevation) Rz(sh_rotation)`` of the left arm (the right
arm is its mirror image ``y -> -y``), the upper arm hangs along -z and the elbow flexes the forearm
towards +x of the upper arm.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from fusion.topology import Landmark, Topology
from sim.coordinates import COORDINATES, INDEX

K = len(COORDINATES)

_ARMS = {
    "l": (Landmark.SHOULDER_LEFT, Landmark.ELBOW_LEFT, Landmark.WRIST_LEFT),
    "r": (Landmark.SHOULDER_RIGHT, Landmark.ELBOW_RIGHT, Landmark.WRIST_RIGHT),
}
_MIRROR = {"l": np.array([1.0, 1.0, 1.0]), "r": np.array([1.0, -1.0, 1.0])}

_SEED_BELOW = np.radians(25.0)
"""Below this shoulder elevation the warm start is compared with the arm solved from the target
(near the gimbal lock the landmark error hardly depends on the plane of elevation, so the solver
alone does not find the plane the arm is rising in)."""

_TWIST_ABOVE = np.radians(15.0)
"""The wrist fixes the axial rotation only with the elbow flexed at least this much."""

_TWISTS = np.linspace(-np.pi, np.pi, 12, endpoint=False)


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


@dataclass(frozen=True)
class ArmAngles:
    """One arm's shoulder and elbow coordinates that lay the humanoid's upper arm and forearm along
    the target's, radians; ``elbow_flexion`` is None without a wrist target, ``sh_rotation`` None
    while the elbow is too straight to show the axial rotation."""

    sh_plane: float
    sh_elevation: float
    elbow_flexion: float | None
    sh_rotation: float | None


def arm_angles(target: np.ndarray, weight: np.ndarray, topology: Topology, side: str,
               R_world_parent: np.ndarray) -> ArmAngles | None:
    """Solve one arm's shoulder and elbow in closed form from its shoulder, elbow and wrist targets.

    Parameters
    ----------
    target : (J, 3) world positions [m].
    weight : (J,) confidences; 0 = absent.
    topology : the targets' joint set.
    side : ``"l"`` or ``"r"``.
    R_world_parent : (3, 3) rotation of the shoulder's parent body (the clavicle) in the world.

    Returns
    -------
    ArmAngles or None
        None if the shoulder or elbow target is absent or they coincide.
    """
    s, e, w = (topology.index(j) for j in _ARMS[side])
    if not (weight[s] > 0 and weight[e] > 0):
        return None
    mirror = _MIRROR[side]
    upper = (R_world_parent.T @ (target[e] - target[s])) * mirror
    norm = np.linalg.norm(upper)
    if norm < 1e-6:
        return None
    u = upper / norm
    elevation = float(np.arccos(np.clip(-u[2], -1.0, 1.0)))
    plane = float(np.arctan2(u[0], u[1]))
    flexion = rotation = None
    fore = (R_world_parent.T @ (target[w] - target[e])) * mirror
    if weight[w] > 0 and np.linalg.norm(fore) > 1e-6:
        flexion = _angle(upper, fore)
        if flexion > _TWIST_ABOVE:
            # undo the plane (about -z) and the elevation (about +x): what is left is Rz(sh_rotation)
            cp, sp, ce, se = np.cos(plane), np.sin(plane), np.cos(elevation), np.sin(elevation)
            v = np.array([cp * fore[0] - sp * fore[1], sp * fore[0] + cp * fore[1], fore[2]])
            v = np.array([v[0], ce * v[1] + se * v[2], -se * v[1] + ce * v[2]])
            rotation = float(np.arctan2(v[1], v[0]))
    return ArmAngles(plane, elevation, flexion, rotation)


def _with_arm(x: np.ndarray, side: str, arm: ArmAngles, *, elbow: bool) -> np.ndarray:
    """``x`` with one arm's plane and elevation (and elbow) set; the axial rotation solved, or the
    twist ``sh_rotation - sh_plane`` kept."""
    x = x.copy()
    plane, rot = INDEX[f"sh_plane_{side}"], INDEX[f"sh_rotation_{side}"]
    twist = x[rot] - x[plane]
    x[plane], x[INDEX[f"sh_elevation_{side}"]] = arm.sh_plane, arm.sh_elevation
    x[rot] = arm.sh_rotation if arm.sh_rotation is not None else arm.sh_plane + twist
    x[rot] = _wrap(x[rot])
    if elbow and arm.elbow_flexion is not None:
        x[INDEX[f"elbow_flexion_{side}"]] = arm.elbow_flexion
    return x


def seed_arms(x: np.ndarray, target: np.ndarray, weight: np.ndarray, topology: Topology,
              parents: Mapping[str, np.ndarray], cost: Callable[[np.ndarray], float],
              lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Replace a nearly hanging arm of the warm start by the arm solved from the target if that fits better.

    At ``sh_elevation`` near 0 the Y-X-Y shoulder is gimbal-locked: the landmark error hardly
    depends on ``sh_plane``, so a warm start does not find the plane an arm starts to rise in, and
    the elbow and elevation absorb the error until it does. Each arm below :data:`_SEED_BELOW`
    gets its plane, elevation and axial rotation from :func:`arm_angles` (the twist kept when the
    elbow is straight) and keeps them if ``cost`` drops.

    Parameters
    ----------
    x : (K + 1,) warm start.
    target, weight : (J, 3) world targets [m] and (J,) confidences.
    topology : the targets' joint set.
    parents : side -> (3, 3) world rotation of that shoulder's parent body at ``x``.
    cost : unknowns -> landmark error of the frame.
    lower, upper : (K + 1,) bounds of the unknowns.
    """
    best = cost(x)
    for side in _ARMS:
        if x[INDEX[f"sh_elevation_{side}"]] > _SEED_BELOW:
            continue
        arm = arm_angles(target, weight, topology, side, parents[side])
        if arm is None:
            continue
        candidate = np.clip(_with_arm(x, side, arm, elbow=False), lower, upper)
        c = cost(candidate)
        if c < best:
            x, best = candidate, c
    return x


def _wrap(a: float) -> float:
    """An angle wrapped to [-pi, pi), radians."""
    return float((a + np.pi) % (2 * np.pi) - np.pi)


def _angle(u: np.ndarray, v: np.ndarray) -> float:
    """Angle between two vectors, radians."""
    c = u @ v / max(np.linalg.norm(u) * np.linalg.norm(v), 1e-12)
    return float(np.arccos(np.clip(c, -1.0, 1.0)))


def restart_guess(x: np.ndarray, target: np.ndarray, weight: np.ndarray, topology: Topology,
                  parents: Mapping[str, np.ndarray], cost: Callable[[np.ndarray], float],
                  lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """Both arms solved from the targets (:func:`arm_angles`, any elevation); where the elbow is too
    straight to show the axial rotation, the twist of 12 candidates that brings the arm's sites
    closest."""
    x = x.copy()
    for side in _ARMS:
        arm = arm_angles(target, weight, topology, side, parents[side])
        if arm is None:
            continue
        x = _with_arm(x, side, arm, elbow=True)
        if arm.sh_rotation is None:
            rot = INDEX[f"sh_rotation_{side}"]
            costs = []
            for twist in _TWISTS:
                x[rot] = _wrap(arm.sh_plane + twist)
                costs.append(cost(np.clip(x, lower, upper)))
            x[rot] = _wrap(arm.sh_plane + _TWISTS[int(np.argmin(costs))])
    return np.clip(x, lower, upper)
