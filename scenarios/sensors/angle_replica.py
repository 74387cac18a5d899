"""The simulated side of ``angle-validate``: an optical episode's joints retargeted onto the humanoid
and seen by one virtual camera standing where the real one stood (:func:`simulate_replica`)."""

from __future__ import annotations

import dataclasses
import tempfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from fusion.errors import BadInputError
from fusion.io.formats.ui_prmd import read_ui_prmd_vicon
from fusion.io.marker_map import apply_marker_map, load_marker_map
from fusion.io.mocap import LandmarkTrajectory
from fusion.merge.marker_reference import marker_reference, reference_skeleton
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, TrackingState
from scenarios.config import (
    NoiseLevel,
    ReplayConfig,
    RigConfig,
    Scenario,
    SegmentConfig,
    SegmentKind,
    SensorConfig,
    SubjectConfig,
)
from scenarios.runner import build_simulation
from scenarios.sensors.replica import camera_stand_in
from sim.replay import fit_motion, save_motion
from sim.session import simulate_session

RETARGET_RATE_HZ = 100.0 / 3.0
"""Rate [Hz] the optical joints are retargeted at (every third 100 Hz frame): the simulated camera
samples at 30 Hz, and the replay interpolates between fitted frames."""

def replica_trajectory(vicon_path: Path) -> tuple[LandmarkTrajectory, SkeletonStream]:
    """The optical episode's joints for retargeting, and its reference skeleton.

    The reference's joint centres (trunk, glenohumeral, elbow, wrist, hips) replace the marker map's
    joints where they are finite; the other joints are the ``plug_in_gait`` map's. Every third frame
    is kept (:data:`RETARGET_RATE_HZ`)."""
    markers = read_ui_prmd_vicon(vicon_path)
    reference = reference_skeleton(marker_reference(markers))
    mapped = apply_marker_map(markers, load_marker_map("plug_in_gait"))
    if mapped.topology is not KINECT_V2:
        raise BadInputError(f"the plug_in_gait map gives {mapped.topology.name} joints, expected kinect_v2")
    centre = np.isfinite(reference.positions).all(axis=-1)
    P = np.where(centre[..., None], reference.positions, mapped.positions)
    conf = np.where(centre, 1.0, mapped.confidence)
    keep = slice(None, None, 3)
    trajectory = LandmarkTrajectory(KINECT_V2, mapped.times[keep], P[keep], conf[keep], source=str(vicon_path))
    return trajectory, reference


def _replica_scenario(trajectory: LandmarkTrajectory, T_world_camera: np.ndarray, motion_path: Path, *,
                      profile: str | None, seed: int, person_seed: int | None, height_m: float,
                      lab: str | None) -> Scenario:
    camera = camera_stand_in(T_world_camera, trajectory.positions)
    return Scenario(
        name="angle_validate_replica", description=f"replica of {trajectory.source}", seed=seed, duration_s=None,
        subject=SubjectConfig(height_m=round(height_m, 3), topology=KINECT_V2.name),
        rig=RigConfig(camera=[camera]),
        session=(SegmentConfig(SegmentKind.REPLAY, replay=ReplayConfig(source=str(motion_path), format="motion")),),
        sensors=SensorConfig(profile=profile, depth_noise=NoiseLevel.DEFAULT, tracker_noise=NoiseLevel.DEFAULT,
                             person_seed=person_seed, lab=lab),
    )


def simulate_replica(trajectory: LandmarkTrajectory, T_world_camera: np.ndarray, *, profile: str | None = None,
                     seeds: Sequence[int] = (0,), person_seeds: Sequence[int] | None = None,
                     lab: str | None = None) -> list[tuple[SkeletonStream, SkeletonStream]]:
    """Retarget ``trajectory`` onto the humanoid, place one camera at ``T_world_camera`` (Kinect v2
    axes) and simulate it once per seed: a session of the profile's population drawn with the seed, of
    the person of the matching ``person_seeds`` entry (None: a person drawn from the seed as well), a
    person of ``lab`` (the real Kinect's: :attr:`fusion.recording.Recording.lab`).

    Returns
    -------
    list of (truth, camera)
        Per seed: the humanoid's true joints (Kinect v2 joints, world frame, TRACKED) at the camera's
        frame times, and the simulated camera's stream (camera frame).
    """
    motion, _, _ = fit_motion(trajectory)
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "motion.npz"
        save_motion(motion, path)
        persons = [None] * len(seeds) if person_seeds is None else [int(p) for p in person_seeds]
        if len(persons) != len(seeds):
            raise BadInputError(f"person_seeds must give one person per seed: {len(persons)} for {len(seeds)} seeds")
        for seed, person in zip(seeds, persons):
            scenario = _replica_scenario(trajectory, T_world_camera, path, profile=profile, seed=int(seed),
                                         person_seed=person, height_m=motion.anthropometry.height_m, lab=lab)
            sim = build_simulation(scenario)
            sensors = dataclasses.replace(sim.sensors, depth_rate_hz=0.0)
            rec, truth = simulate_session(sim.humanoid, sim.motion, sim.rig, sensors, seed=sim.session_seed,
                                          person_seed=sim.person_seed)
            stream = rec.cameras[0].skeleton
            true = truth.cameras[0].joints_world
            states = np.full(true.shape[:2], TrackingState.TRACKED, dtype=np.int8)
            out.append((SkeletonStream(stream.topology, stream.timestamps, true, states), stream))
    return out


