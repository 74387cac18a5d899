"""Calibration files: the rig's camera poses, intrinsics and quality figures, as TOML.

Layout (format ``mocap-bench-calibration``, version 1)::

    format = "mocap-bench-calibration"
    version = 1
    reference = "cam1"            # camera whose frame the pairwise solution was built in
    refine = "icp"                # none | icp
    rig = "graph"                 # chain | graph
    world = "floor z = 0, z up, origin under the subject's start, x along its initial facing"
    floor_rmse_mm = 2.1           # optional
    loop_closure_mm = 1.5         # optional, rings of three or more cameras
    notes = ["..."]               # what was skipped or fell back

    [[camera]]
    name = "cam1"
    T_world_cam = [[r00, r01, r02, tx], [r10, r11, r12, ty], [r20, r21, r22, tz], [0, 0, 0, 1]]  # metres
    clock_offset_s = 0.0          # this camera's clock minus the reference camera's
    [camera.intrinsics]           # width, height, fx, fy, cx, cy, min_depth_m, max_depth_m, axes

    [[pair]]                      # one per calibrated camera pair (quality figures)
    cameras = ["cam1", "cam2"]
    support = 0.83                # fraction of shared Tracked joint measurements that agree
    residual_rmse_mm = 31.2       # RMS distance of the inlier joints after the skeleton fit
    rotation_std_deg = 0.11       # bootstrap spread of the skeleton transform
    translation_std_mm = 4.0
    icp = "accepted"              # accepted | rejected | not run
    icp_fitness = 0.54            # when ICP ran
    icp_rmse_mm = 4.2
    note = "..."                  # why ICP was not run or not used, if so
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from fusion.calibration import Calibration
from fusion.camera import Intrinsics
from fusion.errors import BadInputError, BenchError, RecordingError
from fusion.io.atomic import write_text_atomic

FORMAT_NAME = "mocap-bench-calibration"
FORMAT_VERSION = 1
def save_calibration(calibration: Calibration, path: str | os.PathLike) -> Path:
    """Write ``calibration`` as TOML at ``path`` atomically."""
    doc: dict[str, Any] = {"format": FORMAT_NAME, "version": FORMAT_VERSION, "reference": calibration.reference}
    doc |= {k: v for k, v in calibration.info.items() if k != "pair"}
    doc["camera"] = [
        {"name": n, "T_world_cam": calibration.T_world_cam[n].tolist(),
         "clock_offset_s": float(calibration.clock_offset_s[n]), "intrinsics": calibration.intrinsics[n].to_dict()}
        for n in calibration.camera_names
    ]
    if calibration.info.get("pair"):
        doc["pair"] = calibration.info["pair"]
    write_text_atomic(path, tomli_w.dumps(doc))
    return Path(path)


def read_toml_file(path: Path) -> dict[str, Any]:
    """The parsed TOML document of a calibration file; a missing or invalid file is a RecordingError."""
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise RecordingError(f"calibration file {path} does not exist; create it with `mocap-bench calibrate`") from None
    except OSError as exc:
        raise RecordingError(f"cannot read calibration file {path}: {exc.strerror}") from None
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise RecordingError(f"{path} is not a valid TOML calibration file: {exc}") from None


def load_calibration(path: str | os.PathLike) -> Calibration:
    """Read a calibration TOML written by :func:`save_calibration` (or by hand in that layout).

    Raises
    ------
    RecordingError
        The file is missing, not TOML, of another format or version, or inconsistent.
    """
    path = Path(path)
    doc = read_toml_file(path)
    if doc.get("format") != FORMAT_NAME or doc.get("version") != FORMAT_VERSION:
        raise RecordingError(f"{path}: not a {FORMAT_NAME} version {FORMAT_VERSION} file")
    try:
        cams = doc["camera"]
        T = {c["name"]: np.array(c["T_world_cam"], dtype=float) for c in cams}
        intr = {c["name"]: Intrinsics.from_dict(c["intrinsics"]) for c in cams}
        offsets = {c["name"]: float(c.get("clock_offset_s", 0.0)) for c in cams}
        if len(T) != len(cams):
            raise BadInputError("camera names are not unique")
        info = {k: v for k, v in doc.items() if k not in ("format", "version", "reference", "camera")}
        return Calibration(T, intr, offsets, doc["reference"], info)
    except (BenchError, KeyError, TypeError, ValueError) as exc:
        raise RecordingError(f"{path}: inconsistent calibration ({type(exc).__name__}: {exc})") from None
