"""Reading aniposelib / Pose2Sim camera TOMLs as calibrations of a recording's cameras.

The layout is the one :func:`fusion.io.export.export_camera_toml` writes: one table per camera with
``name``, ``size`` [px], ``matrix`` (K) [px], ``rotation`` (Rodrigues vector of ``R_cam_world``)
and ``translation`` (``t_cam_world``) in OpenCV camera axes (x right, y down, z forward), plus an
optional ``[metadata]`` table whose ``units`` (``"m"`` or ``"mm"``) give the translation's unit
(metres when absent). Such a file has no clock offsets (all 0) and its world frame is whatever the
calibration board defined (not the floor-based world of ``mocap-bench calibrate``).

The recording says each camera's native axis layout; a Kinect v2 camera (+x left, +y up) is
``T_opencv_kinect = diag(-1, -1, 1)`` away from the file's OpenCV camera. A negative fx is a
mirrored Kinect v2 image as the bench once wrote it; a positive fx for a Kinect v2 camera describes
the unmirrored image, whose principal point is ``cx' = width - 1 - cx``.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from fusion.calibration import Calibration
from fusion.camera import AxisConvention, Intrinsics
from fusion.errors import BenchError, RecordingError
from fusion.io.calibration_file import FORMAT_NAME, load_calibration, read_toml_file
from fusion.io.plausibility import check_camera_sets, check_usable_streams
from fusion.recording import Recording
from fusion.transforms import compose, from_rotvec, invert

MAX_CAMERA_DISTANCE_M = 100.0
"""A camera farther than this from the file's world origin means the translation is not in metres."""

_T_OPENCV_KINECT = np.diag([-1.0, -1.0, 1.0, 1.0])


def is_camera_toml(doc: dict[str, Any]) -> bool:
    """Whether a parsed TOML document is an aniposelib / Pose2Sim camera file (tables with a matrix)."""
    return doc.get("format") != FORMAT_NAME and any(
        isinstance(v, dict) and {"matrix", "rotation", "translation"} <= set(v) for v in doc.values())


def _camera(table: dict[str, Any], base: Intrinsics, scale: float, where: str) -> tuple[np.ndarray, Intrinsics]:
    """``T_world_cam`` (4, 4) [m] in the native axes of ``base`` and the intrinsics of one camera table."""
    K = np.asarray(table["matrix"], dtype=float)
    rotvec = np.asarray(table["rotation"], dtype=float)
    t = np.asarray(table["translation"], dtype=float) * scale
    if K.shape != (3, 3) or rotvec.shape != (3,) or t.shape != (3,) or not (
            np.all(np.isfinite(K)) and np.all(np.isfinite(rotvec)) and np.all(np.isfinite(t))):
        raise RecordingError(f"{where}: matrix must be 3 x 3, rotation and translation 3 finite numbers each")
    T_world_opencv = invert(from_rotvec(rotvec, t))
    if np.linalg.norm(T_world_opencv[:3, 3]) > MAX_CAMERA_DISTANCE_M:
        raise RecordingError(f"{where}: the camera is {np.linalg.norm(T_world_opencv[:3, 3]):.4g} m from the world "
                             "origin: the translation is not in metres; set units = \"mm\" in [metadata]")
    width, height = (int(v) for v in table.get("size", (base.width, base.height)))
    fx, fy, cx, cy = K[0, 0], K[1, 1], K[0, 2], K[1, 2]
    if base.axes is AxisConvention.KINECT_V2:
        T_world_cam = compose(T_world_opencv, _T_OPENCV_KINECT)
        if fx > 0:
            cx = width - 1 - cx
    else:
        T_world_cam = T_world_opencv
    intr = Intrinsics(width=width, height=height, fx=abs(fx), fy=fy, cx=cx, cy=cy, min_depth_m=base.min_depth_m,
                      max_depth_m=base.max_depth_m, axes=base.axes)
    return T_world_cam, intr


def load_camera_toml(path: str | os.PathLike, native: dict[str, Intrinsics]) -> Calibration:
    """A calibration of the cameras ``native`` names, from an aniposelib / Pose2Sim camera TOML.

    Parameters
    ----------
    path : path-like
        The camera TOML.
    native : dict
        Camera name -> the recording's intrinsics of that camera (for its axis layout and depth range).

    Returns
    -------
    Calibration
        ``T_world_cam`` (4, 4) [m] in each camera's native axes, intrinsics from the file, clock
        offsets 0, the first camera as reference; ``info`` notes the file's world frame.

    Raises
    ------
    RecordingError
        Unreadable or malformed file, a translation that is not in metres, a camera the recording lacks.
    """
    path = Path(path)
    doc = read_toml_file(path)
    meta = doc.get("metadata", {}) if isinstance(doc.get("metadata"), dict) else {}
    units = meta.get("units", "m")
    if units not in ("m", "mm"):
        raise RecordingError(f"{path}: [metadata] units must be \"m\" or \"mm\", got {units!r}")
    scale = 1.0 if units == "m" else 1e-3
    poses, intrinsics = {}, {}
    try:
        for key, table in doc.items():
            if key == "metadata" or not isinstance(table, dict):
                continue
            name = str(table.get("name", key))
            if name not in native:
                raise RecordingError(f"{path}: camera {name!r} is not in the recording "
                                     f"(recording: {', '.join(native)}); rename the table's name")
            poses[name], intrinsics[name] = _camera(table, native[name], scale, f"{path}, [{key}]")
        if not poses:
            raise RecordingError(f"{path}: no camera tables (with matrix, rotation, translation)")
        names = list(poses)
        return Calibration(poses, intrinsics, dict.fromkeys(names, 0.0), names[0],
                           {"world": "the camera file's world frame", "source": path.name,
                            "notes": ["camera TOML: no clock offsets (all 0 s)"]})
    except RecordingError:
        raise
    except (BenchError, KeyError, TypeError, ValueError) as exc:
        raise RecordingError(f"{path}: malformed camera TOML ({type(exc).__name__}: {exc})") from None


def load_any_calibration(path: str | os.PathLike, native: dict[str, Intrinsics]) -> Calibration:
    """A ``mocap-bench-calibration`` file, or an aniposelib / Pose2Sim camera TOML (see the module).

    Parameters
    ----------
    path : path-like
        Calibration file.
    native : dict
        Camera name -> the recording's intrinsics (used for camera TOMLs only).

    Raises
    ------
    RecordingError
        The file is missing, malformed or of neither format.
    """
    path = Path(path)
    doc = read_toml_file(path)
    if is_camera_toml(doc):
        return load_camera_toml(path, native)
    return load_calibration(path)


def load_calibration_for(recording: Recording, path: str | os.PathLike) -> Calibration:
    """The calibration at ``path`` (either format, see :func:`load_any_calibration`), checked to cover
    exactly the recording's cameras, each of which has a usable skeleton stream.

    Raises
    ------
    RecordingError
        The file cannot be read, or a camera has no usable skeleton (fewer than 2 frames, no joints).
    BadInputError
        The calibration lacks a camera of the recording or names one the recording lacks.
    """
    calibration = load_any_calibration(path, {c.name: c.intrinsics for c in recording.cameras})
    check_camera_sets(recording.camera_names, calibration.camera_names, str(path))
    check_usable_streams({c.name: c.skeleton for c in recording.cameras}, "the recording")
    return calibration
