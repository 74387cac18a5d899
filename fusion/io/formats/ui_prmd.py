"""UI-PRMD episode files: Kinect v2 joint positions and angles, and Vicon Plug-in-Gait markers.

UI-PRMD (University of Idaho Physical Rehabilitation Movements Data Set; Vakanski et al., Data 3(1):2,
2018) recorded each episode (one repetition of a movement) with a Kinect v2 and a Vicon system at
once. Files ``mMM_sSS_eEE_{positions,angles}.txt.gz`` (movement, subject, episode; ``_inc`` before
``.txt`` for an incorrect execution), in the folders ``Kinect/Positions``, ``Kinect/Angles`` and
``Vicon/Positions``. Each is gzip-compressed text, comma-separated, one frame per row, no header and
no timestamps.

Kinect (:func:`read_ui_prmd_kinect`): 22 joints in a hierarchy (:data:`~fusion.topology.UI_PRMD`),
66 values per row. The positions file holds the root (``Waist``) position and, for every other joint,
its offset from its parent in the parent's frame, in centimetres; the angles file holds each joint's
rotation relative to its parent as Euler angles in degrees about x, y and z
(:func:`euler_zxy`). Absolute positions follow by forward kinematics (:func:`forward_kinematics`) in
the files' axes: x to the subject's left, y up, z toward the camera (the subject faces the camera,
about 2.4 m from it). :data:`R_CAM_FILE` turns them into Kinect v2 camera space, in this one place.
*Assumed*: frames at the nominal 30 Hz (frame k at ``k / 30`` s) and every joint TRACKED (the files
carry neither timestamps nor tracking states). :func:`join_episodes` makes one recording of a
person's episodes (a tracker's statistics need more than one repetition's 1.3-3.7 s).

Vicon (:func:`read_ui_prmd_vicon`): the 39 Plug-in-Gait skin markers :data:`VICON_MARKERS`
(absolute positions of markers, not joint centres), 117 values per row, millimetres, x forward
(the subject faces +x), y to the subject's left, z up, floor near z = 0: already the axes of the
project's z-up world. A marker the system lost is stored as (0, 0, 0), sometimes for a whole
episode; it is read as absent (NaN). *Assumed*: frames at the nominal 100 Hz (frame k at
``k / 100`` s). The Kinect and Vicon files of one episode were cut separately: their lengths and
start times differ, so their clocks are not aligned.

A malformed file raises :class:`~fusion.errors.RecordingError` naming the file, the line and what
to do.
"""

from __future__ import annotations

import dataclasses
import re
import zlib
from pathlib import Path

import numpy as np

from fusion.camera import KINECT_V2_DEPTH, AxisConvention, Intrinsics
from fusion.errors import BadInputError, RecordingError
from fusion.io.formats import PathLike, build_stream, checked_recording
from fusion.io.mocap_files import MarkerData
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import UI_PRMD, TrackingState

KINECT_RATE_HZ = 30.0
"""Nominal Kinect v2 skeleton rate; frame k of a Kinect file is at ``k / KINECT_RATE_HZ`` seconds."""

VICON_RATE_HZ = 100.0
"""Nominal Vicon rate of the data set; frame k of a Vicon file is at ``k / VICON_RATE_HZ`` seconds."""

VICON_MARKERS: tuple[str, ...] = (
    "LFHD", "RFHD", "LBHD", "RBHD", "C7", "T10", "CLAV", "STRN", "RBAK",
    "LSHO", "LUPA", "LELB", "LFRM", "LWRA", "LWRB", "LFIN",
    "RSHO", "RUPA", "RELB", "RFRM", "RWRA", "RWRB", "RFIN",
    "LASI", "RASI", "LPSI", "RPSI",
    "LTHI", "LKNE", "LTIB", "LANK", "LHEE", "LTOE",
    "RTHI", "RKNE", "RTIB", "RANK", "RHEE", "RTOE",
)
"""The 39 Plug-in-Gait markers of a Vicon file, in column order (x, y, z each)."""

KINECT_CAMERA = "kinect"
"""Name of the one camera of a recording read from a Kinect episode."""

LAB = "ui_prmd"
"""The lab of UI-PRMD's recordings (:attr:`fusion.recording.Recording.lab`): one Kinect v2 set-up."""

R_CAM_FILE = np.diag([-1.0, 1.0, -1.0])
"""Rotation taking the Kinect files' axes to Kinect v2 camera space: a half turn about y.

The files have x to the subject's left, y up and z toward the camera, and the subject faces the
camera; Kinect v2 camera space has +x to the sensor's left (the subject's right), +y up and +z out of
the sensor (toward the subject). So ``(x, y, z)`` in a file is ``(-x, y, -z)`` in camera space: the
root, about 2.4 m in front of the sensor, has z near -240 cm in the files and +2.4 m in camera space.
"""

_CM = 0.01
_MM = 0.001
_NAME = re.compile(r"m(\d+)_s(\d+)_e(\d+)_(positions|angles)(_inc)?\.txt(\.gz)?", re.IGNORECASE)
_NUMBER = r"[ \t]*[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?[ \t]*"
_GZIP_MAGIC = b"\x1f\x8b"


def euler_zxy(angles_deg: np.ndarray) -> np.ndarray:
    """Rotation matrices ``R = Rz(gamma) Rx(alpha) Ry(beta)`` of UI-PRMD's Euler angles.

    Parameters
    ----------
    angles_deg : numpy.ndarray
        (..., 3) angles [deg] about x, y and z: ``(alpha, beta, gamma)``, the files' column order.

    Returns
    -------
    numpy.ndarray
        (..., 3, 3) rotation matrices (the intrinsic z-x-y sequence ``Rotation.from_euler("ZXY",
        [gamma, alpha, beta])`` of scipy).
    """
    a = np.radians(np.asarray(angles_deg, dtype=np.float64))
    ca, sa = np.cos(a[..., 0]), np.sin(a[..., 0])
    cb, sb = np.cos(a[..., 1]), np.sin(a[..., 1])
    cg, sg = np.cos(a[..., 2]), np.sin(a[..., 2])
    one, zero = np.ones_like(ca), np.zeros_like(ca)
    Rx = np.stack([one, zero, zero, zero, ca, -sa, zero, sa, ca], axis=-1).reshape(*ca.shape, 3, 3)
    Ry = np.stack([cb, zero, sb, zero, one, zero, -sb, zero, cb], axis=-1).reshape(*ca.shape, 3, 3)
    Rz = np.stack([cg, -sg, zero, sg, cg, zero, zero, zero, one], axis=-1).reshape(*ca.shape, 3, 3)
    return Rz @ Rx @ Ry


def forward_kinematics(offsets: np.ndarray, angles_deg: np.ndarray, parents: tuple[int, ...] | np.ndarray
                       ) -> np.ndarray:
    """Absolute joint positions of a hierarchy of parent-relative offsets and rotations.

    ``G_root = R_root``, ``G_j = G_parent R_j``, ``X_root = p_root``, ``X_j = X_parent + G_parent p_j``,
    with ``R_j = euler_zxy(angles_j)`` (:func:`euler_zxy`).

    Parameters
    ----------
    offsets : numpy.ndarray
        (T, J, 3): the root's position and every other joint's offset from its parent, in the
        parent's frame (any length unit).
    angles_deg : numpy.ndarray
        (T, J, 3) each joint's rotation relative to its parent [deg] about x, y, z.
    parents : sequence of int
        (J,) parent index per joint, -1 for the root; every parent comes before its children.

    Returns
    -------
    numpy.ndarray
        (T, J, 3) absolute positions, in the unit and axes of ``offsets``.

    Raises
    ------
    BadInputError
        Shapes disagree, or the parents are not a tree listed parents first.
    """
    offsets = np.asarray(offsets, dtype=np.float64)
    angles_deg = np.asarray(angles_deg, dtype=np.float64)
    parents = [int(p) for p in parents]
    J = len(parents)
    if offsets.ndim != 3 or offsets.shape[1:] != (J, 3) or angles_deg.shape != offsets.shape:
        raise BadInputError(f"offsets and angles must both be (T, {J}, 3), got {offsets.shape} and {angles_deg.shape}")
    if parents[0] != -1 or any(not 0 <= p < j for j, p in enumerate(parents) if j > 0):
        raise BadInputError(f"parents must list the root (-1) first and every parent before its children, got {parents}")
    R = euler_zxy(angles_deg)
    G = np.empty_like(R)
    X = np.empty_like(offsets)
    G[:, 0], X[:, 0] = R[:, 0], offsets[:, 0]
    for j in range(1, J):
        p = parents[j]
        G[:, j] = G[:, p] @ R[:, j]
        X[:, j] = X[:, p] + np.einsum("tab,tb->ta", G[:, p], offsets[:, j])
    return X


def episode_info(path: PathLike) -> dict[str, int | bool | None]:
    """Movement, subject, episode and correct/incorrect execution from a file's name.

    Returns
    -------
    dict
        ``movement``, ``subject``, ``episode`` (int) and ``correct`` (False with the ``_inc``
        suffix), all None when the name does not follow ``mMM_sSS_eEE_{positions,angles}[_inc].txt.gz``.
    """
    m = _NAME.fullmatch(Path(path).name)
    if m is None:
        return {"movement": None, "subject": None, "episode": None, "correct": None}
    return {"movement": int(m[1]), "subject": int(m[2]), "episode": int(m[3]), "correct": m[5] is None}


def file_kind(path: PathLike) -> str | None:
    """``"positions"`` or ``"angles"`` from a Kinect file's name; None when the name does not say."""
    m = _NAME.fullmatch(Path(path).name)
    return None if m is None else m[4].lower()


def angles_file_for(positions: PathLike) -> Path:
    """The angles file of a Kinect positions file: the same name with ``angles`` for ``positions``, in
    the same folder or in the data set's sibling ``Angles`` folder (``Kinect/Positions`` ->
    ``Kinect/Angles``).

    Raises
    ------
    RecordingError
        The name is not a positions file's, or no such angles file exists (names the places looked at).
    """
    positions = Path(positions)
    m = _NAME.fullmatch(positions.name)
    if m is None or m[4].lower() != "positions":
        raise RecordingError(f"{positions}: the name is not a UI-PRMD positions file's (mMM_sSS_eEE_positions.txt.gz), "
                             "so its angles file cannot be found by name; give the angles file as well")
    name = positions.name[: m.start(4)] + "angles" + positions.name[m.end(4):]
    candidates = [positions.with_name(name)]
    if positions.parent.name.lower() == "positions":
        candidates.append(positions.parent.parent / "Angles" / name)
    for path in candidates:
        if path.is_file():
            return path
    raise RecordingError(f"{positions}: its angles file is missing (looked for {' and '.join(map(str, candidates))}); "
                         "the joint positions need the angles of the same episode: give the angles file as well")


def _gunzip(path: Path, data: bytes) -> bytes:
    """The decompressed bytes of a (possibly multi-member) gzip file; truncation and damage are errors."""
    out: list[bytes] = []
    while data:
        stream = zlib.decompressobj(wbits=31)
        try:
            out.append(stream.decompress(data))
        except zlib.error as exc:
            line = b"".join(out).count(b"\n") + 1
            raise RecordingError(f"{path}, line {line}: the gzip data is corrupt ({exc}); copy or download the file "
                                 "again") from None
        if not stream.eof:
            complete = b"".join(out).count(b"\n")
            raise RecordingError(f"{path}, line {complete + 1}: the gzip data ends early (the file is cut short after "
                                 f"{complete} complete lines); copy or download the file again")
        data = stream.unused_data
        if not data.strip(b"\x00"):
            break
        if not data.startswith(_GZIP_MAGIC):
            raise RecordingError(f"{path}: data that is not gzip follows the compressed text; copy or download the "
                                 "file again")
    return b"".join(out)


def _read_rows(path: Path, columns: list[str], kind: str) -> np.ndarray:
    """The (T, len(columns)) numbers of a UI-PRMD text file (gzip or plain), every row checked."""
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise RecordingError(f"{path}: cannot read the file ({exc.strerror or exc})") from None
    if data.startswith(_GZIP_MAGIC) or path.suffix.lower() == ".gz":
        if not data.startswith(_GZIP_MAGIC):
            raise RecordingError(f"{path}: the name ends in .gz but the file is not gzip data; give the UI-PRMD "
                                 f"{kind} file as distributed (or decompressed, without .gz)")
        data = _gunzip(path, data)
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        raise RecordingError(f"{path}, line {line}: not text (byte {exc.start} is not valid UTF-8); "
                             f"this is not a UI-PRMD {kind} file") from None
    if not text.strip():
        raise RecordingError(f"{path}, line 1: the file is empty (no frames); give a UI-PRMD {kind} file that holds "
                             "frames")
    lines = text.rstrip().splitlines()
    n = len(columns)
    row = re.compile(",".join([_NUMBER] * n))
    rows = np.empty((len(lines), n))
    for k, line in enumerate(lines):
        where = f"{path}, line {k + 1}"
        if row.fullmatch(line):
            rows[k] = line.split(",")
            if np.isfinite(rows[k]).all():
                continue
        tokens = line.split(",") if line.strip() else []
        if len(tokens) != n:
            other = {66: "a UI-PRMD Kinect positions or angles file", 117: "a UI-PRMD Vicon positions file"}
            hint = f": it looks like {other[len(tokens)]}" if len(tokens) in other else ""
            raise RecordingError(f"{where}: {len(tokens)} values, but every row of a UI-PRMD {kind} file holds {n} "
                                 f"(one frame per row, comma-separated){hint}; give the right file")
        bad = next(i for i, t in enumerate(tokens) if not re.fullmatch(_NUMBER, t) or not np.isfinite(float(t)))
        raise RecordingError(f"{where}: value {bad + 1} ({columns[bad]}) is {tokens[bad].strip()[:40]!r}, not a finite "
                             "number; UI-PRMD files hold finite numbers only (a lost Vicon marker is 0, 0, 0): the file "
                             "is damaged, copy or download it again")
    return rows


def _columns(names: tuple[str, ...], what: str = "") -> list[str]:
    return [f"{name} {what}{axis}" for name in names for axis in "xyz"]


def read_ui_prmd_kinect(positions: PathLike, angles: PathLike | None = None, *,
                        intrinsics: Intrinsics = KINECT_V2_DEPTH) -> Recording:
    """Read one Kinect episode of UI-PRMD (its positions and angles files) as a one-camera recording.

    Parameters
    ----------
    positions : path
        The episode's ``..._positions.txt.gz`` (root position and parent-relative offsets [cm]).
    angles : path, optional
        Its ``..._angles.txt.gz`` (parent-relative Euler angles [deg]); default found by name
        (:func:`angles_file_for`).
    intrinsics : Intrinsics
        Depth intrinsics of the camera (the files carry none; default the nominal Kinect v2 ones).

    Returns
    -------
    Recording
        One camera ``kinect`` with a :data:`~fusion.topology.UI_PRMD` stream: (T, 22, 3) positions
        [m] in Kinect v2 camera space (:data:`R_CAM_FILE`), timestamps ``k / 30`` [s] (assumed: the
        files carry none), every joint TRACKED (assumed: the files carry no states). Metadata:
        ``source_format``, ``source_files``, ``movement``, ``subject``, ``episode``, ``correct``
        (None where the name does not say), ``timestamps`` and ``confidence`` (what was assumed),
        ``fixed_rate`` (True: the timestamps are not a camera's clock), ``floor_referenced`` (True: the
        origin lies on the floor below the camera, whose height is not in the files), ``lab`` (:data:`LAB`).

    Raises
    ------
    RecordingError
        A file is missing, unreadable, truncated, empty, has a row without 66 finite numbers, or the
        two files hold different numbers of frames.
    BadInputError
        ``intrinsics`` are not in Kinect v2 axes, or the two files' names say they are of different
        episodes or given in the wrong order.
    """
    positions = Path(positions)
    angles = angles_file_for(positions) if angles is None else Path(angles)
    if intrinsics.axes is not AxisConvention.KINECT_V2:
        raise BadInputError(f"UI-PRMD Kinect positions are in Kinect v2 camera space; the intrinsics use "
                            f"{intrinsics.axes.value} axes: give Kinect v2 intrinsics")
    kinds = [file_kind(f) for f in (positions, angles)]
    if kinds[0] == "angles" or kinds[1] == "positions":
        raise BadInputError(f"{positions.name} and {angles.name}: give the positions file first and the angles file "
                            "second")
    info, info_angles = episode_info(positions), episode_info(angles)
    if None not in info.values() and None not in info_angles.values() and info != info_angles:
        raise BadInputError(f"{positions.name} and {angles.name} are different episodes; give the angles file of "
                            "the same episode")
    p = _read_rows(positions, _columns(UI_PRMD.joints), "Kinect positions")
    a = _read_rows(angles, _columns(UI_PRMD.joints, "angle about "), "Kinect angles")
    if len(p) != len(a):
        longer, shorter = (positions, angles) if len(p) > len(a) else (angles, positions)
        raise RecordingError(f"{longer}, line {min(len(p), len(a)) + 1}: no matching row in {shorter} ({positions.name} "
                             f"holds {len(p)} frames, {angles.name} {len(a)}): the files are not one episode or one is "
                             "cut short; give the positions and angles files of the same episode")
    T, J = len(p), UI_PRMD.n_joints
    X_file = forward_kinematics(p.reshape(T, J, 3), a.reshape(T, J, 3), UI_PRMD.parents)
    p_cam = X_file @ R_CAM_FILE.T * _CM
    states = np.full((T, J), TrackingState.TRACKED, dtype=np.int8)
    stream = build_stream(positions, UI_PRMD, np.arange(T) / KINECT_RATE_HZ, p_cam, states,
                          length_hint="UI-PRMD Kinect files hold centimetres.")
    metadata = {"source_format": "ui_prmd_kinect", "source_files": [positions.name, angles.name], **info,
                "timestamps": "assumed_30hz", "confidence": "assumed_tracked", "fixed_rate": True,
                "floor_referenced": True, "lab": LAB}
    return checked_recording([CameraRecording(KINECT_CAMERA, intrinsics, stream)], metadata)


def join_episodes(episodes: list[Recording]) -> Recording:
    """One person's Kinect episodes (:func:`read_ui_prmd_kinect`) as one recording, in the given order.

    Each episode starts two frame periods after the previous one ends (one frame left out), so no
    second difference spans a cut; a repetition ends at rest, where the next starts. Metadata:
    ``source_files``, ``episodes`` (each one's :func:`episode_info` and first frame), ``subject``,
    ``movement`` (None when they differ) and the assumptions of :func:`read_ui_prmd_kinect`.
    Raises :class:`~fusion.errors.BadInputError` for no episode or episodes of different subjects."""
    if not episodes:
        raise BadInputError("give at least one UI-PRMD Kinect episode to join")
    subjects = {e.metadata.get("subject") for e in episodes}
    if len(subjects) > 1:
        raise BadInputError(f"episodes of subjects {sorted(map(str, subjects))} given: a recording is one person; "
                            "join each subject's episodes on their own")
    period = 1.0 / KINECT_RATE_HZ
    parts, info, start = [], [], 0
    for e in episodes:
        stream = e.cameras[0].skeleton
        parts.append(stream)
        info.append({**{k: e.metadata.get(k) for k in ("movement", "subject", "episode", "correct")},
                     "first_frame": start})
        start += stream.n_frames + 1
    times = np.concatenate([p.timestamps - p.timestamps[0] + period * i["first_frame"] for p, i in zip(parts, info)])
    stream = SkeletonStream(UI_PRMD, times, np.concatenate([p.positions for p in parts]),
                            np.concatenate([p.states for p in parts]))
    movements = {i["movement"] for i in info}
    metadata = {"source_format": "ui_prmd_kinect", "source_files": [f for e in episodes for f in e.metadata["source_files"]],
                "subject": subjects.pop(), "movement": movements.pop() if len(movements) == 1 else None,
                "episodes": info, "timestamps": "assumed_30hz", "confidence": "assumed_tracked", "fixed_rate": True,
                "floor_referenced": True, "lab": LAB}
    return checked_recording([dataclasses.replace(episodes[0].cameras[0], skeleton=stream)], metadata)


def read_ui_prmd_vicon(path: PathLike) -> MarkerData:
    """Read one Vicon episode of UI-PRMD: the 39 Plug-in-Gait markers over time.

    Parameters
    ----------
    path : path
        The episode's ``Vicon/Positions/..._positions.txt.gz``.

    Returns
    -------
    MarkerData
        :data:`VICON_MARKERS`, times ``k / 100`` [s] (assumed: the file carries none), (T, 39, 3)
        positions [m], x forward (the subject faces +x), y to the subject's left, z up; a marker
        stored as (0, 0, 0) is absent (NaN), also when it is lost for the whole episode.

    Raises
    ------
    RecordingError
        The file is missing, unreadable, truncated, empty, or a row does not hold 117 finite numbers.
    """
    path = Path(path)
    rows = _read_rows(path, _columns(VICON_MARKERS), "Vicon positions")
    pos = rows.reshape(len(rows), len(VICON_MARKERS), 3) * _MM
    pos[np.all(pos == 0.0, axis=-1)] = np.nan
    return MarkerData(VICON_MARKERS, np.arange(len(rows)) / VICON_RATE_HZ, pos, str(path))
