"""The live fusion protocol, version 1: what camera clients, the server and subscribers exchange.

Transport: ZeroMQ over TCP. The server binds two ports on one host (loopback, 127.0.0.1, unless
told otherwise):

- ``PORT`` (a PULL socket): camera clients connect PUSH sockets and send one message per camera
  frame (``frame``), and ``bye`` when their stream ends;
- ``PORT + 1`` (a PUB socket): subscribers connect SUB sockets and receive ``fused`` frames, a
  ``status`` message about once a second and ``end`` when the server stops.

Every message is one ZeroMQ frame holding one msgpack map with the keys ``v`` (protocol version,
1), ``type`` and the fields below. Arrays travel as raw little-endian bytes in joint order of the
named topology. Times are seconds; positions metres.

``frame`` (client -> server)
    ``sensor`` str (camera name: letters, digits, ``-``, ``_``), ``seq`` int (per-client frame
    counter), ``t`` float (timestamp on the camera's own clock), ``topology`` str
    (:func:`fusion.topology.topology_by_name`), ``positions`` bytes (J x 3 float64, camera frame,
    NaN = joint absent), ``states`` bytes (J int8 tracking states), and ``token`` str when the
    server requires one.
``bye`` (client -> server)
    ``sensor``, optional ``token``: the camera's stream ended (the server stops waiting for it).
``fused`` (server -> subscribers)
    ``index`` int (instant counter), ``t`` float (reference camera's clock), ``topology``,
    ``positions`` bytes (J x 3 float64, world frame), ``states`` bytes (J int8: 2 tracked by at
    least one camera, 1 inferred or back-facing only, 0 absent), ``reliability`` bytes (J int8,
    :class:`fusion.merge.methods.Reliability`), ``cameras`` list of str (cameras that contributed
    a frame to this instant), ``complete`` bool (False: merged at its deadline without them all).
``status`` (server -> subscribers)
    ``status`` map: counters (frames accepted, rejected by reason, dropped at the queue bound,
    late, duplicates), per camera (frames, last time, silent, observed clock drift), the
    calibration in use and its quality, latency percentiles, CPU time and peak memory.
``end`` (server -> subscribers)
    The server stops; ``status`` as above.

A message that does not decode, lacks a field, has a wrong type, a wrong version, an unknown
topology, arrays of the wrong size, non-finite times, or more than ``max_bytes`` bytes is rejected
and counted under its reason; it never disturbs other clients. Listening beyond loopback requires
a shared token: every client message must carry it (and ZeroMQ's PLAIN mechanism checks it on both
sockets).
"""

from __future__ import annotations

import enum
import ipaddress
import re
import socket
from dataclasses import dataclass
from typing import Any

import msgpack
import numpy as np

from fusion.errors import BadInputError, BenchError
from fusion.topology import Topology, TrackingState, topology_by_name

VERSION = 1
"""Protocol version carried in every message as ``v``."""

MAX_MESSAGE_BYTES = 65536
"""Default largest accepted message [bytes] (a 32-joint frame is about 1 kB)."""

_SENSOR = re.compile(r"^[A-Za-z0-9_-]{1,64}$")


class ProtocolError(BadInputError):
    """A message that breaks the protocol; ``reason`` names the rule (a :class:`Reject` value)."""

    def __init__(self, reason: "Reject", message: str):
        self.reason = reason
        super().__init__(f"{reason.value}: {message}")


class Reject(enum.Enum):
    """Why a client message was rejected (the counters of the server's status)."""

    OVERSIZED = "oversized"
    UNDECODABLE = "undecodable"
    VERSION = "version"
    FIELDS = "fields"
    TOPOLOGY = "topology"
    ARRAYS = "arrays"
    TOKEN = "token"


class MessageType(enum.Enum):
    """The ``type`` field."""

    FRAME = "frame"
    BYE = "bye"
    FUSED = "fused"
    STATUS = "status"
    END = "end"


@dataclass(frozen=True, eq=False)
class CameraFrame:
    """One camera frame as received.

    Attributes
    ----------
    sensor : str
        Camera name.
    seq : int
        Client's frame counter.
    timestamp : float
        Seconds on the camera's clock.
    topology : Topology
        Joint set (J joints).
    positions : np.ndarray
        (J, 3) float64 metres in the camera frame; NaN where absent.
    states : np.ndarray
        (J,) int8 tracking states; 0 wherever positions are NaN.
    """

    sensor: str
    seq: int
    timestamp: float
    topology: Topology
    positions: np.ndarray
    states: np.ndarray

    def __post_init__(self) -> None:
        J = self.topology.n_joints
        pos = np.array(self.positions, dtype=np.float64).reshape(-1, 3) if np.size(self.positions) == 3 * J else None
        st = np.asarray(self.states)
        if not isinstance(self.sensor, str) or not _SENSOR.match(self.sensor):
            raise ProtocolError(Reject.FIELDS, f"sensor must be 1-64 letters, digits, '-' or '_', got {self.sensor!r}")
        if not np.isfinite(self.timestamp):
            raise ProtocolError(Reject.FIELDS, f"timestamp must be finite, got {self.timestamp}")
        if pos is None or st.shape != (J,) or not np.issubdtype(st.dtype, np.integer):
            raise ProtocolError(Reject.ARRAYS, f"need {J} x 3 positions and {J} integer states for "
                                f"{self.topology.name}")
        if np.isinf(pos).any() or st.min(initial=0) < 0 or st.max(initial=0) > max(TrackingState):
            raise ProtocolError(Reject.ARRAYS, "positions must be finite or NaN and states in 0..3")
        st = st.astype(np.int8)
        absent = np.isnan(pos).any(axis=1)
        st[absent] = TrackingState.NOT_TRACKED
        pos[st == TrackingState.NOT_TRACKED] = np.nan
        for arr in (pos, st):
            arr.setflags(write=False)
        object.__setattr__(self, "positions", pos)
        object.__setattr__(self, "states", st)
        object.__setattr__(self, "timestamp", float(self.timestamp))


@dataclass(frozen=True, eq=False)
class FusedFrame:
    """One merged instant.

    Attributes
    ----------
    index : int
        Instant counter from 0.
    time : float
        Reference camera's timestamp [s].
    positions : np.ndarray
        (J, 3) float64 world positions [m]; NaN where absent.
    states : np.ndarray
        (J,) int8 states of :meth:`fusion.merge.methods.MergedSkeleton.to_stream`.
    reliability : np.ndarray
        (J,) int8 :class:`fusion.merge.methods.Reliability`.
    cameras : tuple of str
        Cameras that had a frame at or after the instant when it was merged.
    complete : bool
        False when merged at the deadline without every camera.
    ready_at : float
        Wall-clock time [s] (the server's clock) at which the instant's last needed frame arrived.
    """

    index: int
    time: float
    positions: np.ndarray
    states: np.ndarray
    reliability: np.ndarray
    cameras: tuple[str, ...]
    complete: bool
    ready_at: float


def encode_frame(frame: CameraFrame, *, token: str | None = None) -> bytes:
    """The ``frame`` message of one camera frame."""
    body = {"v": VERSION, "type": MessageType.FRAME.value, "sensor": frame.sensor, "seq": int(frame.seq),
            "t": frame.timestamp, "topology": frame.topology.name,
            "positions": frame.positions.astype("<f8").tobytes(), "states": frame.states.astype("i1").tobytes()}
    return _pack(body, token)


def encode_bye(sensor: str, *, token: str | None = None) -> bytes:
    """The ``bye`` message of a camera whose stream ended."""
    return _pack({"v": VERSION, "type": MessageType.BYE.value, "sensor": sensor}, token)


def _pack(body: dict[str, Any], token: str | None) -> bytes:
    if token is not None:
        body["token"] = token
    return msgpack.packb(body, use_bin_type=True)


def decode_client_message(data: bytes, *, token: str | None = None,
                          max_bytes: int = MAX_MESSAGE_BYTES) -> CameraFrame | str:
    """Check and decode a client message.

    Parameters
    ----------
    data : bytes
        One ZeroMQ message.
    token : str or None
        The shared token the server requires, or None.
    max_bytes : int
        Largest accepted size [bytes].

    Returns
    -------
    CameraFrame or str
        The frame, or for ``bye`` the sensor name.

    Raises
    ------
    ProtocolError
        With the :class:`Reject` reason.
    """
    if len(data) > max_bytes:
        raise ProtocolError(Reject.OVERSIZED, f"{len(data)} bytes > {max_bytes}")
    body = unpack(data)
    if token is not None and body.get("token") != token:
        raise ProtocolError(Reject.TOKEN, "missing or wrong token")
    kind = body.get("type")
    sensor = body.get("sensor")
    if kind == MessageType.BYE.value and isinstance(sensor, str) and _SENSOR.match(sensor):
        return sensor
    if kind != MessageType.FRAME.value:
        raise ProtocolError(Reject.FIELDS, f"a client sends 'frame' or 'bye' with a sensor name, got type {kind!r}")
    fields = {"sensor": str, "seq": int, "t": (float, int), "topology": str, "positions": bytes, "states": bytes}
    wrong = [k for k, kind_ in fields.items() if not isinstance(body.get(k), kind_) or isinstance(body.get(k), bool)]
    if wrong:
        raise ProtocolError(Reject.FIELDS, f"missing or mistyped field(s) {', '.join(wrong)}")
    try:
        topology = topology_by_name(body["topology"])
    except BenchError as exc:
        raise ProtocolError(Reject.TOPOLOGY, str(exc)) from None
    J = topology.n_joints
    if len(body["positions"]) != 24 * J or len(body["states"]) != J:
        raise ProtocolError(Reject.ARRAYS, f"{topology.name} needs {24 * J} position bytes and {J} state bytes")
    return CameraFrame(body["sensor"], body["seq"], body["t"], topology,
                       np.frombuffer(body["positions"], "<f8").reshape(J, 3), np.frombuffer(body["states"], "i1"))


def unpack(data: bytes) -> dict[str, Any]:
    """The msgpack map of a message of this protocol version.

    Raises
    ------
    ProtocolError
        Not a msgpack map (UNDECODABLE) or another version (VERSION).
    """
    try:
        body = msgpack.unpackb(data, raw=False, strict_map_key=True)
    except Exception as exc:  # msgpack raises several unrelated types on garbage
        raise ProtocolError(Reject.UNDECODABLE, f"not a msgpack message ({type(exc).__name__})") from None
    if not isinstance(body, dict):
        raise ProtocolError(Reject.UNDECODABLE, f"a message is a msgpack map, got {type(body).__name__}")
    if body.get("v") != VERSION:
        raise ProtocolError(Reject.VERSION, f"protocol version {body.get('v')!r}; this server speaks {VERSION}")
    return body


def encode_server_message(kind: MessageType, fields: dict[str, Any]) -> bytes:
    """A ``fused``, ``status`` or ``end`` message with the given fields."""
    return msgpack.packb({"v": VERSION, "type": kind.value} | fields, use_bin_type=True)


def encode_fused(frame: FusedFrame, topology: Topology) -> bytes:
    """The ``fused`` message of one merged instant."""
    return encode_server_message(MessageType.FUSED, {
        "index": frame.index, "t": frame.time, "topology": topology.name,
        "positions": np.asarray(frame.positions, "<f8").tobytes(), "states": np.asarray(frame.states, "i1").tobytes(),
        "reliability": np.asarray(frame.reliability, "i1").tobytes(), "cameras": list(frame.cameras),
        "complete": bool(frame.complete)})


def decode_fused(body: dict[str, Any]) -> tuple[FusedFrame, Topology]:
    """The merged instant of an unpacked ``fused`` message, and its topology.

    Raises
    ------
    ProtocolError
        A field is missing or malformed.
    """
    try:
        topology = topology_by_name(body["topology"])
        J = topology.n_joints
        frame = FusedFrame(int(body["index"]), float(body["t"]),
                           np.frombuffer(body["positions"], "<f8").reshape(J, 3).copy(),
                           np.frombuffer(body["states"], "i1").reshape(J).copy(),
                           np.frombuffer(body["reliability"], "i1").reshape(J).copy(),
                           tuple(body["cameras"]), bool(body["complete"]), np.nan)
    except (KeyError, TypeError, ValueError, BenchError) as exc:
        raise ProtocolError(Reject.FIELDS, f"malformed fused message ({exc})") from None
    return frame, topology


@dataclass(frozen=True)
class Endpoint:
    """A ``HOST:PORT`` address; the server uses ``PORT`` for frames and ``PORT + 1`` for subscribers."""

    host: str
    port: int

    def __post_init__(self) -> None:
        if not 1 <= self.port <= 65534:
            raise BadInputError(f"port must lie in 1..65534 (the next port publishes), got {self.port}")

    @classmethod
    def parse(cls, text: str) -> "Endpoint":
        """``HOST:PORT`` (e.g. ``127.0.0.1:5570``)."""
        host, sep, port = str(text).rpartition(":")
        if not sep or not host or not port.isdigit():
            raise BadInputError(f"an address is HOST:PORT, e.g. 127.0.0.1:5570; got {text!r}")
        return cls(host, int(port))

    @classmethod
    def free_loopback(cls) -> "Endpoint":
        """An endpoint on 127.0.0.1 whose two ports are free now."""
        for _ in range(50):
            with socket.socket() as a, socket.socket() as b:
                a.bind(("127.0.0.1", 0))
                port = a.getsockname()[1]
                try:
                    b.bind(("127.0.0.1", port + 1))
                except OSError:
                    continue
                return cls("127.0.0.1", port)
        raise BadInputError("no two consecutive free TCP ports on 127.0.0.1")

    @property
    def loopback(self) -> bool:
        """True for a loopback address (127.0.0.0/8, ::1 or ``localhost``)."""
        if self.host == "localhost":
            return True
        try:
            return ipaddress.ip_address(self.host.strip("[]")).is_loopback
        except ValueError:
            return False

    def frames_url(self) -> str:
        """ZeroMQ URL of the frame port."""
        return f"tcp://{self.host}:{self.port}"

    def publish_url(self) -> str:
        """ZeroMQ URL of the publishing port."""
        return f"tcp://{self.host}:{self.port + 1}"
