"""Joint-angle tables on disk: CSV and the OpenSim motion format (``.mot``).

``angles.csv``: header ``time_s,<angle>_deg,...``; one row per frame, time [s] then angles [deg]
(shortest round-trip decimals, an empty field where an angle is undefined).

``.mot`` (OpenSim Storage, version 1)::

    <name>
    version=1
    nRows=<T>
    nColumns=<1 + K>
    inDegrees=yes
    endheader
    time<TAB><angle><TAB>...
    <rows, tab-separated; NaN where an angle is undefined>
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from fusion.arrays import check_times
from fusion.errors import BadInputError, RecordingError
from fusion.io.atomic import write_text_atomic


def _checked(times: np.ndarray, names: tuple[str, ...] | list[str], degrees: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    t = check_times(times)
    d = np.asarray(degrees, dtype=float)
    if d.shape != (t.size, len(names)):
        raise BadInputError(f"degrees must have shape ({t.size}, {len(names)}), got {d.shape}")
    if t.size == 0:
        raise BadInputError("an angle table needs at least one frame")
    if np.any(np.isinf(d)):
        raise BadInputError("angles contain infinite values")
    if any(not n or any(c in n for c in ",\t\n ") for n in names):
        raise BadInputError(f"angle names must be non-empty without commas, tabs or spaces, got {list(names)}")
    return t, d


def write_angles_csv(times: np.ndarray, names: tuple[str, ...] | list[str], degrees: np.ndarray,
                     path: str | os.PathLike) -> Path:
    """Write (T,) ``times`` [s] and (T, K) ``degrees`` named ``names`` as ``angles.csv`` (module
    docstring), atomically; returns ``path``."""
    t, d = _checked(times, names, degrees)
    lines = [",".join(["time_s", *(f"{n}_deg" for n in names)])]
    lines += [",".join([repr(float(ti)), *("" if np.isnan(x) else repr(float(x)) for x in row)]) for ti, row in zip(t, d)]
    write_text_atomic(path, "\n".join(lines) + "\n")
    return Path(path)


def read_angles_csv(path: str | os.PathLike) -> tuple[np.ndarray, tuple[str, ...], np.ndarray]:
    """(T,) times [s], angle names and (T, K) degrees of an ``angles.csv``.

    Raises
    ------
    RecordingError
        The header or a row does not follow the format.
    """
    lines = Path(path).read_text(encoding="utf-8").splitlines()
    if not lines or not lines[0].startswith("time_s,") or not all(h.endswith("_deg") for h in lines[0].split(",")[1:]):
        raise RecordingError(f"{path}: not an angles.csv (header must be time_s,<angle>_deg,...)")
    names = tuple(h[:-4] for h in lines[0].split(",")[1:])
    rows = [line.split(",") for line in lines[1:]]
    if any(len(r) != len(names) + 1 for r in rows):
        raise RecordingError(f"{path}: every row needs {len(names) + 1} fields")
    values = np.array([[float(x) if x else np.nan for x in r] for r in rows], dtype=float).reshape(len(rows), -1)
    return values[:, 0], names, values[:, 1:]


def write_mot(times: np.ndarray, names: tuple[str, ...] | list[str], degrees: np.ndarray,
              path: str | os.PathLike, *, title: str = "joint_angles") -> Path:
    """Write (T,) ``times`` [s] and (T, K) ``degrees`` as an OpenSim ``.mot`` (module docstring),
    atomically; returns ``path``."""
    t, d = _checked(times, names, degrees)
    header = [title, "version=1", f"nRows={t.size}", f"nColumns={len(names) + 1}", "inDegrees=yes", "endheader",
              "\t".join(["time", *names])]
    rows = ["\t".join([f"{ti:.6f}", *("NaN" if np.isnan(x) else f"{x:.6f}" for x in row)]) for ti, row in zip(t, d)]
    write_text_atomic(path, "\n".join(header + rows) + "\n")
    return Path(path)


def read_mot(path: str | os.PathLike) -> tuple[np.ndarray, tuple[str, ...], np.ndarray]:
    """(T,) times [s], column names and (T, K) degrees of a ``.mot`` written by :func:`write_mot`.

    Raises
    ------
    RecordingError
        No ``endheader`` line, angles not in degrees, or rows that disagree with the header.
    """
    lines = Path(path).read_text(encoding="utf-8").splitlines()
    try:
        end = lines.index("endheader")
    except ValueError:
        raise RecordingError(f"{path}: no endheader line; not an OpenSim .mot") from None
    if "inDegrees=yes" not in lines[:end]:
        raise RecordingError(f"{path}: angles are not in degrees (inDegrees=yes missing)")
    columns = lines[end + 1].split("\t")
    values = np.array([[float(x) for x in line.split("\t")] for line in lines[end + 2:]], dtype=float)
    if values.ndim != 2 or values.shape[1] != len(columns):
        raise RecordingError(f"{path}: rows must have {len(columns)} columns")
    return values[:, 0], tuple(columns[1:]), values[:, 1:]
