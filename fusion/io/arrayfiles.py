"""Directories of ``.npy`` arrays listed in a JSON manifest with sizes and SHA-256 checksums.

Shared by recordings, ground truth and results so that every on-disk artefact is byte-for-byte
reproducible and reports truncation or corruption by file name.
"""

from __future__ import annotations

import hashlib
import io
from pathlib import Path
from typing import Any

import numpy as np

from fusion.errors import RecordingError


def write_arrays(root: Path, subdir: str, arrays: dict[str, np.ndarray]) -> dict[str, dict[str, Any]]:
    """Write each array to ``root/subdir/<key>.npy``; return manifest entries keyed like ``arrays``."""
    entries = {}
    (root / subdir).mkdir(parents=True, exist_ok=True)
    for key, arr in arrays.items():
        buf = io.BytesIO()
        np.save(buf, np.ascontiguousarray(arr), allow_pickle=False)
        data = buf.getvalue()
        rel = f"{subdir}/{key}.npy" if subdir else f"{key}.npy"
        (root / rel).write_bytes(data)
        entries[key] = {"path": rel, "bytes": len(data), "sha256": hashlib.sha256(data).hexdigest()}
    return entries


def read_array(root: Path, entry: dict[str, Any]) -> np.ndarray:
    """Load one array listed by :func:`write_arrays`, checking size and checksum.

    Raises
    ------
    RecordingError
        The file is missing, truncated, corrupt or not a valid ``.npy`` array.
    """
    try:
        fpath = root / entry["path"]
        expected_bytes, expected_sha = entry["bytes"], entry["sha256"]
    except (KeyError, TypeError):
        raise RecordingError(f"{root}: malformed file entry {entry!r} in the manifest") from None
    try:
        data = fpath.read_bytes()
    except FileNotFoundError:
        raise RecordingError(f"{fpath} is missing") from None
    if len(data) != expected_bytes:
        raise RecordingError(f"{fpath} is truncated or altered: {len(data)} bytes, manifest says {expected_bytes}")
    if hashlib.sha256(data).hexdigest() != expected_sha:
        raise RecordingError(f"{fpath} is corrupt: its SHA-256 does not match the manifest")
    try:
        return np.load(io.BytesIO(data), allow_pickle=False)
    except ValueError as exc:
        raise RecordingError(f"{fpath} is not a valid .npy array: {exc}") from None
