"""Fitted motions: the file a retargeting writes and the :class:`~sim.timeline.Motion` that replays it.

Motion file (``.npz``, NumPy's zip of arrays, written atomically), format ``mocap-bench-motion``
version 1. Arrays:

============  ==========  ===================================================================
name          shape       content
============  ==========  ===================================================================
meta          ()          JSON string: ``format``, ``version``, ``coordinates`` (column names of
                          ``coords``), ``topology`` (joint set of ``errors``), ``joints``,
                          ``anthropometry`` (the scaled subject: height_m, the stature scale,
                          build and the length multipliers), ``source`` (what was fitted),
                          ``summary`` (residual statistics per joint group [m], failed frames,
                          measured segment lengths [m], ``stature_m``: standing height of the
                          scaled humanoid [m])
times         (T,)        seconds on the source's clock
coords        (T, K)      coordinates of :mod:`sim.coordinates` (metres / radians), world frame of
                          the source (z up, floor z = 0)
errors        (T, J)      landmark residual per frame and joint [m], NaN where absent
frame_rms     (T,)        confidence-weighted RMS residual per frame [m]
converged     (T,)        bool, the frame's fit converged
============  ==========  ===================================================================

A replay (:func:`replay_motion`) interpolates the coordinates linearly between frames: a window of
the source's time runs from 0 s, placed either where the source stood in its world frame or
moved so that its first frame stands at a given floor position and facing.
"""

from __future__ import annotations

import io
import json
import os
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fusion.errors import BadInputError, RecordingError
from fusion.io.atomic import write_bytes_atomic
from fusion.io.mocap import LandmarkTrajectory
from fusion.merge.metrics import Stats
from sim.anthropometry import Anthropometry, Build
from sim.coordinates import COORDINATES, INDEX
from sim.humanoid_model import build_humanoid
from sim.retarget import RetargetOptions, RetargetResult, retarget
from sim.retarget_scale import ScaleEstimate, estimate_anthropometry
from sim.timeline import Motion, Move

FORMAT_NAME = "mocap-bench-motion"
FORMAT_VERSION = 1


@dataclass(frozen=True, eq=False)
class FittedMotion:
    """A motion fitted to a source, with the subject it was fitted for and its residuals.

    Attributes
    ----------
    times : (T,) s, strictly increasing.
    coords : (T, K) coordinates, metres / radians.
    anthropometry : the subject the coordinates were fitted on.
    topology : name of the joint set of ``errors``.
    joints : joint names, the columns of ``errors``.
    errors : (T, J) landmark residuals [m], NaN where absent.
    frame_rms : (T,) weighted RMS residual per frame [m].
    converged : (T,) bool.
    source : what was fitted.
    summary : JSON-able residual summary.
    """

    times: np.ndarray
    coords: np.ndarray
    anthropometry: Anthropometry
    topology: str
    joints: tuple[str, ...]
    errors: np.ndarray
    frame_rms: np.ndarray
    converged: np.ndarray
    source: str = ""
    summary: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        t = np.asarray(self.times, dtype=float)
        T = t.size
        if t.ndim != 1 or T < 2 or not np.isfinite(t).all() or np.any(np.diff(t) <= 0):
            raise BadInputError("a fitted motion needs at least two finite, strictly increasing times")
        shapes = {"coords": (T, len(COORDINATES)), "errors": (T, len(self.joints)), "frame_rms": (T,),
                  "converged": (T,)}
        for name, shape in shapes.items():
            if np.shape(getattr(self, name)) != shape:
                raise BadInputError(f"{name} must have shape {shape}, got {np.shape(getattr(self, name))}")
        if not np.isfinite(self.coords).all():
            raise BadInputError("coords contain NaN or inf")

    @property
    def duration(self) -> float:
        """Span of the fitted times, seconds."""
        return float(self.times[-1] - self.times[0])


def save_motion(motion: FittedMotion, path: str | os.PathLike) -> Path:
    """Write a fitted motion file (module docstring) atomically; returns ``path``."""
    a = motion.anthropometry
    anthro = {k: (v.value if isinstance(v, Build) else v) for k, v in asdict(a).items()}
    meta = {"format": FORMAT_NAME, "version": FORMAT_VERSION, "coordinates": list(COORDINATES),
            "topology": motion.topology, "joints": list(motion.joints), "anthropometry": anthro,
            "source": motion.source, "summary": motion.summary or {}}
    buf = io.BytesIO()
    np.savez(buf, meta=np.array(json.dumps(meta)), times=motion.times, coords=motion.coords, errors=motion.errors,
             frame_rms=motion.frame_rms, converged=motion.converged)
    write_bytes_atomic(path, buf.getvalue())
    return Path(path)


def load_motion(path: str | os.PathLike) -> FittedMotion:
    """Read a fitted motion file.

    Raises
    ------
    RecordingError
        The file is missing, not a motion file, of another version or of other coordinates.
    """
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
        meta = json.loads(str(arrays.pop("meta")))
    except (OSError, ValueError, KeyError) as exc:
        raise RecordingError(f"{path}: not a readable motion file ({exc}); write one with `mocap-bench retarget`") from None
    if meta.get("format") != FORMAT_NAME or meta.get("version") != FORMAT_VERSION:
        raise RecordingError(f"{path}: format {meta.get('format')!r} version {meta.get('version')!r}; "
                             f"expected {FORMAT_NAME!r} version {FORMAT_VERSION}")
    if meta["coordinates"] != list(COORDINATES):
        raise RecordingError(f"{path}: its coordinates differ from this humanoid's; fit the source again")
    anthro = dict(meta["anthropometry"])
    anthro["build"] = Build(anthro["build"])
    try:
        return FittedMotion(arrays["times"], arrays["coords"], Anthropometry(**anthro), meta["topology"],
                            tuple(meta["joints"]), arrays["errors"], arrays["frame_rms"],
                            arrays["converged"].astype(bool), meta.get("source", ""), meta.get("summary"))
    except (KeyError, TypeError, BadInputError) as exc:
        raise RecordingError(f"{path}: inconsistent motion file: {exc}") from None


@dataclass(frozen=True, eq=False)
class _Linear:
    """Progress rising linearly from 0 to 1 over ``duration`` seconds."""

    duration: float

    def sample(self, t: np.ndarray) -> np.ndarray:
        return np.clip(np.asarray(t, dtype=float) / self.duration, 0.0, 1.0)


_STEP_S = 1e-9
"""Duration of the jump to the first frame's pose, placed just before time 0."""


def replay_motion(motion: FittedMotion, *, start_s: float | None = None, end_s: float | None = None,
                  position_m: tuple[float, float] | None = None, facing_deg: float | None = None) -> Motion:
    """A fitted motion as a timeline segment, linear between frames.

    Parameters
    ----------
    motion : FittedMotion
    start_s, end_s : float, optional
        Window on the fitted times (seconds on the source's clock); default all of it. The
        segment runs from 0 s at ``start_s``.
    position_m : (2,) floats, optional
        Floor position (x, y) [m] of the pelvis at the window's first frame; with ``facing_deg``
        the motion is turned about the vertical so that it starts facing that way (0 = +x). Both
        None (default): the source's own world placement.
    facing_deg : float, optional
        Facing at the first frame, degrees; default the source's.

    Returns
    -------
    Motion
        Duration ``end - start`` of the window; no repetition annotations.

    Raises
    ------
    BadInputError
        The window holds fewer than two frames.
    """
    t, q = motion.times, motion.coords.copy()
    lo = t[0] if start_s is None else float(start_s)
    hi = t[-1] if end_s is None else float(end_s)
    keep = (t >= lo - 1e-9) & (t <= hi + 1e-9)
    if keep.sum() < 2:
        raise BadInputError(f"the window [{lo}, {hi}] s holds fewer than two frames of the fitted motion "
                            f"(it spans {t[0]:.3f} .. {t[-1]:.3f} s)")
    t, q = t[keep] - t[keep][0], q[keep]
    ix, iy, iyaw = INDEX["root_x"], INDEX["root_y"], INDEX["root_yaw"]
    if position_m is not None or facing_deg is not None:
        turn = 0.0 if facing_deg is None else np.radians(facing_deg) - q[0, iyaw]
        c, s = np.cos(turn), np.sin(turn)
        xy = q[:, [ix, iy]] - q[0, [ix, iy]]
        q[:, ix], q[:, iy] = c * xy[:, 0] - s * xy[:, 1], s * xy[:, 0] + c * xy[:, 1]
        q[:, [ix, iy]] += motion.coords[keep][0, [ix, iy]] if position_m is None else np.asarray(position_m, float)
        q[:, iyaw] += turn
    moves = [Move(-_STEP_S, q[0].copy(), _Linear(_STEP_S))]
    moves += [Move(float(a), d, _Linear(float(b - a))) for a, b, d in zip(t[:-1], t[1:], np.diff(q, axis=0))]
    return Motion(float(t[-1]), (), tuple(moves), ())


def fit_motion(trajectory: LandmarkTrajectory, options: RetargetOptions = RetargetOptions(), *,
               build: Build = Build.AVERAGE, units_option: str = "units",
               progress: Callable[[int], None] | None = None) -> tuple[FittedMotion, RetargetResult, ScaleEstimate]:
    """Scale the humanoid to a trajectory, retarget it, and package the result as a motion file's content.

    Parameters
    ----------
    trajectory : LandmarkTrajectory
        (T, J, 3) world-frame targets [m], at least two frames.
    options : RetargetOptions
    build : Build
        The humanoid's girth.
    units_option : str
        Option named by the implausible-stature error.
    progress : callable, optional
        Called with the number of frames fitted since the last call.

    Returns
    -------
    motion : FittedMotion
        With the residual summary per joint group [m] and the failed frames' count and indices.
    result : RetargetResult
    scale : ScaleEstimate
    """
    scale = estimate_anthropometry(trajectory, build=build, units_option=units_option)
    result = retarget(build_humanoid(scale.anthropometry), trajectory, options, progress=progress)
    summary = {"groups_m": {g: s.as_dict() for g, s in result.group_stats().items()},
               "frame_rms_m": Stats.of(result.frame_rms).as_dict(),
               "failed_frames": result.failed_frames.tolist(),
               "segment_lengths_m": scale.segment_lengths_m, "clipped_multipliers": list(scale.clipped),
               "stature_m": scale.stature_m}
    motion = FittedMotion(result.times, result.coords, scale.anthropometry, trajectory.topology.name,
                          trajectory.topology.joints, result.errors, result.frame_rms, result.converged,
                          trajectory.source, summary)
    return motion, result, scale
