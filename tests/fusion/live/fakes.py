"""A small synthetic rig for the live tests: cameras on an arc in front of a moving person, each
with its own clock offset and frame phase, and the matching calibration."""

from __future__ import annotations

import numpy as np

from fusion.calibration import Calibration
from fusion.camera import Intrinsics
from fusion.recording import CameraRecording, Recording
from fusion.transforms import invert
from tests.fusion.skeleton_fakes import Motion, observe


def arc_pose(angle: float, radius: float = 2.5, height: float = 1.0) -> np.ndarray:
    """(4, 4) ``T_world_cam`` of a Kinect-frame camera (+z out, +y up) at ``angle`` [rad] on a circle
    around the origin (world +y up, the person facing +z), looking at the vertical axis."""
    centre = np.array([radius * np.sin(angle), height, radius * np.cos(angle)])
    z = np.array([-np.sin(angle), 0.0, -np.cos(angle)])
    y = np.array([0.0, 1.0, 0.0])
    T = np.eye(4)
    T[:3, :3] = np.column_stack([np.cross(y, z), y, z])
    T[:3, 3] = centre
    return T


def session(*, rng: np.random.Generator, n_cameras: int = 3, seconds: float = 4.0, rate_hz: float = 30.0,
            max_offset_s: float = 0.02) -> tuple[Recording, Calibration]:
    """A recording of ``n_cameras`` cameras and its exact calibration (poses and clock offsets)."""
    motion = Motion.random(rng=rng)
    cameras, poses, offsets = [], {}, {}
    for k, angle in enumerate(np.linspace(-0.8, 0.8, n_cameras)):
        name = f"cam{k + 1}"
        T_world_cam = arc_pose(float(angle))
        offset = 0.0 if k == 0 else float(rng.uniform(-max_offset_s, max_offset_s))
        true = np.arange(rng.uniform(0, 1 / rate_hz), seconds, 1 / rate_hz)
        stream = observe(motion.joints(true), invert(T_world_cam), true + offset, rng=rng)
        cameras.append(CameraRecording(name, Intrinsics(), stream))
        poses[name], offsets[name] = T_world_cam, offset
    calibration = Calibration(poses, {c.name: c.intrinsics for c in cameras}, offsets, "cam1")
    return Recording(tuple(cameras), {"source": "test"}), calibration


def arrivals(recording: Recording, *, delays: dict[str, float] | None = None) -> list[tuple[float, object]]:
    """Every camera frame with a simulated arrival time (its timestamp plus a per-camera delay), in
    arrival order: ``(arrival, (camera name, frame index))``."""
    delays = delays or {}
    out = []
    for cam in recording.cameras:
        for k, t in enumerate(cam.skeleton.timestamps):
            out.append((float(t) + delays.get(cam.name, 0.0), (cam.name, k)))
    return sorted(out, key=lambda a: a[0])
