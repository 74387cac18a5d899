"""Simulate a whole capture session: every camera's clock, skeleton stream and depth frames.

``simulate_session`` returns ``(Recording, GroundTruth)``; the recording holds only what real
sensors would deliver, the truth everything the evaluation needs.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from fusion.errors import BadInputError
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, Topology
from sim.camera_clock import ClockModel, sample_clock
from sim.depth_noise import DepthNoise
from sim.depth_renderer import DepthRenderer
from sim.depth_session import DepthJob, render_depth
from sim.humanoid import Humanoid
from sim.rig import CameraPlacement, Rig
from sim.sensor_population import person_streams
from sim.timeline import Motion
from sim.tracker import track
from sim.tracker_bones import ScaleWaves, session_waves
from sim.tracker_model_bias import sample_model_bias
from sim.tracker_noise import TrackerNoise
from sim.truth import CameraTruth, GroundTruth
from sim.visibility import visibility_over_time

REFERENCE_RATE_HZ = 30.0
"""Rate of the uniform reference track stored with the truth [Hz]."""


@dataclass(frozen=True)
class SensorModels:
    """Sensor models shared by every camera of a session.

    Attributes
    ----------
    topology : joint set the body trackers report.
    tracker : skeleton tracker errors.
    depth : depth noise model.
    clock : clock model (each camera draws its own phase and offset from it).
    depth_rate_hz : depth frames kept per second [Hz], 0 for skeletons only.
    depth_renderer : what renders the depth frames (``AUTO``: MuJoCo's renderer on hardware OpenGL).
    """

    topology: Topology = KINECT_V2
    tracker: TrackerNoise = field(default_factory=TrackerNoise)
    depth: DepthNoise = field(default_factory=DepthNoise)
    clock: ClockModel = field(default_factory=ClockModel)
    depth_rate_hz: float = 1.0
    depth_renderer: DepthRenderer = DepthRenderer.AUTO

    def __post_init__(self) -> None:
        if not 0 <= self.depth_rate_hz <= self.clock.rate_hz:
            raise BadInputError(f"depth_rate_hz must lie in [0, {self.clock.rate_hz}], got {self.depth_rate_hz}")


def _depth_frame_indices(true_times: np.ndarray, rate_hz: float, duration_s: float) -> np.ndarray:
    """Indices of the frames nearest to every 1 / rate_hz seconds of true time, unique and sorted."""
    if rate_hz == 0 or true_times.size == 0:
        return np.empty(0, dtype=int)
    wanted = np.arange(0.0, duration_s, 1.0 / rate_hz)
    idx = np.clip(np.searchsorted(true_times, wanted), 1, true_times.size - 1)
    idx -= (wanted - true_times[idx - 1]) < (true_times[idx] - wanted)
    return np.unique(idx)


def _simulate_camera(
    humanoid: Humanoid,
    motion: Motion,
    placement: CameraPlacement,
    sensors: SensorModels,
    model_bias,
    duration_s: float,
    rngs: list[np.random.Generator],
    tick: Callable[[int], None],
    view_rng: np.random.Generator | None = None,
    scale_waves: ScaleWaves | None = None,
) -> tuple[SkeletonStream, CameraTruth, DepthJob | None]:
    """One camera's clock, skeleton stream and truth, and the depth frames it is to render (None: none);
    ``scale_waves`` the session's shared body scale (:func:`sim.tracker_bones.session_waves`)."""
    clock_rng, tracker_rng, depth_rng = rngs
    topo = sensors.topology
    clock = sample_clock(duration_s, sensors.clock, rng=clock_rng)
    if clock.n_frames == 0:
        raise BadInputError(f"{placement.name}: the session is too short for a single frame")
    coords = motion.sample(clock.true_times)
    sites = humanoid.site_ids(topo)
    bodies = humanoid.model.site_bodyid[sites]
    depth_idx = _depth_frame_indices(clock.true_times, sensors.depth_rate_hz, duration_s)
    qpos, joints, facing = humanoid.track(coords, topo)
    visible = visibility_over_time(humanoid, qpos, placement.position, joints, bodies)
    tick(clock.n_frames)
    depth = None
    if depth_idx.size:
        depth = DepthJob(placement, qpos[depth_idx], clock.camera_timestamps[depth_idx], depth_rng)
    stream, tracker_truth = track(
        joints, facing, clock.camera_timestamps, placement, topo, sensors.tracker, model_bias, visible, rng=tracker_rng,
        view_rng=view_rng, shared_scale=None if scale_waves is None else scale_waves(clock.true_times),
    )
    truth = CameraTruth(
        name=placement.name,
        T_world_cam=placement.T_world_cam,
        true_times=clock.true_times,
        joints_world=joints,
        facing_yaw=facing,
        yaw_to_camera=tracker_truth.yaw_to_camera,
        flipped=tracker_truth.flipped,
        visible=visible,
        clock_offset_s=clock.offset_s,
    )
    return stream, truth, depth


def work_units(rig: Rig, sensors: SensorModels, duration_s: float) -> int:
    """Approximate count of progress ticks :func:`simulate_session` reports (frames + depth renders)."""
    frames = int(np.ceil(duration_s * sensors.clock.rate_hz))
    return len(rig.cameras) * (frames + int(np.ceil(duration_s * sensors.depth_rate_hz)))


def simulate_session(
    humanoid: Humanoid,
    motion: Motion,
    rig: Rig,
    sensors: SensorModels,
    *,
    seed: int | np.random.SeedSequence,
    duration_s: float | None = None,
    metadata: dict | None = None,
    progress: Callable[[int], None] | None = None,
    depth_dir: str | Path | None = None,
    person_seed: int | None = None,
    depth_workers: int | None = None,
) -> tuple[Recording, GroundTruth]:
    """Record ``motion`` performed by ``humanoid`` with every camera of ``rig``.

    Parameters
    ----------
    humanoid : the subject's body.
    motion : what the subject does; sampled at each camera's own capture times.
    rig : cameras with their true poses and intrinsics.
    sensors : tracker, depth and clock models and the depth frame rate.
    seed : the session's seed (or a SeedSequence spawned from the scenario's seed); split with ``SeedSequence.spawn`` into the subject's tracker
        model bias and, per camera, its clock, tracker and depth noise.
    duration_s : recording length [s]; defaults to the motion's duration (and may not exceed it).
    metadata : JSON-able facts written into the recording (scenario name, ...).
    progress : called with the number of work units done since the last call.
    depth_dir : a recording directory being written (see :func:`fusion.io.recording_files.write_recording`):
        depth frames are streamed into its per-camera depth files as they are rendered, and the
        recording's depth reads them lazily, so memory does not grow with the session's length.
        None keeps the frames in memory.
    person_seed : the simulated person's seed (:func:`sim.sensor_population.person_streams`): the
        tracker's model bias and each camera's view bias are drawn from it, so the person's sessions
        with one rig share them; None draws them from ``seed`` (a new person each session).
    depth_workers : cameras whose depth frames render at once (threads; :func:`sim.depth_session.render_depth`);
        None for as many as the usable cores allow (1 with MuJoCo's renderer). The frames do not depend on it.

    Returns
    -------
    recording : what the sensors delivered (camera frames, timestamps on camera clocks).
    truth : camera poses, true joints, facing and flips per camera frame, a uniform reference track,
        the repetition annotations and the clock offsets.
    """
    root = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    duration = motion.duration if duration_s is None else float(duration_s)
    if not 0 < duration <= motion.duration + 1e-9:
        raise BadInputError(f"duration_s must lie in (0, {motion.duration:.3f}] s (the motion's length), got {duration}")
    tick = progress or (lambda n: None)
    bias_seq, *camera_seqs = root.spawn(1 + len(rig.cameras))
    bias_rng, view_rngs = np.random.default_rng(bias_seq), [None] * len(rig.cameras)
    if person_seed is not None:
        _, bias_rng, view_rngs = person_streams(person_seed, len(rig.cameras))
    model_bias = sample_model_bias(sensors.topology, sensors.tracker, rng=bias_rng)
    waves = session_waves(sensors.tracker, bias_seq)
    streams, truths, jobs = [], [], []
    for placement, seq, view_rng in zip(rig.cameras, camera_seqs, view_rngs):
        rngs = [np.random.default_rng(s) for s in seq.spawn(3)]
        stream, tr, job = _simulate_camera(humanoid, motion, placement, sensors, model_bias, duration, rngs, tick,
                                           view_rng, waves)
        streams.append(stream)
        truths.append(tr)
        jobs.append(job)
    todo = [job for job in jobs if job is not None]
    rendered = iter(render_depth(humanoid.model, todo, sensors.depth, sensors.depth_renderer, tick=tick,
                                 depth_dir=None if depth_dir is None else Path(depth_dir), workers=depth_workers)
                    if todo else [])
    observations = [CameraRecording(p.name, p.intrinsics, stream, None if job is None else next(rendered))
                    for p, stream, job in zip(rig.cameras, streams, jobs)]
    times = np.arange(0.0, duration, 1.0 / REFERENCE_RATE_HZ)
    _, ref_joints, ref_facing = humanoid.track(motion.sample(times), sensors.topology)
    meta = {"source": "simulation", "sensor": sensors.topology.name, "duration_s": duration}
    if sensors.depth_rate_hz > 0:
        meta["depth_renderer"] = sensors.depth_renderer.resolve().value
    meta |= metadata or {}
    recording = Recording(tuple(observations), meta)
    truth = GroundTruth(
        cameras=tuple(truths),
        times=times,
        joints_world=ref_joints,
        facing_yaw=ref_facing,
        repetitions=tuple(
            {"movement": r.movement.value, "side": None if r.side is None else r.side.name.lower(), "index": r.index,
             "t_start": r.t_start, "t_peak": r.t_peak, "t_end": r.t_end}
            for r in motion.repetitions if r.t_start < duration
        ),
        metadata={
            "duration_s": duration,
            "height_m": humanoid.anthro.height_m,
        }
        | (metadata or {}),
    )
    return recording, truth
