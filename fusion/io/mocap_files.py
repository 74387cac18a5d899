"""Readers of optical motion capture and animation files: C3D, OpenSim TRC and BVH.

Each reader returns :class:`MarkerData`: named 3-D points over time in a z-up frame, metres. The
file's vertical axis is given by ``up_axis`` (:class:`~fusion.frames.UpAxis`): ``"z"`` keeps the
axes, ``"y"`` (OpenSim, most BVH) maps ``(X, Y, Z)`` to ``(x, y, z) = (X, -Z, Y)``, the inverse of
what :func:`fusion.io.export.export_trc` writes. Lengths are converted with the file's own unit
(C3D ``POINT:UNITS``, TRC ``Units``) unless ``units`` overrides it; BVH has no unit field, so its
``units`` is required knowledge of the file (default centimetres, the CMU convention).

- C3D (ezc3d): ``POINT:LABELS``, ``POINT:RATE``; invalid points (residual < 0, or NaN) are absent.
- TRC: the PathFileType 4 layout documented in :func:`fusion.io.export.export_trc`; empty fields
  are absent markers.
- BVH (bvhio): world positions of every joint of the hierarchy, named after the joints.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fusion.errors import BadInputError, RecordingError
from fusion.frames import LengthUnit, UpAxis

_R_ZUP_YUP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
"""Rotation taking y-up file coordinates (X, Y, Z) to z-up (X, -Z, Y)."""


@dataclass(frozen=True, eq=False)
class MarkerData:
    """Named points over time.

    Attributes
    ----------
    names : marker (or BVH joint) names, length M.
    times : (T,) seconds, strictly increasing.
    positions : (T, M, 3) metres, z up; NaN where a marker is absent.
    source : the file read.
    """

    names: tuple[str, ...]
    times: np.ndarray
    positions: np.ndarray
    source: str = ""

    def __post_init__(self) -> None:
        T, M = np.shape(self.times)[0], len(self.names)
        if np.shape(self.positions) != (T, M, 3):
            raise BadInputError(f"positions must have shape ({T}, {M}, 3), got {np.shape(self.positions)}")
        if T == 0 or np.any(np.diff(self.times) <= 0):
            raise BadInputError(f"{self.source}: times must be non-empty and strictly increasing")
        if len(set(self.names)) != M:
            raise BadInputError(f"{self.source}: marker names are not unique")


def _to_world(points: np.ndarray, up_axis: UpAxis | str, scale: float) -> np.ndarray:
    p = np.asarray(points, dtype=float) * scale
    return p @ _R_ZUP_YUP.T if UpAxis(up_axis) is UpAxis.Y else p


def _scale(units: str | LengthUnit | None, file_units: str, path: Path) -> float:
    name = units.value if isinstance(units, LengthUnit) else (units or file_units)
    name = str(name).strip().lower()
    try:
        return LengthUnit(name).metres
    except ValueError:
        raise BadInputError(f"{path}: unknown length unit {name!r}; give units as one of "
                            f"{', '.join(u.value for u in LengthUnit)}") from None


def read_trc(path: str | os.PathLike, *, up_axis: UpAxis | str = UpAxis.Y, units: str | None = None) -> MarkerData:
    """Read an OpenSim TRC marker file (PathFileType 4).

    Parameters
    ----------
    path : path-like
    up_axis : UpAxis or str
        The file's vertical axis (``"y"``, the OpenSim default, or ``"z"``).
    units : str, optional
        ``"m"``, ``"mm"`` or ``"cm"``; default the file's ``Units`` field.

    Returns
    -------
    MarkerData

    Raises
    ------
    RecordingError
        The file is missing or not in the TRC layout (names the line).
    """
    path = Path(path)
    try:
        lines = path.read_text(encoding="utf-8").splitlines()
    except OSError as exc:
        raise RecordingError(f"{path}: cannot read: {exc}") from None
    if len(lines) < 5 or not lines[0].startswith("PathFileType"):
        raise RecordingError(f"{path}: not a TRC file (the first line must start with PathFileType)")
    header = dict(zip(lines[1].split("\t"), lines[2].split("\t")))
    if "Units" not in header or "NumMarkers" not in header:
        raise RecordingError(f"{path}: line 2-3 must hold the DataRate ... Units ... header and its values")
    scale = _scale(units, header["Units"], path)
    names = tuple(n for n in lines[3].split("\t")[2:] if n.strip())
    if len(names) != int(float(header["NumMarkers"])):
        raise RecordingError(f"{path}: line 4 names {len(names)} markers, NumMarkers says {header['NumMarkers']}")
    times, rows = [], []
    for k, line in enumerate(lines[5:], start=6):
        if not line.strip():
            continue
        fields = line.split("\t")
        fields += [""] * (2 + 3 * len(names) - len(fields))
        try:
            times.append(float(fields[1]))
            rows.append([float(v) if v.strip() else np.nan for v in fields[2 : 2 + 3 * len(names)]])
        except ValueError:
            raise RecordingError(f"{path}, line {k}: a field is not a number") from None
    pos = np.array(rows, dtype=float).reshape(len(times), len(names), 3)
    return MarkerData(names, np.array(times), _to_world(pos, up_axis, scale), str(path))


def read_c3d(path: str | os.PathLike, *, up_axis: UpAxis | str = UpAxis.Z, units: str | None = None) -> MarkerData:
    """Read the 3-D points of a C3D file.

    Parameters
    ----------
    path : path-like
    up_axis : UpAxis or str
        The file's vertical axis (``"z"`` default, as most laboratories record).
    units : str, optional
        ``"m"``, ``"mm"`` or ``"cm"``; default ``POINT:UNITS``.

    Returns
    -------
    MarkerData
        Times ``k / POINT:RATE``.

    Raises
    ------
    RecordingError
        The file cannot be read as C3D.
    """
    import ezc3d

    path = Path(path)
    try:
        c3d = ezc3d.c3d(str(path))
    except Exception as exc:  # ezc3d raises plain RuntimeError / IOError
        raise RecordingError(f"{path}: not a readable C3D file ({exc})") from None
    point = c3d["parameters"]["POINT"]
    names = tuple(str(n).strip() for n in point["LABELS"]["value"])
    rate = float(point["RATE"]["value"][0])
    points = np.array(c3d["data"]["points"][:3], dtype=float)  # (3, M, T)
    pos = np.transpose(points, (2, 1, 0))
    residual = c3d["data"]["meta_points"]["residuals"][0].T
    pos[residual < 0] = np.nan
    scale = _scale(units, point["UNITS"]["value"][0] if "UNITS" in point else "mm", path)
    times = np.arange(pos.shape[0]) / rate
    return MarkerData(names, times, _to_world(pos, up_axis, scale), str(path))


def read_bvh(path: str | os.PathLike, *, up_axis: UpAxis | str = UpAxis.Y, units: str = "cm") -> MarkerData:
    """World positions of the joints of a BVH file.

    Parameters
    ----------
    path : path-like
    up_axis : UpAxis or str
        The file's vertical axis (``"y"`` default).
    units : str
        Length unit of the OFFSETs and root positions (``"cm"`` default, the CMU convention).

    Returns
    -------
    MarkerData
        One point per joint (end sites left out), times ``k * Frame Time``.

    Raises
    ------
    RecordingError
        The file cannot be parsed.
    """
    import bvhio

    path = Path(path)
    scale = _scale(units, units, path)
    try:
        container = bvhio.readAsBvh(str(path))
        root = bvhio.readAsHierarchy(str(path))
    except Exception as exc:  # bvhio raises plain exceptions on malformed files
        raise RecordingError(f"{path}: not a readable BVH file ({exc})") from None
    joints = [j for j, _, _ in root.layout()]
    n = container.FrameCount
    pos = np.empty((n, len(joints), 3))
    for k in range(n):
        root.loadPose(k)
        pos[k] = [tuple(j.PositionWorld) for j in joints]
    times = np.arange(n) * float(container.FrameTime)
    return MarkerData(tuple(j.Name for j in joints), times, _to_world(pos, up_axis, scale), str(path))
