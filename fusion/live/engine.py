"""The live fusion engine: camera frames in, fused frames out, no sockets (the server feeds it).

Each frame of the calibration's reference camera opens an *instant* at its timestamp ``t``.
Camera ``c`` contributes its skeleton at ``t + clock_offset_s[c]`` (its clock minus the
reference's), interpolated between its frames around that time exactly as offline
(:func:`fusion.merge.views.views_from_streams`), so an instant is *complete* once every camera has
a frame at or after that time (or has said ``bye``). Instants are merged in time order, as soon as
they are complete or when their deadline passes (then without the late cameras), by the offline
merging code (:func:`fusion.merge.fuse.fuse_views`), with back-facing flags from
:class:`fusion.merge.causal.CausalBackFacing` and the causal One-Euro filter
(:class:`fusion.merge.filters.OneEuroFilter`). Fed a whole recording, it reproduces
:func:`fusion.merge.causal.fuse_causal` frame for frame.

Each camera's frames are taken in time order (one client's frames arrive in order over TCP);
a frame not newer than its camera's newest is counted *late* (or a *duplicate*) and dropped.
Frames of different cameras may arrive in any order.

Frames are checked as the offline readers check files: a frame of another joint set, of a camera the
calibration lacks, or whose body size or distance says it is not in metres
(:func:`fusion.io.plausibility.check_length_units`) is counted by reason and dropped. A frame more
than :data:`MAX_CLOCK_STEP_S` from its camera's newest (or, for a camera's first frame, from the
other cameras' newest, on the reference clock) is held back as a *clock step*: one stray timestamp
is dropped, and only :data:`CLOCK_STEP_FRAMES` consecutive frames that agree with each other move
the camera to the new time (its held frames are forgotten). So one bad frame never locks a camera.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field, replace

import numpy as np

from fusion.calibration import Calibration
from fusion.errors import BadInputError, RecordingError
from fusion.io.plausibility import MAX_INTERVAL_S, check_length_units
from fusion.live.protocol import CameraFrame, FusedFrame
from fusion.merge.backfacing import cross_check_back_facing
from fusion.merge.causal import CausalBackFacing, check_causal
from fusion.merge.filters import OneEuroFilter, TemporalFilter
from fusion.merge.fuse import FuseOptions, fuse_views
from fusion.merge.views import views_from_streams
from fusion.skeleton import SkeletonStream
from fusion.topology import Topology

MAX_CLOCK_STEP_S = 5.0
CLOCK_STEP_FRAMES = 3


@dataclass(frozen=True)
class EngineOptions:
    """How the engine fuses and waits.

    Attributes
    ----------
    fuse : FuseOptions
        Merging method and options; the temporal filter must be causal (none or one_euro) and
        bone lengths off (:func:`fusion.merge.causal.check_causal`).
    deadline_s : float
        Wall-clock seconds [s] after an instant's reference frame arrived at which it is merged
        with whatever has arrived; ``inf`` waits for every camera (or its ``bye``).
    silent_after_s : float
        A camera without a frame for this long [s, wall clock] is silent: instants stop waiting for
        it, and if it is the reference another camera's frames open the instants.
    max_held : int
        Most frames held per camera; beyond it the oldest is forgotten (e.g. while no reference frame
        opens instants).
    """

    fuse: FuseOptions = FuseOptions(temporal=TemporalFilter.ONE_EURO)
    deadline_s: float = 0.1
    silent_after_s: float = 1.0
    max_held: int = 300

    def __post_init__(self) -> None:
        check_causal(self.fuse)
        if not (isinstance(self.max_held, int) and self.max_held >= 4):
            raise BadInputError(f"max_held must be an integer >= 4 (frames per camera), got {self.max_held}")
        for name in ("deadline_s", "silent_after_s"):
            if not getattr(self, name) > 0:
                raise BadInputError(f"{name} must be positive [s], got {getattr(self, name)}")


@dataclass
class _Camera:
    """The recent frames of one camera in time order, with their back-facing flags and arrival times."""

    detector: CausalBackFacing
    done: list[CameraFrame] = field(default_factory=list)
    flags: list[bool] = field(default_factory=list)
    arrivals: list[float] = field(default_factory=list)
    ended: bool = False
    frames: int = 0
    late: int = 0
    duplicates: int = 0
    forgotten: int = 0
    clock_steps: int = 0
    rejected: dict[str, int] = field(default_factory=lambda: {"units": 0, "clock": 0})
    stepped: list[CameraFrame] = field(default_factory=list)  # consecutive frames far from the newest
    last_arrival: float = -np.inf

    def newest(self) -> float:
        """Timestamp of the newest frame held (-inf without one)."""
        return self.done[-1].timestamp if self.done else -np.inf

    def clock_plausible(self, frame: CameraFrame, expected: float) -> bool:
        """Whether ``frame`` lies within :data:`MAX_CLOCK_STEP_S` of ``expected`` [s, this camera's clock;
        NaN: anything goes]; else hold it as part of a clock step, and once :data:`CLOCK_STEP_FRAMES`
        consecutive such frames agree, forget the held frames and take the step (True)."""
        if np.isnan(expected) or abs(frame.timestamp - expected) <= MAX_CLOCK_STEP_S:
            self.rejected["clock"] += len(self.stepped)
            self.stepped.clear()
            return True
        if self.stepped and not 0 < frame.timestamp - self.stepped[-1].timestamp <= MAX_INTERVAL_S:
            self.rejected["clock"] += len(self.stepped)
            self.stepped.clear()
        self.stepped.append(frame)
        if len(self.stepped) < CLOCK_STEP_FRAMES:
            return False
        self.forgotten += len(self.done)
        self.done.clear(), self.flags.clear(), self.arrivals.clear()
        self.clock_steps += 1
        return True

    def add(self, frame: CameraFrame, arrival: float, max_held: int) -> bool:
        """Flag and hold a frame; False (and counted) if not newer than the newest held.

        Returns
        -------
        bool
            Whether the frame was taken. Beyond ``max_held`` frames the oldest is forgotten (and
            counted: a camera that runs that far ahead of the reference loses frames its instants need).
        """
        t = frame.timestamp
        if t <= self.newest():
            if t == self.newest():
                self.duplicates += 1
            else:
                self.late += 1
            return False
        self.flags.append(self.detector.step(t, frame.positions, frame.states))
        self.done.append(frame)
        self.arrivals.append(arrival)
        if len(self.done) > max_held:
            del self.done[0], self.flags[0], self.arrivals[0]
            self.forgotten += 1
        self.frames += 1
        self.last_arrival = max(self.last_arrival, arrival)
        return True

    def window(self, local: float) -> tuple[SkeletonStream, np.ndarray, float]:
        """The frames around ``local`` (one before the bracketing pair, then the pair), their flags and
        the arrival of the frame at or after ``local`` (-inf without one); older frames are forgotten."""
        times = [f.timestamp for f in self.done]
        k0 = bisect.bisect_right(times, local) - 1
        lo, hi = max(k0 - 1, 0), min(k0 + 2, len(times))
        needed = k0 if k0 >= 0 and times[k0] == local else k0 + 1
        arrival = self.arrivals[needed] if needed < len(times) else -np.inf
        frames = self.done[lo:hi]
        J = self.detector.topology.n_joints
        stream = SkeletonStream(self.detector.topology, np.array([f.timestamp for f in frames]),
                                np.array([f.positions for f in frames]).reshape(-1, J, 3),
                                np.array([f.states for f in frames], dtype=np.int8).reshape(-1, J))
        flags = np.array(self.flags[lo:hi], dtype=bool)
        del self.done[:lo], self.flags[:lo], self.arrivals[:lo]
        return stream, flags, arrival


class LiveFusion:
    """Incremental fusion of camera frames into fused frames (see the module docstring).

    Parameters
    ----------
    calibration : Calibration
        Poses, clock offsets and reference camera; only its cameras are fused.
    topology : Topology
        Joint set of every camera.
    options : EngineOptions
        Merging and waiting.
    """

    def __init__(self, calibration: Calibration, topology: Topology, options: EngineOptions = EngineOptions()):
        if not isinstance(calibration, Calibration):
            raise BadInputError(f"calibration must be a Calibration, got {type(calibration).__name__}")
        self.topology = topology
        self.options = options
        self.cameras = {n: _Camera(CausalBackFacing(topology)) for n in calibration.camera_names}
        self._filter = OneEuroFilter(topology.n_joints) if options.fuse.temporal is TemporalFilter.ONE_EURO else None
        self._instants: list[tuple[float, float]] = []  # (reference time, wall deadline)
        self._last_emitted = -np.inf
        self._first_arrival: float | None = None
        self._index = 0
        self.counts = {"unknown_camera": 0, "wrong_topology": 0, "units": 0, "clock": 0, "late_instants": 0,
                       "incomplete": 0}
        self.unknown_cameras: dict[str, int] = {}  # frames per camera name the calibration lacks (first 32 names)
        self.set_calibration(calibration)

    def set_calibration(self, calibration: Calibration) -> None:
        """Use another calibration of the same cameras from the next instant on (e.g. an improved one)."""
        missing = sorted(set(self.cameras) - set(calibration.camera_names))
        if missing:
            raise BadInputError(f"the new calibration lacks camera(s) {', '.join(missing)}")
        self.calibration = calibration
        ref = calibration.reference
        self._offsets = {n: calibration.clock_offset_s[n] - calibration.clock_offset_s[ref] for n in self.cameras}

    def push(self, frame: CameraFrame, arrival: float) -> list[FusedFrame]:
        """Take one frame that arrived at wall-clock time ``arrival`` [s]; returns the instants it completed."""
        if self._first_arrival is None:
            self._first_arrival = arrival
        camera = self.cameras.get(frame.sensor)
        if camera is None:
            self.counts["unknown_camera"] += 1
            if frame.sensor in self.unknown_cameras or len(self.unknown_cameras) < 32:
                self.unknown_cameras[frame.sensor] = self.unknown_cameras.get(frame.sensor, 0) + 1
            return []
        if frame.topology != self.topology:
            self.counts["wrong_topology"] += 1
            return []
        try:
            check_length_units(frame.positions[None], self.topology, f"camera {frame.sensor}")
        except RecordingError:
            self.counts["units"] += 1
            camera.rejected["units"] += 1
            return []
        plausible = camera.clock_plausible(frame, self._expected_time(frame.sensor))
        self.counts["clock"] = sum(c.rejected["clock"] for c in self.cameras.values())
        if not plausible:
            return []
        if camera.ended:
            camera.ended = False  # a client that reconnects
        stepped, camera.stepped = camera.stepped or [frame], []
        for held in stepped:  # a clock step's frames, now taken
            if not camera.add(held, arrival, self.options.max_held):
                return []
            self._open_instant(held, arrival)
        return self.poll(arrival)

    def _expected_time(self, sensor: str) -> float:
        """Where camera ``sensor``'s next timestamp should lie [s, its clock]: after its newest frame,
        or for its first frame near the other cameras' newest (NaN if no camera has a frame)."""
        newest = self.cameras[sensor].newest()
        if newest > -np.inf:
            return newest
        others = [c.newest() - self._offsets[n] for n, c in self.cameras.items() if c.done]
        return max(others) + self._offsets[sensor] if others else np.nan

    def _open_instant(self, frame: CameraFrame, arrival: float) -> None:
        if frame.sensor == self.timebase(arrival):
            t = frame.timestamp - self._offsets[frame.sensor]
            if t <= self._last_emitted:
                self.counts["late_instants"] += 1
            else:
                bisect.insort(self._instants, (t, arrival + self.options.deadline_s))

    def timebase(self, now: float) -> str:
        """The camera whose frames open instants: the reference, or while it is silent
        the first camera (calibration order) that is not (a camera that said bye is not silent at once)."""
        live = [n for n, c in self.cameras.items() if not self._silent(c, now)]
        ref = self.calibration.reference
        return ref if ref in live or not live else live[0]

    def _silent(self, camera: "_Camera", now: float) -> bool:
        """No frame for ``silent_after_s`` (counted from the engine's first frame for a camera not yet heard)."""
        last = camera.last_arrival if camera.frames else self._first_arrival
        return last is not None and now - last > self.options.silent_after_s

    def bye(self, sensor: str, now: float) -> list[FusedFrame]:
        """A camera's stream ended: stop waiting for it."""
        if sensor in self.cameras:
            self.cameras[sensor].ended = True
        return self.poll(now)

    def poll(self, now: float, *, flush: bool = False) -> list[FusedFrame]:
        """Merge the instants that are complete, past their deadline at wall-clock ``now`` [s], or
        (``flush``) all of them."""
        out = []
        while self._instants:
            t, deadline = self._instants[0]
            have = {n: c.newest() >= t + self._offsets[n] for n, c in self.cameras.items()}
            complete = all(have.values())
            waiting = any(not (h or c.ended or self._silent(c, now)) for h, c in zip(have.values(), self.cameras.values()))
            if waiting and not (flush or now >= deadline):
                break
            self._instants.pop(0)
            out.append(self._merge(t, complete))
        return out

    def _merge(self, t: float, complete: bool) -> FusedFrame:
        streams, flags, arrivals, present = {}, {}, [], []
        for name, camera in self.cameras.items():
            local = t + self._offsets[name]
            streams[name], flags[name], arrival = camera.window(local)
            if arrival > -np.inf:
                present.append(name)
                arrivals.append(arrival)
        views = views_from_streams(streams, self.calibration.T_world_cam, np.array([t]), self._offsets, flags)
        fuse = self.options.fuse
        if fuse.cross_check:
            views = replace(views, back_facing=cross_check_back_facing(views))
        merged = fuse_views(views, replace(fuse, temporal=TemporalFilter.NONE))
        positions = merged.positions[0]
        if self._filter is not None:
            positions = self._filter.step(t, positions)
        stream = replace(merged, positions=positions[None]).to_stream(self.topology)
        self._last_emitted = t
        if not complete:
            self.counts["incomplete"] += 1
        frame = FusedFrame(self._index, t, stream.positions[0], stream.states[0], merged.reliability[0],
                           tuple(present), complete, max(arrivals, default=-np.inf))
        self._index += 1
        return frame

    def camera_status(self, now: float) -> dict[str, dict[str, object]]:
        """Per camera: frames accepted, late, duplicates, forgotten (beyond ``max_held`` or at a clock
        step), rejected by reason (units, clock), clock steps taken and frames held for one, newest timestamp, seconds since its
        last frame, silent, ended."""
        return {n: {"frames": c.frames, "late": c.late, "duplicates": c.duplicates, "forgotten": c.forgotten,
                    "rejected_units": c.rejected["units"], "rejected_clock": c.rejected["clock"],
                    "clock_steps": c.clock_steps, "held_for_clock_step": len(c.stepped),
                    "last_time_s": None if not c.done else c.newest(),
                    "since_last_s": None if c.last_arrival == -np.inf else float(now - c.last_arrival),
                    "silent": bool(self._silent(c, now)), "ended": c.ended}
                for n, c in self.cameras.items()}

    @property
    def pending(self) -> int:
        """Instants waiting to be merged."""
        return len(self._instants)
