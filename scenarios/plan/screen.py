"""The planner's cheap geometric screen: which candidate camera places see the protocol's key joints.

Candidate places are spread over the room's mount regions. The subject is posed at a few instants
of the protocol's arm movements; from every candidate, each key joint (trunk and both arms) counts as seen when it
projects inside the image within the depth range (camera aimed at the subject), no obstacle box
cuts the sight line, and no body segment hides it (ray cast by :func:`sim.visibility.joint_visibility`,
the tracker's own occlusion test). Candidates seeing less than ``search.min_visible`` of the key
joint-instants are dropped before the optimiser runs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fusion.camera import KINECT_V2_DEPTH, Intrinsics
from fusion.errors import ScenarioError
from fusion.topology import Landmark, topology_by_name
from fusion.transforms import apply, invert
from scenarios.plan.room import Mount, MountKind, Room
from sim.rig import look_at
from sim.timeline import Motion
from sim.visibility import joint_visibility

KEY_LANDMARKS = (Landmark.SPINE_MID, Landmark.SPINE_SHOULDER, Landmark.SHOULDER_LEFT, Landmark.ELBOW_LEFT,
                 Landmark.WRIST_LEFT, Landmark.HAND_LEFT, Landmark.SHOULDER_RIGHT, Landmark.ELBOW_RIGHT,
                 Landmark.WRIST_RIGHT, Landmark.HAND_RIGHT)
"""Joints the Fugl-Meyer upper-limb items are measured from."""


@dataclass(frozen=True, eq=False)
class ScreenResult:
    """Candidate places and what each sees.

    Attributes
    ----------
    places_room : (K, 3) candidate camera centres, room frame [m].
    mount : (K,) int index of the mount region of each candidate.
    visible : (K,) share of key joint-instants seen from each candidate, in [0, 1].
    kept : (K,) bool, passed the screen (``visible >= min_visible``).
    poses : number of protocol instants used.
    """

    places_room: np.ndarray
    mount: np.ndarray
    visible: np.ndarray
    kept: np.ndarray
    poses: int

    def __post_init__(self) -> None:
        k = self.places_room.shape[0]
        if self.places_room.shape != (k, 3) or self.mount.shape != (k,) or self.visible.shape != (k,) \
                or self.kept.shape != (k,):
            raise ScenarioError("screen arrays must be places (K, 3), mount (K,), visible (K,), kept (K,)")

    @property
    def kept_indices(self) -> np.ndarray:
        """Indices of the candidates that passed, best first."""
        idx = np.flatnonzero(self.kept)
        return idx[np.argsort(-self.visible[idx], kind="stable")]


def _heights(m: Mount) -> np.ndarray:
    lo, hi = m.height_m
    return np.unique(np.round([lo, (lo + hi) / 2, hi], 3))


def _blocked_floor(room: Room, xy: np.ndarray) -> np.ndarray:
    """(N,) True where a floor point lies in a forbidden zone, under an obstacle or in the subject zone."""
    bad = np.linalg.norm(xy - np.asarray(room.subject.position_m), axis=1) < room.subject.radius_m + 0.5
    for r in (*room.forbidden, *room.obstacles):
        lo, hi = np.asarray(r.min_m[:2]), np.asarray(r.max_m[:2])
        bad |= np.all((xy >= lo) & (xy <= hi), axis=1)
    return bad


def candidate_places(room: Room) -> tuple[np.ndarray, np.ndarray]:
    """Candidate camera centres (K, 3) in the room frame [m] and the mount index (K,) of each."""
    n = room.search.candidates_per_mount
    places, mounts = [], []
    for i, m in enumerate(room.mounts):
        if m.kind is MountKind.POINTS:
            pts = np.asarray(m.points_m, dtype=float)
        else:
            if m.kind is MountKind.WALL:
                a, b = np.asarray(m.from_m, float), np.asarray(m.to_m, float)
                s = (np.arange(n) + 0.5) / n
                xy = a + s[:, None] * (b - a)
            else:
                lo, hi = np.asarray(m.min_m, float), np.asarray(m.max_m, float)
                k = max(1, int(np.ceil(np.sqrt(n))))
                gx, gy = np.meshgrid((np.arange(k) + 0.5) / k, (np.arange(k) + 0.5) / k)
                xy = lo + np.column_stack([gx.ravel(), gy.ravel()]) * (hi - lo)
            xy = xy[~_blocked_floor(room, xy)]
            h = _heights(m)
            pts = np.column_stack([np.repeat(xy, h.size, axis=0), np.tile(h, xy.shape[0])])
        places.append(pts)
        mounts.append(np.full(pts.shape[0], i))
    places_room, mount = np.concatenate(places), np.concatenate(mounts)
    if places_room.shape[0] == 0:
        raise ScenarioError("no candidate camera place is left once forbidden zones and obstacles are removed")
    return places_room, mount


def sight_blocked(room: Room, origins: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """(C, J) True where an obstacle box cuts the segment from origin c (C, 3) to target j (J, 3), room frame."""
    o = origins[:, None, :]
    d = targets[None, :, :] - o
    blocked = np.zeros(d.shape[:2], dtype=bool)
    with np.errstate(divide="ignore", invalid="ignore"):
        for box in room.obstacles:
            t1 = (np.asarray(box.min_m) - o) / d
            t2 = (np.asarray(box.max_m) - o) / d
            near = np.nanmax(np.minimum(t1, t2), axis=-1)
            far = np.nanmin(np.maximum(t1, t2), axis=-1)
            blocked |= (near <= far) & (far > 0) & (near < 1)
    return blocked


def in_view(T_world_cam: np.ndarray, intrinsics: Intrinsics, p_world: np.ndarray) -> np.ndarray:
    """(J,) True where world points (J, 3) project inside the image within the depth range."""
    uv, z = intrinsics.project(apply(invert(T_world_cam), p_world))
    return intrinsics.in_image(uv) & (z >= intrinsics.min_depth_m) & (z <= intrinsics.max_depth_m)


def pose_times(motion: Motion, n: int) -> np.ndarray:
    """(n,) instants [s] spread evenly over the motion's arm-movement repetitions (the whole motion if none)."""
    spans = [(r.t_start, r.t_end) for r in motion.repetitions if r.side is not None]
    if not spans:
        return np.linspace(0.0, motion.duration, n, endpoint=False)
    lengths = np.array([b - a for a, b in spans])
    edges = np.concatenate([[0.0], np.cumsum(lengths)])
    u = (np.arange(n) + 0.5) / n * edges[-1]
    k = np.clip(np.searchsorted(edges, u, side="right") - 1, 0, len(spans) - 1)
    return np.array([spans[i][0] for i in k]) + (u - edges[k])


def screen(room: Room, *, intrinsics: Intrinsics = KINECT_V2_DEPTH) -> ScreenResult:
    """Score every candidate place of ``room`` by the share of key joint-instants it sees.

    Parameters
    ----------
    room : the planning problem.
    intrinsics : the camera model (image size, focal length, depth range).

    Returns
    -------
    ScreenResult
    """
    from scenarios.runner import build_simulation

    sim = build_simulation(room.scenario("screen", room.room.seed))
    topology = topology_by_name(room.subject.topology)
    times = pose_times(sim.motion, room.search.screen_poses)
    qpos, joints_world, _ = sim.humanoid.track(sim.motion.sample(times), topology)
    keys = np.array([topology.index(lm) for lm in KEY_LANDMARKS])
    bodies = sim.humanoid.model.site_bodyid[sim.humanoid.site_ids(topology)]
    places_room, mount = candidate_places(room)
    T_world_room = room.T_world_room
    places_world = apply(T_world_room, places_room)
    aim = np.mean(room.search.aim_height_m)
    T_world_cams = [look_at(p, [0.0, 0.0, aim]) for p in places_world]
    T_room_world = invert(T_world_room)
    seen = np.zeros((places_room.shape[0], keys.size))
    for t in range(times.size):
        sim.humanoid.set_qpos(qpos[t])
        j = joints_world[t]
        sight = joint_visibility(sim.humanoid.model, sim.humanoid.data, places_world, j, bodies)[:, keys]
        sight &= ~sight_blocked(room, places_room, apply(T_room_world, j[keys]))
        sight &= np.stack([in_view(T, intrinsics, j[keys]) for T in T_world_cams])
        seen += sight
    visible = seen.sum(axis=1) / (times.size * keys.size)
    return ScreenResult(places_room, mount, visible, visible >= room.search.min_visible, int(times.size))
