"""``mocap-bench view``: what the bench writes, in the Rerun viewer (the optional extra ``view``).

One path is shown: a simulated run directory (``recording/`` and ``truth/``), a recording (simulated,
real or imported), a fused output (``fused.json`` beside ``recording/``) or a plan output
(``rig_*.toml``). The kind is told from the files (:func:`detect_kind`). Entity paths and timelines
are listed in the documentation page ``reference/viewer.md``; the room and the cameras are logged by
:mod:`scenarios.interop.rerun_plan`.

Cameras stand where a calibration puts them (when one is given), else at their true poses (a
simulated run), else each at the origin, level (nothing says where they are). Camera data (skeletons,
depth clouds) is logged in the camera's own frame under its transform, on the ``time`` timeline at
``timestamp - clock offset`` (the calibration's offset, or the true one). The fused skeleton, the
truth, the clinical angles and the per-joint errors share the reference camera's frames.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from fusion.calibrate.floor import align_gauge
from fusion.calibration import Calibration
from fusion.depth import depth_to_points
from fusion.errors import BadInputError, BenchError
from fusion.frames import T_upright_camera
from fusion.io.angle_tables import read_angles_csv
from fusion.io.atomic import check_output_file, write_file_atomic
from fusion.io.recording_files import MANIFEST, load_recording
from fusion.merge.angles import joint_angles
from fusion.merge.fuse import camera_views, fuse_views, fused_angles
from fusion.recording import CameraRecording, Recording
from scenarios.interop.rerun_plan import (
    FUSED_COLOUR,
    TRUTH_COLOUR,
    WORLD,
    log_camera,
    log_joint_names,
    log_plan,
    log_series,
    log_skeleton,
    log_world,
    read_plan,
    require_rerun,
    set_time,
)
from scenarios.runner import load_truth_if_any, recording_dir
from sim.truth import GroundTruth

APPLICATION_ID = "mocap-bench"
LABEL_COLOURS = ((100, 170, 255), (255, 140, 60), (120, 120, 120))
"""Colour of a depth point labelled none, body, floor (:class:`fusion.depth.Label`)."""


class SourceKind(enum.Enum):
    """What ``mocap-bench view`` can show (see :attr:`description`)."""

    RUN = "run"
    RECORDING = "recording"
    FUSED = "fused"
    PLAN = "plan"

    @property
    def description(self) -> str:
        """The files that make a directory this kind, and the command that writes it."""
        return {SourceKind.RUN: "a simulated run with recording/ and truth/ (mocap-bench simulate)",
                SourceKind.RECORDING: "a recording with recording.json (simulated, real or mocap-bench import)",
                SourceKind.FUSED: "a fused output with fused.json, recording/, angles.csv (mocap-bench fuse)",
                SourceKind.PLAN: "a plan output with rig_*.toml files (mocap-bench plan)"}[self]


class Viewer(enum.Enum):
    """Where the data goes when no file is saved."""

    NATIVE = "native"
    """Spawn the desktop viewer (the ``rerun`` program of the SDK)."""
    WEB = "web"
    """Serve the data and the web viewer on this machine and open a browser."""


@dataclass(frozen=True)
class ViewOptions:
    """How much of the depth data is logged.

    Attributes
    ----------
    depth_points : most points per depth cloud (pixels are taken with a regular stride).
    depth_interval_s : least time between two logged depth clouds of one camera [s].
    """

    depth_points: int = 5000
    depth_interval_s: float = 0.5

    def __post_init__(self) -> None:
        if self.depth_points < 1 or not self.depth_interval_s >= 0:
            raise BadInputError(f"depth_points (--depth-points) must be >= 1 and depth_interval_s (--depth-interval) "
                                f">= 0, got {self.depth_points} and {self.depth_interval_s}")


@dataclass(frozen=True)
class ViewResult:
    """What was logged.

    Attributes
    ----------
    kind : the kind of the path shown.
    poses : where the cameras stand (``calibration``, ``true poses``, ``none: ...``, ``plan rig files``).
    entities : entity paths logged, in order.
    frames : frames of the reference time base (the fused skeleton's, else the first camera's; 0 for a plan).
    notes : what could not be shown, and why.
    saved : the ``.rrd`` file written, or None.
    """

    kind: SourceKind
    poses: str
    entities: tuple[str, ...]
    frames: int
    notes: tuple[str, ...] = ()
    saved: Path | None = None


def detect_kind(path: str | Path) -> SourceKind:
    """The kind of what ``path`` holds, from its files.

    Raises
    ------
    BadInputError
        ``path`` is none of the kinds; the message lists them.
    """
    path = Path(path)
    if not path.exists():
        raise BadInputError(f"{path} does not exist; give a directory written by simulate, import, fuse or plan")
    if path.is_dir():
        if (path / "fused.json").is_file() and (path / "recording").is_dir():
            return SourceKind.FUSED
        if (path / "truth").is_dir() and (path / "recording").is_dir():
            return SourceKind.RUN
        if (path / MANIFEST).is_file() or (path / "recording" / MANIFEST).is_file():
            return SourceKind.RECORDING
        if any(path.glob("rig_*.toml")):
            return SourceKind.PLAN
    kinds = "; ".join(k.description for k in SourceKind)
    raise BadInputError(f"{path} is not something the viewer shows; give one of these directories: {kinds}")


def true_time_calibration(recording: Recording, truth: GroundTruth) -> Calibration:
    """The rig as the truth has it: true poses and absolute clock offsets (times become true times)."""
    names = [c.name for c in truth.cameras if c.name in recording.camera_names]
    return Calibration({n: truth.camera(n).T_world_cam for n in names},
                       {n: recording.camera(n).intrinsics for n in names},
                       {n: truth.camera(n).clock_offset_s for n in names}, names[0])


def _log_depth(rec: Any, rr: ModuleType, entity: str, cam: CameraRecording, offset_s: float,
               options: ViewOptions) -> int:
    """Depth clouds of one camera in its frame, on the ``time`` timeline only; returns how many."""
    depth, last, logged = cam.depth, -math.inf, 0
    for k, stamp in enumerate(depth.timestamps):
        if stamp - last < options.depth_interval_s:
            continue
        labels = None if depth.labels is None else depth.labels[k]
        points, point_labels = depth_to_points(depth.depth_mm[k], cam.intrinsics, labels)
        step = max(1, math.ceil(len(points) / options.depth_points))
        colours = np.array(LABEL_COLOURS)[np.zeros(len(points), int) if point_labels is None
                                          else np.minimum(point_labels, 2)]
        set_time(rec, stamp - offset_s, None)
        rec.log(entity, rr.Points3D(points[::step], colors=colours[::step], radii=0.005))
        last, logged = stamp, logged + 1
    return logged


def _log_cameras(rec: Any, rr: ModuleType, recording: Recording, calibration: Calibration | None,
                 options: ViewOptions) -> tuple[list[str], list[str]]:
    """Every camera placed by ``calibration`` (or level at the origin without one), with its
    skeletons and depth clouds; returns the entities and notes."""
    entities, notes = [], []
    for cam in recording.cameras:
        if calibration is not None and cam.name not in calibration.T_world_cam:
            notes.append(f"camera {cam.name} is not in the calibration: not shown")
            continue
        T = T_upright_camera(cam.intrinsics.axes) if calibration is None else calibration.pose(cam.name)
        offset = 0.0 if calibration is None else calibration.clock_offset_s[cam.name]
        entity = f"{WORLD}/cameras/{cam.name}"
        entities += log_camera(rec, rr, entity, cam.name, T, cam.intrinsics)
        if cam.skeleton is not None:
            s = cam.skeleton
            entities += log_skeleton(rec, rr, f"{entity}/skeleton", s.topology, s.timestamps - offset, s.positions,
                                     states=s.states)
        if cam.depth is not None and _log_depth(rec, rr, f"{entity}/depth", cam, offset, options):
            entities.append(f"{entity}/depth")
    return entities, notes


def _log_fusion(rec: Any, rr: ModuleType, recording: Recording, calibration: Calibration,
                truth: GroundTruth | None, true_poses: bool) -> tuple[list[str], int]:
    """Fuse the cameras (default options), log the fused skeleton and its angles, and with ``truth``
    the true skeleton, its angles and the per-joint errors [mm]; returns the entities and frames."""
    views = camera_views(recording, calibration)
    merged = fuse_views(views)
    ref = calibration.reference if calibration.reference in views.names else views.names[0]
    times = merged.times - calibration.clock_offset_s[ref]
    entities = log_skeleton(rec, rr, f"{WORLD}/fused", views.topology, times, merged.positions)
    entities += log_series(rec, rr, "angles/fused", times, fused_angles(merged, views.topology).as_dict(),
                           FUSED_COLOUR)
    if truth is not None and ref in truth.camera_names:
        true = truth.camera(ref).joints_world
        entities += log_skeleton(rec, rr, f"{WORLD}/truth", views.topology, times, true, colour=TRUTH_COLOUR)
        entities += log_series(rec, rr, "angles/truth", times, joint_angles(true, views.topology).as_dict(),
                               TRUTH_COLOUR)
        est = merged.positions
        if not true_poses:  # the calibration's world is the true one up to a rigid gauge
            T_true_est, _ = align_gauge(calibration.T_world_cam, truth.T_world_cam())
            est = est @ T_true_est[:3, :3].T + T_true_est[:3, 3]
        errors = np.linalg.norm(est - true, axis=-1) * 1e3
        entities += log_series(rec, rr, "errors/fused", times, dict(zip(views.topology.joints, errors.T)),
                               FUSED_COLOUR)
    return entities, int(merged.times.size)


def _log_cameras_and_fusion(rec: Any, rr: ModuleType, path: Path, calibration: Calibration | None,
                            options: ViewOptions) -> tuple[str, list[str], int, list[str]]:
    """A run or a recording: poses, entities, reference frames, notes."""
    recording, truth = load_recording(recording_dir(path)), load_truth_if_any(path)
    true_poses = calibration is None and truth is not None
    calibration = true_time_calibration(recording, truth) if true_poses else calibration
    poses = ("true poses (ground truth)" if true_poses else "calibration" if calibration is not None
             else "none: each camera at the origin, level (give a calibration to place them)")
    log_joint_names(rec, rr, recording.topology)
    centres = [calibration.pose(n)[:3, 3] for n in calibration.camera_names] if calibration is not None else []
    entities = log_world(rec, rr, np.array(centres))
    more, notes = _log_cameras(rec, rr, recording, calibration, options)
    entities += more
    first = next((c.skeleton for c in recording.cameras if c.skeleton is not None), None)
    frames = 0 if first is None else first.n_frames
    if calibration is None:
        notes.append("no calibration: no fused skeleton")
    elif recording.topology is not None:
        try:
            more, frames = _log_fusion(rec, rr, recording, calibration, truth, true_poses)
            entities += more
        except BenchError as exc:
            notes.append(f"no fused skeleton: {exc}")
    return poses, entities, frames, notes


def _log_fused(rec: Any, rr: ModuleType, path: Path, calibration: Calibration | None
               ) -> tuple[str, list[str], int, list[str]]:
    """A fused output: its skeleton (world frame) and angles, the cameras where ``calibration`` puts them."""
    fused = load_recording(path / "recording").cameras[0].skeleton
    log_joint_names(rec, rr, fused.topology)
    entities = log_world(rec, rr, np.array([calibration.pose(n)[:3, 3] for n in calibration.camera_names])
                         if calibration is not None else np.zeros((0, 3)))
    notes = ["a fused output stores no camera data: only the fused skeleton, its angles and the rig"]
    for name in () if calibration is None else calibration.camera_names:
        entities += log_camera(rec, rr, f"{WORLD}/cameras/{name}", name, calibration.pose(name),
                               calibration.intrinsics[name])
    entities += log_skeleton(rec, rr, f"{WORLD}/fused", fused.topology, fused.timestamps, fused.positions)
    if (path / "angles.csv").is_file():
        times, names, degrees = read_angles_csv(path / "angles.csv")
        entities += log_series(rec, rr, "angles/fused", times, dict(zip(names, degrees.T)), FUSED_COLOUR)
    else:
        notes.append("no angles.csv: no clinical angles")
    return "calibration" if calibration is not None else "none (give a calibration to draw the rig)", \
        entities, fused.n_frames, notes


def log_source(rec: Any, path: str | Path, *, calibration: Calibration | None = None,
               options: ViewOptions = ViewOptions()) -> ViewResult:
    """Log what ``path`` holds into the Rerun recording stream ``rec``.

    Parameters
    ----------
    rec : a ``rerun.RecordingStream`` with a sink (file, viewer or memory).
    path : a run, recording, fused or plan directory (see :class:`SourceKind`).
    calibration : where the cameras stand; default the true poses of a run, else each at the origin.
    options : how much depth data to log.

    Raises
    ------
    BadInputError
        ``path`` is none of the kinds, or the Rerun SDK is not installed.
    RecordingError, ScenarioError
        A file of ``path`` is damaged.
    """
    rr, path = require_rerun(), Path(path)
    kind = detect_kind(path)
    if kind is SourceKind.PLAN:
        poses, entities, frames, notes = "plan rig files", log_plan(rec, rr, read_plan(path)), 0, []
    elif kind is SourceKind.FUSED:
        poses, entities, frames, notes = _log_fused(rec, rr, path, calibration)
    else:
        poses, entities, frames, notes = _log_cameras_and_fusion(rec, rr, path, calibration, options)
    rec.log("info", rr.TextDocument("\n".join([f"{kind.value}: {path}", f"cameras: {poses}", *notes])),
            static=True)
    return ViewResult(kind, poses, ("info", *entities), frames, tuple(notes))


def blueprint(kind: SourceKind) -> Any:
    """The viewer's default layout: the room in 3D, the angles and errors as plots (or a plan's ranking),
    the notes, and the ``time`` timeline selected."""
    import rerun.blueprint as rrb

    room = rrb.Spatial3DView(origin=WORLD, name="room (z up, metres)")
    side = [rrb.TextDocumentView(origin="plan", name="ranked layouts")] if kind is SourceKind.PLAN else [
        rrb.TimeSeriesView(origin="angles", name="clinical angles [deg]"),
        rrb.TimeSeriesView(origin="errors", name="joint errors against truth [mm]")]
    return rrb.Blueprint(rrb.Horizontal(room, rrb.Vertical(*side, rrb.TextDocumentView(origin="info", name="info")),
                                        column_shares=[2, 1]), rrb.TimePanel(timeline="time"))


def view(path: str | Path, *, save: str | Path | None = None, overwrite: bool = False,
         calibration: Calibration | None = None, viewer: Viewer = Viewer.NATIVE,
         options: ViewOptions = ViewOptions()) -> ViewResult:
    """Show ``path`` in the Rerun viewer, or with ``save`` write it to a ``.rrd`` file atomically.

    Parameters
    ----------
    save : the ``.rrd`` file to write (open it later with ``rerun FILE.rrd``); None: stream to ``viewer``.
    overwrite : replace an existing ``save`` file.
    viewer : the desktop viewer (spawned) or the web viewer (served on this machine; it lives as long as
        this process does).

    Raises
    ------
    BadInputError
        See :func:`log_source`; also ``save`` exists (without ``overwrite``) or cannot be written, or the
        desktop viewer cannot be started.
    """
    rr = require_rerun()
    layout = blueprint(detect_kind(path))
    rec = rr.RecordingStream(APPLICATION_ID)
    rec.set_log_time_enabled(False)
    rec.set_log_tick_enabled(False)
    if save is None:
        if viewer is Viewer.NATIVE:
            try:
                rec.spawn(default_blueprint=layout)
            except RuntimeError as exc:  # the SDK's "viewer not found on PATH"
                raise BadInputError(f"cannot start the desktop viewer: {str(exc).splitlines()[0]}; put the bin folder "
                                    "of the environment holding rerun-sdk on PATH, or use --viewer web or --save "
                                    "FILE.rrd") from None
        else:
            rr.serve_web_viewer(connect_to=rec.serve_grpc(default_blueprint=layout))
        result = log_source(rec, path, calibration=calibration, options=options)
        rec.flush()
        return result
    save = check_output_file(save, overwrite=overwrite)
    results = []

    def write(tmp: str) -> None:
        rec.save(tmp, default_blueprint=layout)
        try:
            results.append(log_source(rec, path, calibration=calibration, options=options))
            rec.flush()
        finally:
            rec.disconnect()

    write_file_atomic(save, write)
    return dataclasses.replace(results[0], saved=save)
