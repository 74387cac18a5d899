"""Exports to formats of other tools: C3D, OpenSim TRC, CSV, and aniposelib / Pose2Sim camera TOML.

Skeleton exports take a :class:`~fusion.skeleton.SkeletonStream` and the frame it is in: the
fused recording's world frame (``camera_axes=None``: z up, floor z = 0, metres) or a single camera's
native frame (``camera_axes`` its :class:`~fusion.camera.AxisConvention`), which is first turned into
a z-up frame by :func:`z_up_positions` (x along the camera's view, y to its left, z up), so that C3D
is z up and TRC y up whichever frame the stream came from. Markers are named after the joints of the
stream's topology.

C3D and TRC need a constant frame rate. Their samples lie on the grid ``t0 + k / rate_hz``
(``t0`` the first timestamp, up to the last timestamp); ``rate_hz`` defaults to the median frame
rate of the stream. A grid time that coincides with a frame (within 1e-6 of a grid period) takes
that frame's positions, absent joints included; otherwise each joint is interpolated linearly
between the nearest frames before and after where it is present, if those are at most two source
frame periods apart (10 % slack for clock jitter), and is a gap otherwise. Uniform timestamps at
the default rate are therefore written unchanged.
"""

from __future__ import annotations

import enum
import io
import os
from collections.abc import Mapping
from pathlib import Path

import ezc3d
import numpy as np
import tomli_w
from scipy.spatial.transform import Rotation

from fusion.calibration import WORLD, Calibration
from fusion.camera import AxisConvention
from fusion.errors import BadInputError
from fusion.frames import T_YUP_ZUP, LengthUnit, UpAxis, z_up_positions
from fusion.io.atomic import write_file_atomic, write_text_atomic
from fusion.io.formats.labels import LABEL_GROUP, check_labels
from fusion.skeleton import SkeletonStream
from fusion.transforms import apply, invert

_MAX_GAP_FRAMES = 2.0 * 1.1  # two source frame periods plus slack for clock jitter


class ExportFormat(enum.Enum):
    """What ``mocap-bench export`` writes."""

    C3D = "c3d"
    TRC = "trc"
    CSV = "csv"
    CAMERA_TOML = "camera-toml"
    """An aniposelib / Pose2Sim camera TOML of a calibration."""
    BIDS = "bids"
    """A Motion-BIDS data set (BIDS 1.9 motion modality) of a whole cohort folder."""


class KinectImage(enum.Enum):
    """Which pixel coordinates a Kinect v2 camera's exported intrinsics describe."""

    AS_RECORDED = "as_recorded"
    """The SDK's mirrored images (the ``depthX``/``depthY`` pixels): ``matrix`` has a negative fx."""
    UNMIRRORED = "unmirrored"
    """Images flipped left-right (``u' = width - 1 - u``): an ordinary camera with positive fx."""


_R_OPENCV_KINECT = np.diag([-1.0, -1.0, 1.0])
"""Kinect v2 camera axes seen in OpenCV axes (x right, y down, z forward)."""


EXPORT_UNITS = (LengthUnit.M, LengthUnit.MM)
"""The length units C3D and TRC exports write."""


def _export_unit(units: LengthUnit | str) -> LengthUnit:
    unit = LengthUnit(units)
    if unit not in EXPORT_UNITS:
        raise BadInputError(f"exports write metres or millimetres, got {unit.value!r}: use units m or mm")
    return unit


def _check_rate(stream: SkeletonStream, rate_hz: float | None) -> float:
    """The export rate [Hz]: ``rate_hz`` if given, else the stream's median frame rate."""
    if stream.n_frames == 0:
        raise BadInputError("the skeleton stream is empty: nothing to export")
    if rate_hz is not None:
        if not (np.isfinite(rate_hz) and rate_hz > 0):
            raise BadInputError(f"rate_hz must be a positive finite number, got {rate_hz}")
        span = float(stream.timestamps[-1] - stream.timestamps[0])
        if span * rate_hz > 10 * stream.n_frames + 100:  # interpolating finer adds nothing, and costs memory
            most = (10 * stream.n_frames + 100) / span
            raise BadInputError(f"rate_hz {rate_hz:g} would interpolate {span * rate_hz:.3g} frames from "
                                f"{stream.n_frames}; give at most {most:.4g} Hz (ten times the recording's frames)")
        return float(rate_hz)
    if stream.n_frames < 2:
        raise BadInputError("estimating the frame rate needs at least 2 frames; pass rate_hz explicitly")
    return float(1.0 / np.median(np.diff(stream.timestamps)))


def resample_uniform(stream: SkeletonStream, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Joint positions on the uniform grid ``t0 + k / rate_hz`` (see the module docstring).

    Parameters
    ----------
    stream : SkeletonStream
        At least one frame.
    rate_hz : float
        Grid rate [Hz], positive.

    Returns
    -------
    times : np.ndarray
        (N,) grid times [s] on the stream's clock.
    positions : np.ndarray
        (N, J, 3) positions [m]; NaN for gaps.
    """
    ts = stream.timestamps
    n = int(np.floor((ts[-1] - ts[0]) * rate_hz + 1e-6)) + 1
    times = ts[0] + np.arange(n) / rate_hz
    period = float(np.median(np.diff(ts))) if stream.n_frames > 1 else 1.0 / rate_hz
    tol = 1e-6 / rate_hz
    out = np.full((n, stream.topology.n_joints, 3), np.nan)
    frame = np.clip(np.searchsorted(ts, times - tol), 0, ts.size - 1)
    exact = np.abs(ts[frame] - times) <= tol
    out[exact] = stream.positions[frame[exact]]
    for j in range(stream.topology.n_joints):
        present = ~np.isnan(stream.positions[:, j, 0])
        t_j, p_j = ts[present], stream.positions[present, j]
        if t_j.size == 0:
            continue
        right = np.clip(np.searchsorted(t_j, times), 0, t_j.size - 1)
        left = np.clip(right - 1, 0, t_j.size - 1)
        t0, t1 = t_j[left], t_j[right]
        inside = ~exact & (t0 < times) & (times < t1) & (t1 - t0 <= _MAX_GAP_FRAMES * period)
        w = np.where(inside, (times - t0) / np.where(t1 > t0, t1 - t0, 1.0), 0.0)[:, None]
        interp = (1.0 - w) * p_j[left] + w * p_j[right]
        out[inside, j] = interp[inside]
    return times, out


def _check_c3d(tmp: Path, path: Path, n_joints: int, n_frames: int) -> None:
    """Raise BadInputError unless the C3D file ``tmp`` reads back with ``n_joints`` points and ``n_frames`` frames."""
    try:
        got = ezc3d.c3d(str(tmp))["data"]["points"].shape[1:]
    except (OSError, RuntimeError) as exc:  # ezc3d's errors on a short or corrupt file
        raise BadInputError(f"cannot write {path}: the written file does not read back ({exc}); "
                            "free some space or choose a folder on another disk") from exc
    if got != (n_joints, n_frames):
        raise BadInputError(f"cannot write {path}: the written file reads back as {got[1]} frames of {got[0]} points "
                            f"instead of {n_frames} of {n_joints} (a short write: is the disk full?)")


def export_c3d(
    stream: SkeletonStream,
    path: str | os.PathLike,
    *,
    rate_hz: float | None = None,
    units: LengthUnit | str = LengthUnit.MM,
    camera_axes: AxisConvention | None = None,
    labels: Mapping[str, str] | None = None,
) -> Path:
    """Write ``stream`` as a C3D file of 3-D points, one per joint, atomically.

    Parameters
    ----------
    stream : SkeletonStream
        (T, J, 3) positions [m]; written in the stream's frame (the world frame: z up).
    path : path-like
        Output ``.c3d`` file.
    rate_hz : float, optional
        POINT:RATE [Hz]; default the median frame rate. Samples are resampled onto the uniform grid.
    units : LengthUnit or str
        POINT:UNITS, ``"mm"`` (the C3D convention, default) or ``"m"``.
    camera_axes : AxisConvention, optional
        The stream's camera frame; None (default) for the z-up world frame (see :func:`z_up_positions`).
    labels : mapping of str to str, optional
        Data set labels, parameters of the ``MOCAP_BENCH`` group (:mod:`fusion.io.formats.labels`).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    BadInputError
        The stream is empty, has one frame and no ``rate_hz``, or ``rate_hz`` is not positive; or the
        file cannot be written (no space, no permission) or does not read back complete. ``path`` is
        then untouched.

    Notes
    -----
    Gaps and absent joints are C3D "invalid" points: NaN coordinates and residual -1. Valid points
    have residual 0 (no reconstruction residual is known). Coordinates are stored as float32.
    """
    units = _export_unit(units)
    rate = _check_rate(stream, rate_hz)
    _, pos = resample_uniform(stream, rate)
    pos = z_up_positions(pos, camera_axes)
    n, J = pos.shape[:2]
    points = np.ones((4, J, n))
    points[:3] = np.transpose(pos * units.per_metre, (2, 1, 0))
    residuals = np.where(np.isnan(pos[..., 0]).T, -1.0, 0.0)[None]
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = [rate]
    c3d["parameters"]["POINT"]["UNITS"]["value"] = [units.value]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = tuple(stream.topology.joints)
    for name, text in check_labels(labels).items():
        c3d.add_parameter(LABEL_GROUP, name, [text])
    c3d["data"]["points"] = points
    c3d["data"]["meta_points"] = {"residuals": residuals, "camera_masks": np.zeros((7, J, n), dtype=bool)}
    path = Path(path)
    write_file_atomic(path, c3d.write, check=lambda tmp: _check_c3d(tmp, path, J, n))
    return path


def _fmt(values: np.ndarray, decimals: int) -> list[str]:
    """Fixed-point strings, ``NaN`` for NaN (as OpenSim writes missing markers; empty trailing fields
    are dropped by its reader)."""
    return ["NaN" if np.isnan(v) else f"{v:.{decimals}f}" for v in values]


def export_trc(
    stream: SkeletonStream,
    path: str | os.PathLike,
    *,
    rate_hz: float | None = None,
    units: LengthUnit | str = LengthUnit.M,
    up_axis: UpAxis | str = UpAxis.Y,
    camera_axes: AxisConvention | None = None,
    labels: Mapping[str, str] | None = None,
) -> Path:
    """Write ``stream`` as an OpenSim TRC marker file (PathFileType 4), atomically.

    Layout (tab-separated)::

        PathFileType  4  (X/Y/Z)  <file name>
        DataRate  CameraRate  NumFrames  NumMarkers  Units  OrigDataRate  OrigDataStartFrame  OrigNumFrames
        <rate>    <rate>      <N>        <J>         m|mm   <rate>        1                   <N>
        Frame#  Time  <joint 1>  ''  ''  <joint 2> ...
        ''      ''    X1  Y1  Z1  X2  Y2  Z2 ...
        1       <t>   x   y   z   ...

    Frames are numbered from 1; Time is the grid time [s] on the stream's clock; a missing marker
    has ``NaN`` in its three fields (OpenSim's convention). Values have 6 decimals in metres, 3 in millimetres.

    Parameters
    ----------
    stream : SkeletonStream
        (T, J, 3) positions [m] in a z-up frame (the fused world frame).
    path : path-like
        Output ``.trc`` file.
    rate_hz : float, optional
        DataRate [Hz]; default the median frame rate. Samples are resampled onto the uniform grid.
    units : LengthUnit or str
        ``"m"`` (default) or ``"mm"``.
    up_axis : UpAxis or str
        ``"y"`` (default, OpenSim: x forward, y up, z right) rotates the z-up frame by -90 degrees
        about x; ``"z"`` keeps the z-up axes.
    camera_axes : AxisConvention, optional
        The stream's camera frame; None (default) for the z-up world frame (see :func:`z_up_positions`).
    labels : mapping of str to str, optional
        Data set labels, ``name=text`` fields after the file name on the first line (OpenSim reads past them).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    BadInputError
        The stream is empty, has one frame and no ``rate_hz``, or ``rate_hz`` is not positive.
    """
    units, up_axis, extra = _export_unit(units), UpAxis(up_axis), check_labels(labels)
    rate = _check_rate(stream, rate_hz)
    times, pos = resample_uniform(stream, rate)
    pos = z_up_positions(pos, camera_axes)
    if up_axis is UpAxis.Y:
        pos = apply(T_YUP_ZUP, pos)
    pos = pos * units.per_metre
    decimals = 6 if units is LengthUnit.M else 3
    path = Path(path)
    names = stream.topology.joints
    n = times.size
    out = io.StringIO()
    out.write("\t".join(["PathFileType\t4\t(X/Y/Z)", path.name, *(f"{k}={v}" for k, v in extra.items())]) + "\n")
    out.write("DataRate\tCameraRate\tNumFrames\tNumMarkers\tUnits\tOrigDataRate\tOrigDataStartFrame\tOrigNumFrames\n")
    out.write(f"{rate:g}\t{rate:g}\t{n}\t{len(names)}\t{units.value}\t{rate:g}\t1\t{n}\n")
    out.write("Frame#\tTime\t" + "\t".join(f"{m}\t\t" for m in names) + "\n")
    out.write("\t\t" + "\t".join(f"X{i}\tY{i}\tZ{i}" for i in range(1, len(names) + 1)) + "\n")
    for k in range(n):
        out.write(f"{k + 1}\t{times[k]:.6f}\t" + "\t".join(_fmt(pos[k].ravel(), decimals)) + "\n")
    write_text_atomic(path, out.getvalue())
    return path


def export_csv(stream: SkeletonStream, path: str | os.PathLike, *, labels: Mapping[str, str] | None = None) -> Path:
    """Write ``stream`` as CSV, one row per frame, atomically.

    Header: the names of ``labels`` (data set labels, their texts repeated on every row), ``time_s``, then for each joint ``<joint>_x_m,<joint>_y_m,<joint>_z_m,<joint>_state``.
    Rows: the frame's timestamp [s], positions [m] in the stream's frame (shortest round-trip
    decimal, an empty field where the joint is absent) and the integer
    :class:`~fusion.topology.TrackingState`. Frames are written as they are, without resampling.

    Parameters
    ----------
    stream : SkeletonStream
        (T, J, 3) positions [m], (T, J) states, (T,) timestamps [s]; at least one frame.
    path : path-like
        Output ``.csv`` file.

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    BadInputError
        The stream is empty.
    """
    if stream.n_frames == 0:
        raise BadInputError("the skeleton stream is empty: nothing to export")
    extra = check_labels(labels)
    header = [*extra, "time_s"] + [f"{j}_{c}" for j in stream.topology.joints for c in ("x_m", "y_m", "z_m", "state")]
    out = io.StringIO()
    out.write(",".join(header) + "\n")
    for t, p, s in zip(stream.timestamps, stream.positions, stream.states):
        fields = [*extra.values(), repr(float(t))]
        for xyz, state in zip(p, s):
            fields += ["" if np.isnan(v) else repr(float(v)) for v in xyz] + [str(int(state))]
        out.write(",".join(fields) + "\n")
    write_text_atomic(path, out.getvalue())
    return Path(path)


def export_camera_toml(calibration: Calibration, path: str | os.PathLike, *,
                       kinect_image: KinectImage | str = KinectImage.UNMIRRORED) -> Path:
    """Write the rig as an aniposelib / Pose2Sim camera file (TOML), atomically.

    One table per camera, ``[cam_1]``, ``[cam_2]``, ... in calibration order::

        name = "cam1"
        size = [width, height]            # px
        matrix = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]   # px
        distortions = [0.0, 0.0, 0.0, 0.0, 0.0]         # k1 k2 p1 p2 k3 (pinhole, none modelled)
        rotation = [rx, ry, rz]           # Rodrigues vector of R_cam_world [rad]
        translation = [tx, ty, tz]        # t_cam_world [m]
        fisheye = false

    plus ``[metadata]`` (``adjusted = false``, ``error = 0.0``, ``units = "m"``, the world frame and
    the reference camera). Extrinsics follow OpenCV: ``x_cam = R x_world + t`` with camera axes
    x right, y down, z forward, so ``s [u, v, 1] = K (R x_world + t)``. Translations are in metres:
    aniposelib and Pose2Sim triangulate in the unit of the translation.

    A Kinect v2 camera frame (+x to the sensor's left, +y up) becomes OpenCV axes by
    ``diag(-1, -1, 1)``. Its images are mirrored (``u = cx + fx * x / z`` in Kinect space), which
    no rotation reproduces; ``kinect_image`` chooses the pixels the file describes.

    Parameters
    ----------
    calibration : Calibration
        Camera poses ``T_world_cam`` (4, 4) [m] and intrinsics.
    path : path-like
        Output ``.toml`` file.
    kinect_image : KinectImage or str
        ``"unmirrored"`` (default): pixels of the left-right flipped images, ``u' = width - 1 - u``,
        with positive fx and ``cx' = width - 1 - cx``: an ordinary camera, which aniposelib's bundle
        adjustment and Pose2Sim expect. ``"as_recorded"``: pixels of the mirrored Kinect v2 images,
        the same as :meth:`~fusion.camera.Intrinsics.project`, via a negative fx (aniposelib loads it
        but its bundle adjustment diverges). Cameras with OpenCV axes are unaffected.

    Returns
    -------
    Path
        ``path``.
    """
    kinect_image = KinectImage(kinect_image)
    doc: dict = {}
    for i, name in enumerate(calibration.camera_names, start=1):
        intr = calibration.intrinsics[name]
        T_cam_world = invert(calibration.pose(name))
        R, t = T_cam_world[:3, :3], T_cam_world[:3, 3]
        fx, cx = intr.fx, intr.cx
        if intr.axes is AxisConvention.KINECT_V2:
            R, t = _R_OPENCV_KINECT @ R, _R_OPENCV_KINECT @ t
            if kinect_image is KinectImage.AS_RECORDED:
                fx = -fx
            else:
                cx = intr.width - 1 - cx
        doc[f"cam_{i}"] = {
            "name": name, "size": [intr.width, intr.height],
            "matrix": [[fx, 0.0, cx], [0.0, intr.fy, intr.cy], [0.0, 0.0, 1.0]], "distortions": [0.0] * 5,
            "rotation": Rotation.from_matrix(R).as_rotvec().tolist(), "translation": t.tolist(), "fisheye": False,
        }
    doc["metadata"] = {"adjusted": False, "error": 0.0, "units": "m", "world": WORLD,
                       "reference": calibration.reference, "kinect_image": kinect_image.value}
    write_text_atomic(path, tomli_w.dumps(doc))
    return Path(path)
