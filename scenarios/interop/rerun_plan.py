"""What the Rerun viewer draws (the optional extra ``view``): the room, cameras, skeletons, time
series, and the ranked layouts of a camera plan.

The world frame is the bench's: z up, the floor at z = 0, metres (:mod:`fusion.frames`), logged as
``rr.ViewCoordinates.RIGHT_HAND_Z_UP`` on ``world``. A camera is a transform ``T_world_cam`` on
``world/.../<camera>`` (its name as a label at its centre) and a pinhole frustum on ``<camera>/image``
whose axes follow the camera's :class:`~fusion.camera.AxisConvention` (Kinect v2: left, up, forward;
OpenCV: right, down, forward). Skeletons are joints (keypoint ids = joint indices, named by the
annotation context on ``world``) and bones, per frame on the ``time`` (seconds) and ``frame``
timelines; time series are scalars on the same timelines.

A plan (the output directory of ``mocap-bench plan``) is read through its rig files only
(``rig_*.toml``: scenario files with explicit cameras, the layout's name in the description and its
mean score in the header comment), so that the viewer depends on nothing else the planner writes.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from fusion.camera import AxisConvention, Intrinsics
from fusion.errors import BadInputError
from fusion.topology import Topology, TrackingState
from scenarios.config import load_scenario
from scenarios.runner import build_simulation
from sim.rig import Rig

WORLD = "world"
"""Entity of the world frame (z up, metres)."""
FLOOR_COLOUR = (110, 110, 110)
STATE_COLOURS = {TrackingState.NOT_TRACKED: (150, 150, 150), TrackingState.INFERRED: (255, 150, 0),
                 TrackingState.TRACKED: (60, 180, 75), TrackingState.HIGH: (0, 110, 255)}
"""Colour (RGB) of a camera's joint (and of a bone, by its less trusted end) per tracking state."""
FUSED_COLOUR = (0, 215, 230)
TRUTH_COLOUR = (240, 40, 220)
CAMERA_COLOUR = (255, 215, 0)
IMAGE_PLANE_M = 0.3
"""Distance of a drawn frustum's image plane from the camera centre [m]."""
_SCORE = re.compile(r"mean score (-?\d+(?:\.\d+)?|nan)")


def require_rerun() -> ModuleType:
    """The Rerun SDK module.

    Raises
    ------
    BadInputError
        The SDK is not installed; says how to install the extra.
    """
    try:
        import rerun
    except ImportError:
        raise BadInputError("the viewer needs the Rerun SDK, which is not installed: "
                            "pip install 'mocap-bench[view]'") from None
    return rerun


def log_world(rec: Any, rr: ModuleType, positions_m: np.ndarray, *, spacing_m: float = 0.5) -> list[str]:
    """Log the world's axes (z up) and a floor grid at z = 0 around ``positions_m`` (N, 3) [m], static.

    The grid spans the points' x-y extent plus one metre on each side, in steps of ``spacing_m`` [m].
    Returns the entity paths logged.
    """
    rec.log(WORLD, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    p = np.vstack([np.zeros((1, 3)), np.asarray(positions_m, dtype=float).reshape(-1, 3)])
    p = p[np.all(np.isfinite(p), axis=1)]
    lo = np.floor((p[:, :2].min(axis=0) - 1.0) / spacing_m) * spacing_m
    hi = np.ceil((p[:, :2].max(axis=0) + 1.0) / spacing_m) * spacing_m
    xs, ys = np.arange(lo[0], hi[0] + spacing_m / 2, spacing_m), np.arange(lo[1], hi[1] + spacing_m / 2, spacing_m)
    strips = [[(x, lo[1], 0.0), (x, hi[1], 0.0)] for x in xs] + [[(lo[0], y, 0.0), (hi[0], y, 0.0)] for y in ys]
    rec.log(f"{WORLD}/floor", rr.LineStrips3D(strips, colors=[FLOOR_COLOUR], radii=0.002), static=True)
    return [WORLD, f"{WORLD}/floor"]


def log_camera(rec: Any, rr: ModuleType, entity: str, name: str, T_world_cam: np.ndarray,
               intrinsics: Intrinsics) -> list[str]:
    """Log one camera, static: its pose ``T_world_cam`` (4, 4) [m] on ``entity`` with its name as a
    label at its centre, and its frustum on ``entity/image``. Returns the entity paths logged."""
    T = np.asarray(T_world_cam, dtype=float)
    rec.log(entity, rr.Transform3D(translation=T[:3, 3], mat3x3=T[:3, :3]),
            rr.Points3D([[0.0, 0.0, 0.0]], labels=[name], colors=[CAMERA_COLOUR], radii=0.03), static=True)
    axes = rr.ViewCoordinates.LUF if intrinsics.axes is AxisConvention.KINECT_V2 else rr.ViewCoordinates.RDF
    rec.log(f"{entity}/image", rr.Pinhole(focal_length=[intrinsics.fx, intrinsics.fy],
                                          principal_point=[intrinsics.cx, intrinsics.cy],
                                          width=intrinsics.width, height=intrinsics.height, camera_xyz=axes,
                                          image_plane_distance=IMAGE_PLANE_M, color=CAMERA_COLOUR), static=True)
    return [entity, f"{entity}/image"]


def set_time(rec: Any, t: float, frame: int | None) -> None:
    """Set the ``time`` timeline to ``t`` [s] and the ``frame`` sequence to ``frame`` (cleared when None)."""
    rec.reset_time()
    rec.set_time("time", duration=float(t))
    if frame is not None:
        rec.set_time("frame", sequence=int(frame))


def log_skeleton(rec: Any, rr: ModuleType, entity: str, topology: Topology, times: np.ndarray,
                 positions: np.ndarray, *, states: np.ndarray | None = None,
                 colour: tuple[int, int, int] = FUSED_COLOUR) -> list[str]:
    """Joints (``entity/joints``, keypoint ids = joint indices) and bones (``entity/bones``) of a
    (T, J, 3) [m] stream at ``times`` (T,) [s] on frames 0..T-1, coloured by ``states`` (T, J)
    (:data:`STATE_COLOURS`; a bone by its less trusted end) or all in ``colour``. Absent joints (NaN)
    and their bones are left out."""
    palette = np.array([STATE_COLOURS[s] for s in TrackingState])
    for k, t in enumerate(times):
        set_time(rec, t, k)
        present = ~np.isnan(positions[k]).any(axis=-1)
        st = np.zeros(len(present), int) if states is None else states[k].astype(int)
        colours = np.tile(colour, (len(st), 1)) if states is None else palette[st]
        idx = np.flatnonzero(present)
        rec.log(f"{entity}/joints", rr.Points3D(positions[k][idx], colors=colours[idx], keypoint_ids=idx,
                                                class_ids=np.zeros(idx.size, int), radii=0.02,
                                                show_labels=False))
        bones = topology.bones[present[topology.bones].all(axis=1)]
        worse = np.where(st[bones[:, 0]] <= st[bones[:, 1]], bones[:, 0], bones[:, 1])
        rec.log(f"{entity}/bones", rr.LineStrips3D(positions[k][bones], colors=colours[worse], radii=0.008))
    return [f"{entity}/joints", f"{entity}/bones"]


def log_series(rec: Any, rr: ModuleType, prefix: str, times: np.ndarray, series: dict[str, np.ndarray],
                colour: tuple[int, int, int]) -> list[str]:
    """One scalar time series per name on ``prefix/<name>``, on the reference frames."""
    index = [rr.TimeColumn("time", duration=np.asarray(times, float)),
             rr.TimeColumn("frame", sequence=np.arange(len(times)))]
    for name, values in series.items():
        rec.log(f"{prefix}/{name}", rr.SeriesLines(colors=[colour], names=[name]), static=True)
        rec.send_columns(f"{prefix}/{name}", indexes=index, columns=rr.Scalars.columns(scalars=values))
    return [f"{prefix}/{name}" for name in series]


def log_joint_names(rec: Any, rr: ModuleType, topology: Topology | None) -> None:
    """The joint names of the skeletons' keypoint ids, on ``world`` (static)."""
    if topology is not None:
        rec.log(WORLD, rr.AnnotationContext([rr.ClassDescription(
            info=rr.AnnotationInfo(id=0, label=topology.name),
            keypoint_annotations=[rr.AnnotationInfo(id=i, label=n) for i, n in enumerate(topology.joints)])]),
            static=True)


@dataclass(frozen=True, eq=False)
class PlannedLayout:
    """One layout of a plan, as its rig file states it.

    Attributes
    ----------
    file : the rig file's name (``rig_best.toml``, ``rig_<n>cam.toml``).
    name : the layout's name (from the scenario's description), or the file's stem.
    score : mean score (lower is better); NaN where the file states none.
    rig : the cameras, world frame (subject at the origin facing +x).
    """

    file: str
    name: str
    score: float
    rig: Rig


def read_plan(path: str | Path) -> tuple[PlannedLayout, ...]:
    """The layouts of a plan output directory, best (lowest score) first (``rig_best.toml`` first among
    equals), NaN scores last.

    Raises
    ------
    BadInputError
        The directory holds no ``rig_*.toml`` file.
    ScenarioError
        A rig file is not a valid scenario.
    """
    files = sorted(Path(path).glob("rig_*.toml"))
    if not files:
        raise BadInputError(f"{path} holds no rig_*.toml file: not the output directory of `mocap-bench plan`")
    layouts = []
    for f in files:
        scenario = load_scenario(f)
        match = _SCORE.search(f.read_text(encoding="utf-8").split("\n[", 1)[0])
        name = scenario.description.split(": ", 1)[-1] or f.stem
        layouts.append(PlannedLayout(f.name, name, float(match.group(1)) if match else math.nan,
                                     build_simulation(scenario).rig))
    return tuple(sorted(layouts, key=lambda r: (math.isnan(r.score), r.score, r.file != "rig_best.toml", r.file)))


def log_plan(rec: Any, rr: ModuleType, layouts: tuple[PlannedLayout, ...]) -> list[str]:
    """Log the ranked layouts, static: each layout's cameras on ``world/layouts/<rank>_<file stem>/<camera>``
    (labelled ``#<rank> <camera>``) and its rank, name and score as text on ``world/layouts/<rank>_<file stem>``,
    the subject's place and facing (origin, +x) on ``world/subject``, and the ranking as a Markdown table
    on ``plan``. Returns the entity paths logged."""
    positions = np.array([c.T_world_cam[:3, 3] for lay in layouts for c in lay.rig.cameras])
    entities = log_world(rec, rr, positions)
    rec.log(f"{WORLD}/subject", rr.Arrows3D(origins=[[0.0, 0.0, 0.0]], vectors=[[0.5, 0.0, 0.0]],
                                           labels=["subject (facing +x)"], colors=[(230, 25, 75)]), static=True)
    rows = ["| rank | file | layout | score | cameras (x, y, z) [m] |", "| --- | --- | --- | --- | --- |"]
    for rank, lay in enumerate(layouts, start=1):
        group = f"{WORLD}/layouts/{rank}_{Path(lay.file).stem}"
        rec.log(group, rr.TextDocument(f"#{rank} {lay.name}: score {lay.score:.1f}"), static=True)
        entities.append(group)
        for cam in lay.rig.cameras:
            entities += log_camera(rec, rr, f"{group}/{cam.name}", f"#{rank} {cam.name}", cam.T_world_cam,
                                   cam.intrinsics)
        where = "; ".join("(" + ", ".join(f"{v:.2f}" for v in c.T_world_cam[:3, 3]) + ")" for c in lay.rig.cameras)
        rows.append(f"| {rank} | {lay.file} | {lay.name} | {lay.score:.1f} | {where} |")
    rec.log("plan", rr.TextDocument("\n".join(rows) + "\n", media_type=rr.MediaType.MARKDOWN), static=True)
    return entities + [f"{WORLD}/subject", "plan"]
