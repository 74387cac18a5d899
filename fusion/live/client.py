"""Clients of the live fusion server: a camera client, a recording replayed as one client per
camera, and a subscriber that collects the fused stream into a recording."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import zmq
from zmq.utils.monitor import recv_monitor_message

from fusion.camera import Intrinsics
from fusion.errors import BadInputError
from fusion.live.protocol import (
    CameraFrame,
    Endpoint,
    FusedFrame,
    MessageType,
    ProtocolError,
    Reject,
    decode_fused,
    encode_bye,
    encode_frame,
    unpack,
)
from fusion.live.sockets import secure
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import Topology


class CameraClient:
    """One camera's connection to the server's frame port (a PUSH socket of its own).

    Parameters
    ----------
    endpoint : Endpoint
        The server's address.
    sensor : str
        Camera name sent with every frame.
    token : str or None
        Shared token, if the server requires one.
    send_timeout_s : float
        A send that cannot be queued within this time [s] fails (:meth:`send` returns False).
    context : zmq.Context or None
        ZeroMQ context (default: the process's shared one).
    """

    def __init__(self, endpoint: Endpoint, sensor: str, *, token: str | None = None, send_timeout_s: float = 1.0,
                 context: zmq.Context | None = None) -> None:
        self.sensor, self.token = sensor, token
        self._socket = secure((context or zmq.Context.instance()).socket(zmq.PUSH), token, server=False)
        self._socket.setsockopt(zmq.SNDTIMEO, int(1e3 * send_timeout_s))
        self._socket.setsockopt(zmq.LINGER, 2000)
        self._monitor = self._socket.get_monitor_socket(zmq.EVENT_HANDSHAKE_SUCCEEDED)
        self._reached = False
        self._socket.connect(endpoint.frames_url())
        self._seq = 0
        self.unsent = 0

    def reached(self, wait_s: float = 0.0) -> bool:
        """Whether a server has accepted this connection (its handshake, token included, succeeded),
        waiting up to ``wait_s`` [s] for it."""
        deadline = time.perf_counter() + wait_s
        while not self._reached:
            if not self._monitor.poll(max(0, int(1e3 * (deadline - time.perf_counter())))):
                break
            self._reached = recv_monitor_message(self._monitor)["event"] == zmq.EVENT_HANDSHAKE_SUCCEEDED
        return self._reached

    def send(self, topology: Topology, timestamp: float, positions: np.ndarray, states: np.ndarray) -> bool:
        """Send one frame ((J, 3) positions [m] in the camera frame, (J,) states, timestamp [s] on the
        camera's clock); False (counted in :attr:`unsent`) if it could not be queued in time."""
        frame = CameraFrame(self.sensor, self._seq, timestamp, topology, positions, states)
        self._seq += 1
        return self.send_raw(encode_frame(frame, token=self.token))

    def send_raw(self, data: bytes) -> bool:
        """Send arbitrary bytes as one message (for fault tests); False if not queued in time."""
        try:
            self._socket.send(data)
            return True
        except zmq.Again:
            self.unsent += 1
            return False

    def bye(self) -> None:
        """Tell the server this camera's stream ended."""
        self.send_raw(encode_bye(self.sensor, token=self.token))

    def close(self, *, abrupt: bool = False) -> None:
        """Close the connection; ``abrupt`` drops what is still queued (like a killed process)."""
        self._socket.disable_monitor()
        self._monitor.close(linger=0)
        self._socket.close(linger=0 if abrupt else None)


@dataclass
class ReplayResult:
    """Frames sent and not sent per camera, and the wall time [s] of the replay."""

    sent: dict[str, int] = field(default_factory=dict)
    unsent: dict[str, int] = field(default_factory=dict)
    wall_s: float = 0.0


def replay(recording: Recording, endpoint: Endpoint, *, speed: float = 1.0, token: str | None = None,
           progress: Callable[[int], None] | None = None, stop: threading.Event | None = None) -> ReplayResult:
    """Replay a recording's skeletons as one live client (thread and socket) per camera.

    Each camera sends frame ``k`` at wall time ``(t_k - t_first) / speed`` after the start, with its
    own timestamp ``t_k`` (its own clock; ``t_first`` is the earliest timestamp of all cameras),
    then ``bye``. A camera whose frame cannot be queued in time (the server takes no frames: not
    listening, stopped, or refusing the token) stops there: its remaining frames count as unsent; so
    do all of a camera's frames when no server ever accepted its connection (frames queued for
    nobody).

    Parameters
    ----------
    recording : Recording
        Cameras with skeleton streams.
    endpoint : Endpoint
        The server.
    speed : float
        Replay speed (1 = real time); 0 sends as fast as possible.
    token : str or None
        Shared token.
    progress : callable or None
        Called with the number of frames each time a camera sent one.
    stop : threading.Event or None
        Set to stop all cameras early.
    """
    if not (np.isfinite(speed) and speed >= 0):
        raise BadInputError(f"speed must be >= 0 (0: as fast as possible), got {speed}")
    cameras = [c for c in recording.cameras if c.skeleton is not None and c.skeleton.n_frames]
    if not cameras:
        raise BadInputError("the recording has no skeleton frames to stream")
    t_first = min(c.skeleton.timestamps[0] for c in cameras)
    result = ReplayResult()
    stop = stop or threading.Event()
    start = time.perf_counter() + 0.2  # every client connected before the first frame

    def run(cam: CameraRecording) -> None:
        client = CameraClient(endpoint, cam.name, token=token)
        s = cam.skeleton
        sent = 0
        for k, (t, p, st) in enumerate(zip(s.timestamps, s.positions, s.states)):
            if stop.is_set():
                break
            wait = start + ((t - t_first) / speed if speed > 0 else 0.0) - time.perf_counter()
            if wait > 0:
                time.sleep(wait)
            if not client.send(s.topology, float(t), p, st):
                client.unsent += s.n_frames - k - 1  # the server takes nothing: the rest would wait in vain
                break
            sent += 1
            if progress:
                progress(1)
        if not client.reached(wait_s=1.0):
            client.unsent, sent = client.unsent + sent, 0
        if not client.unsent:
            client.bye()
        client.close(abrupt=bool(client.unsent))
        result.sent[cam.name], result.unsent[cam.name] = sent, client.unsent

    threads = [threading.Thread(target=run, args=(c,), name=f"camera-{c.name}") for c in cameras]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    result.wall_s = time.perf_counter() - start
    return result


class Subscriber:
    """A subscription to the server's publishing port.

    Parameters
    ----------
    endpoint : Endpoint
        The server's address.
    token : str or None
        Shared token, if the server requires one.
    """

    def __init__(self, endpoint: Endpoint, *, token: str | None = None, context: zmq.Context | None = None) -> None:
        self._socket = secure((context or zmq.Context.instance()).socket(zmq.SUB), token, server=False)
        self._socket.setsockopt(zmq.SUBSCRIBE, b"")
        self._socket.setsockopt(zmq.LINGER, 0)
        self._socket.connect(endpoint.publish_url())

    def receive(self, timeout_s: float) -> tuple[MessageType, dict] | None:
        """The next message (type, unpacked map), or None after ``timeout_s`` [s] without one."""
        if not self._socket.poll(int(1e3 * timeout_s)):
            return None
        body = unpack(self._socket.recv())
        try:
            return MessageType(body.get("type")), body
        except ValueError:
            raise ProtocolError(Reject.FIELDS, f"unknown message type {body.get('type')!r}") from None

    def close(self) -> None:
        """Close the subscription."""
        self._socket.close()


@dataclass
class Collected:
    """A fused stream as received: frames in order, topology, the last status, and whether ``end`` came."""

    frames: list[FusedFrame] = field(default_factory=list)
    topology: Topology | None = None
    status: dict = field(default_factory=dict)
    ended: bool = False


def collect(subscriber: Subscriber, *, idle_timeout_s: float = 10.0, max_frames: int | None = None,
            stop: threading.Event | None = None, progress: Callable[[int], None] | None = None) -> Collected:
    """Receive fused frames until the server's ``end``, ``idle_timeout_s`` [s] without any message,
    ``max_frames`` frames, or ``stop``."""
    if not (np.isfinite(idle_timeout_s) and idle_timeout_s > 0):
        raise BadInputError(f"the idle timeout must be a positive number of seconds, got {idle_timeout_s}")
    if max_frames is not None and max_frames < 1:
        raise BadInputError(f"max_frames must be >= 1, got {max_frames}")
    out = Collected()
    last = time.perf_counter()
    while not (stop is not None and stop.is_set()) and (max_frames is None or len(out.frames) < max_frames):
        message = subscriber.receive(min(idle_timeout_s, 0.2))
        if message is None:
            if time.perf_counter() - last > idle_timeout_s:
                break
            continue
        last = time.perf_counter()
        kind, body = message
        if kind is MessageType.FUSED:
            frame, out.topology = decode_fused(body)
            out.frames.append(frame)
            if progress:
                progress(1)
        elif kind in (MessageType.STATUS, MessageType.END):
            out.status = body.get("status", {})
            if kind is MessageType.END:
                out.ended = True
                break
    return out


def frames_recording(frames: list[FusedFrame], topology: Topology, metadata: dict | None = None) -> Recording:
    """Fused frames as a one-camera recording named ``fused`` in the world frame (the ``fuse`` layout)."""
    if not frames:
        raise BadInputError("no fused frames to write: did the cameras reach the server and is it calibrated?")
    stream = SkeletonStream(topology, np.array([f.time for f in frames]), np.array([f.positions for f in frames]),
                            np.array([f.states for f in frames]))
    meta = {"source": "live fusion", "frame": "world",
            "incomplete_instants": int(sum(not f.complete for f in frames))} | (metadata or {})
    return Recording((CameraRecording("fused", Intrinsics(), stream),), meta)
