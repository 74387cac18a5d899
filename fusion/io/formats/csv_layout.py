"""Skeleton CSVs of other tools, read through a small layout mapping instead of one reader per dataset.

A :class:`CsvLayout` says how a file is laid out: the separator, whether a header row names the
columns, where time comes from (a time column and its unit, or a fixed frame rate), how joint columns
are named (a pattern such as ``"{joint} ({field})"``) or ordered (fields per joint when there is no
header), the length unit, the camera axes and the confidence scale. Two layouts ship as examples:

- :data:`AZURE_2CAM`: ``;``-separated, a header, ``timestamp`` in microseconds, ``body_idx``, then per
  K4ABT joint ``NAME (c)``, ``NAME (x)``, ``NAME (y)``, ``NAME (z)``; millimetres, OpenCV axes,
  confidence 0..3.
- :data:`KIMORE`: ``,``-separated, no header, no time (30 Hz), per Kinect v2 joint x, y, z,
  trackingState; metres, Kinect v2 axes, states 0..2; blank lines and a trailing comma ignored.

A layout can also be written as a TOML table (:func:`layout_from_dict`), with the keys of
:class:`CsvLayout` (``topology`` by name, enums by value). A person re-acquired under a new body id
is stitched into one track (see :func:`stitch_bodies`), not dropped.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from fusion.camera import AxisConvention, Intrinsics
from fusion.errors import BadInputError, RecordingError
from fusion.frames import LengthUnit
from fusion.io.formats import PathLike, build_stream, read_text, reader_inputs
from fusion.io.formats.csv_skeleton import ConfidenceScale
from fusion.recording import CameraRecording, Recording
from fusion.topology import K4ABT, KINECT_V2, Topology, TrackingState, topology_by_name

_FIELDS = ("c", "x", "y", "z")


@dataclass(frozen=True)
class CsvLayout:
    """How a skeleton CSV of some tool is laid out.

    Attributes
    ----------
    topology : Topology
        Joint set; the joints appear in its order when there is no header.
    separator : str
        Column separator (one character).
    header : bool
        Whether the first non-blank row names the columns.
    time_column : str or None
        Header name of the time column (with a header), or None for a fixed rate.
    time_unit_s : float
        Size of one time unit in seconds (1e-6 for microseconds).
    rate_hz : float or None
        Frame rate [Hz] when the file has no time column; frame k is at k / rate_hz.
    body_column : str or None
        Header name of the body id column, or None (one body per row, id 0).
    joint_pattern : str
        With a header: the name of a joint's column, with ``{joint}`` and ``{field}`` (one of
        ``c``, ``x``, ``y``, ``z``) filled in.
    field_order : tuple of str
        Without a header: the order of the four fields of each joint, a permutation of
        ``("c", "x", "y", "z")``; joints follow each other from the first column.
    unit : LengthUnit
        Unit of x, y, z.
    axes : AxisConvention
        Axis layout of the camera frame the positions are in.
    confidence : ConfidenceScale
        Meaning of the ``c`` fields (STATE_0_2 or STATE_0_3; PROBABILITY is not supported here).
    """

    topology: Topology
    separator: str = ","
    header: bool = True
    time_column: str | None = "timestamp"
    time_unit_s: float = 1.0
    rate_hz: float | None = None
    body_column: str | None = None
    joint_pattern: str = "{joint}_{field}"
    field_order: tuple[str, str, str, str] = _FIELDS
    unit: LengthUnit = LengthUnit.M
    axes: AxisConvention = AxisConvention.KINECT_V2
    confidence: ConfidenceScale = ConfidenceScale.STATE_0_2

    def __post_init__(self) -> None:
        for name, cls in (("topology", Topology), ("unit", LengthUnit), ("axes", AxisConvention),
                          ("confidence", ConfidenceScale)):
            if not isinstance(getattr(self, name), cls):
                raise BadInputError(f"CsvLayout.{name} must be a {cls.__name__}, got {getattr(self, name)!r}")
        if not isinstance(self.separator, str) or len(self.separator) != 1:
            raise BadInputError(f"CsvLayout.separator must be one character, got {self.separator!r}")
        if (self.time_column is None) == (self.rate_hz is None):
            raise BadInputError("CsvLayout needs exactly one of time_column (a header name) and rate_hz")
        if self.rate_hz is not None and not (np.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise BadInputError(f"CsvLayout.rate_hz must be positive, got {self.rate_hz}")
        if not (np.isfinite(self.time_unit_s) and self.time_unit_s > 0):
            raise BadInputError(f"CsvLayout.time_unit_s must be positive, got {self.time_unit_s}")
        if not self.header and (self.time_column is not None or self.body_column is not None):
            raise BadInputError("without a header, time comes from rate_hz and there is no body column")
        if self.header and ("{joint}" not in self.joint_pattern or "{field}" not in self.joint_pattern):
            raise BadInputError(f"CsvLayout.joint_pattern needs {{joint}} and {{field}}, got {self.joint_pattern!r}")
        if sorted(self.field_order) != sorted(_FIELDS):
            raise BadInputError(f"CsvLayout.field_order must be a permutation of {_FIELDS}, got {self.field_order}")
        if self.confidence is ConfidenceScale.PROBABILITY:
            raise BadInputError("CsvLayout reads integer confidences (state_0_2 or state_0_3); "
                                "use CsvOptions for probabilities")

    @property
    def max_state(self) -> int:
        """The highest confidence the scale allows."""
        return int(TrackingState.TRACKED if self.confidence is ConfidenceScale.STATE_0_2 else TrackingState.HIGH)


AZURE_2CAM = CsvLayout(
    topology=K4ABT, separator=";", header=True, time_column="timestamp", time_unit_s=1e-6, body_column="body_idx",
    joint_pattern="{joint} ({field})", unit=LengthUnit.MM, axes=AxisConvention.OPENCV,
    confidence=ConfidenceScale.STATE_0_3,
)
"""Azure Kinect CSV export: ``timestamp;body_idx;PELVIS (c);PELVIS (x);...`` (microseconds, mm)."""

KIMORE = CsvLayout(
    topology=KINECT_V2, separator=",", header=False, time_column=None, rate_hz=30.0,
    field_order=("x", "y", "z", "c"), unit=LengthUnit.M, axes=AxisConvention.KINECT_V2,
    confidence=ConfidenceScale.STATE_0_2,
)
"""KIMORE ``JointPositionExercise*.csv``: no header, 30 Hz, per joint x, y, z, trackingState (metres)."""

LAYOUTS: Mapping[str, CsvLayout] = {"azure_2cam": AZURE_2CAM, "kimore": KIMORE}
"""The built-in layouts by name."""


def layout_from_dict(table: Mapping[str, Any]) -> CsvLayout:
    """A :class:`CsvLayout` from a parsed TOML table (``topology`` by name, ``unit``/``axes``/``confidence``
    by value, ``unit`` as ``"m"`` or ``"mm"``; ``rate_hz`` without ``time_column`` means no time
    column, as TOML has no null); unknown keys are errors naming the allowed ones."""
    allowed = [f.name for f in fields(CsvLayout)]
    unknown = [k for k in table if k not in allowed]
    if unknown:
        raise BadInputError(f"unknown CSV layout key {unknown[0]!r}; allowed: {', '.join(allowed)}")
    kw = dict(table)
    for key, kinds, what in (("rate_hz", (int, float), "a number"), ("time_unit_s", (int, float), "a number"),
                             ("header", (bool,), "true or false"), ("separator", (str,), "a string"),
                             ("time_column", (str,), "a string"), ("body_column", (str,), "a string"),
                             ("joint_pattern", (str,), "a string")):
        value = kw.get(key)
        if value is not None and (not isinstance(value, kinds) or (bool not in kinds and isinstance(value, bool))):
            raise BadInputError(f"CSV layout {key} must be {what}, got {value!r}")
    if "rate_hz" in kw and "time_column" not in kw:
        kw["time_column"] = None
    try:
        if "topology" not in kw:
            raise BadInputError("a CSV layout needs topology = 'kinect_v2' or 'k4abt'")
        kw["topology"] = topology_by_name(kw["topology"])
        if "unit" in kw:
            kw["unit"] = LengthUnit[str(kw["unit"]).upper()]
        if "axes" in kw:
            kw["axes"] = AxisConvention(kw["axes"])
        if "confidence" in kw:
            kw["confidence"] = ConfidenceScale(kw["confidence"])
        if "field_order" in kw:
            kw["field_order"] = tuple(kw["field_order"])
    except (KeyError, ValueError) as exc:
        raise BadInputError(f"bad CSV layout value: {exc}") from None
    return CsvLayout(**kw)


def _columns(layout: CsvLayout, header: list[str] | None, path: Path) -> tuple[int | None, int | None, np.ndarray]:
    """Time column, body column and (J, 4) column indices of c, x, y, z."""
    J = layout.topology.n_joints
    if header is None:
        pos = {f: i for i, f in enumerate(layout.field_order)}
        return None, None, np.array([[4 * j + pos[f] for f in _FIELDS] for j in range(J)])
    where = {name.strip(): i for i, name in enumerate(header)}

    def find(name: str) -> int:
        if name not in where:
            raise RecordingError(f"{path}, line 1: no column {name!r} in the header; the layout expects it "
                                 "(check CsvLayout.joint_pattern / time_column / body_column)")
        return where[name]

    cols = np.array([[find(layout.joint_pattern.format(joint=j, field=f)) for f in _FIELDS]
                     for j in layout.topology.joints])
    time_col = find(layout.time_column) if layout.time_column is not None else None
    body_col = find(layout.body_column) if layout.body_column is not None else None
    return time_col, body_col, cols


def _table(path: Path, layout: CsvLayout) -> tuple[list[str] | None, np.ndarray]:
    """Header (or None) and the numeric rows (N, C) of a file; blank rows and empty trailing cells dropped."""
    lines = [ln for ln in read_text(path).splitlines() if ln.strip()]
    header = None
    if layout.header:
        if not lines:
            raise RecordingError(f"{path}: no header row")
        header, lines = lines[0].split(layout.separator), lines[1:]
    if not lines:
        raise RecordingError(f"{path}: the file holds no frames")
    rows = [ln.rstrip().rstrip(layout.separator).split(layout.separator) for ln in lines]
    width = len(rows[0])
    bad = next((i for i, r in enumerate(rows) if len(r) != width), None)
    if bad is not None:
        raise RecordingError(f"{path}: data row {bad + 1} has {len(rows[bad])} columns, the first has {width}")
    try:
        values = np.array(rows, dtype=float)
    except ValueError as exc:
        raise RecordingError(f"{path}: a cell is not a number ({exc})") from None
    if not np.all(np.isfinite(values)):
        r = int(np.argwhere(~np.isfinite(values))[0, 0])
        raise RecordingError(f"{path}: data row {r + 1} holds a non-finite number")
    return header, values


def stitch_bodies(body_ids: np.ndarray, frame_of_row: np.ndarray, pelvis: np.ndarray) -> np.ndarray:
    """Rows kept for one person's track: per frame, the body nearest the previous kept pelvis.

    A body re-acquired under a new id continues the track; with two people at once, the one nearer
    the track is kept. The track starts with the id seen in the most rows.

    Parameters
    ----------
    body_ids : np.ndarray
        (N,) body id of each row.
    frame_of_row : np.ndarray
        (N,) int frame index of each row, non-decreasing.
    pelvis : np.ndarray
        (N, 3) [m] pelvis position of each row (NaN when not tracked).

    Returns
    -------
    np.ndarray
        (N,) bool, True for the kept rows (at most one per frame).
    """
    ids, counts = np.unique(body_ids, return_counts=True)
    main = ids[np.argmax(counts)]
    keep = np.zeros(len(body_ids), dtype=bool)
    last = None
    starts = np.flatnonzero(np.r_[True, np.diff(frame_of_row) != 0])
    for a, b in zip(starts, np.r_[starts[1:], len(body_ids)]):
        if b - a == 1:
            k = a
        elif last is None or not np.all(np.isfinite(pelvis[a:b])):
            k = a + int(np.argmax(body_ids[a:b] == main))
        else:
            k = a + int(np.argmin(np.linalg.norm(pelvis[a:b] - last, axis=1)))
        keep[k] = True
        if np.all(np.isfinite(pelvis[k])):
            last = pelvis[k]
    return keep


def read_csv_layout(paths: PathLike | Sequence[PathLike], layout: CsvLayout, *,
                    intrinsics: Intrinsics | None = None, names: Sequence[str] | None = None) -> Recording:
    """Read skeleton CSVs laid out as ``layout``, one file per camera, as one recording.

    Parameters
    ----------
    paths : path or sequence of paths
        One CSV file per camera.
    layout : CsvLayout
        How the files are laid out (e.g. :data:`AZURE_2CAM`, :data:`KIMORE`).
    intrinsics : Intrinsics, optional
        Depth intrinsics of every camera; default the Kinect v2 default for Kinect v2 axes and the
        nominal Azure Kinect NFOV unbinned intrinsics for OpenCV axes.
    names : sequence of str, optional
        Camera names; default the file stems when valid and unique.

    Returns
    -------
    Recording
        (T, J, 3) positions [m] in each camera's frame, timestamps [s]; confidence 0 joints are NaN.
        Metadata: ``source_format`` ("csv_layout"), ``source_files``, ``body_ids`` (ids stitched
        into the track, per camera), ``fixed_rate`` (True when the times come from ``rate_hz``, so
        they say nothing about the sensor's clock).

    Raises
    ------
    RecordingError
        Missing columns, ragged or non-numeric rows, confidences outside the scale, or timestamps
        that do not increase.
    """
    if not isinstance(layout, CsvLayout):
        raise BadInputError(f"layout must be a CsvLayout, got {type(layout).__name__}")
    files, names, intrinsics = reader_inputs(paths, names, intrinsics, layout.axes)
    cameras, body_ids = [], {}
    pelvis = layout.topology.index(layout.topology.joints[0])
    for path, name in zip(files, names):
        header, values = _table(path, layout)
        time_col, body_col, cols = _columns(layout, header, path)
        if cols.max() >= values.shape[1]:
            raise RecordingError(f"{path}: {values.shape[1]} columns, the layout needs {cols.max() + 1}")
        conf = values[:, cols[:, 0]]
        if np.any((conf != np.round(conf)) | (conf < 0) | (conf > layout.max_state)):
            raise RecordingError(f"{path}: confidences must be integers 0..{layout.max_state}")
        xyz = values[:, cols[:, 1:]] * layout.unit.metres
        if time_col is None:
            t_row = np.arange(len(values)) / layout.rate_hz
        else:
            t_row = values[:, time_col] * layout.time_unit_s
        if np.any(np.diff(t_row) < 0):
            raise RecordingError(f"{path}: timestamps decrease; rows must be in time order")
        bodies = values[:, body_col].astype(np.int64) if body_col is not None else np.zeros(len(values), np.int64)
        frame_of_row = np.r_[0, np.cumsum(np.diff(t_row) > 0)]
        p = np.where(conf[:, pelvis, None] > 0, xyz[:, pelvis], np.nan)
        keep = stitch_bodies(bodies, frame_of_row, p)
        states = conf[keep].astype(np.int8)
        positions = np.where(states[..., None] > 0, xyz[keep], np.nan)
        stream = build_stream(path, layout.topology, t_row[keep], positions, states)
        cameras.append(CameraRecording(name, intrinsics, stream))
        body_ids[name] = sorted(int(b) for b in np.unique(bodies[keep]))
    metadata = {"source_format": "csv_layout", "source_files": [p.name for p in files], "body_ids": body_ids,
                "fixed_rate": layout.rate_hz is not None}
    return Recording(tuple(cameras), metadata)
