"""The fitting recordings' replicas for a simulation-based fit: each replica (:mod:`scenarios.sensors.replica`: the
recording's fused motion retargeted onto the humanoid, its cameras at the calibrated places) is simulated
once with an ideal tracker, keeping its true joints, facing, visibility and camera timestamps, so the
tracker model can be re-run on them with any trial profile (:func:`retrack`) without simulating again,
and the re-tracked replica measured through a calibration from its own body (:func:`retracked_stats`).
"""

from __future__ import annotations

import dataclasses
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from joblib import Parallel, delayed

from fusion.calibration import Calibration
from fusion.errors import CalibrationError
from fusion.merge.sensor_stats import STAT_GROUPS, SensorStats, sensor_stats
from fusion.recording import CameraRecording, Recording
from fusion.topology import Topology
from scenarios.config import NoiseLevel
from scenarios.runner import build_simulation
from scenarios.sensors.fit import body_calibration, measure
from scenarios.sensors.replica import build_replica
from sim.replay import save_motion
from sim.rig import CameraPlacement
from sim.sensor_population import labelled_seed, person_streams
from sim.sensor_profile import SensorProfile
from sim.session import simulate_session
from sim.tracker import session_activity, track
from sim.tracker_bones import session_waves
from sim.tracker_model_bias import sample_model_bias


@dataclass(frozen=True, eq=False)
class ReplicaCase:
    """One fitting recording and its replica, simulated once with an ideal tracker.

    Attributes
    ----------
    name : str
        Recording name.
    real : SensorStats
        Statistics of the real recording.
    motion : SensorStats
        Statistics of the replica seen by an ideal tracker (the motion's own jitter and spikes).
    placements : tuple of CameraPlacement
        The replica's cameras.
    timestamps, joints_world, facing_yaw, visible : tuple of np.ndarray
        Per camera: (T,) [s] camera timestamps, (T, J, 3) [m] true joints, (T,) [rad] facing,
        (T, J) bool line of sight.
    hidden_share : mapping stat group -> float
        Share of the group's in-view samples hidden from the camera.
    topology : Topology or None
        The recording's joint set, which the re-tracked replica is reduced to when the tracker reports
        a fuller one (:meth:`fusion.recording.Recording.as_joint_set`); None: the tracker's own.
    never_reported : tuple of np.ndarray
        Per camera, (J,) bool: the joints the real recording never reports, left out of the re-tracked
        replica too (:meth:`fusion.recording.Recording.without_joints`); empty: none.
    lab : str or None
        The lab the recording comes from (:attr:`fusion.recording.Recording.lab`).
    person : str or None
        Who was recorded (:func:`with_persons`), for statistics taken over one person's sessions; None:
        unknown.
    """

    name: str
    real: SensorStats
    motion: SensorStats
    placements: tuple[CameraPlacement, ...]
    timestamps: tuple[np.ndarray, ...]
    joints_world: tuple[np.ndarray, ...]
    facing_yaw: tuple[np.ndarray, ...]
    visible: tuple[np.ndarray, ...]
    hidden_share: Mapping[str, float]
    topology: Topology | None = None
    never_reported: tuple[np.ndarray, ...] = ()
    lab: str | None = None
    person: str | None = None

    @property
    def activity(self) -> float:
        """The session's activity [m/s] (:func:`sim.tracker.session_activity` of the first camera's true joints)."""
        return session_activity(self.joints_world[0], self.timestamps[0])


def with_persons(cases: Sequence[ReplicaCase], persons: Mapping[str, str]) -> list[ReplicaCase]:
    """``cases`` each with its person from ``persons`` (recording name -> person; names it lacks keep theirs)."""
    return [dataclasses.replace(c, person=persons.get(c.name, c.person)) for c in cases]


def prepare_case(name: str, recording: Recording, calibration: Calibration, real: SensorStats, *,
                 progress: Callable[[int], None] | None = None) -> ReplicaCase:
    """Build the replica of ``recording`` and simulate it once with an ideal tracker."""
    with tempfile.TemporaryDirectory() as tmp:
        replica = build_replica(recording, calibration, name=f"replica_{name}", motion_path=Path(tmp) / "motion.npz",
                                noise=NoiseLevel.NONE, progress=progress)
        save_motion(replica.motion, replica.motion_path)
        sim = build_simulation(replica.scenario)
    sensors = dataclasses.replace(sim.sensors, depth_rate_hz=0.0)
    rec, truth = simulate_session(sim.humanoid, sim.motion, sim.rig, sensors, seed=0)
    absent = recording.never_reported()
    motion = measure(rec.as_joint_set(recording.topology).without_joints(absent), None, n_boot=0,
                     rng=np.random.default_rng(0))
    topology = rec.topology
    hidden = {}
    for group, landmarks in STAT_GROUPS.items():
        cols = [topology.index(lm) for lm in landmarks if lm in topology.landmarks]
        counts = [(~tr.visible[:, cols] & np.isfinite(c.skeleton.positions[:, cols, 0])).sum() /
                  max(np.isfinite(c.skeleton.positions[:, cols, 0]).sum(), 1) for c, tr in zip(rec.cameras, truth.cameras)]
        hidden[group] = float(np.mean(counts)) if cols else np.nan
    return ReplicaCase(
        name, real, motion, tuple(sim.rig.cameras), tuple(c.skeleton.timestamps for c in rec.cameras),
        tuple(t.joints_world for t in truth.cameras), tuple(t.facing_yaw for t in truth.cameras),
        tuple(t.visible for t in truth.cameras), hidden, recording.topology, absent, recording.lab)


def prepare_cases(recordings: Mapping[str, Recording], calibrations: Mapping[str, Calibration],
                  stats: Mapping[str, SensorStats], *, jobs: int = 1,
                  progress: Callable[[int], None] | None = None) -> list[ReplicaCase]:
    """:func:`prepare_case` of every recording (by name), ``jobs`` at once (joblib; -1: one per core);
    ``progress`` is called with 1 as each is done."""
    tick = progress or (lambda n: None)
    cases = []
    for case in Parallel(n_jobs=jobs, return_as="generator")(
            delayed(prepare_case)(n, recordings[n], calibrations[n], stats[n]) for n in recordings):
        cases.append(case)
        tick(1)
    return cases


def retrack(case: ReplicaCase, profile: SensorProfile, *, seed: int = 0, person_seed: int | None = None) -> Recording:
    """The replica's cameras re-run with ``profile``'s tracker (no depth); with ``person_seed`` the
    tracker's systematic errors are that person's (:func:`sim.sensor_population.person_streams`), as
    :func:`sim.session.simulate_session` draws them; reduced to the recording's joint set and without the
    joints it never reports (:attr:`ReplicaCase.topology`, :attr:`ReplicaCase.never_reported`)."""
    root = np.random.SeedSequence(seed)
    bias_seq, *camera_seqs = root.spawn(1 + len(case.placements))
    topology = profile.topology
    bias_rng, view_rngs = np.random.default_rng(bias_seq), [None] * len(case.placements)
    if person_seed is not None:
        _, bias_rng, view_rngs = person_streams(person_seed, len(case.placements))
    model_bias = sample_model_bias(topology, profile.tracker, rng=bias_rng)
    waves = session_waves(profile.tracker, bias_seq)  # sampled at the camera times, milliseconds from the true ones
    cameras = []
    for i, (placement, seq) in enumerate(zip(case.placements, camera_seqs)):
        stream, _ = track(case.joints_world[i], case.facing_yaw[i], case.timestamps[i], placement, topology,
                          profile.tracker, model_bias, case.visible[i], rng=np.random.default_rng(seq),
                          view_rng=view_rngs[i],
                          shared_scale=None if waves is None else waves(case.timestamps[i]))
        cameras.append(CameraRecording(placement.name, placement.intrinsics, stream, None))
    recording = Recording(tuple(cameras), {"source": "simulation", "sensor": topology.name})
    if case.topology is not None:
        recording = recording.as_joint_set(case.topology)
    return recording.without_joints(case.never_reported) if case.never_reported else recording


Poses = Mapping[str, np.ndarray] | None
"""Camera poses of a body calibration (None: a one-camera recording)."""


def person_seeds(cases: Sequence[ReplicaCase], seed: int) -> list[tuple[int, int | None]]:
    """Per case, the seeds of a re-tracking (:func:`retrack`) that draws its own session for each case and
    one simulated person for each person (:attr:`ReplicaCase.person`; None: the case's own), given ``seed``."""
    return [(labelled_seed(seed, c.name), None if c.person is None else labelled_seed(seed, c.person)) for c in cases]


def retracked_stats(case: ReplicaCase, profile: SensorProfile, seed: int,
                    poses: Poses | str = "calibrate", person_seed: int | None = None) -> tuple[SensorStats, Poses]:
    """Statistics of ``case`` re-tracked with ``profile`` (as the person of ``person_seed``, :func:`retrack`)
    and the poses they were measured through: calibrated from the re-tracked body unless given."""
    recording = retrack(case, profile, seed=seed, person_seed=person_seed)
    T = body_poses(recording, seed) if isinstance(poses, str) else poses
    return sensor_stats(recording, T, n_boot=0, rng=np.random.default_rng(seed)), T


def retracked_or_none(case: ReplicaCase, profile: SensorProfile, seed: int,
                      person_seed: int | None = None) -> tuple[SensorStats, Poses] | None:
    """:func:`retracked_stats`, or None when the re-tracked replica cannot be calibrated from the body."""
    try:
        return retracked_stats(case, profile, seed, person_seed=person_seed)
    except CalibrationError:
        return None


def body_poses(recording: Recording, seed: int) -> Poses:
    """Camera poses of a calibration of ``recording`` from the body (None when it has one camera)."""
    calibration = body_calibration(recording, rng=np.random.default_rng(seed))
    return None if calibration is None else calibration.T_world_cam
