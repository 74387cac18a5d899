"""NTU RGB+D ``.skeleton`` files (Kinect v2, 25 joints, 30 Hz).

A file is a whitespace-separated token stream (LF or CRLF line ends): the frame count, then per
frame the body count and per body 10 body fields, the joint count (25) and per joint ``x y z depthX
depthY colorX colorY orientationW orientationX orientationY orientationZ trackingState``. Positions
are Kinect v2 camera space in metres (+x the sensor's left, +y up, +z forward).

File names ``SsssCcccPpppRrrrAaaa`` give setup, camera, performer, replication and action. Files
that differ only in C are one performance seen by several cameras; they are read as one recording
with cameras ``cam<C>``. The files carry no timestamps: frame k gets ``k / 30`` s on every camera, so
cameras are aligned by frame index only, to within about one frame (their lengths differ by a few
frames).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from fusion.camera import KINECT_V2_DEPTH, Intrinsics
from fusion.errors import BadInputError, RecordingError
from fusion.io.atomic import write_text_atomic
from fusion.io.formats import (
    Body,
    PathLike,
    as_paths,
    build_stream,
    checked_recording,
    fmt,
    parse_float,
    parse_int,
    read_text,
    select_main_body,
    skeleton_cameras,
)
from fusion.recording import CameraRecording, Recording
from fusion.topology import KINECT_V2, TrackingState

FRAME_RATE_HZ = 30.0
"""Kinect v2 skeleton rate; frame k of a file is at ``k / FRAME_RATE_HZ`` seconds."""

KINECT_V2_COLOR_APPROX = Intrinsics(width=1920, height=1080, fx=1081.37, fy=1081.37, cx=959.5, cy=539.5)
"""Approximate Kinect v2 colour camera, used only to write ``colorX``/``colorY``.

It ignores the ~5 cm baseline between the depth and colour cameras, so written colour pixels are
off by up to a few tens of pixels; the reader ignores them.
"""

_NAME = re.compile(r"S(\d{3})C(\d{3})P(\d{3})R(\d{3})A(\d{3})")
_BODY_FIELDS = 10
_JOINT_FIELDS = ("x", "y", "z", "depthX", "depthY", "colorX", "colorY",
                 "orientationW", "orientationX", "orientationY", "orientationZ")


class _Tokens:
    """A cursor over the whitespace-separated tokens of one file, remembering line numbers."""

    def __init__(self, path: Path, text: str):
        self.path = path
        self.tokens = [(tok, ln) for ln, line in enumerate(text.splitlines(), 1) for tok in line.split()]
        self.i = 0

    def _next(self, what: str) -> tuple[str, str]:
        if self.i >= len(self.tokens):
            raise RecordingError(f"{self.path}: truncated: the file ends where {what} was expected")
        tok, ln = self.tokens[self.i]
        self.i += 1
        return tok, f"{self.path}, line {ln}"

    def int(self, what: str, lo: int | None = None, hi: int | None = None) -> int:
        return parse_int(*self._next(what), what, lo, hi)

    def float(self, what: str) -> float:
        return parse_float(*self._next(what), what)

    def check_end(self) -> None:
        if self.i < len(self.tokens):
            tok, ln = self.tokens[self.i]
            raise RecordingError(f"{self.path}, line {ln}: unexpected data {tok[:40]!r} after the last frame "
                                 "(frame or body counts are wrong)")


def _parse_name(path: Path) -> dict[str, int]:
    m = _NAME.search(path.stem)
    if m is None:
        raise RecordingError(f"{path}: the name does not follow the NTU pattern SsssCcccPpppRrrrAaaa "
                             "(needed to tell cameras and performances apart)")
    return dict(zip(("setup", "camera", "performer", "replication", "action"), map(int, m.groups())))


def _parse_file(path: Path) -> list[list[Body]]:
    tokens = _Tokens(path, read_text(path))
    n_frames = tokens.int("the frame count", 0)
    frames: list[list[Body]] = []
    for f in range(n_frames):
        n_bodies = tokens.int(f"the body count of frame {f + 1}", 0)
        bodies: list[Body] = []
        for b in range(n_bodies):
            at = f"frame {f + 1}, body {b + 1}"
            body_id = tokens.int(f"the bodyID of {at}")
            for k in range(1, _BODY_FIELDS):
                tokens.float(f"body field {k + 1} of {at}")
            tokens.int(f"the joint count of {at}", KINECT_V2.n_joints, KINECT_V2.n_joints)
            pos = np.empty((KINECT_V2.n_joints, 3))
            st = np.empty(KINECT_V2.n_joints, dtype=np.int8)
            for j, joint in enumerate(KINECT_V2.joints):
                values = [tokens.float(f"{name} of {joint} in {at}") for name in _JOINT_FIELDS]
                pos[j] = values[:3]
                st[j] = tokens.int(f"the trackingState of {joint} in {at}", 0, int(TrackingState.TRACKED))
            bodies.append((body_id, pos, st))
        frames.append(bodies)
    tokens.check_end()
    return frames


def read_ntu(paths: PathLike | Sequence[PathLike], *, intrinsics: Intrinsics = KINECT_V2_DEPTH) -> Recording:
    """Read the ``.skeleton`` files of one NTU RGB+D performance as one recording.

    Parameters
    ----------
    paths : path or sequence of paths
        Files named ``SsssCcccPpppRrrrAaaa.skeleton`` that differ only in the camera C.
    intrinsics : Intrinsics
        Depth intrinsics given to every camera (the files do not carry them).

    Returns
    -------
    Recording
        Cameras ``cam<C>`` in increasing C; (T, 25, 3) positions [m] in Kinect v2 camera space,
        timestamps ``frame_index / 30`` [s]. Two-person files keep the body id present in the most
        frames. Metadata: ``source_format``, ``source_files``, ``setup``, ``performer``,
        ``replication``, ``action`` and the kept ``body_ids`` per camera.

    Raises
    ------
    RecordingError
        A file is unreadable, truncated, has wrong counts or non-numeric tokens.
    BadInputError
        The files belong to different performances or two files are the same camera.
    """
    entries = sorted(((p, _parse_name(p)) for p in as_paths(paths)), key=lambda e: e[1]["camera"])
    files, names = [p for p, _ in entries], [n for _, n in entries]
    performance = {k: v for k, v in names[0].items() if k != "camera"}
    for p, n in zip(files, names):
        if {k: v for k, v in n.items() if k != "camera"} != performance:
            raise BadInputError(f"{files[0].name} and {p.name} are different performances (S, P, R or A "
                                "differ); read them separately")
    cams = [n["camera"] for n in names]
    if len(set(cams)) != len(cams):
        raise BadInputError(f"several files of the same camera: {[p.name for p in files]}")
    cameras, body_ids, stitched = [], {}, {}
    for path, cam in zip(files, cams):
        frames = _parse_file(path)
        name = f"cam{cam}"
        body_id, positions, states, stitched[name] = select_main_body(frames, KINECT_V2.n_joints)
        timestamps = np.arange(len(frames)) / FRAME_RATE_HZ
        cameras.append(CameraRecording(name, intrinsics, build_stream(
            path, KINECT_V2, timestamps, positions, states,
            length_hint="NTU .skeleton files hold metres; convert the file's x, y, z to metres.")))
        body_ids[name] = body_id
    metadata = {"source_format": "ntu_skeleton", "source_files": [p.name for p in files], **performance,
                "body_ids": body_ids,
                "stitched_body_ids": stitched}
    return checked_recording(cameras, metadata)


def _camera_numbers(names: Sequence[str]) -> list[int]:
    numbers = [int(n[3:]) if re.fullmatch(r"cam\d{1,3}", n) else None for n in names]
    if None in numbers or len(set(numbers)) != len(numbers):
        return list(range(1, len(names) + 1))
    return numbers


def _body_text(positions: np.ndarray, states: np.ndarray, intrinsics: Intrinsics) -> list[str]:
    lines = ["72057594037927936 0 0 0 0 0 0 0 0 2", str(KINECT_V2.n_joints)]
    absent = states == TrackingState.NOT_TRACKED
    xyz = np.where(absent[:, None], 0.0, positions)
    uv_depth, _ = intrinsics.project(xyz)
    uv_color, _ = KINECT_V2_COLOR_APPROX.project(xyz)
    uv = np.nan_to_num(np.concatenate([uv_depth, uv_color], axis=1))
    for j in range(KINECT_V2.n_joints):
        numbers = " ".join(fmt(v) for v in (*xyz[j], *uv[j]))
        lines.append(f"{numbers} 0 0 0 0 {min(int(states[j]), int(TrackingState.TRACKED))}")
    return lines


def write_ntu(recording: Recording, out_dir: PathLike, *, setup: int = 1, performer: int = 1,
              replication: int = 1, action: int = 1) -> list[Path]:
    """Write each camera's skeleton stream as an NTU ``.skeleton`` file.

    Cameras named ``cam<N>`` keep N as the file's camera number; otherwise cameras are numbered
    1, 2, ... in recording order. Frame k of a file holds the sample at ``t0 + k / 30`` s, t0 being
    the earliest timestamp of all cameras; frames with no sample or no joint are written with 0
    bodies. Positions are written exactly (shortest round-trip text); ``depthX``/``depthY`` are the
    projections with the camera's intrinsics, ``colorX``/``colorY`` approximate (see
    :data:`KINECT_V2_COLOR_APPROX`), orientations ``0 0 0 0``, body fields zero with bodyID
    72057594037927936 and trackingState 2. State HIGH (3) is written as Tracked (2).

    Parameters
    ----------
    recording : Recording
        Kinect v2-topology recording.
    out_dir : path
        Directory for the files (created if missing); each file is written atomically.
    setup, performer, replication, action : int
        The S, P, R, A numbers of the file names (0..999).

    Returns
    -------
    list of Path
        The written files, one per camera with a skeleton stream.

    Raises
    ------
    BadInputError
        Not Kinect v2 topology, S/P/R/A outside 0..999, or samples closer than one 30 Hz frame.
    """
    cams = skeleton_cameras(recording, KINECT_V2, "NTU .skeleton")
    if not all(isinstance(v, int) and 0 <= v <= 999 for v in (setup, performer, replication, action)):
        raise BadInputError("setup, performer, replication and action must be integers in 0..999")
    t0 = min((c.skeleton.timestamps[0] for c in cams if c.skeleton.n_frames), default=0.0)
    out_dir = Path(out_dir)
    written = []
    for cam, number in zip(cams, _camera_numbers([c.name for c in cams])):
        s = cam.skeleton
        index = np.rint((s.timestamps - t0) * FRAME_RATE_HZ).astype(int)
        if np.any(np.diff(index) < 1):
            raise BadInputError(f"camera {cam.name}: samples closer than one frame at 30 Hz cannot be written "
                                "as NTU frames")
        n_frames = int(index[-1]) + 1 if len(index) else 0
        frames: list[list[str]] = [["0"] for _ in range(n_frames)]
        for t, k in enumerate(index):
            if np.any(s.states[t] != TrackingState.NOT_TRACKED):
                frames[k] = ["1", *_body_text(s.positions[t], s.states[t], cam.intrinsics)]
        path = out_dir / f"S{setup:03d}C{number:03d}P{performer:03d}R{replication:03d}A{action:03d}.skeleton"
        write_text_atomic(path, "\n".join([str(n_frames), *(line for f in frames for line in f)]) + "\n")
        written.append(path)
    return written
