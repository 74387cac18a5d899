"""A replica of a real session: a scenario that performs the recorded motion in front of virtual
cameras placed where the calibration put the real ones.

:func:`build_replica` fuses the calibrated recording (:mod:`fusion.merge.fuse`), scales the humanoid
and retargets the fused skeleton onto it (:func:`sim.replay.fit_motion`), and returns a
:class:`~scenarios.config.Scenario` whose

- cameras sit at the calibrated poses: position, optical axis and the image's up direction
  (``position_m``, ``target_m`` one metre along the axis, ``up_m``), so a tilted or rolled camera
  keeps its roll; a floor-referenced recording's (metadata ``floor_referenced``: UI-PRMD's files,
  whose camera height is not in the data) stands level at the height that sees the whole motion
  (:func:`camera_stand_in`);
- subject topology (hence sensor kind: Kinect v2 or Azure Kinect) is the recording's, or the full set of a
  reduced one (:attr:`~fusion.topology.Topology.full_set`: UI-PRMD's files are simulated as the Kinect v2 they came from);
- session is one ``replay`` segment of the fitted motion file, in the calibration's world frame, so
  the simulated subject stands where the real one stood. The fused joints are low-passed before
  retargeting (:data:`LOWPASS_HZ`; the legs of a one-camera recording further, :data:`LEGS_LOWPASS_HZ`),
  so the replica performs the motion without the real tracker's frame-to-frame noise, which the
  simulated tracker adds back; a template tracker's body scale is taken out of each camera's skeletons
  before fusing (:func:`fusion.merge.body_scale.without_body_scale`: the person does not change size,
  and a humanoid of fixed size contorts to follow bones that do).

A one-camera recording is calibrated as a level camera (:func:`fusion.calibrate.level.level_camera_calibration`).

:func:`write_replica` writes the scenario TOML and, next to it, the motion file it replays (so the
scenario replays without refitting).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fusion.calibration import Calibration
from fusion.camera import AxisConvention
from fusion.errors import BadInputError
from fusion.io.atomic import write_text_atomic
from fusion.io.mocap import trajectory_from_recording
from fusion.io.plausibility import check_camera_sets
from fusion.merge.body_scale import without_body_scale
from fusion.merge.fuse import FuseOptions, camera_views, fuse_views, fused_recording
from fusion.recording import Recording
from fusion.topology import Landmark
from scenarios.config import (
    CameraConfig,
    NoiseLevel,
    ReplayConfig,
    RigConfig,
    Scenario,
    SegmentConfig,
    SegmentKind,
    SensorConfig,
    SubjectConfig,
    scenario_toml,
)
from sim.replay import FittedMotion, fit_motion, save_motion
from sim.retarget import RetargetOptions, RetargetResult
from sim.rig import view_of
from sim.sensor_profile import load_profile

LOWPASS_HZ = 6.0
"""Default cutoff of the replica's marker filter: 4th-order Butterworth at 6 Hz, the common choice
for human movement before inverse kinematics (Winter, Biomechanics and Motor Control of Human Movement)."""


LEGS_LOWPASS_HZ = 1.0
"""Cutoff of the legs' filter in a one-camera replica [Hz]: a Kinect v2 foot joint switches between two
places for a few frames (7 cm apart in KIMORE), which a 6 Hz filter turns into an ankle swing, and
the replay, grounding the lowest point of the feet in every frame, into a lift of the whole body."""

LEG_LANDMARKS = (Landmark.KNEE_LEFT, Landmark.ANKLE_LEFT, Landmark.FOOT_LEFT,
                 Landmark.KNEE_RIGHT, Landmark.ANKLE_RIGHT, Landmark.FOOT_RIGHT)
"""The joints :data:`LEGS_LOWPASS_HZ` applies to."""


@dataclass(frozen=True, eq=False)
class Replica:
    """A replica scenario and what it was made from.

    Attributes
    ----------
    scenario : the scenario (its replay source is ``motion_path``).
    motion : the fitted motion it replays.
    result : the retargeting result (residuals per frame and joint).
    motion_path : where the scenario expects the motion file.
    """

    scenario: Scenario
    motion: FittedMotion
    result: RetargetResult
    motion_path: Path


def camera_stand_in(T_world_camera: np.ndarray, joints: np.ndarray, *, name: str = "kinect",
                    axes: AxisConvention = AxisConvention.KINECT_V2) -> CameraConfig:
    """Where the virtual camera ``name`` (of camera ``axes``) stands: the aligned camera's place across
    the floor, looking level along its horizontal viewing direction, at the height that centres
    ``joints`` (..., 3) [m] (z up) in the vertical field of view.

    UI-PRMD's Kinect files are floor-referenced (their feet sit at height 0; in camera space as written,
    a third of an abduction's joints would lie outside the image; metadata ``floor_referenced``), so the
    sensor's height and tilt are not in the data; a level camera that sees the whole episode stands in
    for them."""
    centre, forward, _ = view_of(T_world_camera, axes)
    ahead = np.array([forward[0], forward[1], 0.0])
    if np.linalg.norm(ahead) < 1e-6:
        raise BadInputError("the aligned camera looks straight up or down; it cannot stand in for a Kinect")
    ahead /= np.linalg.norm(ahead)
    P = joints[np.isfinite(joints).all(axis=-1)]
    if P.size == 0:
        raise BadInputError("no joint of the episode is known; nothing for the camera to see")
    depth = np.maximum((P[:, :2] - centre[:2]) @ ahead[:2], 0.1)
    heights = np.linspace(0.0, 2.5, 251)
    spread = [np.abs(np.arctan2(P[:, 2] - h, depth)).max() for h in heights]
    position = np.array([centre[0], centre[1], heights[int(np.argmin(spread))]])
    return CameraConfig(name, position.tolist(), (position + ahead).tolist(), [0.0, 0.0, 1.0])


def build_replica(recording: Recording, calibration: Calibration, *, name: str, motion_path: str | os.PathLike,
                  noise: NoiseLevel = NoiseLevel.DEFAULT, profile: str | None = None, seed: int = 0,
                  fuse_options: FuseOptions = FuseOptions(),
                  retarget_options: RetargetOptions = RetargetOptions(), lowpass_hz: float | None = LOWPASS_HZ,
                  one_camera_legs_hz: float | None = LEGS_LOWPASS_HZ, progress: Callable[[int], None] | None = None) -> Replica:
    """A scenario replaying a real recording's fused motion from the calibrated camera places.

    Parameters
    ----------
    recording : Recording
        The real (or simulated) recording.
    calibration : Calibration
        Its calibration (``mocap-bench calibrate``; for one camera e.g.
        :func:`fusion.calibrate.level.level_camera_calibration`).
    name : str
        Scenario name.
    motion_path : path-like
        Where the motion file will be written (:func:`write_replica` writes it); the scenario's
        replay source, made absolute.
    noise : NoiseLevel
        Sensor noise preset of the replica (tracker and depth).
    profile : str, optional
        Sensor profile of the replica (built-in name or TOML path); None: that of the topology.
    seed : int
        Scenario seed.
    fuse_options : FuseOptions
        How to fuse the recording.
    retarget_options : RetargetOptions
        How to retarget.
    lowpass_hz : float or None
        Cutoff [Hz] of the zero-phase low-pass applied to the fused joints before retargeting (so the
        replica performs the motion, not the real tracker's noise); None: no filter.
    one_camera_legs_hz : float or None
        Cutoff [Hz] of a further low-pass of the knees, ankles and feet (:data:`LEG_LANDMARKS`) when
        the recording has one calibrated camera (no second view averages its foot joints); None: none.
    progress : callable, optional
        Called with the number of frames fitted since the last call.

    Returns
    -------
    Replica

    Raises
    ------
    BadInputError
        The recording has no skeletons, the calibration lacks one of its cameras or names another,
        or ``profile`` is unknown or for another joint set.
    """
    topology = recording.topology
    if topology is None:
        raise BadInputError("the recording has no skeleton stream to replay")
    check_camera_sets(recording.camera_names, calibration.camera_names, "replica")
    simulated = topology.full_set
    if profile is not None and load_profile(profile).topology != simulated:
        raise BadInputError(f"sensor profile {profile!r} is for {load_profile(profile).topology.name} skeletons, the "
                            f"recording's are {topology.name}; choose a {simulated.name} profile")
    views = camera_views(without_body_scale(recording), calibration)
    fused = fused_recording(fuse_views(views, fuse_options), views, fuse_options)
    trajectory = trajectory_from_recording(fused)
    if lowpass_hz is not None:
        trajectory = trajectory.lowpass(lowpass_hz)
    if one_camera_legs_hz is not None and len(views.names) == 1:
        trajectory = trajectory.lowpass(one_camera_legs_hz, joints=topology.indices(list(LEG_LANDMARKS)))
    motion, result, _ = fit_motion(trajectory, retarget_options, progress=progress)
    cameras = []
    for cam in views.names:
        axes = recording.camera(cam).intrinsics.axes
        if recording.metadata.get("floor_referenced"):
            cameras.append(camera_stand_in(calibration.pose(cam), trajectory.positions, name=cam, axes=axes))
            continue
        centre, forward, up = view_of(calibration.pose(cam), axes)
        cameras.append(CameraConfig(cam, centre.tolist(), (centre + forward).tolist(), up.tolist()))
    path = Path(motion_path).absolute()
    scenario = Scenario(
        name=name,
        description=f"replica of a {topology.name} recording of {len(cameras)} camera(s)",
        seed=seed,
        duration_s=None,
        subject=SubjectConfig(height_m=round(motion.anthropometry.height_m, 3), topology=simulated.name),
        rig=RigConfig(camera=cameras),
        session=(SegmentConfig(SegmentKind.REPLAY, replay=ReplayConfig(source=str(path), format="motion")),),
        sensors=SensorConfig(profile=profile, depth_noise=noise, tracker_noise=noise, lab=recording.lab),
    )
    return Replica(scenario, motion, result, path)


def write_replica(replica: Replica, scenario_path: str | os.PathLike) -> tuple[Path, Path]:
    """Write the motion file and the scenario TOML (atomically); returns both paths."""
    save_motion(replica.motion, replica.motion_path)
    path = Path(scenario_path)
    write_text_atomic(path, scenario_toml(replica.scenario))
    return path, replica.motion_path


def residual_table(result: RetargetResult) -> str:
    """Markdown table of the landmark residuals per joint group, millimetres."""
    lines = ["| group | median [mm] | rmse [mm] | max [mm] | n |", "|---|---|---|---|---|"]
    for group, s in result.group_stats().items():
        lines.append(f"| {group} | {1e3 * s.median:.1f} | {1e3 * s.rmse:.1f} | {1e3 * s.max:.1f} | {s.n} |")
    frames = result.failed_frames
    lines.append("")
    lines.append(f"frames: {result.times.size}, not converged: {frames.size}"
                 + (f" (first: {', '.join(map(str, frames[:10]))})" if frames.size else ""))
    lines.append(f"frame RMS residual median {1e3 * float(np.nanmedian(result.frame_rms)):.1f} mm")
    return "\n".join(lines)
