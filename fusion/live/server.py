"""The live fusion server: camera clients in, fused frames and status out (:mod:`fusion.live.protocol`).

Two threads. The *receiver* takes each message off the frame socket, stamps its arrival, checks and
decodes it (a bad one is counted under its :class:`~fusion.live.protocol.Reject` reason and
dropped) and puts it on a bounded queue; when the queue is full the message is dropped and counted.
The *fuser* takes frames off the queue into the :class:`~fusion.live.engine.LiveFusion` engine,
merges instants when complete or at their deadline, publishes each fused frame, and a status
message about once a second. Without a calibration it calibrates from the body as frames accumulate
(:class:`~fusion.live.autocal.AutoCalibrator`, in a third, short-lived thread per attempt) and fuses
once one exists. :meth:`FusionServer.stop` merges what is pending, publishes ``end`` and returns
everything fused (for an atomic write by the caller). With :attr:`ServerConfig.lsl` it also publishes
each fused frame as a Lab Streaming Layer stream (:mod:`fusion.live.lsl_outlet`); its joint set is then
the session's, and frames of another are counted and not fused.
"""

from __future__ import annotations

import queue
import resource
import threading
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import zmq

from fusion.calibration import Calibration
from fusion.errors import BadInputError
from fusion.live.engine import EngineOptions, LiveFusion
from fusion.live.lsl_outlet import LslOptions, LslOutlet
from fusion.live.protocol import (
    MAX_MESSAGE_BYTES,
    CameraFrame,
    Endpoint,
    FusedFrame,
    MessageType,
    ProtocolError,
    Reject,
    decode_client_message,
    encode_fused,
    encode_server_message,
)
from fusion.live.sockets import secure, start_authenticator
from fusion.topology import Topology

if TYPE_CHECKING:  # the calibration pipeline loads open3d: imported only when calibrating from the body
    from fusion.live.autocal import AutoCalibrationOptions, CalibrationAttempt

_POLL_MS = 20
SETTLE_FRAMES = 3  # frames of one joint set that fix a session's (a stray frame of another does not)
_MAX_SETTLING = 64


def _peak_rss_mb(usage: resource.struct_rusage) -> float:
    """Peak resident memory [MB] of this process image: ``VmHWM`` where /proc has it (``ru_maxrss``
    also counts the parent's peak before ``exec`` on Linux), else ``ru_maxrss``."""
    try:
        with open("/proc/self/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return round(int(line.split()[1]) / 1024, 1)
    except OSError:
        pass
    return round(usage.ru_maxrss / 1024, 1)


@dataclass(frozen=True)
class ServerConfig:
    """Where and how the server listens.

    Attributes
    ----------
    endpoint : Endpoint
        Frame port (``PORT``) and publishing port (``PORT + 1``) on one host.
    token : str or None
        Shared token; required unless the host is loopback.
    queue_size : int
        Bound of the queue between receiver and fuser [messages].
    max_message_bytes : int
        Largest accepted client message [bytes].
    status_every_s : float
        Wall-clock interval [s] of status messages.
    keep_frames : bool
        Keep every fused frame for :meth:`FusionServer.stop` (to write them out).
    lsl : LslOptions or None
        Also publish the fused frames as this LSL stream (needs ``pylsl``).
    """

    endpoint: Endpoint = Endpoint("127.0.0.1", 5570)
    token: str | None = None
    queue_size: int = 4096
    max_message_bytes: int = MAX_MESSAGE_BYTES
    status_every_s: float = 1.0
    keep_frames: bool = True
    lsl: LslOptions | None = None

    def __post_init__(self) -> None:
        if not self.endpoint.loopback and not self.token:
            raise BadInputError(f"listening on {self.endpoint.host} (beyond loopback) requires a shared token "
                                "(--token); every client must send it")
        if self.token is not None and not self.token:
            raise BadInputError("the token must not be empty")
        if self.queue_size < 1 or self.max_message_bytes < 64 or not self.status_every_s > 0:
            raise BadInputError("queue_size >= 1, max_message_bytes >= 64 and status_every_s > 0 are required")


@dataclass
class ServerResult:
    """What a server fused until it stopped: the frames (if kept), their topology and the final status."""

    frames: list[FusedFrame] = field(default_factory=list)
    topology: Topology | None = None
    status: dict[str, object] = field(default_factory=dict)


class FusionServer:
    """The server (see the module docstring).

    Parameters
    ----------
    config : ServerConfig
        Sockets, token, bounds.
    engine : EngineOptions
        Merging method, filter and deadlines.
    calibration : Calibration or None
        Poses and clock offsets; None calibrates from the body on the fly.
    autocal : AutoCalibrationOptions or None
        Schedule of the on-the-fly calibration (used without ``calibration``; default options).
    rng : np.random.Generator
        Random source of the on-the-fly calibration (RANSAC, bootstrap).
    """

    def __init__(self, config: ServerConfig, engine: EngineOptions = EngineOptions(),
                 calibration: Calibration | None = None, autocal: AutoCalibrationOptions | None = None,
                 *, rng: np.random.Generator) -> None:
        self.config, self.engine_options, self.calibration = config, engine, calibration
        self._lsl = None if config.lsl is None else LslOutlet(config.lsl, calibration, {
            "method": engine.fuse.method.value, "fit": engine.fuse.fit.value,
            "temporal_filter": engine.fuse.temporal.value, "deadline_s": engine.deadline_s,
            "calibration": "body" if calibration is None else "file"})
        self._autocal = None
        if calibration is None:
            from fusion.live.autocal import AutoCalibrationOptions, AutoCalibrator

            self._autocal = AutoCalibrator(autocal or AutoCalibrationOptions())
        self._rng = rng
        self._queue: queue.Queue = queue.Queue(config.queue_size)
        self._stop = threading.Event()
        self._counts = {"received": 0, "accepted": 0, "dropped_queue": 0, "fused": 0, "byes": 0} | {
            f"rejected_{r.value}": 0 for r in Reject}
        self._latency_ms: list[float] = []
        self._engine: LiveFusion | None = None
        self._settling: list[tuple[CameraFrame, float]] = []  # calibrated cameras' frames before the engine
        self._attempt: CalibrationAttempt | None = None
        self._calibrating: threading.Thread | None = None
        self.result = ServerResult()
        self._lag: dict[str, tuple[float, float]] = {}  # camera -> (first, latest) median arrival - timestamp
        self._recent_lag: dict[str, list[float]] = {}
        self._ctx = zmq.Context()
        self._auth = None if config.token is None else start_authenticator(self._ctx, config.token)
        self._pull = secure(self._ctx.socket(zmq.PULL), config.token, server=True)
        self._pub = secure(self._ctx.socket(zmq.PUB), config.token, server=True)
        self._pull.setsockopt(zmq.MAXMSGSIZE, 16 * config.max_message_bytes)  # hard guard; counted below it
        self._pull.setsockopt(zmq.LINGER, 0)
        self._pub.setsockopt(zmq.LINGER, 1000)
        self._pull.bind(config.endpoint.frames_url())
        self._pub.bind(config.endpoint.publish_url())
        self._threads = [threading.Thread(target=self._receive, name="receiver", daemon=True),
                         threading.Thread(target=self._fuse, name="fuser", daemon=True)]
        self._started = time.perf_counter()
        for thread in self._threads:
            thread.start()

    # receiver thread -------------------------------------------------------------------------
    def _receive(self) -> None:
        poller = zmq.Poller()
        poller.register(self._pull, zmq.POLLIN)
        while not self._stop.is_set():
            if not poller.poll(_POLL_MS):
                continue
            while True:
                try:
                    data = self._pull.recv(zmq.NOBLOCK, copy=True)
                except zmq.Again:
                    break
                arrival = time.perf_counter()
                self._counts["received"] += 1
                try:
                    message = decode_client_message(data, token=self.config.token,
                                                    max_bytes=self.config.max_message_bytes)
                except ProtocolError as exc:
                    self._counts[f"rejected_{exc.reason.value}"] += 1
                    continue
                if isinstance(message, str):  # a bye is never dropped: the stream's end must be known
                    self._queue.put((arrival, message))
                    continue
                try:
                    self._queue.put_nowait((arrival, message))
                except queue.Full:
                    self._counts["dropped_queue"] += 1

    # fuser thread ----------------------------------------------------------------------------
    def _fuse(self) -> None:
        next_status = time.perf_counter() + self.config.status_every_s
        while not self._stop.is_set():
            try:
                arrival, message = self._queue.get(timeout=_POLL_MS / 1e3)
            except queue.Empty:
                message = None
            now = time.perf_counter()
            if message is not None:
                self._handle(message, arrival, now)
            if self._engine is not None and self._queue.empty():  # deadlines only once caught up: a
                self._publish(self._engine.poll(time.perf_counter()))  # backlog is judged by its arrival times
            if now >= next_status:
                self._pub.send(encode_server_message(MessageType.STATUS, {"status": self.status()}))
                next_status = now + self.config.status_every_s

    def _handle(self, message: CameraFrame | str, arrival: float, now: float) -> None:
        if isinstance(message, str):
            self._counts["byes"] += 1
            if self._engine is not None:
                self._publish(self._engine.bye(message, now))
        else:
            self._counts["accepted"] += 1
            self._take(message, arrival)

    def _take(self, frame: CameraFrame, arrival: float) -> None:
        self._track_lag(frame, arrival)
        if self._autocal is not None:
            self._calibrate_if_due(frame)
        if self._engine is None and self.calibration is not None and frame.sensor in self.calibration.camera_names:
            self._settle(frame, arrival)
        elif self._engine is not None:
            self._publish(self._engine.push(frame, arrival))

    def _settle(self, frame: CameraFrame, arrival: float) -> None:
        """Start the engine once the session's joint set is known: the LSL outlet's, or the first one
        :data:`SETTLE_FRAMES` frames of calibrated cameras share; the frames held until then are pushed
        (those of another joint set are counted as such)."""
        self._settling = [*self._settling[-(_MAX_SETTLING - 1):], (frame, arrival)]
        topology = None if self._lsl is None else self._lsl.options.topology
        if topology is None:
            names = [f.topology.name for f, _ in self._settling]
            topology = frame.topology if names.count(frame.topology.name) >= SETTLE_FRAMES else None
        if topology is None:
            return
        self._engine = LiveFusion(self.calibration, topology, self.engine_options)
        self.result.topology = topology
        held, self._settling = self._settling, []
        for f, t in held:
            self._publish(self._engine.push(f, t))

    def _calibrate_if_due(self, frame: CameraFrame) -> None:
        due = self._autocal.add(frame)
        busy = self._calibrating is not None and self._calibrating.is_alive()
        if self._attempt is not None and not busy:  # a finished attempt: use it if it is the best
            best = self._autocal.best
            if best is not None and best.calibration is not self.calibration:
                self._use(best.calibration)
        if due and not busy:
            snapshot = self._autocal.snapshot()
            if snapshot is not None:
                rng = self._rng.spawn(1)[0]

                def attempt() -> None:
                    self._attempt = self._autocal.calibrate(snapshot, rng=rng)

                self._calibrating = threading.Thread(target=attempt, name="calibrator", daemon=True)
                self._calibrating.start()

    def _use(self, calibration: Calibration) -> None:
        same = self._engine is not None and set(self._engine.cameras) == set(calibration.camera_names)
        self.calibration = calibration
        if same:
            self._engine.set_calibration(calibration)
        else:
            self._engine = None  # created with the next frame of a calibrated camera

    def _publish(self, frames: list[FusedFrame]) -> None:
        for frame in frames:
            self._pub.send(encode_fused(frame, self._engine.topology))
            if self._lsl is not None:
                self._lsl.push(frame)
            if frame.complete and np.isfinite(frame.ready_at):
                self._latency_ms.append(1e3 * (time.perf_counter() - frame.ready_at))
            self._counts["fused"] += 1
            if self.config.keep_frames:
                self.result.frames.append(frame)

    def _track_lag(self, frame: CameraFrame, arrival: float) -> None:
        """Median of (arrival - timestamp) over a camera's first and latest 32 frames: a change of it
        relative to the other cameras' is a step of that camera's clock (or of its link)."""
        recent = self._recent_lag.setdefault(frame.sensor, [])
        recent.append(arrival - frame.timestamp)
        if len(recent) == 32:
            median = float(np.median(recent))
            first = self._lag.get(frame.sensor, (median, median))[0]
            self._lag[frame.sensor] = (first, median)
            recent.clear()

    def clock_steps(self) -> dict[str, float]:
        """Per camera: change [s] of its arrival lag since its first frames, minus the median change of
        all cameras (so a common network or replay-speed change cancels); about -0.1 for a clock that
        jumped 100 ms ahead."""
        change = {n: latest - first for n, (first, latest) in self._lag.items()}
        common = float(np.median(list(change.values()))) if change else 0.0
        return {n: round(c - common, 4) for n, c in change.items()}

    def status(self) -> dict[str, object]:
        """The status message's content (see :mod:`fusion.live.protocol`)."""
        now = time.perf_counter()
        latency = np.array(self._latency_ms)
        usage = resource.getrusage(resource.RUSAGE_SELF)
        cal: dict[str, object] = {"source": "none"}
        if self.calibration is not None:
            cal = {"source": "body" if self._autocal else "file", "cameras": list(self.calibration.camera_names),
                   "reference": self.calibration.reference}
        if self._autocal is not None:
            cal |= {"attempts": self._autocal.attempts,
                    "last_error": None if self._attempt is None else self._attempt.error,
                    "quality": None if self._autocal.best is None else self._autocal.best.quality,
                    "stream_time_s": None if self._autocal.best is None else self._autocal.best.stream_time_s}
        engine = self._engine
        return {
            "uptime_s": round(now - self._started, 3),
            "counts": dict(self._counts),
            "queue": {"size": self._queue.qsize(), "bound": self.config.queue_size},
            "engine": {} if engine is None else dict(engine.counts) | {
                "pending": engine.pending, "timebase": engine.timebase(now),
                "unknown_cameras": dict(engine.unknown_cameras)},
            "cameras": {} if engine is None else engine.camera_status(now),
            "clock_steps_s": self.clock_steps(),
            "calibration": cal,
            "latency_ms": {"n": int(latency.size)} | ({} if not latency.size else {
                "p50": round(float(np.percentile(latency, 50)), 3), "p99": round(float(np.percentile(latency, 99)), 3),
                "max": round(float(latency.max()), 3)}),
            "cpu_s": round(usage.ru_utime + usage.ru_stime, 3),
            "max_rss_mb": _peak_rss_mb(usage),
        } | ({} if self._lsl is None else {"lsl": self._lsl.status()})

    def done(self) -> bool:
        """True once every calibrated camera said ``bye`` and nothing waits to be merged."""
        engine = self._engine
        return (engine is not None and self._queue.empty() and engine.pending == 0
                and all(c.ended for c in engine.cameras.values()))

    def stop(self) -> ServerResult:
        """Stop receiving, merge what is pending, publish ``end`` and return what was fused."""
        self._stop.set()
        for thread in self._threads:
            thread.join()
        while True:
            try:
                arrival, message = self._queue.get_nowait()
            except queue.Empty:
                break
            self._handle(message, arrival, time.perf_counter())
        if self._engine is not None:
            self._publish(self._engine.poll(time.perf_counter(), flush=True))
        self.result.status = self.status()
        self._pub.send(encode_server_message(MessageType.END, {"status": self.result.status}))
        self._pull.close()
        self._pub.close()
        if self._auth is not None:
            self._auth.stop()
        self._ctx.term()
        if self._lsl is not None:
            self._lsl.close()
        return self.result
