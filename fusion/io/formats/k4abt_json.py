"""Azure Kinect / Orbbec body-tracking JSON, as written by the K4ABT SDK's ``offline_processor``.

Top level: ``k4abt_sdk_version``, ``source_file``, ``joint_names`` (the 32 K4ABT joints),
``bone_list`` and ``frames``; a frame is ``{timestamp_usec, frame_id, num_bodies, bodies}`` and a
body ``{body_id, joint_positions: 32 x [x, y, z] mm, joint_orientations: 32 x [w, x, y, z]}``.
Positions are in the depth camera frame (+x right, +y down, +z forward); readers convert them to
metres and keep those axes (``Intrinsics.axes`` is OPENCV). Orientations are checked but not kept.

The SDK writes no confidences, so every joint is *assumed* TRACKED (2). A body may carry a list
of 32 integers 0..3 under ``joint_confidences`` (or ``confidence_level``), which is used when
present; the writer always adds ``joint_confidences`` so states survive a round trip.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fusion.camera import AxisConvention, Intrinsics
from fusion.errors import BadInputError, RecordingError
from fusion.io.atomic import write_text_atomic
from fusion.io.formats import (
    Body,
    PathLike,
    as_paths,
    build_stream,
    camera_names,
    checked_recording,
    read_text,
    select_main_body,
    skeleton_cameras,
)
from fusion.recording import CameraRecording, Recording
from fusion.topology import K4ABT, TrackingState

K4A_NFOV_UNBINNED = Intrinsics(width=640, height=576, fx=504.0, fy=504.0, cx=320.0, cy=288.0,
                               min_depth_m=0.5, max_depth_m=3.86, axes=AxisConvention.OPENCV)
"""*Default* Azure Kinect depth intrinsics, NFOV unbinned mode (640 x 576, 0.5-3.86 m).

Nominal values; a real unit's factory calibration differs by a few pixels.
"""

_CONFIDENCE_KEYS = ("joint_confidences", "confidence_level")
_J = K4ABT.n_joints


def _reject_constant(name: str) -> None:
    raise ValueError(f"{name} is not a finite number")


def _get(obj: Any, key: str, where: str) -> Any:
    if not isinstance(obj, dict):
        raise RecordingError(f"{where}: expected a JSON object, got {type(obj).__name__}")
    if key not in obj:
        raise RecordingError(f"{where}: missing key {key!r}")
    return obj[key]


def _is_number(x: Any) -> bool:
    return type(x) in (int, float)


def _table(value: Any, n_cols: int, where: str, what: str) -> np.ndarray:
    """A (32, n_cols) float array from a JSON list of 32 lists of n_cols finite numbers."""
    ok = isinstance(value, list) and len(value) == _J and all(
        isinstance(r, list) and len(r) == n_cols and all(map(_is_number, r)) for r in value)
    if not ok:
        raise RecordingError(f"{where}: {what} must be {_J} lists of {n_cols} numbers")
    try:
        arr = np.array(value, dtype=np.float64)
    except OverflowError:
        arr = np.array([np.inf])
    if not np.all(np.isfinite(arr)):
        raise RecordingError(f"{where}: {what} contains a number out of range")
    return arr


def _states(body: dict, where: str) -> np.ndarray | None:
    key = next((k for k in _CONFIDENCE_KEYS if k in body), None)
    if key is None:
        return None
    value = body[key]
    if not (isinstance(value, list) and len(value) == _J
            and all(type(c) is int and 0 <= c <= int(TrackingState.HIGH) for c in value)):
        raise RecordingError(f"{where}: {key} must be {_J} integers in 0..3")
    return np.array(value, dtype=np.int8)


def _parse_file(path: Path) -> tuple[dict, list[float], list[list[Body]], bool]:
    """Top level, timestamps [s], bodies per frame and whether confidences were in the file."""
    try:
        doc = json.loads(read_text(path), parse_constant=_reject_constant)
    except (ValueError, RecursionError) as exc:  # JSONDecodeError, NaN/Infinity literals, deep nesting
        raise RecordingError(f"{path}: not valid body-tracking JSON ({exc})") from None
    names = _get(doc, "joint_names", str(path))
    if names != list(K4ABT.joints):
        raise RecordingError(f"{path}: joint_names must be the {_J} K4ABT joints in SDK order")
    frames_json = _get(doc, "frames", str(path))
    if not isinstance(frames_json, list):
        raise RecordingError(f"{path}: 'frames' must be a list")
    timestamps, frames, has_confidence = [], [], False
    for f, frame in enumerate(frames_json):
        where = f"{path}, frame {f + 1}"
        t_usec = _get(frame, "timestamp_usec", where)
        bodies_json = _get(frame, "bodies", where)
        num_bodies = _get(frame, "num_bodies", where)
        if not (_is_number(t_usec) and np.isfinite(t_usec)):
            raise RecordingError(f"{where}: timestamp_usec must be a number, got {t_usec!r}")
        if type(frame.get("frame_id", 0)) is not int:
            raise RecordingError(f"{where}: frame_id must be an integer, got {frame['frame_id']!r}")
        if not isinstance(bodies_json, list) or type(num_bodies) is not int or num_bodies != len(bodies_json):
            raise RecordingError(f"{where}: num_bodies ({num_bodies!r}) must equal the length of the bodies list")
        bodies: list[Body] = []
        for b, body in enumerate(bodies_json):
            at = f"{where}, body {b + 1}"
            body_id = _get(body, "body_id", at)
            if type(body_id) is not int:
                raise RecordingError(f"{at}: body_id must be an integer, got {body_id!r}")
            positions = _table(_get(body, "joint_positions", at), 3, at, "joint_positions") / 1000.0
            if "joint_orientations" in body:  # unused, but checked: damage there means a corrupt file
                _table(body["joint_orientations"], 4, at, "joint_orientations")
            states = _states(body, at)
            has_confidence |= states is not None
            if states is None:
                states = np.full(_J, TrackingState.TRACKED, dtype=np.int8)
            bodies.append((body_id, positions, states))
        timestamps.append(t_usec / 1e6)
        frames.append(bodies)
    return doc, timestamps, frames, has_confidence


def read_k4abt_json(paths: PathLike | Sequence[PathLike], *, intrinsics: Intrinsics = K4A_NFOV_UNBINNED,
                    names: Sequence[str] | None = None) -> Recording:
    """Read ``offline_processor`` JSON files, one per camera, as one recording.

    Parameters
    ----------
    paths : path or sequence of paths
        One JSON file per camera.
    intrinsics : Intrinsics
        Depth intrinsics for every camera (default: nominal NFOV unbinned).
    names : sequence of str, optional
        Camera names; default the file stems when valid and unique, else ``cam1`` ... ``camN``.

    Returns
    -------
    Recording
        K4ABT skeletons, (T, 32, 3) [m] in each camera's own frame (+x right, +y down, +z
        forward), timestamps ``timestamp_usec / 1e6`` [s]. Metadata: ``source_format``,
        ``source_files``, ``k4abt_sdk_version`` and ``confidence`` (``"file"`` or
        ``"assumed_tracked"``) per camera, and the kept ``body_ids``.

    Raises
    ------
    RecordingError
        Invalid JSON, missing keys, wrong counts or shapes, non-finite numbers, or timestamps that
        do not increase.
    BadInputError
        ``names`` does not give one name per file.
    """
    files = as_paths(paths)
    names = camera_names(files) if names is None else list(names)
    if len(names) != len(files):
        raise BadInputError(f"got {len(names)} camera names for {len(files)} files")
    cameras, versions, confidence, body_ids, stitched = [], {}, {}, {}, {}
    for path, name in zip(files, names):
        doc, timestamps, frames, has_confidence = _parse_file(path)
        body_id, positions, states, stitched[name] = select_main_body(frames, _J)
        stream = build_stream(path, K4ABT, np.array(timestamps), positions, states,
                              length_hint="K4ABT JSON holds millimetres; convert the file's positions to mm.",
                              time_hint="timestamp_usec must be in microseconds; convert the file's timestamps.")
        cameras.append(CameraRecording(name, intrinsics, stream))
        versions[name] = str(doc.get("k4abt_sdk_version", "unknown"))
        confidence[name] = "file" if has_confidence else "assumed_tracked"
        body_ids[name] = body_id
    metadata = {"source_format": "k4abt_json", "source_files": [p.name for p in files],
                "k4abt_sdk_version": versions, "confidence": confidence, "body_ids": body_ids,
                "stitched_body_ids": stitched}
    return checked_recording(cameras, metadata)


def write_k4abt_json(recording: Recording, out_dir: PathLike) -> list[Path]:
    """Write each camera's skeleton stream as ``<out_dir>/<camera>.json`` in ``offline_processor`` layout.

    Positions are written in millimetres (absent joints as ``[0, 0, 0]`` with confidence 0),
    timestamps as whole microseconds, orientations as identity ``[1, 0, 0, 0]``, ``body_id`` 1 and
    the states under ``joint_confidences``. Frames without any joint have no body.

    Parameters
    ----------
    recording : Recording
        K4ABT-topology recording.
    out_dir : path
        Directory for the files (created if missing); each file is written atomically.

    Returns
    -------
    list of Path
        The written files, one per camera with a skeleton stream.
    """
    cams = skeleton_cameras(recording, K4ABT, "K4ABT JSON")
    bones = [[K4ABT.joints[p], K4ABT.joints[c]] for p, c in K4ABT.bones]
    written = []
    for cam in cams:
        s = cam.skeleton
        frames = []
        for t in range(s.n_frames):
            present = s.states[t] != TrackingState.NOT_TRACKED
            bodies = [{
                "body_id": 1,
                "joint_positions": np.where(present[:, None], s.positions[t] * 1000.0, 0.0).tolist(),
                "joint_orientations": [[1.0, 0.0, 0.0, 0.0]] * _J,
                "joint_confidences": s.states[t].tolist(),
            }] if present.any() else []
            frames.append({"timestamp_usec": round(float(s.timestamps[t]) * 1e6), "frame_id": t,
                           "num_bodies": len(bodies), "bodies": bodies})
        doc = {"k4abt_sdk_version": "unknown", "source_file": cam.name, "joint_names": list(K4ABT.joints),
               "bone_list": bones, "frames": frames}
        path = Path(out_dir) / f"{cam.name}.json"
        write_text_atomic(path, json.dumps(doc, allow_nan=False) + "\n")
        written.append(path)
    return written
