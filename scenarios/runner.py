"""Turn a scenario into simulator objects, run it, and read or write a run directory.

A run directory holds ``recording/`` (observations, see :mod:`fusion.io.recording_files`), ``truth/``
(ground truth, see :mod:`sim.truth`) and ``scenario.json`` (the resolved scenario and seed).
"""

from __future__ import annotations

import dataclasses
import enum
import json
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from fusion.errors import BadInputError, ScenarioError
from fusion.io.atomic import atomic_directory
from fusion.io.recording_files import load_recording, write_recording
from fusion.recording import Recording
from fusion.topology import K4ABT, topology_by_name
from scenarios.config import (
    NoiseLevel,
    PopulationDraw,
    ReplayConfig,
    Scenario,
    SegmentKind,
    SensorConfig,
    check_memory,
    scenario_to_dict,
)
from scenarios.replay_source import (
    SourceFormat,
    SourceOptions,
    guess_format,
    load_or_fit,
)
from sim.anthropometry import Anthropometry, Build
from sim.depth_noise import DepthNoise
from sim.humanoid import Humanoid
from sim.humanoid_model import build_humanoid
from sim.motions import calibration_turn, hand_lift, idle, salute
from sim.patient_motion import Group, Movement, Side, SubjectProfile, sample_profile
from sim.replay import FittedMotion, replay_motion
from sim.rig import (
    CameraPlacement,
    Rig,
    as_azure_kinect,
    look_at,
    ring_rig,
    vary_intrinsics,
)
from sim.sensor_population import Family, apply_factors, session_tracker
from sim.sensor_profile import SensorProfile, load_profile
from sim.session import SensorModels, simulate_session, work_units
from sim.timeline import Motion, compose
from sim.tracker_noise import TrackerNoise
from sim.truth import GroundTruth, load_truth, save_truth

VERSION = "0.1.0"

SOURCE_ROOT = Path(__file__).resolve().parents[1]
"""The checkout the package runs from (its commit goes into study pages and datasheets)."""


def commit_id(root: Path, *, outputs: Path | None = None) -> str:
    """The checkout's short commit, with ``+changes`` when the working tree differs from it outside
    ``outputs`` (the study pages being written); ``unknown`` outside a git checkout."""
    def git(*args: str) -> str:
        return subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True, check=True).stdout

    try:
        head = git("rev-parse", "--short", "HEAD").strip()
        spec = []
        if outputs is not None:
            spec = ["--", ".", f":(exclude){Path(outputs).resolve().relative_to(Path(root).resolve())}"]
        dirty = git("status", "--porcelain", "--untracked-files=no", *spec).strip()
    except (OSError, ValueError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+changes" if dirty else "")


DEFAULT_PROFILE = {"kinect_v2": "kinect_v2", "k4abt": "azure_kinect"}
"""The built-in sensor profile a scenario uses for each topology when it names none."""


def default_profile(topology: str) -> str:
    """The built-in sensor profile of a joint set (:data:`DEFAULT_PROFILE`).

    Raises
    ------
    BadInputError
        No built-in profile simulates that joint set (UI-PRMD's reduced Kinect v2 set).
    """
    if topology not in DEFAULT_PROFILE:
        built_in = ", ".join(f"{p} ({t})" for t, p in DEFAULT_PROFILE.items())
        raise BadInputError(f"no built-in sensor profile simulates the {topology} joint set (built-in: {built_in}); "
                            "give a profile of that joint set")
    return DEFAULT_PROFILE[topology]


def _enum(cls: type[enum.Enum], value: str, key: str) -> Any:
    try:
        return cls(value)
    except ValueError:
        raise ScenarioError(f"{key} = {value!r}: choose one of {[m.value for m in cls]}") from None


def _side(value: str | None, key: str) -> Side | None:
    if value is None:
        return None
    sides = {"left": Side.LEFT, "right": Side.RIGHT}
    if value not in sides:
        raise ScenarioError(f"{key} = {value!r}: choose 'left' or 'right'")
    return sides[value]


@dataclasses.dataclass(frozen=True, eq=False)
class Simulation:
    """Everything a scenario resolves to, ready for :func:`sim.session.simulate_session`."""

    scenario: Scenario
    humanoid: Humanoid
    profile: SubjectProfile
    motion: Motion
    rig: Rig
    sensors: SensorModels
    session_seed: np.random.SeedSequence
    person_seed: int
    """The simulated person's seed (``sensors.person_seed``, else drawn from the scenario's seed):
    its population factors and its tracker's systematic errors (:func:`sim.sensor_population.person_streams`)."""


def _replay_segment(r: ReplayConfig, key: str) -> tuple[FittedMotion, Motion]:
    """The fitted motion of a replay segment (read, or fitted to its source) and its timeline segment."""
    source = Path(r.source)
    if not source.exists():
        raise ScenarioError(f"{key}.source = {r.source!r} does not exist (paths are relative to the working directory)")
    fmt = guess_format(source) if r.format is None else _enum(SourceFormat, r.format, f"{key}.format")
    options = SourceOptions(camera=r.camera, calibration=None if r.calibration is None else Path(r.calibration),
                            marker_map=r.marker_map, units=r.units, up_axis=r.up_axis)
    fitted = load_or_fit(source, fmt, options)
    position = None if r.position_m is None else (r.position_m[0], r.position_m[1])
    return fitted, replay_motion(fitted, start_s=r.start_s, end_s=r.end_s, position_m=position,
                                 facing_deg=r.facing_deg)


def build_simulation(scenario: Scenario) -> Simulation:
    """Resolve a scenario: subject, motion timeline, rig and sensor models, all from its one seed.

    The seed is split with ``SeedSequence.spawn`` into the subject's profile, the motion, the rig's
    intrinsics and the session's sensors (which split it further per camera and noise source).
    A ``replay`` segment brings its own subject: the humanoid is the first replay's fitted
    anthropometry (the subject table's height and build are then not used).
    """
    profile_seq, motion_seq, rig_seq, session_seq, person_seq, sensor_day_seq = \
        np.random.SeedSequence(scenario.seed).spawn(6)
    person_seed = scenario.sensors.person_seed
    person_seed = int(person_seq.generate_state(1)[0]) if person_seed is None else person_seed
    subj = scenario.subject
    anthro = Anthropometry(height_m=subj.height_m, build=_enum(Build, subj.build, "subject.build"))
    group = _enum(Group, subj.group, "subject.group")
    affected = _side(subj.affected_side, "subject.affected_side")
    if group is Group.HEALTHY:
        profile = SubjectProfile.healthy()
    else:
        profile = sample_profile(group, rng=np.random.default_rng(profile_seq), affected_side=affected)
    motion_rng = np.random.default_rng(motion_seq)
    segments = []
    for i, seg in enumerate(scenario.session):
        if seg.kind is SegmentKind.REPLAY:
            fitted, segment = _replay_segment(seg.replay, f"session.segment[{i}].replay")
            if not any(s.kind is SegmentKind.REPLAY for s in scenario.session[:i]):
                anthro = fitted.anthropometry
            segments.append(segment)
        elif seg.kind is SegmentKind.IDLE:
            segments.append(idle(seg.duration_s, rng=motion_rng))
        elif seg.kind is SegmentKind.CALIBRATION_TURN:
            segments.append(calibration_turn(seg.duration_s, rng=motion_rng))
        else:
            side = _side(seg.side, f"session.segment[{i}].side")
            movement = Movement.SALUTE if seg.kind is SegmentKind.SALUTE else Movement.HAND_LIFT
            make = salute if movement is Movement.SALUTE else hand_lift
            segments.append(make(side, seg.repetitions, profile.movement(movement, side), rng=motion_rng,
                                 rest=seg.rest_s))
    motion = compose(segments)
    if scenario.duration_s is not None and scenario.duration_s > motion.duration:
        motion = compose([motion, idle(scenario.duration_s - motion.duration, rng=motion_rng)])
    r = scenario.rig
    if r.camera:
        rig = Rig(tuple(CameraPlacement(c.name, look_at(c.position_m, c.target_m, c.up_m)) for c in r.camera))
    else:
        rig = ring_rig(r.n_cameras, radius_m=r.radius_m, height_m=r.height_m, target_height_m=r.target_height_m,
                       start_deg=r.start_deg, angles_deg=r.angles_deg, subset=r.subset)
    topology = topology_by_name(subj.topology)
    if topology is K4ABT:
        rig = Rig(tuple(as_azure_kinect(c) for c in rig.cameras))
    if r.vary_intrinsics:
        rig_rng = np.random.default_rng(rig_seq)
        rig = Rig(tuple(dataclasses.replace(c, intrinsics=vary_intrinsics(c.intrinsics, rng=rig_rng))
                        for c in rig.cameras))
    s = scenario.sensors
    sensor = load_profile(s.profile if s.profile is not None else default_profile(topology.name))
    if sensor.topology != topology:
        raise ScenarioError(f"sensors.profile {sensor.name!r} reports {sensor.topology.name} skeletons but "
                            f"subject.topology is {topology.name}; choose a matching profile")
    overrides = {k: v for k, v in (("offset_sigma_s", s.clock_offset_sd_ms), ("jitter_sigma_s", s.clock_jitter_ms),
                                   ("drop_probability", s.drop_probability)) if v is not None}
    overrides = {k: v * 1e-3 if k.endswith("_s") else v for k, v in overrides.items()}
    sensors = SensorModels(
        topology=topology,
        tracker=_tracker(sensor, s, person_seed, len(rig.cameras), sensor_day_seq),
        depth=sensor.depth if s.depth_noise is NoiseLevel.DEFAULT else DepthNoise.none(),
        clock=dataclasses.replace(sensor.clock, **overrides),
        depth_rate_hz=s.depth_rate_hz,
        depth_renderer=s.depth_renderer,
    )
    return Simulation(scenario, build_humanoid(anthro), profile, motion, rig, sensors, session_seq, person_seed)


def _tracker(sensor: SensorProfile, s: SensorConfig, person_seed: int, n_cameras: int,
             session_seq: np.random.SeedSequence) -> TrackerNoise:
    """The scenario's tracker: none, the profile's typical person, or (``population = "draw"`` and a
    profile with a population) the person of ``person_seed``, of the scenario's lab, and a session of
    that person drawn with ``session_seq``; then the scenario's noise scale and flip switch."""
    if s.tracker_noise is not NoiseLevel.DEFAULT:
        return TrackerNoise.none()
    tracker = sensor.tracker
    if s.population is PopulationDraw.DRAW and sensor.population is not None:
        tracker = session_tracker(tracker, sensor.population.for_lab(s.lab), person_seed, n_cameras,
                                  np.random.default_rng(session_seq))
    if s.noise_scale != 1.0:
        tracker = apply_factors(tracker, {Family.NOISE: float(np.log(s.noise_scale))})
    return tracker if s.flips else dataclasses.replace(tracker, flip_enabled=False)


def simulate(
    scenario: Scenario, *, progress: bool = True, depth_dir: Path | None = None
) -> tuple[Recording, GroundTruth]:
    """Run a scenario; a progress bar on stderr when ``progress``.

    Depth frames stay in memory, or with ``depth_dir`` (a recording directory being staged) are
    streamed into its depth files (see :func:`sim.session.simulate_session`).

    Raises
    ------
    ScenarioError
        In memory, a run whose depth frames would exceed the memory limit of :func:`check_scenario`.
    """
    if depth_dir is None:
        check_memory(scenario, depth_in_memory=True)
    sim = build_simulation(scenario)
    duration = scenario.duration_s or sim.motion.duration
    meta = {"scenario": scenario.name, "seed": scenario.seed, "version": VERSION}
    with tqdm(total=work_units(sim.rig, sim.sensors, duration), desc=f"simulate {scenario.name}",
              unit="frame", leave=False, **({} if progress else {"disable": True})) as bar:  # TQDM_DISABLE applies
        return simulate_session(sim.humanoid, sim.motion, sim.rig, sim.sensors, seed=sim.session_seed,
                                person_seed=sim.person_seed,
                                duration_s=duration, metadata=meta, progress=bar.update, depth_dir=depth_dir)


def simulate_to_disk(
    scenario: Scenario,
    out_dir: str | Path,
    *,
    seed: int | None = None,
    duration_s: float | None = None,
    overwrite: bool = False,
    progress: bool = True,
) -> Path:
    """Simulate ``scenario`` (optionally with another seed or duration) into a run directory, atomically.

    Depth frames are streamed to the recording's depth files as they are rendered (memory does not grow
    with the session's length).
    """
    if seed is not None:
        if seed < 0:
            raise BadInputError(f"--seed must be >= 0, got {seed}")
        scenario = scenario.replace(seed=seed)
    if duration_s is not None:
        if duration_s <= 0:
            raise BadInputError(f"--duration must be positive, got {duration_s}")
        scenario = scenario.replace(duration_s=duration_s)
    out_dir = Path(out_dir)
    with atomic_directory(out_dir, overwrite=overwrite) as tmp:
        recording, truth = simulate(scenario, progress=progress, depth_dir=tmp / "recording")
        write_recording(recording, tmp / "recording")
        save_truth(truth, tmp / "truth")
        doc = {"scenario": scenario_to_dict(scenario), "seed": scenario.seed, "version": VERSION}
        (tmp / "scenario.json").write_text(json.dumps(doc, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    return out_dir


def recording_dir(path: str | Path) -> Path:
    """The recording inside a run directory, or ``path`` itself if it is a recording."""
    path = Path(path)
    return path / "recording" if (path / "recording").is_dir() else path


def load_truth_if_any(path: str | Path) -> GroundTruth | None:
    """Ground truth of a run directory, or None for a bare (e.g. real) recording without ``truth/``."""
    path = Path(path)
    return load_truth(path / "truth") if (path / "truth").is_dir() else None


def load_run(path: str | Path) -> tuple[Recording, GroundTruth]:
    """Recording and ground truth of a run directory written by :func:`simulate_to_disk`."""
    path = Path(path)
    return load_recording(recording_dir(path)), load_truth(path / "truth")
