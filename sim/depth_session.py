"""A session's depth frames: every camera's frames rendered, cameras in parallel threads where cores allow.

Each camera renders its frames in order with its own random stream, its own ``mujoco.MjData`` and
its own :class:`sim.depth_camera.DepthCamera`, so the frames do not depend on how many cameras
render at once. The ray caster's compiled loops (numba, ``nogil``) and NumPy's array operations
release Python's GIL, so threads share the cores. MuJoCo's OpenGL renderer draws in one context per
process, so with it the cameras render one after another.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np

from fusion.depth import DepthStream
from fusion.errors import BadInputError
from fusion.io.depth_store import DepthWriter
from fusion.io.recording_files import depth_file
from sim.depth_camera import DepthCamera
from sim.depth_noise import DepthNoise
from sim.depth_renderer import DepthRenderer
from sim.rig import CameraPlacement


@dataclass(frozen=True, eq=False)
class DepthJob:
    """The depth frames one camera records.

    Attributes
    ----------
    placement : the camera.
    qpos : (F, nq) the humanoid's generalised positions at the frames.
    timestamps : (F,) the frames' times on the camera's clock [s].
    rng : the camera's depth noise stream.
    """

    placement: CameraPlacement
    qpos: np.ndarray
    timestamps: np.ndarray
    rng: np.random.Generator


def usable_cores() -> int:
    """Cores this process may run on (its CPU affinity where the system tells it)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def depth_workers(renderer: DepthRenderer, n_cameras: int) -> int:
    """How many cameras render at once by default: 1 with MuJoCo's renderer, else up to the usable cores."""
    if renderer.resolve() is DepthRenderer.MUJOCO:
        return 1
    return max(1, min(n_cameras, usable_cores()))


def render_depth(
    model: mujoco.MjModel,
    jobs: list[DepthJob],
    noise: DepthNoise,
    renderer: DepthRenderer,
    *,
    tick: Callable[[int], None],
    depth_dir: Path | None,
    workers: int | None = None,
) -> list[DepthStream]:
    """Render every job's frames: in memory, or streamed into ``depth_dir``'s per-camera depth files.

    Parameters
    ----------
    model : the humanoid's model (read only; each job poses its own ``MjData``).
    jobs : one per camera.
    noise, renderer : the depth noise model and what renders the body.
    tick : called with 1 per rendered frame (from the rendering threads, one at a time).
    depth_dir : a recording directory being written, or None to keep the frames in memory.
    workers : cameras rendered at once; None for :func:`depth_workers`. The frames are the same for any.

    Returns
    -------
    One :class:`fusion.depth.DepthStream` per job, in order.

    Raises
    ------
    BadInputError
        ``workers`` below 1, or above 1 with MuJoCo's renderer.
    """
    if workers is None:
        workers = depth_workers(renderer, len(jobs))
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise BadInputError(f"depth workers must be a whole number >= 1, got {workers!r}")
    if workers > 1 and renderer.resolve() is DepthRenderer.MUJOCO:
        raise BadInputError("MuJoCo's depth renderer draws one camera at a time; use 1 worker or the ray caster")
    lock = threading.Lock()

    def locked_tick(n: int) -> None:
        with lock:
            tick(n)

    def one(job: DepthJob) -> DepthStream:
        return _record(model, job, DepthCamera(job.placement, noise, renderer=renderer), locked_tick, depth_dir)

    if workers == 1 or len(jobs) < 2:
        return [one(job) for job in jobs]
    with ThreadPoolExecutor(max_workers=min(workers, len(jobs))) as pool:
        return list(pool.map(one, jobs))


def _record(
    model: mujoco.MjModel, job: DepthJob, camera: DepthCamera, tick: Callable[[int], None], depth_dir: Path | None
) -> DepthStream:
    """Render one camera's frames in order into memory or into its depth file."""
    intr = job.placement.intrinsics
    data = mujoco.MjData(model)
    writer = None if depth_dir is None else DepthWriter(depth_file(depth_dir, job.placement.name), intr.height,
                                                        intr.width, labels=True)
    frames, labels = [], []
    try:
        for q, t in zip(job.qpos, job.timestamps):
            data.qpos[:] = q
            mujoco.mj_kinematics(model, data)
            frame = camera.render(model, data, rng=job.rng)
            if writer is None:
                frames.append(frame.depth_mm)
                labels.append(frame.labels)
            else:
                writer.append(t, frame.depth_mm, frame.labels)
            tick(1)
    finally:
        if writer is not None:
            writer.close()
    return DepthStream(job.timestamps, np.stack(frames), np.stack(labels)) if writer is None else writer.stream()
