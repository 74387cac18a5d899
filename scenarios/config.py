"""Scenario files: TOML in, validated frozen dataclasses out.

Unknown keys are rejected with a message naming the key, its table and the keys allowed there.
See ``scenarios/README.md`` for every key with its unit and default.
"""

from __future__ import annotations

import dataclasses
import enum
import tomllib
import types
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fusion.errors import ScenarioError

SCENARIO_DIR = Path(__file__).resolve().parent


class SegmentKind(enum.Enum):
    """Kinds of session segments."""

    IDLE = "idle"
    CALIBRATION_TURN = "calibration_turn"
    SALUTE = "salute"
    HAND_LIFT = "hand_lift"
    REPLAY = "replay"


class NoiseLevel(enum.Enum):
    """Sensor noise presets."""

    DEFAULT = "default"
    NONE = "none"


@dataclass(frozen=True)
class SubjectConfig:
    """Who performs: anthropometry, kinematic profile and the sensor's joint topology."""

    height_m: float = 1.75
    build: str = "average"
    group: str = "healthy"
    affected_side: str | None = None
    topology: str = "kinect_v2"


@dataclass(frozen=True)
class CameraConfig:
    """One explicitly placed camera: its centre and the point it looks at, world frame [m]."""

    name: str
    position_m: list[float]
    target_m: list[float]


@dataclass(frozen=True)
class RigConfig:
    """Camera ring: evenly spaced ``n_cameras`` or explicit ``angles_deg``; ``subset`` is 1-based.
    Or explicit cameras (``[[rig.camera]]``), which replace the ring."""

    camera: list[CameraConfig] | None = None
    n_cameras: int = 2
    angles_deg: list[float] | None = None
    start_deg: float = 0.0
    subset: list[int] | None = None
    radius_m: float = 2.0
    height_m: float = 1.0
    target_height_m: float = 1.0
    vary_intrinsics: bool = False


@dataclass(frozen=True)
class ReplayConfig:
    """A recorded motion replayed by a ``replay`` segment (``[session.segment.replay]``).

    ``source`` is a path (relative to the working directory); ``format`` one of motion, recording,
    c3d, trc, bvh (default from the name); ``camera``/``calibration`` for recordings,
    ``marker_map``/``units``/``up_axis`` for C3D/TRC/BVH; ``start_s``/``end_s`` the window on the
    source's clock [s]; ``position_m`` (x, y) [m] and ``facing_deg`` where the subject starts
    (default: where the source stood).
    """

    source: str
    format: str | None = None
    camera: str | None = None
    calibration: str | None = None
    marker_map: str | None = None
    units: str | None = None
    up_axis: str | None = None
    start_s: float | None = None
    end_s: float | None = None
    position_m: list[float] | None = None
    facing_deg: float | None = None


@dataclass(frozen=True)
class SegmentConfig:
    """One piece of the session timeline."""

    kind: SegmentKind
    duration_s: float | None = None
    side: str | None = None
    repetitions: int = 3
    rest_s: float = 1.0
    replay: ReplayConfig | None = None


@dataclass(frozen=True)
class SensorConfig:
    """Sensor models: noise presets, depth frame rate stored with the recording, clocks."""

    depth_noise: NoiseLevel = NoiseLevel.DEFAULT
    tracker_noise: NoiseLevel = NoiseLevel.DEFAULT
    depth_rate_hz: float = 1.0
    clock_offset_sd_ms: float = 5.0
    clock_jitter_ms: float = 1.0
    drop_probability: float = 0.005


@dataclass(frozen=True)
class Scenario:
    """A complete, reproducible simulation set-up."""

    name: str
    description: str = ""
    seed: int = 0
    duration_s: float | None = None
    subject: SubjectConfig = field(default_factory=SubjectConfig)
    rig: RigConfig = field(default_factory=RigConfig)
    session: tuple[SegmentConfig, ...] = ()
    sensors: SensorConfig = field(default_factory=SensorConfig)

    def replace(self, **changes: Any) -> Scenario:
        """A copy with some top-level fields changed (e.g. ``seed``, ``duration_s``)."""
        return dataclasses.replace(self, **changes)


def _strip_optional(tp: Any) -> tuple[Any, bool]:
    if isinstance(tp, types.UnionType) or typing.get_origin(tp) is typing.Union:
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        return args[0], True
    return tp, False


def _convert(value: Any, tp: Any, where: str) -> Any:
    tp, optional = _strip_optional(tp)
    if value is None and optional:
        return None
    origin = typing.get_origin(tp)
    if isinstance(tp, type) and issubclass(tp, enum.Enum):
        try:
            return tp(value)
        except ValueError:
            raise ScenarioError(f"{where}: {value!r} is not one of {[m.value for m in tp]}") from None
    if origin is list:
        (item_tp,) = typing.get_args(tp)
        if not isinstance(value, list):
            raise ScenarioError(f"{where}: expected a list, got {value!r}")
        return [_convert(v, item_tp, f"{where}[{i}]") for i, v in enumerate(value)]
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ScenarioError(f"{where}: expected a number, got {value!r}")
        return float(value)
    if tp in (int, str, bool):
        if not isinstance(value, tp) or (tp is int and isinstance(value, bool)):
            raise ScenarioError(f"{where}: expected {tp.__name__}, got {value!r}")
        return value
    if dataclasses.is_dataclass(tp):
        return build_table(tp, value, where)
    raise ScenarioError(f"{where}: unsupported value {value!r}")


def build_table(cls: type, table: Any, where: str) -> Any:
    """An instance of the dataclass ``cls`` from a TOML table, each value checked against its type hint.

    ``where`` names the table in error messages. Unknown keys and wrongly typed values raise
    :class:`ScenarioError` listing what is allowed.
    """
    if not isinstance(table, dict):
        raise ScenarioError(f"{where}: expected a table, got {table!r}")
    hints = typing.get_type_hints(cls)
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = [k for k in table if k not in fields]
    if unknown:
        raise ScenarioError(f"unknown key {unknown[0]!r} in [{where}]; allowed keys: {', '.join(fields)}")
    kwargs = {}
    for name, value in table.items():
        kwargs[name] = _convert(value, hints[name], f"{where}.{name}")
    missing = [n for n, f in fields.items() if n not in kwargs and f.default is dataclasses.MISSING
               and f.default_factory is dataclasses.MISSING]
    if missing:
        raise ScenarioError(f"[{where}] is missing required key(s): {', '.join(missing)}")
    return cls(**kwargs)


def scenario_from_dict(data: dict[str, Any], where: str = "scenario") -> Scenario:
    """Validate a parsed TOML document (see module docstring) into a :class:`Scenario`."""
    data = dict(data)
    top = data.pop("scenario", None)
    if top is None:
        raise ScenarioError(f"{where}: missing [scenario] table with at least name = ...")
    allowed = {"subject", "rig", "session", "sensors"}
    unknown = [k for k in data if k not in allowed]
    if unknown:
        raise ScenarioError(f"{where}: unknown table [{unknown[0]}]; allowed: [scenario], "
                            + ", ".join(f"[{a}]" for a in sorted(allowed)))
    session = data.pop("session", {})
    if not isinstance(session, dict) or set(session) - {"segment"}:
        raise ScenarioError(f"{where}: [session] holds only [[session.segment]] entries")
    segments = tuple(build_table(SegmentConfig, s, f"session.segment[{i}]")
                     for i, s in enumerate(session.get("segment", [])))
    if not segments:
        raise ScenarioError(f"{where}: the session needs at least one [[session.segment]]")
    parts = {k: build_table(cls, data.get(k, {}), k)
             for k, cls in (("subject", SubjectConfig), ("rig", RigConfig), ("sensors", SensorConfig))}
    base = build_table(Scenario, top, "scenario")
    scenario = dataclasses.replace(base, session=segments, **parts)
    _check_values(scenario)
    return scenario


def _check_values(s: Scenario) -> None:
    if s.seed < 0:
        raise ScenarioError("scenario.seed must be >= 0")
    if s.duration_s is not None and s.duration_s <= 0:
        raise ScenarioError("scenario.duration_s must be positive")
    if s.rig.n_cameras < 1 and s.rig.angles_deg is None:
        raise ScenarioError("rig.n_cameras must be >= 1")
    for i, cam in enumerate(s.rig.camera or []):
        if len(cam.position_m) != 3 or len(cam.target_m) != 3:
            raise ScenarioError(f"rig.camera[{i}]: position_m and target_m need three numbers (x, y, z) in metres")
    if s.sensors.depth_rate_hz < 0 or s.sensors.depth_rate_hz > 30:
        raise ScenarioError("sensors.depth_rate_hz must lie in [0, 30]")
    for i, seg in enumerate(s.session):
        if (seg.kind is SegmentKind.REPLAY) != (seg.replay is not None):
            raise ScenarioError(f"session.segment[{i}]: a [session.segment.replay] table belongs to, and is needed "
                                "by, kind = \"replay\" only")
        if seg.kind is SegmentKind.REPLAY:
            r = seg.replay
            if r.position_m is not None and len(r.position_m) != 2:
                raise ScenarioError(f"session.segment[{i}].replay.position_m needs two numbers (x, y) in metres")
            if r.start_s is not None and r.end_s is not None and r.end_s <= r.start_s:
                raise ScenarioError(f"session.segment[{i}].replay: end_s must exceed start_s")
        elif seg.kind in (SegmentKind.SALUTE, SegmentKind.HAND_LIFT):
            if seg.side not in ("left", "right"):
                raise ScenarioError(f"session.segment[{i}].side must be 'left' or 'right' for {seg.kind.value}")
            if seg.repetitions < 1:
                raise ScenarioError(f"session.segment[{i}].repetitions must be >= 1")
        elif seg.duration_s is None or seg.duration_s <= 0:
            raise ScenarioError(f"session.segment[{i}] ({seg.kind.value}) needs a positive duration_s")


def resolve_builtin(name_or_path: str | Path, directory: Path, kind: str) -> Path:
    """A TOML file by path, or by the name of a built-in file in ``directory`` (without suffix)."""
    p = Path(name_or_path)
    if p.is_file():
        return p
    builtin = directory / f"{p.stem}.toml"
    known = (Path("."), Path(directory.name), Path("scenarios"), Path("scenarios") / directory.name)
    if p.suffix in ("", ".toml") and builtin.is_file() and p.parent in known:
        return builtin
    names = sorted(f.stem for f in directory.glob("*.toml"))
    raise ScenarioError(f"{kind} {str(name_or_path)!r} not found; give a TOML path or a built-in: {', '.join(names)}")


def read_toml(path: Path) -> dict[str, Any]:
    """The parsed TOML document at ``path``; invalid TOML is a :class:`ScenarioError` naming the file."""
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{path}: not valid TOML: {exc}") from None


def resolve_scenario_path(name_or_path: str | Path) -> Path:
    """A scenario file by path, or by the name of a built-in scenario (``fma_2cam``, ``ring6``, ...)."""
    return resolve_builtin(name_or_path, SCENARIO_DIR, "scenario")


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Read and validate a scenario TOML file (path or built-in name)."""
    path = resolve_scenario_path(name_or_path)
    return scenario_from_dict(read_toml(path), where=str(path))
