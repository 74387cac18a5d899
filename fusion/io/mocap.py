"""Motion sources as landmark trajectories: one time-stamped joint trajectory in a world frame.

A :class:`LandmarkTrajectory` is what retargeting consumes: the joints of one topology
(:data:`~fusion.topology.KINECT_V2` or :data:`~fusion.topology.K4ABT`) over time, in a world frame
with z up and the floor at z = 0 (metres), each joint with a confidence weight in [0, 1] (0 where it
is absent). Sources:

- a skeleton stream of a recording: :func:`trajectory_from_recording` takes one camera, mapped to
  the world with that camera's ``T_world_cam`` from a calibration, or a fused recording (camera
  ``fused``, already in the world frame);
- optical motion capture and BVH files: :mod:`fusion.io.mocap_files` reads the markers,
  :mod:`fusion.io.marker_map` turns them into landmarks.

Confidence of a skeleton joint from its tracking state: TRACKED and HIGH 1, INFERRED (K4ABT LOW)
``inferred_weight`` (default 0.5: inferred joints are guesses of the tracker, counted half),
NOT_TRACKED 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, sosfiltfilt

from fusion.calibration import Calibration
from fusion.errors import BadInputError
from fusion.recording import Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import Topology, TrackingState
from fusion.transforms import apply, validate_transform

FUSED_CAMERA = "fused"
"""Name of the single camera of a fused recording (its frame is the world frame)."""


@dataclass(frozen=True, eq=False)
class LandmarkTrajectory:
    """Joint positions of one subject over time in a world frame (z up, floor z = 0).

    Attributes
    ----------
    topology : Topology
        Joint set (J joints).
    times : numpy.ndarray
        (T,) float64 seconds, strictly increasing.
    positions : numpy.ndarray
        (T, J, 3) float64 metres, world frame; NaN where a joint is absent.
    confidence : numpy.ndarray
        (T, J) float64 weights in [0, 1]; 0 exactly where a joint is absent.
    source : str
        What the trajectory was read from (for reports).

    Raises
    ------
    BadInputError
        Shapes disagree, times are not finite and strictly increasing, positions are infinite or
        confidences lie outside [0, 1].
    """

    topology: Topology
    times: np.ndarray
    positions: np.ndarray
    confidence: np.ndarray
    source: str = ""

    def __post_init__(self) -> None:
        ts = np.array(self.times, dtype=np.float64)
        pos = np.array(self.positions, dtype=np.float64)
        conf = np.array(self.confidence, dtype=np.float64)
        J = self.topology.n_joints
        if ts.ndim != 1 or ts.size == 0:
            raise BadInputError(f"times must be a non-empty (T,) array, got shape {ts.shape}")
        T = ts.size
        if pos.shape != (T, J, 3) or conf.shape != (T, J):
            raise BadInputError(f"positions must be ({T}, {J}, 3) and confidence ({T}, {J}), "
                                f"got {pos.shape} and {conf.shape}")
        if not np.isfinite(ts).all() or np.any(np.diff(ts) <= 0):
            raise BadInputError("times must be finite and strictly increasing")
        if np.isinf(pos).any():
            raise BadInputError("positions contain infinite values")
        if np.isnan(conf).any() or conf.min() < 0 or conf.max() > 1:
            raise BadInputError("confidence must lie in [0, 1]")
        absent = np.isnan(pos).any(axis=-1)
        pos[absent] = np.nan
        conf[absent] = 0.0
        pos[conf == 0] = np.nan
        for name, arr in (("times", ts), ("positions", pos), ("confidence", conf)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def n_frames(self) -> int:
        """Number of frames T."""
        return self.times.size

    def lowpass(self, cutoff_hz: float, *, order: int = 4, joints: np.ndarray | None = None) -> LandmarkTrajectory:
        """The trajectory filtered by a zero-phase Butterworth low-pass (``sosfiltfilt``), each joint's
        runs of present frames on their own (the usual marker filter before inverse kinematics, e.g.
        4th order at 6 Hz); runs too short to filter are kept as they are. ``joints`` (indices) limits
        the filter to those joints; the others are kept as they are.

        Raises
        ------
        BadInputError
            If ``cutoff_hz`` is not positive or not below the Nyquist frequency of the median frame rate.
        """
        rate = 1.0 / float(np.median(np.diff(self.times))) if self.n_frames > 1 else np.inf
        if not (np.isfinite(cutoff_hz) and 0 < cutoff_hz < rate / 2):
            raise BadInputError(f"the low-pass cutoff must lie in (0, {rate / 2:.1f}) Hz (half the frame rate), "
                                f"got {cutoff_hz}")
        sos = butter(order, cutoff_hz, fs=rate, output="sos")
        pad = 3 * (2 * len(sos) + 1)
        out = self.positions.copy()
        present = ~np.isnan(self.positions[..., 0])
        for j in range(self.topology.n_joints) if joints is None else np.asarray(joints, dtype=int):
            edges = np.flatnonzero(np.diff(np.r_[0, present[:, j].astype(np.int8), 0]))
            for a, b in zip(edges[::2], edges[1::2]):
                if b - a > pad:
                    out[a:b, j] = sosfiltfilt(sos, self.positions[a:b, j], axis=0)
        return LandmarkTrajectory(self.topology, self.times, out, self.confidence, self.source)

    def window(self, start_s: float | None = None, end_s: float | None = None) -> LandmarkTrajectory:
        """The frames with ``start_s <= time <= end_s`` (either bound optional), seconds.

        Raises
        ------
        BadInputError
            If no frame lies in the window.
        """
        keep = np.ones(self.n_frames, dtype=bool)
        if start_s is not None:
            keep &= self.times >= start_s
        if end_s is not None:
            keep &= self.times <= end_s
        if not keep.any():
            raise BadInputError(f"no frame of {self.source or 'the trajectory'} lies in [{start_s}, {end_s}] s "
                                f"(it spans {self.times[0]:.3f} .. {self.times[-1]:.3f} s)")
        return LandmarkTrajectory(self.topology, self.times[keep], self.positions[keep], self.confidence[keep],
                                  self.source)


def trajectory_from_stream(stream: SkeletonStream, T_world_cam: np.ndarray | None = None, *,
                           inferred_weight: float = 0.5, source: str = "") -> LandmarkTrajectory:
    """A skeleton stream as a world-frame landmark trajectory.

    Parameters
    ----------
    stream : SkeletonStream
        (T, J, 3) positions [m] in the camera frame, (T, J) states.
    T_world_cam : numpy.ndarray, optional
        (4, 4) pose of the camera; None if the stream is already in the world frame.
    inferred_weight : float
        Confidence of INFERRED joints, in [0, 1].
    source : str
        Description for reports.

    Returns
    -------
    LandmarkTrajectory

    Raises
    ------
    BadInputError
        Empty stream, bad transform or ``inferred_weight`` outside [0, 1].
    """
    if stream.n_frames == 0:
        raise BadInputError("the skeleton stream is empty: nothing to retarget")
    if not 0.0 <= inferred_weight <= 1.0:
        raise BadInputError(f"inferred_weight must lie in [0, 1], got {inferred_weight}")
    pos = np.array(stream.positions)
    if T_world_cam is not None:
        T = validate_transform(T_world_cam, "T_world_cam")
        pos = apply(T, pos.reshape(-1, 3)).reshape(pos.shape)
    weight = np.zeros(max(TrackingState) + 1)
    weight[TrackingState.INFERRED] = inferred_weight
    weight[TrackingState.TRACKED] = weight[TrackingState.HIGH] = 1.0
    return LandmarkTrajectory(stream.topology, stream.timestamps, pos, weight[stream.states], source)


def trajectory_from_recording(recording: Recording, *, camera: str | None = None,
                              calibration: Calibration | None = None,
                              inferred_weight: float = 0.5) -> LandmarkTrajectory:
    """One camera of a recording (or its fused skeleton) as a world-frame landmark trajectory.

    Parameters
    ----------
    recording : Recording
        A recording (real or simulated) or a fused recording (one camera named ``fused``).
    camera : str, optional
        Camera to take; default the fused camera if present, else the calibration's reference.
    calibration : Calibration, optional
        Gives ``T_world_cam`` of ``camera``; needed unless the camera is the fused one.
    inferred_weight : float
        Confidence of INFERRED joints.

    Returns
    -------
    LandmarkTrajectory

    Raises
    ------
    BadInputError
        A camera frame without a calibration, or a camera without skeletons.
    UnknownNameError
        ``camera`` is not in the recording or not in the calibration (lists the available ones).
    """
    if camera is None:
        if FUSED_CAMERA in recording.camera_names:
            camera = FUSED_CAMERA
        elif calibration is not None:
            camera = calibration.reference
        else:
            raise BadInputError(f"choose a camera ({', '.join(recording.camera_names)}) and give its calibration, "
                                "or give a fused recording")
    cam = recording.camera(camera)
    if cam.skeleton is None:
        raise BadInputError(f"camera {camera} has no skeleton stream")
    if camera == FUSED_CAMERA:
        return trajectory_from_stream(cam.skeleton, inferred_weight=inferred_weight, source="fused skeleton")
    if calibration is None:
        raise BadInputError(f"camera {camera} records in its own frame: give the calibration that places it "
                            "(--calib CALIB.toml)")
    return trajectory_from_stream(cam.skeleton, calibration.pose(camera), inferred_weight=inferred_weight,
                                  source=f"camera {camera}")
