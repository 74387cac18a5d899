"""Live fusion runs: writing a fused stream to disk, and the loopback load test.

The load test starts a ``serve`` process on 127.0.0.1, streams a simulated ring session (looped to
the requested stream length) as one client per camera, collects the fused stream, and reports what
the server measured: latency from an instant's last camera frame to its fused frame, frames lost,
CPU time and peak memory. Traffic never leaves the loopback interface.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from fusion.calibration import Calibration
from fusion.errors import BenchError
from fusion.io.atomic import atomic_directory
from fusion.io.calibration_file import save_calibration
from fusion.io.recording_files import save_recording
from fusion.live.client import Subscriber, collect, frames_recording, replay
from fusion.live.protocol import Endpoint, FusedFrame
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import Topology


def write_stream(out: str | os.PathLike, frames: list[FusedFrame], topology: Topology, status: dict[str, Any],
                 metadata: dict[str, Any] | None = None, *, overwrite: bool = False) -> Path:
    """Write fused frames atomically as ``out/recording/`` (the ``fuse`` layout) and ``out/status.json``."""
    with atomic_directory(out, overwrite=overwrite) as tmp:
        save_recording(frames_recording(frames, topology, metadata), tmp / "recording")
        (tmp / "status.json").write_text(json.dumps(status, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    return Path(out)


def looped(recording: Recording, stream_s: float) -> Recording:
    """The recording's skeletons repeated end to end (each camera's timestamps shifted by whole
    periods of the session) until ``stream_s`` seconds; depth frames are left out."""
    cams = [c for c in recording.cameras if c.skeleton is not None and c.skeleton.n_frames > 1]
    start = min(c.skeleton.timestamps[0] for c in cams)
    step = float(np.median(np.diff(cams[0].skeleton.timestamps)))
    period = max(c.skeleton.timestamps[-1] for c in cams) - start + step
    repeats = int(np.ceil(stream_s / period))
    out = []
    for c in cams:
        s = c.skeleton
        keep = [s.timestamps + k * period for k in range(repeats)]
        times = np.concatenate(keep)
        n = int(np.searchsorted(times, start + stream_s))
        out.append(CameraRecording(c.name, c.intrinsics, SkeletonStream(
            s.topology, times[:n], np.tile(s.positions, (repeats, 1, 1))[:n], np.tile(s.states, (repeats, 1))[:n])))
    return Recording(tuple(out), dict(recording.metadata) | {"looped_to_s": stream_s})


def recording_span(recording: Recording) -> float:
    """Seconds from the first to the last skeleton frame of any camera."""
    cams = [c.skeleton for c in recording.cameras if c.skeleton is not None and c.skeleton.n_frames]
    return float(max(s.timestamps[-1] for s in cams) - min(s.timestamps[0] for s in cams))


def load_test_session(scenario: str, duration_s: float, stream_s: float) -> tuple[Recording, Calibration]:
    """A scenario simulated for ``duration_s`` [s], calibrated from the body (skeletons only, the
    scenario's seed) and looped to ``stream_s`` [s] of stream (:func:`looped`)."""
    from fusion.calibrate.options import CalibrationOptions, Refinement
    from fusion.calibrate.pipeline import calibrate_rig
    from fusion.calibrate.results import calibration_from_rig
    from scenarios.config import load_scenario
    from scenarios.runner import simulate

    sc = load_scenario(scenario).replace(duration_s=duration_s)
    recording, _ = simulate(sc, progress=False)
    rig = calibrate_rig(recording, CalibrationOptions(refine=Refinement.NONE), rng=np.random.default_rng(sc.seed))
    return looped(recording, stream_s), calibration_from_rig(rig)


def load_test(recording: Recording, calibration: Calibration, *, speed: float, method: str = "avg_frontal",
              deadline_ms: float = 100.0, queue_size: int = 4096, progress: bool = True) -> dict[str, Any]:
    """Stream ``recording`` through a ``serve`` process on loopback and report the server's figures.

    Returns
    -------
    dict
        ``stream_s``, ``speed``, ``wall_s``, ``cameras``, ``frames_sent``, ``fused_received``,
        ``instants_expected`` (reference frames), ``lost`` (sent - accepted, and dropped at the
        queue), ``latency_ms`` (p50, p99, max), ``server_cpu_s``, ``server_max_rss_mb``, the
        server's final status.
    """
    endpoint = Endpoint.free_loopback()
    port = endpoint.port
    with tempfile.TemporaryDirectory() as tmp:
        calib = save_calibration(calibration, Path(tmp) / "calib.toml")
        cmd = [sys.executable, "-m", "scenarios.cli", "serve", "--calib", str(calib), "--listen", f"127.0.0.1:{port}",
               "--method", method, "--deadline-ms", str(deadline_ms), "--queue", str(queue_size), "--exit-when-done",
               "--quiet"]
        server = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        try:
            subscriber = Subscriber(endpoint)
            time.sleep(1.0)  # server bound, subscription established
            result: dict[str, Any] = {}
            listener = threading.Thread(target=lambda: result.update(c=collect(subscriber, idle_timeout_s=30.0)))
            listener.start()
            total = sum(c.skeleton.n_frames for c in recording.cameras)
            with tqdm(total=total, desc=f"stream x{speed:g}", unit="frame", leave=False,
                      **({} if progress else {"disable": True})) as bar:  # TQDM_DISABLE applies
                sent = replay(recording, endpoint, speed=speed, progress=bar.update)
            try:  # a server behind on its queue catches up, then says end
                server.wait(timeout=120.0 + (recording_span(recording) / speed if speed > 0 else 0.0))
            except subprocess.TimeoutExpired:
                server.send_signal(signal.SIGTERM)  # graceful: merges what is pending, publishes end
                server.wait(timeout=60)
            listener.join()
            subscriber.close()
        finally:
            if server.poll() is None:
                server.terminate()
                server.wait(timeout=10)
        if server.returncode != 0:
            raise BenchError(f"serve exited with {server.returncode}: {server.stderr.read()[-2000:]}")
    collected = result["c"]
    status = collected.status
    ref = calibration.reference
    counts = status.get("counts", {})
    return {
        "stream_s": round(recording_span(recording), 3), "speed": speed, "wall_s": round(sent.wall_s, 3),
        "cameras": len(recording.cameras), "frames_sent": int(sum(sent.sent.values())),
        "frames_unsent": int(sum(sent.unsent.values())),
        "instants_expected": int(recording.camera(ref).skeleton.n_frames), "fused_received": len(collected.frames),
        "end_received": collected.ended,
        "lost": {"not_accepted": int(sum(sent.sent.values()) - counts.get("accepted", 0)),
                 "dropped_queue": counts.get("dropped_queue", 0)},
        "incomplete_instants": int(sum(not f.complete for f in collected.frames)),
        "latency_ms": status.get("latency_ms", {}), "server_cpu_s": status.get("cpu_s"),
        "server_max_rss_mb": status.get("max_rss_mb"), "status": status,
    }
