"""Room files for the camera-layout planner: TOML in, validated frozen dataclasses out.

Room frame: metres, z up, floor at z = 0, x and y as the floor outline is drawn. The simulation's
world frame puts the subject at the origin facing +x; :meth:`Room.T_world_room` maps one onto the
other. Every key, with units and defaults, is documented in ``scenarios/rooms/README.md``.
"""

from __future__ import annotations

import dataclasses
import enum
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fusion.errors import ScenarioError
from fusion.transforms import make_transform
from scenarios.config import (
    SCENARIO_DIR,
    Scenario,
    SegmentConfig,
    SensorConfig,
    SubjectConfig,
)
from scenarios.toml_tables import build_table, read_toml, resolve_builtin
from sim.sensor_profile import builtin_profiles

ROOM_DIR = SCENARIO_DIR / "rooms"

BUILTIN_SENSORS = tuple(builtin_profiles())
"""Names of the built-in sensor profiles (``sim/sensor_profiles/``) a plan may be simulated with."""


class MountKind(enum.Enum):
    """Where cameras may go."""

    WALL = "wall"
    """Along a wall segment ``from_m`` -> ``to_m`` (floor xy), at heights within ``height_m``."""
    TRIPOD = "tripod"
    """Anywhere in the floor rectangle ``min_m`` .. ``max_m``, at heights within ``height_m``."""
    POINTS = "points"
    """Only at the listed places ``points_m`` (x, y, z)."""


@dataclass(frozen=True)
class RoomConfig:
    """Name, floor outline (a polygon of (x, y) corners [m]), ceiling height [m] and the planner's seed."""

    name: str
    outline_m: list[list[float]]
    ceiling_m: float = 2.7
    description: str = ""
    seed: int = 0


@dataclass(frozen=True)
class SubjectZone:
    """Where the subject stands (centre (x, y) [m], facing [deg, counter-clockwise from +x]) and who it is."""

    position_m: list[float]
    facing_deg: float = 0.0
    radius_m: float = 0.5
    height_m: float = 1.75
    build: str = "average"
    topology: str = "kinect_v2"


@dataclass(frozen=True)
class Box:
    """An obstacle (blocks sight, no camera inside) between corners ``min_m`` and ``max_m`` (x, y, z) [m]."""

    name: str
    min_m: list[float]
    max_m: list[float]


@dataclass(frozen=True)
class Zone:
    """A forbidden floor rectangle (no tripod, no wall mount above it): corners (x, y) [m]."""

    name: str
    min_m: list[float]
    max_m: list[float]


@dataclass(frozen=True)
class Mount:
    """One region where cameras may be mounted (see :class:`MountKind`)."""

    kind: MountKind
    name: str = ""
    from_m: list[float] | None = None
    to_m: list[float] | None = None
    min_m: list[float] | None = None
    max_m: list[float] | None = None
    height_m: list[float] = field(default_factory=lambda: [1.0, 1.0])
    points_m: list[list[float]] | None = None


@dataclass(frozen=True)
class CameraCount:
    """How many cameras to plan for: an inclusive range."""

    min: int = 2
    max: int = 2


@dataclass(frozen=True)
class Objective:
    """Weights of the objectives (score = sum of weight x value, lower is better; units in the README)."""

    joint_error_mm: float = 1.0
    angle_error_deg: float = 1.0
    back_pose_pct: float = 0.5
    not_high_confidence_pct: float = 0.5
    arm_occluded_pct: float = 0.2
    calibration_rotation_deg: float = 5.0
    calibration_translation_mm: float = 0.1
    cameras: float = 0.0


@dataclass(frozen=True)
class SearchConfig:
    """Budget of the planner: screen, optimiser trials and seeds per layout."""

    trials: int = 40
    seeds: int = 2
    final_seeds: int = 4
    candidates_per_mount: int = 12
    screen_poses: int = 12
    min_visible: float = 0.5
    aim_height_m: list[float] = field(default_factory=lambda: [0.8, 1.2])


@dataclass(frozen=True)
class Reference:
    """A fixed layout to compare with the plan: cameras on a ring around the subject (subject frame)."""

    name: str
    angles_deg: list[float]
    radius_m: float = 2.0
    height_m: float = 1.0
    aim_height_m: float = 1.0


@dataclass(frozen=True)
class Room:
    """A complete planning problem (see ``scenarios/rooms/README.md``)."""

    room: RoomConfig
    subject: SubjectZone
    mounts: tuple[Mount, ...]
    protocol: tuple[SegmentConfig, ...]
    obstacles: tuple[Box, ...] = ()
    forbidden: tuple[Zone, ...] = ()
    sensors: SensorConfig = field(default_factory=SensorConfig)
    cameras: CameraCount = field(default_factory=CameraCount)
    objective: Objective = field(default_factory=Objective)
    search: SearchConfig = field(default_factory=SearchConfig)
    references: tuple[Reference, ...] = ()

    @property
    def T_world_room(self) -> np.ndarray:
        """(4, 4) room frame -> simulation world frame (subject at the origin facing +x)."""
        a = np.radians(self.subject.facing_deg)
        R_world_room = np.array([[np.cos(a), np.sin(a), 0.0], [-np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
        centre = np.array([*self.subject.position_m, 0.0])
        return make_transform(R_world_room, -R_world_room @ centre)

    def with_search(self, **changes: Any) -> "Room":
        """A copy with some ``[search]`` values changed (validated like the file's)."""
        room = dataclasses.replace(self, search=dataclasses.replace(self.search, **changes))
        _check_room(room)
        return room

    def with_sensor(self, profile: str, **noise: Any) -> "Room":
        """A copy simulated with another sensor profile (a built-in name or a TOML path), the subject
        taking the profile's joint topology; ``noise`` changes other ``[sensors]`` values
        (e.g. ``tracker_noise=NoiseLevel.NONE``)."""
        from sim.sensor_profile import load_profile

        topology = load_profile(profile).topology.name
        return dataclasses.replace(self, sensors=dataclasses.replace(self.sensors, profile=profile, **noise),
                                   subject=dataclasses.replace(self.subject, topology=topology))

    @property
    def sensor_name(self) -> str:
        """The sensor profile the sessions use: the ``[sensors]`` profile, else the subject topology's default."""
        from scenarios.runner import default_profile

        return self.sensors.profile or default_profile(self.subject.topology)

    def scenario(self, name: str, seed: int) -> Scenario:
        """The protocol as a scenario without cameras (the planner adds them)."""
        s = self.subject
        return Scenario(name=name, seed=seed, subject=SubjectConfig(height_m=s.height_m, build=s.build,
                                                                    topology=s.topology),
                        session=self.protocol, sensors=self.sensors)


_TABLES = {"room": RoomConfig, "subject": SubjectZone, "sensors": SensorConfig, "cameras": CameraCount,
           "objective": Objective, "search": SearchConfig}
_LISTS = {"mount": Mount, "obstacle": Box, "forbidden": Zone, "reference": Reference}


def _pairs(values: list[float], n: int, where: str) -> None:
    if len(values) != n:
        raise ScenarioError(f"{where} needs {n} numbers, got {values}")


def _check_room(r: Room) -> None:
    outline = np.asarray(r.room.outline_m, dtype=float)
    if outline.ndim != 2 or outline.shape[1] != 2 or outline.shape[0] < 3:
        raise ScenarioError("room.outline_m must list at least three [x, y] corners")
    if r.room.ceiling_m <= 0 or r.room.seed < 0:
        raise ScenarioError("room.ceiling_m must be > 0 and room.seed >= 0")
    _pairs(r.subject.position_m, 2, "subject.position_m")
    if not _inside(outline, np.asarray(r.subject.position_m)):
        raise ScenarioError(f"subject.position_m {r.subject.position_m} lies outside room.outline_m")
    for box in r.obstacles:
        _pairs(box.min_m, 3, f"obstacle {box.name}: min_m")
        _pairs(box.max_m, 3, f"obstacle {box.name}: max_m")
    for zone in r.forbidden:
        _pairs(zone.min_m, 2, f"forbidden {zone.name}: min_m")
        _pairs(zone.max_m, 2, f"forbidden {zone.name}: max_m")
    if not r.mounts:
        raise ScenarioError("the room needs at least one [[mount]] where cameras may go")
    for i, m in enumerate(r.mounts):
        where = f"mount[{i}] ({m.kind.value})"
        _pairs(m.height_m, 2, f"{where}: height_m")
        if not 0 < m.height_m[0] <= m.height_m[1] <= r.room.ceiling_m:
            raise ScenarioError(f"{where}: height_m must be [low, high] with 0 < low <= high <= the ceiling")
        needed = {MountKind.WALL: ("from_m", "to_m"), MountKind.TRIPOD: ("min_m", "max_m"),
                  MountKind.POINTS: ("points_m",)}[m.kind]
        for key in needed:
            if getattr(m, key) is None:
                raise ScenarioError(f"{where} needs {', '.join(needed)}")
        if m.kind is MountKind.POINTS:
            for p in m.points_m:
                _pairs(p, 3, f"{where}: points_m entry")
                _check_place(r, outline, np.asarray(p, dtype=float), f"{where}: points_m entry {p}")
        else:
            _pairs(getattr(m, needed[0]), 2, f"{where}: {needed[0]}")
            _pairs(getattr(m, needed[1]), 2, f"{where}: {needed[1]}")
    c, s = r.cameras, r.search
    if not 2 <= c.min <= c.max:
        raise ScenarioError(f"cameras must be a range with 2 <= min <= max (calibration pairs cameras), "
                            f"got {c.min}..{c.max}")
    if min(s.seeds, s.final_seeds, s.candidates_per_mount, s.screen_poses) < 1 or s.trials < 0:
        raise ScenarioError("search.seeds, final_seeds, candidates_per_mount and screen_poses must be >= 1 and "
                            "search.trials >= 0 (0: no search, only the given layouts are scored)")
    if not 0 <= s.min_visible <= 1:
        raise ScenarioError("search.min_visible is a share in [0, 1]")
    _pairs(s.aim_height_m, 2, "search.aim_height_m")
    for name, value in vars(r.objective).items():
        if value < 0:
            raise ScenarioError(f"objective.{name} must be >= 0 (a weight)")
    for ref in r.references:
        if len(ref.angles_deg) < 2:
            raise ScenarioError(f"reference {ref.name}: needs at least two angles_deg")


def _check_place(r: Room, outline: np.ndarray, p: np.ndarray, where: str) -> None:
    """Refuse a camera place (x, y, z) [m] outside the room, at or below the floor, above the ceiling,
    inside an obstacle or over a forbidden zone."""
    if not 0 < p[2] <= r.room.ceiling_m:
        raise ScenarioError(f"{where}: height {p[2]:g} m is not between the floor and the ceiling "
                            f"({r.room.ceiling_m:g} m)")
    if not _inside(outline, p[:2]):
        raise ScenarioError(f"{where} lies outside room.outline_m")
    for box in r.obstacles:
        if np.all(p >= np.asarray(box.min_m)) and np.all(p <= np.asarray(box.max_m)):
            raise ScenarioError(f"{where} lies inside obstacle {box.name}")
    for zone in r.forbidden:
        if np.all(p[:2] >= np.asarray(zone.min_m)) and np.all(p[:2] <= np.asarray(zone.max_m)):
            raise ScenarioError(f"{where} lies in forbidden zone {zone.name}")


def check_camera_place(room: Room, p_room: np.ndarray, where: str) -> None:
    """Refuse a camera centre (3,) [m, room frame] outside the room, at or below the floor, above the
    ceiling, inside an obstacle or over a forbidden zone (:class:`ScenarioError` naming ``where``)."""
    _check_place(room, np.asarray(room.room.outline_m, dtype=float), np.asarray(p_room, dtype=float), where)


def _inside(polygon: np.ndarray, point: np.ndarray) -> bool:
    """Even-odd test of a point (2,) against a polygon (N, 2)."""
    x, y = point
    inside = False
    for (x0, y0), (x1, y1) in zip(polygon, np.roll(polygon, -1, axis=0)):
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            inside = not inside
    return inside


def room_from_dict(data: dict[str, Any], where: str = "room") -> Room:
    """Validate a parsed room TOML document into a :class:`Room`.

    Raises
    ------
    ScenarioError
        Unknown table or key (naming the allowed ones), wrong type or a value out of range.
    """
    allowed = set(_TABLES) | set(_LISTS) | {"protocol"}
    unknown = [k for k in data if k not in allowed]
    if unknown:
        raise ScenarioError(f"{where}: unknown table [{unknown[0]}]; allowed: {', '.join(sorted(allowed))}")
    for required in ("room", "subject", "mount", "protocol"):
        if required not in data:
            raise ScenarioError(f"{where}: missing [{required}]" + ("" if required != "mount" else " (at least one)"))
    protocol = data["protocol"]
    if not isinstance(protocol, dict) or set(protocol) != {"segment"} or not protocol["segment"]:
        raise ScenarioError(f"{where}: [protocol] holds [[protocol.segment]] entries (as a scenario's session)")
    tables = {k: build_table(cls, data.get(k, {}), k) for k, cls in _TABLES.items()}
    lists = {}
    for key, cls in _LISTS.items():
        entries = data.get(key, [])
        if not isinstance(entries, list):
            raise ScenarioError(f"{where}: [[{key}]] must be an array of tables")
        lists[key] = tuple(build_table(cls, e, f"{key}[{i}]") for i, e in enumerate(entries))
    segments = tuple(build_table(SegmentConfig, s, f"protocol.segment[{i}]") for i, s in enumerate(protocol["segment"]))
    room = Room(room=tables["room"], subject=tables["subject"], mounts=lists["mount"], protocol=segments,
                obstacles=lists["obstacle"], forbidden=lists["forbidden"], sensors=tables["sensors"],
                cameras=tables["cameras"], objective=tables["objective"], search=tables["search"],
                references=lists["reference"])
    _check_room(room)
    # the protocol must be a valid scenario session (same checks as a scenario file)
    from scenarios.config import scenario_from_dict

    scenario_from_dict({"scenario": {"name": room.room.name}, "session": protocol}, where=f"{where} [protocol]")
    return room


def resolve_room_path(name_or_path: str | Path) -> Path:
    """A room file by path, or by the name of a built-in room in ``scenarios/rooms/``."""
    return resolve_builtin(name_or_path, ROOM_DIR, "room")


def load_room(name_or_path: str | Path) -> Room:
    """Read and validate a room TOML file (path or built-in name)."""
    path = resolve_room_path(name_or_path)
    return room_from_dict(read_toml(path), where=str(path))
