"""Skeleton CSV: one file per camera, one row per body per frame.

Layout: a header row, then columns ``timestamp`` [s], ``body`` (integer id), then for each joint of
the topology in SDK order ``<joint>_conf, <joint>_x, <joint>_y, <joint>_z``. Positions are in the
camera's own frame in the unit and axis layout given by :class:`CsvOptions`; the reader converts to
metres and keeps the axes (recorded in ``Intrinsics.axes``). Rows of one frame share a timestamp;
several rows of one frame are several bodies. Every cell must be a finite number; the coordinates
of a joint with confidence NOT_TRACKED are ignored (the writer writes 0).
"""

from __future__ import annotations

import csv
import enum
import io
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fusion.camera import AxisConvention, Intrinsics
from fusion.errors import BadInputError, RecordingError
from fusion.frames import LengthUnit
from fusion.io.atomic import write_text_atomic
from fusion.io.formats import (
    Body,
    PathLike,
    build_stream,
    checked_recording,
    fmt,
    parse_float,
    parse_int,
    read_text,
    reader_inputs,
    select_main_body,
    skeleton_cameras,
)
from fusion.recording import CameraRecording, Recording
from fusion.topology import KINECT_V2, Topology, TrackingState


class ConfidenceScale(enum.Enum):
    """Meaning of the ``<joint>_conf`` columns."""

    STATE_0_2 = "state_0_2"
    """Integer Kinect v2 tracking state: 0 NotTracked, 1 Inferred, 2 Tracked."""
    STATE_0_3 = "state_0_3"
    """Integer K4ABT confidence level: 0 NONE, 1 LOW, 2 MEDIUM, 3 HIGH."""
    PROBABILITY = "probability"
    """Float in [0, 1], mapped to a state by :attr:`CsvOptions.thresholds`."""


@dataclass(frozen=True)
class CsvOptions:
    """How a skeleton CSV is laid out.

    Attributes
    ----------
    topology : Topology
        Joint set and column order (KINECT_V2 or K4ABT).
    unit : LengthUnit
        Unit of the x, y, z columns.
    axes : AxisConvention
        Axis layout of the camera frame the positions are in.
    confidence : ConfidenceScale
        Meaning of the confidence columns.
    thresholds : tuple of float
        For PROBABILITY: the lowest probabilities read as INFERRED, TRACKED and HIGH, increasing in
        (0, 1]; below the first is NOT_TRACKED. The writer writes each state as its threshold (0 for
        NOT_TRACKED), so a round trip keeps states exactly.
    """

    topology: Topology = KINECT_V2
    unit: LengthUnit = LengthUnit.M
    axes: AxisConvention = AxisConvention.KINECT_V2
    confidence: ConfidenceScale = ConfidenceScale.STATE_0_2
    thresholds: tuple[float, float, float] = (0.25, 0.5, 1.0)

    def __post_init__(self) -> None:
        for name, cls in (("topology", Topology), ("unit", LengthUnit), ("axes", AxisConvention),
                          ("confidence", ConfidenceScale)):
            if not isinstance(getattr(self, name), cls):
                raise BadInputError(f"CsvOptions.{name} must be a {cls.__name__}, got {getattr(self, name)!r}")
        th = tuple(self.thresholds)
        if len(th) != 3 or not all(isinstance(x, (int, float)) for x in th) or not 0 < th[0] < th[1] < th[2] <= 1:
            raise BadInputError(f"CsvOptions.thresholds must be 3 increasing numbers in (0, 1], got {self.thresholds}")

    @property
    def header(self) -> list[str]:
        """The expected header row."""
        return ["timestamp", "body"] + [f"{j}_{c}" for j in self.topology.joints for c in ("conf", "x", "y", "z")]

    def parse_state(self, token: str, where: str, what: str) -> int:
        """The TrackingState a confidence cell stands for."""
        if self.confidence is ConfidenceScale.PROBABILITY:
            p = parse_float(token, where, what)
            if not 0 <= p <= 1:
                raise RecordingError(f"{where}: {what} must lie in [0, 1], got {p}")
            return int(np.searchsorted(self.thresholds, p, side="right"))
        hi = TrackingState.TRACKED if self.confidence is ConfidenceScale.STATE_0_2 else TrackingState.HIGH
        return parse_int(token, where, what, 0, int(hi))

    def format_states(self, states: np.ndarray) -> list[str]:
        """Confidence cells for (J,) states."""
        if self.confidence is ConfidenceScale.PROBABILITY:
            return [fmt((0.0, *self.thresholds)[s]) for s in states]
        hi = TrackingState.TRACKED if self.confidence is ConfidenceScale.STATE_0_2 else TrackingState.HIGH
        return [str(min(int(s), int(hi))) for s in states]


def _parse_file(path: Path, options: CsvOptions) -> tuple[list[float], list[list[Body]]]:
    """Timestamps [s] and bodies per frame."""
    try:
        rows = list(csv.reader(io.StringIO(read_text(path), newline="")))
    except csv.Error as exc:
        raise RecordingError(f"{path}: not a valid CSV file ({exc})") from None
    header = [c.strip() for c in rows[0]]
    expected = options.header
    if header != expected:
        k = next((i for i, (a, b) in enumerate(zip(header, expected)) if a != b), min(len(header), len(expected)))
        got = header[k] if k < len(header) else "(nothing)"
        want = expected[k] if k < len(expected) else "(no more columns)"
        raise RecordingError(f"{path}, line 1: the header does not match the {options.topology.name} layout "
                             f"(column {k + 1}: expected {want!r}, got {got!r})")
    J = options.topology.n_joints
    timestamps: list[float] = []
    frames: list[list[Body]] = []
    for ln, row in enumerate(rows[1:], 2):
        where = f"{path}, line {ln}"
        if not row:
            continue
        if len(row) != len(expected):
            raise RecordingError(f"{where}: {len(row)} columns, expected {len(expected)}")
        cells = [c.strip() for c in row]
        t = parse_float(cells[0], where, "timestamp")
        body_id = parse_int(cells[1], where, "body")
        states = np.array([options.parse_state(cells[2 + 4 * j], where, f"{name}_conf")
                           for j, name in enumerate(options.topology.joints)], dtype=np.int8)
        xyz = np.array([parse_float(cells[k], where, expected[k]) for k in range(2, len(cells)) if k % 4 != 2])
        positions = xyz.reshape(J, 3) * options.unit.metres
        if timestamps and t == timestamps[-1]:
            frames[-1].append((body_id, positions, states))
        else:
            timestamps.append(t)
            frames.append([(body_id, positions, states)])
    return timestamps, frames


def read_csv_skeleton(paths: PathLike | Sequence[PathLike], options: CsvOptions = CsvOptions(), *,
                      intrinsics: Intrinsics | None = None, names: Sequence[str] | None = None) -> Recording:
    """Read skeleton CSV files, one per camera, as one recording.

    Parameters
    ----------
    paths : path or sequence of paths
        One CSV file per camera.
    options : CsvOptions
        Layout of the files.
    intrinsics : Intrinsics, optional
        Depth intrinsics for every camera; default the Kinect v2 default for KINECT_V2 axes and the
        nominal Azure Kinect NFOV unbinned intrinsics for OPENCV axes.
    names : sequence of str, optional
        Camera names; default the file stems when valid and unique, else ``cam1`` ... ``camN``.

    Returns
    -------
    Recording
        (T, J, 3) positions [m] in each camera's frame (axes as ``options.axes``), timestamps [s]
        as in the file. Metadata: ``source_format``, ``source_files``, the kept ``body_ids``.

    Raises
    ------
    RecordingError
        Wrong header, wrong column count, non-numeric or non-finite cells, confidences outside the
        scale, or timestamps that do not increase.
    BadInputError
        ``options`` or ``names`` are invalid.
    """
    if not isinstance(options, CsvOptions):
        raise BadInputError(f"options must be a CsvOptions, got {type(options).__name__}")
    files, names, intrinsics = reader_inputs(paths, names, intrinsics, options.axes)
    cameras, body_ids, stitched = [], {}, {}
    for path, name in zip(files, names):
        timestamps, frames = _parse_file(path, options)
        body_id, positions, states, stitched[name] = select_main_body(frames, options.topology.n_joints)
        stream = build_stream(path, options.topology, np.array(timestamps), positions, states,
                              length_hint="Choose the unit with --csv-unit m|mm (CsvOptions.unit).",
                              time_hint="The timestamp column must be in seconds; convert it.")
        cameras.append(CameraRecording(name, intrinsics, stream))
        body_ids[name] = body_id
    metadata = {"source_format": "csv_skeleton", "source_files": [p.name for p in files], "body_ids": body_ids,
                "stitched_body_ids": stitched}
    return checked_recording(cameras, metadata)


def write_csv_skeleton(recording: Recording, out_dir: PathLike, options: CsvOptions = CsvOptions()) -> list[Path]:
    """Write each camera's skeleton stream as ``<out_dir>/<camera>.csv``.

    One row per frame with body id 0; absent joints have confidence 0 and coordinates 0. Numbers
    are written as the shortest text that reads back exactly, so with unit M a round trip is exact.
    With a 0..2 confidence scale, state HIGH (3) is written as 2.

    Parameters
    ----------
    recording : Recording
        Recording whose topology is ``options.topology`` and whose cameras use ``options.axes``.
    out_dir : path
        Directory for the files (created if missing); each file is written atomically.
    options : CsvOptions
        Layout of the files.

    Returns
    -------
    list of Path
        The written files, one per camera with a skeleton stream.
    """
    if not isinstance(options, CsvOptions):
        raise BadInputError(f"options must be a CsvOptions, got {type(options).__name__}")
    cams = skeleton_cameras(recording, options.topology, "these CSV options")
    written = []
    for cam in cams:
        if cam.intrinsics.axes is not options.axes:
            raise BadInputError(f"camera {cam.name} uses {cam.intrinsics.axes.value} axes but options.axes is "
                                f"{options.axes.value}; pass CsvOptions(axes=AxisConvention.{cam.intrinsics.axes.name})")
        s = cam.skeleton
        out = io.StringIO()
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(options.header)
        xyz = np.nan_to_num(s.positions / options.unit.metres)
        for t in range(s.n_frames):
            conf = options.format_states(s.states[t])
            cells = [c for j in range(options.topology.n_joints) for c in (conf[j], *map(fmt, xyz[t, j]))]
            writer.writerow([fmt(s.timestamps[t]), "0", *cells])
        path = Path(out_dir) / f"{cam.name}.csv"
        write_text_atomic(path, out.getvalue())
        written.append(path)
    return written
