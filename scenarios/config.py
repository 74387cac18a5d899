"""Scenario files: TOML in, validated frozen dataclasses out.

Unknown keys are rejected naming the key, its table and the keys allowed; ``scenarios/README.md`` lists every key.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fusion.errors import ScenarioError
from fusion.recording import check_lab
from scenarios.toml_tables import build_table, read_toml, resolve_builtin, without_none
from sim.depth_renderer import DepthRenderer

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


class PopulationDraw(enum.Enum):
    """Which person of the sensor profile's population a scenario's tracker is."""

    DRAW = "draw"
    """A person and session drawn with the seed (``sensors.person_seed`` or the scenario's)."""
    TYPICAL = "typical"
    """The profile's typical person, every session alike."""


class PoseSource(enum.Enum):
    """Where the layout study's camera poses come from."""

    BODY = "body"
    """Calibrated from the body (skeleton + ICP, chained)."""
    TRUTH = "truth"
    """The true camera poses and clock offsets (isolates merging from calibration)."""


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
    """One explicitly placed camera: its centre and the point it looks at, world frame [m], and
    optionally ``up_m``, the direction the top of its image points to (its +y in Kinect v2 axes;
    any vector not along the view, only its part across the view counts). Without ``up_m`` the
    camera is levelled (no roll about its optical axis)."""

    name: str
    position_m: list[float]
    target_m: list[float]
    up_m: list[float] | None = None


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
    """Sensor models: the sensor profile (a built-in name or a TOML path; None is the built-in profile
    of the subject's topology), noise switches, depth frame rate stored with the recording, what
    renders depth (``auto``, ``raycast``, ``mujoco``: :class:`sim.depth_renderer.DepthRenderer`), and
    optional overrides of the profile's clock (None keeps the profile's value). ``population``:
    whether the tracker is a person drawn from the profile's population (:mod:`sim.sensor_population`)
    or its typical person; ``person_seed`` fixes the person (the same for every scenario that gives
    it, each scenario's seed still drawing its session); None draws the person from the scenario's seed.
    ``lab``: the lab the simulated person is of (a lab the population knows draws from that lab's
    people, :meth:`sim.sensor_population.Population.for_lab`; another, or None, from the population).
    ``noise_scale`` multiplies the tracker's jitter and wobble (after the person is drawn; 1 keeps the
    profile's); ``flips = false`` stops the tracker from reporting a body seen from behind as facing
    the camera (the back-facing flips of :class:`sim.tracker_noise.TrackerNoise`)."""

    profile: str | None = None
    depth_noise: NoiseLevel = NoiseLevel.DEFAULT
    tracker_noise: NoiseLevel = NoiseLevel.DEFAULT
    depth_rate_hz: float = 1.0
    depth_renderer: DepthRenderer = DepthRenderer.AUTO
    clock_offset_sd_ms: float | None = None
    clock_jitter_ms: float | None = None
    drop_probability: float | None = None
    population: PopulationDraw = PopulationDraw.DRAW
    person_seed: int | None = None
    lab: str | None = None
    noise_scale: float = 1.0
    flips: bool = True


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

    def replace(self, **changes: Any) -> "Scenario":
        """A copy with some top-level fields changed (e.g. ``seed``, ``duration_s``), checked again.

        Raises
        ------
        ScenarioError
            The changed scenario fails :func:`check_scenario`.
        """
        changed = dataclasses.replace(self, **changes)
        check_scenario(changed)
        return changed


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
    rig = data.get("rig", {})
    if "n_cameras" in rig and "angles_deg" in rig and len(rig["angles_deg"]) != rig["n_cameras"]:
        raise ScenarioError(f"{where}: rig.n_cameras = {rig['n_cameras']} but rig.angles_deg lists "
                            f"{len(rig['angles_deg'])} angles; give one angle per camera or drop n_cameras")
    base = build_table(Scenario, top, "scenario")
    scenario = dataclasses.replace(base, session=segments, **parts)
    check_scenario(scenario)
    return scenario


MAX_CAMERAS = 24
"""Most cameras a scenario may place. Calibration works on every camera pair (n (n - 1) / 2 RANSAC
runs) and the merge on every camera per frame; the paper's largest rig has 6 cameras."""

MAX_RECORDING_BYTES = 2 * 1024**3
"""Largest in-memory recording (skeletons, truth, depth frames) a scenario may ask for [bytes]."""

SKELETON_RATE_HZ = 30.0
"""Body-tracker frame rate of the simulated sensors (``sim.camera_clock.ClockModel.rate_hz``) [Hz]."""

_SUBJECT_CENTRE_M = (0.0, 0.0, 1.0)
"""Where the body is, for range checks: the subject stands at the origin, its trunk about 1 m up."""


def _depth_range_m(topology: str) -> tuple[float, float]:
    """Reliable depth range [m] of the sensor that the subject's topology selects."""
    from fusion.camera import KINECT_V2_DEPTH
    from sim.rig import AZURE_KINECT_NFOV

    intr = AZURE_KINECT_NFOV if topology == "k4abt" else KINECT_V2_DEPTH
    return intr.min_depth_m, intr.max_depth_m


def camera_positions(rig: RigConfig) -> list[tuple[str, tuple[float, ...]]]:
    """Names and world positions [m] of the cameras a rig places (the ring as ``sim.rig`` builds it)."""
    from sim.rig import ring_rig

    if rig.camera:
        return [(c.name, tuple(c.position_m)) for c in rig.camera]
    ring = ring_rig(rig.n_cameras, radius_m=rig.radius_m, height_m=rig.height_m, target_height_m=rig.target_height_m,
                    start_deg=rig.start_deg, angles_deg=rig.angles_deg, subset=rig.subset)
    return [(c.name, tuple(c.position)) for c in ring.cameras]


def session_seconds(s: Scenario) -> float:
    """Length of the session [s]: ``duration_s`` if set, else the explicit segment durations plus the
    rests between repetitions (a lower bound: the movements themselves add a few seconds each)."""
    if s.duration_s is not None:
        return s.duration_s
    return sum(seg.duration_s if seg.duration_s is not None else seg.repetitions * seg.rest_s for seg in s.session)


def estimate_recording_bytes(s: Scenario, *, depth_in_memory: bool) -> int:
    """Memory a simulated run of ``s`` holds [bytes]: per camera skeleton frames at 30 Hz (positions,
    states, timestamps, the truth's joints, yaw and visibility) and, if ``depth_in_memory``, depth
    frames (uint16 depth and uint8 labels at the sensor's image size), for :func:`session_seconds`.
    A run simulated to disk streams its depth frames to files (``depth_in_memory=False``)."""
    n_joints = 32 if s.subject.topology == "k4abt" else 25
    pixels = 640 * 576 if s.subject.topology == "k4abt" else 512 * 424
    per_frame = n_joints * (3 * 8 + 1) + 8 + n_joints * 3 * 8 + n_joints + 4 * 8
    per_second = SKELETON_RATE_HZ * per_frame + depth_in_memory * s.sensors.depth_rate_hz * pixels * 3
    return int(len(camera_positions(s.rig)) * session_seconds(s) * per_second)


def check_memory(s: Scenario, *, depth_in_memory: bool) -> None:
    """Refuse a run estimated to hold more than :data:`MAX_RECORDING_BYTES` (see :func:`estimate_recording_bytes`)."""
    need = estimate_recording_bytes(s, depth_in_memory=depth_in_memory)
    if need > MAX_RECORDING_BYTES:
        where = ("simulate it to disk (`mocap-bench simulate`), which streams depth frames to files, or "
                 if depth_in_memory else "")
        raise ScenarioError(f"the run would hold about {need / 1024**3:.1f} GiB in memory (limit "
                            f"{MAX_RECORDING_BYTES / 1024**3:.0f} GiB): {where}shorten it (--duration or "
                            "scenario.duration_s, segment durations, repetitions), use fewer cameras or lower "
                            "sensors.depth_rate_hz")


def check_scenario(s: Scenario) -> None:
    """Refuse values a simulation cannot honour or that would silently give a useless run.

    Checks: seed and durations, camera counts (angle list against ``n_cameras``, at most
    :data:`MAX_CAMERAS`), cameras above the floor and within the sensor's depth range of the subject,
    and the estimated memory against :data:`MAX_RECORDING_BYTES`.

    Raises
    ------
    ScenarioError
        Naming the key, the value and what to change.
    """
    if s.seed < 0:
        raise ScenarioError("scenario.seed must be >= 0")
    if s.duration_s is not None and not (math.isfinite(s.duration_s) and s.duration_s > 0):
        raise ScenarioError(f"scenario.duration_s (or --duration) must be a positive number of seconds, "
                            f"got {s.duration_s}")
    r = s.rig
    if r.n_cameras < 1 and r.angles_deg is None:
        raise ScenarioError("rig.n_cameras must be >= 1")
    n_ring = len(r.angles_deg) if r.angles_deg is not None else r.n_cameras
    if r.angles_deg is not None and not r.angles_deg:
        raise ScenarioError("rig.angles_deg is empty; list one angle per camera")
    if not r.camera and max(n_ring, len(r.subset or ())) > MAX_CAMERAS or len(r.camera or ()) > MAX_CAMERAS:
        raise ScenarioError(f"the rig places {max(n_ring, len(r.camera or ()))} cameras; at most {MAX_CAMERAS} are "
                            "supported (calibration works on every pair); lower rig.n_cameras or use rig.subset")
    if r.subset is not None and (len(set(r.subset)) != len(r.subset) or not all(1 <= k <= n_ring for k in r.subset)):
        raise ScenarioError(f"rig.subset {r.subset} must name distinct cameras among 1..{n_ring}")
    if not r.camera and r.radius_m <= 0:
        raise ScenarioError(f"rig.radius_m must be positive, got {r.radius_m}")
    for i, cam in enumerate(r.camera or []):
        if len(cam.position_m) != 3 or len(cam.target_m) != 3 or (cam.up_m is not None and len(cam.up_m) != 3):
            raise ScenarioError(f"rig.camera[{i}]: position_m, target_m (and up_m) need three numbers (x, y, z)")
        view = np.subtract(cam.target_m, cam.position_m)
        if np.linalg.norm(view) < 1e-9:
            raise ScenarioError(f"rig.camera[{i}]: target_m must differ from position_m")
        if cam.up_m is not None and np.linalg.norm(np.cross(cam.up_m, view)) < 1e-6 * np.linalg.norm(view):
            raise ScenarioError(f"rig.camera[{i}]: up_m {cam.up_m} lies along the view (or is zero) and sets no "
                                "roll; give the direction the top of the image points to")
    lo, hi = _depth_range_m(s.subject.topology)
    for name, pos in camera_positions(r):
        if pos[2] <= 0:
            raise ScenarioError(f"camera {name} is at height {pos[2]:g} m, at or below the floor (z = 0); "
                                "raise rig.height_m (or the camera's position_m z)")
        dist = math.dist(pos, _SUBJECT_CENTRE_M)
        if not lo <= dist <= hi:
            raise ScenarioError(f"camera {name} is {dist:.2f} m from the subject, outside the sensor's depth range "
                                f"{lo:g}-{hi:g} m, so it would track nothing; change rig.radius_m (or position_m)")
    if s.sensors.depth_rate_hz < 0 or s.sensors.depth_rate_hz > 30:
        raise ScenarioError("sensors.depth_rate_hz must lie in [0, 30]")
    if not (math.isfinite(s.sensors.noise_scale) and 0 < s.sensors.noise_scale <= 10):
        raise ScenarioError(f"sensors.noise_scale must lie in (0, 10], got {s.sensors.noise_scale}; use tracker_noise = "
                            "\"none\" for an ideal tracker")
    if s.sensors.lab is not None:
        check_lab(s.sensors.lab, "sensors.lab", ScenarioError)
    if s.sensors.person_seed is not None and s.sensors.person_seed < 0:
        raise ScenarioError(f"sensors.person_seed must be a non-negative integer, got {s.sensors.person_seed}")
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
            if seg.rest_s < 0:
                raise ScenarioError(f"session.segment[{i}].rest_s must be >= 0")
        elif seg.duration_s is None or seg.duration_s <= 0:
            raise ScenarioError(f"session.segment[{i}] ({seg.kind.value}) needs a positive duration_s")
    check_memory(s, depth_in_memory=False)


def resolve_scenario_path(name_or_path: str | Path) -> Path:
    """A scenario file by path, or by the name of a built-in scenario (``fma_2cam``, ``ring6``, ...)."""
    return resolve_builtin(name_or_path, SCENARIO_DIR, "scenario")


def load_scenario(name_or_path: str | Path) -> Scenario:
    """Read and validate a scenario TOML file (path or built-in name)."""
    path = resolve_scenario_path(name_or_path)
    return scenario_from_dict(read_toml(path), where=str(path))


def scenario_to_dict(scenario: Scenario) -> dict[str, Any]:
    """JSON-able form of a scenario (enums by value)."""

    def plain(v: Any) -> Any:
        if isinstance(v, enum.Enum):
            return v.value
        if isinstance(v, dict):
            return {k: plain(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [plain(x) for x in v]
        return v

    return plain(dataclasses.asdict(scenario))


def scenario_toml(scenario: Scenario) -> str:
    """A scenario as the TOML text :func:`load_scenario` reads back."""
    import tomli_w

    doc = without_none(scenario_to_dict(scenario))
    top = {k: doc.pop(k) for k in ("name", "description", "seed", "duration_s") if k in doc}
    doc["session"] = {"segment": doc.pop("session")}
    return tomli_w.dumps({"scenario": top} | doc)
