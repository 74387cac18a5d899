"""The versioned on-disk format of multi-camera recordings (:mod:`fusion.recording`).

On disk a recording is a directory::

    recording.json            manifest (format name, version, topology, cameras, metadata, file checksums)
    <camera>/skeleton_timestamps.npy   (T,) float64 s
    <camera>/skeleton_positions.npy    (T, J, 3) float64 m, camera frame, NaN = absent
    <camera>/skeleton_states.npy       (T, J) int8 TrackingState
    <camera>/depth.h5                  depth frames, timestamps and labels (only if the camera has depth)

Skeleton arrays are plain ``.npy`` files (byte-for-byte reproducible); the manifest lists each file's
size and SHA-256, so truncation or corruption is reported by name. Depth frames (version 2) are
chunked, compressed HDF5 (:mod:`fusion.io.depth_store`), written frame by frame and read lazily, one
frame at a time; the manifest lists the depth file's size and frame count, and each frame's chunk
carries its own checksum. Version 1 recordings, whose depth is in ``depth_timestamps.npy``,
``depth_mm.npy`` and ``depth_labels.npy`` (read whole), are still read. Writing is atomic: the
directory appears complete or not at all.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from fusion.camera import Intrinsics
from fusion.depth import DepthStream
from fusion.errors import BenchError, RecordingError
from fusion.io.arrayfiles import read_array, write_arrays
from fusion.io.atomic import atomic_directory
from fusion.io.depth_store import StoredFrames, open_depth, write_depth
from fusion.io.plausibility import (
    check_clock_overlap,
    check_integer_states,
    check_stream_units,
)
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import topology_by_name

FORMAT_NAME = "mocap-bench-recording"
FORMAT_VERSION = 2
READ_VERSIONS = (1, 2)
MANIFEST = "recording.json"
DEPTH_FILE = "depth.h5"


def depth_file(root: str | os.PathLike, camera: str) -> Path:
    """Where a recording directory ``root`` keeps ``camera``'s depth file."""
    return Path(root) / camera / DEPTH_FILE


def _skeleton_arrays(cam: CameraRecording) -> dict[str, np.ndarray]:
    if cam.skeleton is None:
        return {}
    return {
        "skeleton_timestamps": cam.skeleton.timestamps,
        "skeleton_positions": cam.skeleton.positions,
        "skeleton_states": cam.skeleton.states,
    }


def _stored_at(depth: DepthStream, target: Path) -> bool:
    """Whether ``depth`` is already the depth file ``target`` (streamed there while it was recorded)."""
    parts = [depth.depth_mm] + ([] if depth.labels is None else [depth.labels])
    return target.is_file() and all(isinstance(p, StoredFrames) and p.path.resolve() == target.resolve()
                                    for p in parts)


def write_recording(recording: Recording, root: str | os.PathLike) -> Path:
    """Write ``recording``'s files and manifest into the directory ``root`` (not atomic by itself).

    For staging directories that are made atomic by their caller (:func:`save_recording`, a run
    directory). A camera whose depth was streamed into ``depth_file(root, name)`` keeps that file;
    other depth is copied there frame by frame.
    """
    root = Path(root)
    topology = recording.topology
    manifest: dict[str, Any] = {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "topology": None if topology is None else topology.name,
        "metadata": recording.metadata,
        "cameras": [],
    }
    root.mkdir(parents=True, exist_ok=True)
    for cam in recording.cameras:
        entry = {"name": cam.name, "intrinsics": cam.intrinsics.to_dict(),
                 "files": write_arrays(root, cam.name, _skeleton_arrays(cam))}
        if cam.depth is not None:
            target = depth_file(root, cam.name)
            if not _stored_at(cam.depth, target):
                write_depth(cam.depth, target)
            entry["depth"] = {"path": target.relative_to(root).as_posix(), "bytes": target.stat().st_size,
                              "frames": cam.depth.n_frames}
        manifest["cameras"].append(entry)
    (root / MANIFEST).write_text(json.dumps(manifest, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    return root


def save_recording(recording: Recording, path: str | os.PathLike, *, overwrite: bool = False) -> Path:
    """Write ``recording`` to the directory ``path`` atomically; returns the path.

    Raises
    ------
    BadInputError
        ``path`` exists and is not empty while ``overwrite`` is False.
    """
    path = Path(path)
    with atomic_directory(path, overwrite=overwrite) as tmp:
        write_recording(recording, tmp)
    return path


def _read_manifest(path: Path) -> dict[str, Any]:
    mpath = path / MANIFEST
    if not path.is_dir():
        raise RecordingError(f"{path} is not a recording directory (it does not exist or is a file)")
    if not mpath.is_file():
        raise RecordingError(f"{path} has no {MANIFEST}: not a mocap-bench recording (import real files with "
                             "`mocap-bench import`)")
    try:
        manifest = json.loads(mpath.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise RecordingError(f"{mpath} is corrupt (not valid JSON: {exc})") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT_NAME:
        raise RecordingError(f"{mpath} is not a {FORMAT_NAME} manifest")
    if manifest.get("version") not in READ_VERSIONS:
        raise RecordingError(f"{mpath}: format version {manifest.get('version')!r} is not supported "
                             f"(this mocap-bench reads versions {', '.join(map(str, READ_VERSIONS))})")
    return manifest


def _read_depth(path: Path, entry: dict[str, Any]) -> DepthStream:
    """A version 2 camera's depth file, checked against its manifest entry (size, frame count)."""
    try:
        fpath, expected_bytes, expected_frames = path / entry["path"], entry["bytes"], entry["frames"]
    except (KeyError, TypeError):
        raise RecordingError(f"{path}: malformed depth entry {entry!r} in the manifest") from None
    if fpath.is_file() and fpath.stat().st_size != expected_bytes:
        raise RecordingError(f"{fpath} is truncated or altered: {fpath.stat().st_size} bytes, manifest says "
                             f"{expected_bytes}; re-simulate or re-import the recording")
    depth = open_depth(fpath)
    if depth.n_frames != expected_frames:
        raise RecordingError(f"{fpath} holds {depth.n_frames} frames, the manifest says {expected_frames}")
    return depth


def load_recording(path: str | os.PathLike) -> Recording:
    """Read a recording directory written by :func:`save_recording` (format version 1 or 2).

    Skeletons are read now; version 2 depth frames lazily, one frame per access (a damaged frame
    raises :class:`RecordingError` when it is read).

    Raises
    ------
    RecordingError
        Missing, truncated or corrupt files, an unknown format version or inconsistent arrays.
    """
    path = Path(path)
    manifest = _read_manifest(path)
    try:
        topology = None if manifest["topology"] is None else topology_by_name(manifest["topology"])
        cameras = []
        for cm in manifest["cameras"]:
            arrays = {k: read_array(path, e) for k, e in cm["files"].items()}
            skeleton = depth = None
            if "skeleton_timestamps" in arrays:
                if topology is None:
                    raise RecordingError(f"{path}: skeleton data but no topology in the manifest")
                check_integer_states(arrays["skeleton_states"], f"{path}, camera {cm['name']}")
                skeleton = SkeletonStream(
                    topology, arrays["skeleton_timestamps"], arrays["skeleton_positions"], arrays["skeleton_states"]
                )
                check_stream_units(skeleton, f"{path}, camera {cm['name']}")
            if "depth" in cm:
                depth = _read_depth(path, cm["depth"])
            elif "depth_timestamps" in arrays:  # version 1
                depth = DepthStream(arrays["depth_timestamps"], arrays["depth_mm"], arrays.get("depth_labels"))
            cameras.append(CameraRecording(cm["name"], Intrinsics.from_dict(cm["intrinsics"]), skeleton, depth))
        check_clock_overlap({c.name: (c.skeleton.timestamps[0], c.skeleton.timestamps[-1]) for c in cameras
                             if c.skeleton is not None and c.skeleton.n_frames}, str(path))
        return Recording(tuple(cameras), manifest.get("metadata", {}))
    except RecordingError:
        raise
    except (BenchError, KeyError, TypeError, AttributeError) as exc:
        raise RecordingError(f"{path}: inconsistent recording ({type(exc).__name__}: {exc})") from None
