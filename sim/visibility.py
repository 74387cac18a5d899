"""What a camera can see of the humanoid: yaw of the body to the camera, joints in view and unoccluded
(by ray casting the scene to each joint), per frame.
"""

from __future__ import annotations

import mujoco
import numpy as np

from fusion.errors import BadInputError
from sim.humanoid import Humanoid
from sim.humanoid_model import BODY_GEOM_GROUP
from sim.raycast import RayBatchCaster, cast_rays


def yaw_to_camera(root_world: np.ndarray, facing_yaw: np.ndarray, camera_position: np.ndarray) -> np.ndarray:
    """Unsigned horizontal angle [rad] (T,) between the facing direction and the body-to-camera direction.

    Parameters
    ----------
    root_world : np.ndarray
        (T, 3) [m] pelvis positions in the world frame.
    facing_yaw : np.ndarray
        (T,) [rad] facing direction, counter-clockwise from world +x.
    camera_position : np.ndarray
        (3,) [m] camera centre in the world frame.
    """
    to_cam = np.asarray(camera_position, dtype=float)[:2] - np.asarray(root_world, dtype=float)[:, :2]
    fx, fy = np.cos(facing_yaw), np.sin(facing_yaw)
    return np.abs(np.arctan2(fx * to_cam[:, 1] - fy * to_cam[:, 0], fx * to_cam[:, 0] + fy * to_cam[:, 1]))


_BODY_GROUP_MASK = tuple(g == BODY_GEOM_GROUP for g in range(6))


def joint_visibility(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    cam_position_world: np.ndarray,
    joints_world: np.ndarray,
    joint_body_ids: np.ndarray,
    *,
    parent_of_body: np.ndarray | None = None,
) -> np.ndarray:
    """Which joints each camera sees directly, by casting a ray from the camera to each joint.

    A joint is visible when its ray hits no body geom before the joint, or when the first geom hit
    belongs to the joint's own body or a neighbour: its parent, a child or a sibling (same parent).
    Joints sit inside the surface of the segments that meet there, so that surface hides nothing;
    siblings count because junction joints (the neck base, between the clavicles) lie behind them.

    Parameters
    ----------
    model, data : mujoco.MjModel, mujoco.MjData
        The posed humanoid (``data`` after ``mj_kinematics``, e.g. ``Humanoid.set_pose``).
    cam_position_world : np.ndarray
        (3,) [m] camera centre in the world frame, or (C, 3) for several cameras at once (faster).
    joints_world : np.ndarray
        (J, 3) [m] joint positions in the world frame.
    joint_body_ids : np.ndarray
        (J,) int MuJoCo body of each joint (``model.site_bodyid`` of its site).
    parent_of_body : np.ndarray or None
        (nbody,) int parent body of each body; None uses ``model.body_parentid``.

    Returns
    -------
    np.ndarray
        (J,) bool, or (C, J) for several cameras: True where the camera sees the joint.
    """
    cams = np.asarray(cam_position_world, dtype=float)
    joints = np.asarray(joints_world, dtype=float)
    bodies = np.asarray(joint_body_ids)
    parents = np.asarray(model.body_parentid if parent_of_body is None else parent_of_body)
    if cams.shape[-1:] != (3,) or cams.ndim > 2:
        raise BadInputError(f"cam_position_world must have shape (3,) or (C, 3), got {cams.shape}")
    if joints.ndim != 2 or joints.shape[1] != 3 or bodies.shape != joints.shape[:1]:
        raise BadInputError(f"need joints_world (J, 3) and joint_body_ids (J,), got {joints.shape} and {bodies.shape}")
    if parents.shape != (model.nbody,) or np.any((bodies < 0) | (bodies >= model.nbody)):
        raise BadInputError(f"parent_of_body must have shape ({model.nbody},) and body ids lie in [0, {model.nbody})")
    rays = joints - cams[..., None, :]
    dist = np.linalg.norm(rays, axis=-1)
    if not np.all(np.isfinite(dist)) or np.any(dist < 1e-9):
        raise BadInputError("joints and cameras must be finite and distinct")
    dirs = (rays / dist[..., None]).reshape(-1, joints.shape[0], 3)
    flat_cams, flat_dist = cams.reshape(-1, 3), dist.reshape(dirs.shape[:2])
    hit_geom = np.empty(dirs.shape[:2], dtype=int)
    hit_dist = np.empty(dirs.shape[:2])
    for c, (cam, d) in enumerate(zip(flat_cams, flat_dist)):
        hits = cast_rays(model, data, cam, dirs[c], geomgroup=_BODY_GROUP_MASK, cutoff_m=float(d.max()))
        hit_geom[c], hit_dist[c] = hits.geom_id, hits.dist
    return _unoccluded(model, parents, bodies, hit_geom, hit_dist, flat_dist).reshape(dist.shape)


def _unoccluded(
    model: mujoco.MjModel, parents: np.ndarray, bodies: np.ndarray, hit_geom: np.ndarray, hit_dist: np.ndarray,
    joint_dist: np.ndarray,
) -> np.ndarray:
    """(..., J) bool: nothing hit before the joint, or the first hit is on the joint's body or a neighbour."""
    hit_body = np.where(hit_geom >= 0, model.geom_bodyid[np.maximum(hit_geom, 0)], -1)
    hit_parent = parents[np.maximum(hit_body, 0)]
    neighbour = (hit_body == bodies) | (hit_body == parents[bodies]) | (hit_parent == bodies) | (
        (hit_parent == parents[bodies]) & (hit_body > 0)
    )
    return (hit_geom < 0) | (hit_dist >= joint_dist) | neighbour


def visibility_over_time(
    humanoid: Humanoid, qpos: np.ndarray, cam_position_world: np.ndarray, joints_world: np.ndarray,
    joint_body_ids: np.ndarray,
) -> np.ndarray:
    """:func:`joint_visibility` for every frame of a motion seen by one camera, (T, J) bool.

    Parameters
    ----------
    humanoid : the subject; its ``data`` is posed frame by frame.
    qpos : (T, nq) generalised positions (``humanoid.qpos(coords)``).
    cam_position_world : (3,) [m] camera centre.
    joints_world : (T, J, 3) [m] joint positions at those frames.
    joint_body_ids : (J,) int body of each joint.
    """
    cam = np.ascontiguousarray(cam_position_world, dtype=np.float64)
    joints = np.asarray(joints_world, dtype=float)
    if qpos.shape[0] != joints.shape[0] or cam.shape != (3,):
        raise BadInputError(f"need qpos (T, nq), a (3,) camera and joints (T, J, 3); got {qpos.shape}, "
                            f"{cam.shape}, {joints.shape}")
    rays = joints - cam
    dist = np.linalg.norm(rays, axis=-1)
    if not np.all(np.isfinite(dist)) or np.any(dist < 1e-9):
        raise BadInputError("joints and camera must be finite and distinct")
    dirs = np.ascontiguousarray(rays / dist[..., None])
    caster = RayBatchCaster(humanoid.model, joints.shape[1], geomgroup=_BODY_GROUP_MASK)
    hit_geom = np.empty(dist.shape, dtype=np.int32)
    hit_dist = np.empty(dist.shape)
    for t in range(qpos.shape[0]):
        humanoid.set_qpos(qpos[t])
        hit_geom[t], hit_dist[t] = caster.cast(humanoid.data, cam, dirs[t], float(dist[t].max()))
    bodies = np.asarray(joint_body_ids)
    return _unoccluded(humanoid.model, humanoid.model.body_parentid, bodies, hit_geom, hit_dist, dist)
