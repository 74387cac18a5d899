"""Synthetic skeleton streams for the sync and RANSAC tests (Kinect v2 topology).

A walking-ish person: a rest pose whose arms and legs swing and bend, whose torso turns and which
wanders over the floor, all driven by a few random sinusoids. Everything random comes from the
``rng`` passed in (seeded by hypothesis or by the test).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, Topology, TrackingState
from fusion.transforms import apply

# Rest pose in the body frame [m]: +x to the person's left, +y up, +z forward.
_REST = {
    "SpineBase": (0.0, 1.00, 0.00),
    "SpineMid": (0.0, 1.25, -0.02),
    "Neck": (0.0, 1.55, 0.00),
    "Head": (0.0, 1.68, 0.03),
    "ShoulderLeft": (0.19, 1.45, -0.01),
    "ElbowLeft": (0.22, 1.17, -0.03),
    "WristLeft": (0.23, 0.93, 0.00),
    "HandLeft": (0.23, 0.86, 0.01),
    "ShoulderRight": (-0.19, 1.45, -0.01),
    "ElbowRight": (-0.22, 1.17, -0.03),
    "WristRight": (-0.23, 0.93, 0.00),
    "HandRight": (-0.23, 0.86, 0.01),
    "HipLeft": (0.09, 0.95, 0.00),
    "KneeLeft": (0.10, 0.52, 0.03),
    "AnkleLeft": (0.10, 0.10, -0.02),
    "FootLeft": (0.10, 0.03, 0.10),
    "HipRight": (-0.09, 0.95, 0.00),
    "KneeRight": (-0.10, 0.52, 0.03),
    "AnkleRight": (-0.10, 0.10, -0.02),
    "FootRight": (-0.10, 0.03, 0.10),
    "SpineShoulder": (0.0, 1.47, -0.01),
    "HandTipLeft": (0.23, 0.78, 0.02),
    "ThumbLeft": (0.20, 0.86, 0.04),
    "HandTipRight": (-0.23, 0.78, 0.02),
    "ThumbRight": (-0.20, 0.86, 0.04),
}
REST_POSE = np.array([_REST[name] for name in KINECT_V2.joints])
"""(25, 3) rest pose [m] in Kinect v2 joint order."""


def _subtree(topology: Topology, root: str) -> np.ndarray:
    """Indices of a joint and all its descendants."""
    keep = {topology.index(root)}
    changed = True
    while changed:
        changed = False
        for j, p in enumerate(topology.parents):
            if p in keep and j not in keep:
                keep.add(j)
                changed = True
    return np.array(sorted(keep))


# (joint, axis in the body frame, amplitude range [rad]); distal joints first.
_ARTICULATIONS = (
    ("ElbowLeft", (1.0, 0.0, 0.0), (0.2, 1.2)),
    ("ElbowRight", (1.0, 0.0, 0.0), (0.2, 1.2)),
    ("KneeLeft", (1.0, 0.0, 0.0), (0.1, 0.6)),
    ("KneeRight", (1.0, 0.0, 0.0), (0.1, 0.6)),
    ("ShoulderLeft", (1.0, 0.0, 0.0), (0.3, 1.2)),
    ("ShoulderLeft", (0.0, 0.0, 1.0), (0.1, 0.6)),
    ("ShoulderRight", (1.0, 0.0, 0.0), (0.3, 1.2)),
    ("ShoulderRight", (0.0, 0.0, -1.0), (0.1, 0.6)),
    ("HipLeft", (1.0, 0.0, 0.0), (0.1, 0.5)),
    ("HipRight", (1.0, 0.0, 0.0), (0.1, 0.5)),
)


@dataclass(frozen=True)
class Motion:
    """Random smooth whole-body motion; call :meth:`joints` for positions at any true times."""

    amplitude: np.ndarray  # (A, 2) per articulation: two sinusoid amplitudes [rad]
    frequency: np.ndarray  # (A, 2) [Hz]
    phase: np.ndarray  # (A, 2) [rad]
    yaw: np.ndarray  # (3,) amplitude [rad], frequency [Hz], phase [rad] of the torso heading
    path: np.ndarray  # (2, 3) per floor axis (x, z): amplitude [m], frequency [Hz], phase [rad]

    @classmethod
    def random(cls, *, rng: np.random.Generator, moving: bool = True) -> "Motion":
        """A random motion; ``moving=False`` gives a person standing still in the rest pose."""
        n = len(_ARTICULATIONS)
        lo = np.array([a[2][0] for a in _ARTICULATIONS])[:, None]
        hi = np.array([a[2][1] for a in _ARTICULATIONS])[:, None]
        scale = 1.0 if moving else 0.0
        return cls(
            amplitude=scale * rng.uniform(lo, hi, size=(n, 2)) / 2,
            frequency=rng.uniform(0.15, 0.9, size=(n, 2)),
            phase=rng.uniform(0, 2 * np.pi, size=(n, 2)),
            yaw=np.array([scale * rng.uniform(0.3, 1.0), rng.uniform(0.05, 0.2), rng.uniform(0, 2 * np.pi)]),
            path=np.column_stack(
                [scale * rng.uniform(0.3, 1.0, 2), rng.uniform(0.03, 0.12, 2), rng.uniform(0, 2 * np.pi, 2)]
            ),
        )

    def joints(self, times: np.ndarray) -> np.ndarray:
        """(T, 25, 3) world positions [m] (world: +y up) at true times (T,) [s]."""
        t = np.asarray(times, dtype=float)[:, None]
        wave = np.sin(2 * np.pi * self.frequency[:, None] * t[None] + self.phase[:, None])
        angles = (self.amplitude[:, None] * wave).sum(-1)  # (A, T)
        p = np.broadcast_to(REST_POSE, (t.shape[0],) + REST_POSE.shape).copy()
        for (joint, axis, _), angle in zip(_ARTICULATIONS, angles):
            idx = _subtree(KINECT_V2, joint)
            centre = p[:, KINECT_V2.index(joint)][:, None]
            R = Rotation.from_rotvec(np.outer(angle, axis)).as_matrix()
            p[:, idx] = np.einsum("tij,tkj->tki", R, p[:, idx] - centre) + centre
        yaw = self.yaw[0] * np.sin(2 * np.pi * self.yaw[1] * t[:, 0] + self.yaw[2])
        R_yaw = Rotation.from_rotvec(np.outer(yaw, [0.0, 1.0, 0.0])).as_matrix()
        floor = self.path[:, 0] * np.sin(2 * np.pi * self.path[:, 1] * t + self.path[:, 2])
        offset = np.column_stack([floor[:, 0], np.zeros(t.shape[0]), floor[:, 1]])
        return np.einsum("tij,tkj->tki", R_yaw, p) + offset[:, None]


def observe(
    joints_world: np.ndarray,
    T_cam_world: np.ndarray,
    timestamps: np.ndarray,
    *,
    rng: np.random.Generator,
    noise_m: float = 0.005,
    outlier_fraction: float = 0.0,
    inferred_fraction: float = 0.05,
    missing_fraction: float = 0.02,
) -> SkeletonStream:
    """A camera's skeleton stream of true joints: jitter, outliers, Inferred and missing joints.

    Outliers are (frame, joint) entries moved by 0.3-1.0 m in a random direction, still TRACKED.
    """
    p = apply(T_cam_world, joints_world) + rng.normal(0.0, noise_m, joints_world.shape)
    shape = p.shape[:2]
    outlier = rng.random(shape) < outlier_fraction
    direction = rng.normal(size=shape + (3,))
    direction /= np.linalg.norm(direction, axis=-1, keepdims=True)
    p = np.where(outlier[..., None], p + direction * rng.uniform(0.3, 1.0, shape)[..., None], p)
    states = np.full(shape, TrackingState.TRACKED, dtype=np.int8)
    u = rng.random(shape)
    states[u < inferred_fraction + missing_fraction] = TrackingState.INFERRED
    states[u < missing_fraction] = TrackingState.NOT_TRACKED
    p[states == TrackingState.NOT_TRACKED] = np.nan
    return SkeletonStream(KINECT_V2, timestamps, p, states)


def permuted(stream: SkeletonStream, order: np.ndarray) -> SkeletonStream:
    """The same stream with its joints stored in another order (``order[k]`` = old index of new joint k)."""
    topo = stream.topology
    new_of_old = np.argsort(order)
    permuted_topology = Topology(
        name=topo.name + "_permuted",
        joints=tuple(topo.joints[k] for k in order),
        parents=tuple(-1 if topo.parents[k] < 0 else int(new_of_old[topo.parents[k]]) for k in order),
        regions=tuple(topo.regions[k] for k in order),
        landmarks=topo.landmarks,
    )
    return SkeletonStream(permuted_topology, stream.timestamps, stream.positions[:, order], stream.states[:, order])
