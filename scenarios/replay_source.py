"""Motion sources of a replay, by format: read a file or a recording into a landmark trajectory, or a
fitted motion file as it is.

Formats (:class:`SourceFormat`): ``motion`` (a file written by ``mocap-bench retarget``, replayed
without refitting), ``recording`` (a recording or run directory; one camera with ``--calib``, the
only camera of a one-camera recording turned upright, or a fused directory from ``mocap-bench
fuse``), ``c3d``, ``trc`` and ``bvh`` (with a marker map), and ``ui-prmd-vicon`` (a UI-PRMD Vicon
episode, :func:`fusion.io.formats.ui_prmd.read_ui_prmd_vicon`, through the ``plug_in_gait`` map by
default).
"""

from __future__ import annotations

import enum
import re
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from fusion.errors import BadInputError
from fusion.frames import UpAxis, z_up_positions
from fusion.io.calibration_file import load_calibration
from fusion.io.formats.ui_prmd import read_ui_prmd_vicon
from fusion.io.marker_map import apply_marker_map, load_marker_map
from fusion.io.mocap import (
    FUSED_CAMERA,
    LandmarkTrajectory,
    trajectory_from_recording,
    trajectory_from_stream,
)
from fusion.io.mocap_files import read_bvh, read_c3d, read_trc
from fusion.io.recording_files import load_recording
from sim.replay import FittedMotion, fit_motion, load_motion
from sim.retarget import RetargetOptions


class SourceFormat(enum.Enum):
    """Format of a replay source."""

    MOTION = "motion"
    RECORDING = "recording"
    C3D = "c3d"
    TRC = "trc"
    BVH = "bvh"
    UI_PRMD_VICON = "ui-prmd-vicon"


_DEFAULT_UP = {SourceFormat.C3D: UpAxis.Z, SourceFormat.TRC: UpAxis.Y, SourceFormat.BVH: UpAxis.Y}
_DEFAULT_MAP = {SourceFormat.C3D: "kinect_v2", SourceFormat.TRC: "kinect_v2", SourceFormat.BVH: "cmu",
                SourceFormat.UI_PRMD_VICON: "plug_in_gait"}
_UI_PRMD_POSITIONS = re.compile(r".*_positions(_inc)?\.txt\.gz", re.IGNORECASE)


@dataclass(frozen=True)
class SourceOptions:
    """How to read a source.

    Attributes
    ----------
    camera : camera of a recording (default: the fused one, else the calibration's reference).
    calibration : calibration TOML placing the recording's cameras. A recording of one camera needs
        none: its world frame is then the camera's own, turned upright (x along the view, y to the
        camera's left, z up; :func:`fusion.frames.z_up_positions`), which assumes a level camera.
    marker_map : built-in marker map name or TOML path (C3D/TRC default ``kinect_v2``, BVH ``cmu``,
        UI-PRMD Vicon ``plug_in_gait``).
    units : length unit of a C3D/TRC/BVH file (``m``, ``mm``, ``cm``), overriding the file's.
    up_axis : vertical axis of a C3D/TRC/BVH file (``y`` or ``z``; C3D default z, TRC/BVH y).
    """

    camera: str | None = None
    calibration: Path | None = None
    marker_map: str | None = None
    units: str | None = None
    up_axis: str | None = None


def guess_format(source: Path) -> SourceFormat:
    """The format a source's name suggests: a directory is a recording, a ``..._positions.txt.gz`` file
    in a folder called ``Vicon`` (and none called ``Kinect``) a UI-PRMD Vicon episode, else its suffix.

    Raises
    ------
    BadInputError
        No known suffix (lists the formats), or a UI-PRMD positions file whose folders do not say
        Vicon.
    """
    if source.is_dir():
        return SourceFormat.RECORDING
    if _UI_PRMD_POSITIONS.fullmatch(source.name):
        folders = {p.lower() for p in source.parts[:-1]}
        if "vicon" in folders and "kinect" not in folders:
            return SourceFormat.UI_PRMD_VICON
        raise BadInputError(f"{source} is named like a UI-PRMD positions file, but its folders do not say it holds "
                            f"Vicon markers: give its format ({SourceFormat.UI_PRMD_VICON.value}) if it does; a UI-PRMD "
                            "Kinect episode is read into a recording by `mocap-bench import ui-prmd-kinect`")
    suffix = {".npz": SourceFormat.MOTION, ".c3d": SourceFormat.C3D, ".trc": SourceFormat.TRC,
              ".bvh": SourceFormat.BVH}
    if source.suffix.lower() in suffix:
        return suffix[source.suffix.lower()]
    raise BadInputError(f"cannot tell the format of {source}; give it ({', '.join(f.value for f in SourceFormat)})")


def load_trajectory(source: Path, fmt: SourceFormat, options: SourceOptions = SourceOptions()) -> LandmarkTrajectory:
    """A source (not a fitted motion) as a world-frame landmark trajectory.

    Raises
    ------
    BadInputError
        ``fmt`` is MOTION (already fitted), or an option does not apply.
    """
    if fmt is SourceFormat.MOTION:
        raise BadInputError(f"{source} is a fitted motion: it replays as it is and has no landmarks to fit")
    if fmt is SourceFormat.RECORDING:
        if options.marker_map or options.units or options.up_axis:
            raise BadInputError("marker_map, units and up_axis apply to C3D, TRC and BVH files, not to recordings")
        path = source / "recording" if (source / "recording").is_dir() else source
        recording = load_recording(path)
        if options.calibration is None and FUSED_CAMERA not in recording.camera_names:
            cams = [c for c in recording.cameras if c.skeleton is not None]
            if len(cams) == 1 and options.camera in (None, cams[0].name):
                trajectory = trajectory_from_stream(cams[0].skeleton, source=f"camera {cams[0].name}")
                upright = z_up_positions(trajectory.positions, cams[0].intrinsics.axes)
                return LandmarkTrajectory(trajectory.topology, trajectory.times, upright, trajectory.confidence,
                                          trajectory.source)
        calib = None if options.calibration is None else load_calibration(options.calibration)
        return trajectory_from_recording(recording, camera=options.camera, calibration=calib)
    if options.camera or options.calibration:
        raise BadInputError("camera and calibration apply to recordings, not to C3D, TRC, BVH or UI-PRMD Vicon files")
    if fmt is SourceFormat.UI_PRMD_VICON:
        if options.units or options.up_axis:
            raise BadInputError("units and up_axis do not apply to UI-PRMD Vicon files: they hold millimetres, z up")
        return apply_marker_map(read_ui_prmd_vicon(source), load_marker_map(options.marker_map or _DEFAULT_MAP[fmt]))
    up = UpAxis(options.up_axis) if options.up_axis else _DEFAULT_UP[fmt]
    if fmt is SourceFormat.BVH:
        markers = read_bvh(source, up_axis=up, units=options.units or "cm")
    else:
        markers = (read_c3d if fmt is SourceFormat.C3D else read_trc)(source, up_axis=up, units=options.units)
    return apply_marker_map(markers, load_marker_map(options.marker_map or _DEFAULT_MAP[fmt]))


def load_or_fit(source: Path, fmt: SourceFormat, options: SourceOptions = SourceOptions(),
                retarget_options: RetargetOptions = RetargetOptions(), *,
                progress: Callable[[int], None] | None = None) -> FittedMotion:
    """A fitted motion: read from a motion file, or fitted to any other source."""
    if fmt is SourceFormat.MOTION:
        return load_motion(source)
    motion, _, _ = fit_motion(load_trajectory(source, fmt, options), retarget_options, progress=progress)
    return motion
