"""Hostile cases of the live path: camera clients that send what the offline readers refuse (millimetres,
a stray timestamp, another joint set first, a name the calibration lacks), a stream with no server
and a listener that would wait forever.

A ``serve`` case starts a feeder thread that, once the server is up, streams the base session's frames
as fast as possible with the case's damage, then says ``bye``; ``serve --exit-when-done --out`` writes
what was fused. Correct is: the damaged frames refused and counted by reason, everything else fused.
See :mod:`scenarios.hostile.suite` for how a case is run and classified.
"""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from fusion.io.recording_files import load_recording
from fusion.live.client import CameraClient
from fusion.live.protocol import Endpoint
from fusion.topology import K4ABT, KINECT_V2, Topology
from scenarios.hostile.reader_cases import Base, Built
from scenarios.hostile.suite import Case, Expect

Frame = tuple[str, Topology, float, np.ndarray, np.ndarray]
"""What a client sends: camera name, joint set, timestamp [s], (J, 3) positions [m], (J,) states."""
Damage = Callable[[str, int, Frame], list[Frame]]
"""``damage(camera, frame index, frame)`` -> the frames sent instead (the frame itself to leave it)."""

_STARTUP_S = 1.0


def _feed(recording_dir: Path, endpoint: Endpoint, damage: Damage) -> None:
    """Stream every camera's frames in time order with ``damage`` applied, then ``bye``."""
    time.sleep(_STARTUP_S)  # the server binds when its command starts
    recording = load_recording(recording_dir)
    order = sorted((t, c.name, k) for c in recording.cameras for k, t in enumerate(c.skeleton.timestamps))
    clients: dict[str, CameraClient] = {}
    for t, name, k in order:
        s = recording.camera(name).skeleton
        for sensor, topology, ts, positions, states in damage(name, k, (name, s.topology, float(t), s.positions[k],
                                                                        s.states[k])):
            client = clients.get(sensor) or clients.setdefault(sensor, CameraClient(endpoint, sensor))
            client.send(topology, ts, positions, states)
    for client in clients.values():
        client.bye()
        client.close()


def _serve(base: Base, damage: Damage, reason: str, at_least: int) -> Callable[[Path], Built]:
    """``serve --calib --exit-when-done --out`` fed the base run with ``damage``; correct when the status
    counts ``at_least`` frames refused for ``reason`` and at least 90 % of the reference camera's
    frames were fused, every position within 5 m of the origin."""
    def build(d: Path) -> Built:
        endpoint = Endpoint.free_loopback()
        recording_dir = base.run / "recording"
        threading.Thread(target=_feed, args=(recording_dir, endpoint, damage), daemon=True).start()
        argv = ["serve", "--calib", str(base.calib), "--listen", f"{endpoint.host}:{endpoint.port}",
                "--exit-when-done", "--quiet", "--out", str(d / "out")]

        def check(dd: Path) -> str | None:
            status = json.loads((dd / "out" / "status.json").read_text())
            refused = status.get("engine", {}).get(reason, 0)
            if refused < at_least:
                return f"{refused} frames counted as {reason}, expected at least {at_least}"
            fused = load_recording(dd / "out" / "recording").cameras[0].skeleton
            n_ref = load_recording(recording_dir).cameras[0].skeleton.n_frames
            if fused.n_frames < 0.9 * n_ref:
                return f"fused {fused.n_frames} of {n_ref} instants"
            if np.nanmax(np.abs(fused.positions)) > 5.0:
                return f"fused positions up to {np.nanmax(np.abs(fused.positions)):.4g} m"
            return None
        return argv, check
    return build


def live_cases(base: Base) -> list[Case]:
    """Cases of ``serve``, ``stream`` and ``listen``."""
    def mm(name: str, k: int, f: Frame) -> list[Frame]:  # every fifth frame of cam2 also in millimetres
        bad = (f[0], f[1], f[2] - 1e-4, f[3] * 1000.0, f[4])
        return [bad, f] if name == "cam2" and k % 5 == 0 and k > 0 else [f]

    def stray(name: str, k: int, f: Frame) -> list[Frame]:  # one epoch-nanosecond timestamp
        return [(f[0], f[1], 1.7e18, f[3], f[4]), f] if name == "cam2" and k == 30 else [f]

    def other_first(name: str, k: int, f: Frame) -> list[Frame]:  # one frame of another joint set first
        other = K4ABT if f[1] != K4ABT else KINECT_V2
        first = (name, other, f[2] - 0.01, np.full((other.n_joints, 3), 2.0), np.full(other.n_joints, 2))
        return [first, f] if name == "cam1" and k == 0 else [f]

    def stranger(name: str, k: int, f: Frame) -> list[Frame]:  # a client under a name the calibration lacks
        return [f, ("cam9", *f[1:])] if name == "cam1" else [f]

    def no_server(d: Path) -> Built:
        return ["stream", str(base.run), "--to", f"127.0.0.1:{Endpoint.free_loopback().port}", "--speed", "0"], None

    R, E = Expect.RESULT, Expect.ERROR
    return [
        Case("serve: every fifth frame of a camera also sent in millimetres", "live", _serve(base, mm, "units", 50), R),
        Case("serve: one frame stamped in epoch nanoseconds", "live", _serve(base, stray, "clock", 1), R, quick=False),
        Case("serve: one frame of another joint set before the session's", "live",
             _serve(base, other_first, "wrong_topology", 1), R, quick=False),
        Case("serve: a client under a camera name the calibration lacks", "live",
             _serve(base, stranger, "unknown_camera", 100), R, quick=False),
        Case("stream to a port where no server listens", "live", no_server, E),
        Case("listen --timeout -1", "live", lambda d: (["listen", "127.0.0.1:5599", "--timeout", "-1", "--out",
                                                       str(d / "out")], None), E),
    ]
