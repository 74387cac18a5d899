"""Calibration from the body while the cameras stream, improving as support accumulates.

The server keeps each camera's most recent frames (a bounded window) and, every ``every_s``
seconds of stream time, calibrates them with the offline pipeline
(:func:`fusion.calibrate.pipeline.calibrate_rig`, skeletons only: no depth travels over the wire).
Each result replaces the previous one when it calibrates at least as many cameras; its quality
(per pair: support, residual, bootstrap spread) is published in the server's status.

Only frames that pass the offline readers' unit check are kept, and a snapshot leaves out (and names)
cameras whose held frames span less than :data:`MIN_SPAN_SHARE` of the longest camera's: a client
that sent a few frames under a name of its own, or stopped long ago, cannot block the others'
calibration.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, replace

import numpy as np

from fusion.calibrate.options import CalibrationOptions, Refinement
from fusion.calibration import Calibration
from fusion.camera import Intrinsics
from fusion.errors import BadInputError, BenchError, RecordingError
from fusion.io.plausibility import check_length_units
from fusion.live.protocol import CameraFrame
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream

MIN_SPAN_SHARE = 0.5


@dataclass(frozen=True)
class AutoCalibrationOptions:
    """When and on what the server calibrates.

    Attributes
    ----------
    every_s : float
        Stream time [s] between attempts (and before the first one).
    window_s : float
        Most recent stream time [s] of frames kept per camera and calibrated.
    calibration : CalibrationOptions
        Pipeline options; refinement is forced to NONE (skeletons only).
    """

    every_s: float = 10.0
    window_s: float = 60.0
    calibration: CalibrationOptions = CalibrationOptions(refine=Refinement.NONE)

    def __post_init__(self) -> None:
        if not (0 < self.every_s <= self.window_s):
            raise BadInputError(f"need 0 < every_s <= window_s [s], got {self.every_s}, {self.window_s}")


@dataclass(frozen=True)
class CalibrationAttempt:
    """One calibration attempt: the calibration (None if it failed), why not, and its quality."""

    stream_time_s: float
    calibration: Calibration | None
    error: str | None
    quality: dict[str, object]


class AutoCalibrator:
    """Collects frames per camera and calibrates them when due (see the module docstring).

    Parameters
    ----------
    options : AutoCalibrationOptions
        Schedule and pipeline options.
    """

    def __init__(self, options: AutoCalibrationOptions = AutoCalibrationOptions()) -> None:
        self.options = options
        self._frames: dict[str, deque[CameraFrame]] = {}
        self._next_s: float | None = None
        self.best: CalibrationAttempt | None = None
        self.attempts = 0
        self.left_out: dict[str, str] = {}  # camera -> why the last snapshot left it out

    def add(self, frame: CameraFrame) -> bool:
        """Keep a frame (frames not newer than their camera's newest are ignored); True when a
        calibration attempt is due."""
        try:
            check_length_units(frame.positions[None], frame.topology, frame.sensor)
        except RecordingError:
            return False
        held = self._frames.setdefault(frame.sensor, deque())
        if held and frame.timestamp <= held[-1].timestamp:
            return False
        held.append(frame)
        while held[-1].timestamp - held[0].timestamp > self.options.window_s:
            held.popleft()
        if self._next_s is None:
            self._next_s = frame.timestamp + self.options.every_s
        return len(self._frames) >= 2 and frame.timestamp >= self._next_s

    def snapshot(self) -> Recording | None:
        """The held frames as a skeleton-only recording (placeholder intrinsics), or None with fewer
        than two cameras; schedules the next attempt. Cameras whose frames span less than
        :data:`MIN_SPAN_SHARE` of the longest span are left out (named in :attr:`left_out`)."""
        cameras = []
        spans = {n: h[-1].timestamp - h[0].timestamp for n, h in self._frames.items()}
        longest = max(spans.values())
        self.left_out = {n: f"its frames span {spans[n]:.1f} s of the {longest:.1f} s held"
                         for n in spans if spans[n] < MIN_SPAN_SHARE * longest or spans[n] <= 0}
        for name, held in sorted(self._frames.items()):
            frames = list(held)
            if name in self.left_out:
                continue
            topo = frames[0].topology
            stream = SkeletonStream(topo, np.array([f.timestamp for f in frames]),
                                    np.array([f.positions for f in frames]), np.array([f.states for f in frames]))
            cameras.append(CameraRecording(name, Intrinsics(), stream))
        newest = max(h[-1].timestamp for h in self._frames.values())
        self._next_s = newest + self.options.every_s
        return Recording(tuple(cameras), {"source": "live"}) if len(cameras) >= 2 else None

    def calibrate(self, recording: Recording, *, rng: np.random.Generator) -> CalibrationAttempt:
        """Calibrate a snapshot; the attempt becomes :attr:`best` when it calibrates at least as many
        cameras as the best so far."""
        from fusion.calibrate.pipeline import (
            calibrate_rig,  # open3d and friends: only when calibrating
        )
        from fusion.calibrate.results import calibration_from_rig

        self.attempts += 1
        newest = max(c.skeleton.timestamps[-1] for c in recording.cameras)
        options = replace(self.options.calibration, refine=Refinement.NONE)
        try:
            calibration = calibration_from_rig(calibrate_rig(recording, options, rng=rng))
        except BenchError as exc:
            return CalibrationAttempt(float(newest), None, str(exc), {"cameras": [], "left_out": dict(self.left_out)})
        quality = {"cameras": list(calibration.camera_names), "left_out": dict(self.left_out),
                   "reference": calibration.reference,
                   "pairs": calibration.info.get("pair", []), "notes": calibration.info.get("notes", [])}
        attempt = CalibrationAttempt(float(newest), calibration, None, quality)
        if self.best is None or len(calibration.camera_names) >= len(self.best.calibration.camera_names):
            self.best = attempt
        return attempt
