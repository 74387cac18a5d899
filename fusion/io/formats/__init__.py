"""Readers and writers of real-sensor skeleton files.

- :mod:`fusion.io.formats.ntu`: NTU RGB+D ``.skeleton`` files (Kinect v2, 25 joints).
- :mod:`fusion.io.formats.k4abt_json`: Azure Kinect body-tracking ``offline_processor`` JSON (32 joints).
- :mod:`fusion.io.formats.csv_skeleton`: one-row-per-frame CSV (either topology).
- :mod:`fusion.io.formats.ui_prmd`: the UI-PRMD data set's Kinect v2 episodes (22 joints, read only)
  and its Vicon Plug-in-Gait marker files (read as :class:`~fusion.io.mocap_files.MarkerData`).
- :mod:`fusion.io.formats.labels`: data set labels that :mod:`fusion.io.export` writes inside C3D,
  TRC and CSV files.

Every reader returns a :class:`~fusion.recording.Recording` whose cameras keep the sensor's own
camera frame, converted to metres; the frame's axis layout is recorded in ``Intrinsics.axes``.
A malformed file raises :class:`~fusion.errors.RecordingError` naming the file and the place;
bad arguments raise :class:`~fusion.errors.BadInputError`.

When a file holds several people, every reader keeps one: the body id present in the most frames
(ties go to the id seen first), stitched with the ids under which the tracker re-acquired the same
person (:func:`select_main_body`; listed in the metadata's ``stitched_body_ids`` and logged as a
warning). Frames without that body are absent (NaN positions, state NOT_TRACKED), so timestamps and
frame alignment are kept.

This module also holds the helpers the format modules share.
"""

from __future__ import annotations

import enum
import logging
import os
import re
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from fusion.errors import BadInputError, RecordingError
from fusion.io.plausibility import check_clock_overlap, check_stream_units
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import K4ABT, KINECT_V2, UI_PRMD, Topology, TrackingState

if TYPE_CHECKING:
    from fusion.camera import AxisConvention, Intrinsics


class FileFormat(enum.Enum):
    """Skeleton file formats of real body trackers."""

    NTU = "ntu"
    K4ABT_JSON = "k4abt-json"
    CSV = "csv"
    UI_PRMD_KINECT = "ui-prmd-kinect"

    @property
    def writable(self) -> bool:
        """Whether recordings can be written in this format (UI-PRMD episodes are only read)."""
        return self is not FileFormat.UI_PRMD_KINECT


FORMAT_TOPOLOGY: dict[FileFormat, Topology | None] = {FileFormat.NTU: KINECT_V2, FileFormat.K4ABT_JSON: K4ABT,
                                                      FileFormat.CSV: None, FileFormat.UI_PRMD_KINECT: UI_PRMD}
"""The joint set a format is tied to (None: either)."""

PathLike = str | os.PathLike

log = logging.getLogger(__name__)

_FLOAT = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")
_INT = re.compile(r"[+-]?\d+")

Body = tuple[int, np.ndarray, np.ndarray]
"""One tracked body in one frame: (body id, (J, 3) positions [m], (J,) states)."""


def as_paths(paths: PathLike | Sequence[PathLike]) -> list[Path]:
    """One path or a non-empty sequence of paths as a list of :class:`Path`."""
    if isinstance(paths, (str, os.PathLike)):
        return [Path(paths)]
    out = [Path(p) for p in paths]
    if not out:
        raise BadInputError("no files given; pass at least one path")
    return out


def read_text(path: Path) -> str:
    """The UTF-8 text of ``path`` (a leading BOM dropped); unreadable or empty files are errors."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise RecordingError(f"{path}: cannot read the file ({exc.strerror or exc})") from None
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise RecordingError(f"{path}: not a text file (byte {exc.start} is not valid UTF-8)") from None
    if not text.strip():
        raise RecordingError(f"{path}: the file is empty")
    return text


def parse_float(token: str, where: str, what: str) -> float:
    """A finite decimal number (``1``, ``-0.5``, ``8.094816E-05``); NaN, inf and other text are errors."""
    if not _FLOAT.fullmatch(token):
        raise RecordingError(f"{where}: expected a number for {what}, got {token[:40]!r}")
    value = float(token)
    if not np.isfinite(value):
        raise RecordingError(f"{where}: {what} is out of range ({token[:40]!r})")
    return value


def parse_int(token: str, where: str, what: str, lo: int | None = None, hi: int | None = None) -> int:
    """A decimal integer, optionally within ``lo..hi`` (inclusive)."""
    if not _INT.fullmatch(token):
        raise RecordingError(f"{where}: expected an integer for {what}, got {token[:40]!r}")
    value = int(token)
    if (lo is not None and value < lo) or (hi is not None and value > hi):
        raise RecordingError(f"{where}: {what} must lie in {lo}..{hi if hi is not None else ''}, got {value}")
    return value


def fmt(x: float) -> str:
    """Shortest text that reads back as exactly the float ``x``."""
    return repr(float(x))


MAX_REACQUIRE_JUMP_M = 0.3
"""Largest move [m] of the body's centroid across a change of body id, plus :data:`MAX_SPEED_M_PER_FRAME`
per frame of gap, for the new id to count as the same person re-acquired by the tracker."""

MAX_SPEED_M_PER_FRAME = 0.1
"""A person's centroid moves at most ~3 m/s: 0.1 m per frame at 30 Hz."""


def _centroid(pos: np.ndarray, st: np.ndarray) -> np.ndarray:
    """(3,) mean position of the present joints (NaN if none)."""
    present = st != TrackingState.NOT_TRACKED
    return pos[present].mean(axis=0) if present.any() else np.full(3, np.nan)


def _continues(track: dict[int, np.ndarray], frames_c: dict[int, np.ndarray]) -> bool:
    """Whether the frames of another id continue the track at every boundary where they meet it."""
    checks = []
    first, last = min(frames_c), max(frames_c)
    before = [t for t in track if t < first]
    after = [t for t in track if t > last]
    if before:
        checks.append((track[max(before)], frames_c[first], first - max(before)))
    if after:
        checks.append((track[min(after)], frames_c[last], min(after) - last))
    return bool(checks) and all(
        np.linalg.norm(a - b) <= MAX_REACQUIRE_JUMP_M + MAX_SPEED_M_PER_FRAME * gap for a, b, gap in checks)


def select_main_body(frames: Sequence[Sequence[Body]], n_joints: int
                     ) -> tuple[int | None, np.ndarray, np.ndarray, list[int]]:
    """Keep one person: the body id present in the most frames (ties to the id seen first), stitched
    with the ids under which the tracker re-acquired that person.

    Another id is the same person re-acquired when it never shares a frame with the track built so far
    and its body continues the track where they meet (centroid within :data:`MAX_REACQUIRE_JUMP_M` plus
    :data:`MAX_SPEED_M_PER_FRAME` per frame of gap); ids are tried from the most seen. An id seen
    together with the kept person is someone else and is dropped.

    Parameters
    ----------
    frames : sequence of sequences of Body
        Per frame, the bodies found (possibly none).
    n_joints : int
        J.

    Returns
    -------
    body_id : int or None
        The kept id (None when no frame has a body).
    positions : np.ndarray
        (T, J, 3) float64 [m], NaN where the body is absent or a joint NOT_TRACKED.
    states : np.ndarray
        (T, J) int8 TrackingState, 0 where absent.
    stitched : list of int
        The other ids whose frames were added to the track, in the order they were added.
    """
    counts = Counter(bid for bodies in frames for bid in {b[0] for b in bodies})
    order = {bid: i for i, bid in enumerate(dict.fromkeys(b[0] for bodies in frames for b in bodies))}
    ranked = sorted(counts, key=lambda bid: (-counts[bid], order[bid]))
    body_id = ranked[0] if ranked else None
    by_id: dict[int, dict[int, tuple[np.ndarray, np.ndarray]]] = {bid: {} for bid in ranked}
    for t, bodies in enumerate(frames):
        for bid, pos, st in bodies:
            by_id[bid].setdefault(t, (pos, st))
    positions = np.full((len(frames), n_joints, 3), np.nan)
    states = np.zeros((len(frames), n_joints), dtype=np.int8)
    stitched: list[int] = []
    if body_id is not None:
        track = {t: _centroid(*b) for t, b in by_id[body_id].items()}
        for bid in ranked[1:]:
            if by_id[bid].keys() & track.keys():
                continue
            centroids = {t: _centroid(*b) for t, b in by_id[bid].items()}
            if _continues(track, centroids):
                track |= centroids
                stitched.append(bid)
        for bid in [body_id, *stitched]:
            for t, (pos, st) in by_id[bid].items():
                positions[t], states[t] = pos, st
    positions[states == TrackingState.NOT_TRACKED] = np.nan
    return body_id, positions, states, stitched


def build_stream(path: Path, topology: Topology, timestamps: np.ndarray, positions: np.ndarray,
                 states: np.ndarray, *, length_hint: str = "", time_hint: str = "") -> SkeletonStream:
    """A :class:`SkeletonStream`, with inconsistencies reported as a RecordingError naming ``path``.

    The stream must also pass :func:`~fusion.io.plausibility.check_stream_units`; ``length_hint`` and
    ``time_hint`` tell the user what to do about a length or time unit mistake.
    """
    if len(timestamps) == 0:
        raise RecordingError(f"{path}: the file holds no frames")
    try:
        stream = SkeletonStream(topology, timestamps, positions, states)
    except BadInputError as exc:
        raise RecordingError(f"{path}: inconsistent skeleton data ({exc})") from None
    check_stream_units(stream, str(path), length_hint=length_hint, time_hint=time_hint)
    return stream


def checked_recording(cameras: Sequence[CameraRecording], metadata: dict) -> Recording:
    """The recording of the read cameras, refused when their clocks share no time base
    (:func:`~fusion.io.plausibility.check_clock_overlap`)."""
    spans = {c.name: (float(c.skeleton.timestamps[0]), float(c.skeleton.timestamps[-1])) for c in cameras}
    check_clock_overlap(spans, ", ".join(metadata.get("source_files", [])))
    for name, ids in metadata.get("stitched_body_ids", {}).items():
        if ids:
            log.warning("camera %s: the person was re-acquired under body id(s) %s; stitched into body %s",
                        name, ", ".join(map(str, ids)), metadata["body_ids"][name])
    return Recording(tuple(cameras), metadata)


def camera_names(paths: Sequence[Path]) -> list[str]:
    """File stems when they are valid, unique camera names; otherwise ``cam1`` .. ``camN``."""
    stems = [p.stem for p in paths]
    valid = all(s and s.replace("_", "").replace("-", "").isalnum() and s.isascii() for s in stems)
    if valid and len(set(stems)) == len(stems):
        return stems
    return [f"cam{i + 1}" for i in range(len(paths))]


def reader_inputs(paths: PathLike | Sequence[PathLike], names: Sequence[str] | None,
                  intrinsics: Intrinsics | None, axes: AxisConvention) -> tuple[list[Path], list[str], Intrinsics]:
    """Files, camera names and intrinsics of a one-file-per-camera reader, checked.

    Default names are :func:`camera_names` of the files; default intrinsics the Kinect v2 default
    for Kinect v2 axes and the nominal Azure Kinect NFOV unbinned intrinsics otherwise.
    """
    from fusion.camera import KINECT_V2_DEPTH, AxisConvention
    from fusion.io.formats.k4abt_json import K4A_NFOV_UNBINNED

    files = as_paths(paths)
    names = camera_names(files) if names is None else list(names)
    if len(names) != len(files):
        raise BadInputError(f"got {len(names)} camera names for {len(files)} files")
    if intrinsics is None:
        intrinsics = KINECT_V2_DEPTH if axes is AxisConvention.KINECT_V2 else K4A_NFOV_UNBINNED
    if intrinsics.axes is not axes:
        raise BadInputError(f"intrinsics use {intrinsics.axes.value} axes but the files {axes.value}")
    return files, names, intrinsics


def skeleton_cameras(recording: Recording, topology: Topology, fmt_name: str) -> list:
    """The cameras of ``recording`` that have a skeleton stream, checked to use ``topology``."""
    if not isinstance(recording, Recording):
        raise BadInputError(f"expected a Recording, got {type(recording).__name__}")
    cams = [c for c in recording.cameras if c.skeleton is not None]
    if not cams:
        raise BadInputError("the recording has no skeleton streams to write")
    if recording.topology != topology:
        raise BadInputError(f"{fmt_name} files hold {topology.name} skeletons ({topology.n_joints} joints); "
                            f"this recording uses {recording.topology.name}")
    return cams


from fusion.io.formats.csv_skeleton import (
    CsvOptions,
    read_csv_skeleton,
    write_csv_skeleton,
)
from fusion.io.formats.k4abt_json import read_k4abt_json, write_k4abt_json
from fusion.io.formats.ntu import read_ntu, write_ntu
from fusion.io.formats.ui_prmd import read_ui_prmd_kinect, read_ui_prmd_vicon

__all__ = [
    "CsvOptions",
    "read_csv_skeleton",
    "read_k4abt_json",
    "read_ntu",
    "read_ui_prmd_kinect",
    "read_ui_prmd_vicon",
    "write_csv_skeleton",
    "write_k4abt_json",
    "write_ntu",
]
