"""The server on loopback: a streamed recording fuses exactly as offline; faults during a stream
are survived and reported; tokens keep strangers out. Traffic stays on 127.0.0.1."""

import threading
import time

import numpy as np
import pytest
import zmq

from fusion.errors import BadInputError
from fusion.live.client import (
    CameraClient,
    Subscriber,
    collect,
    frames_recording,
    replay,
)
from fusion.live.engine import EngineOptions
from fusion.live.protocol import Endpoint, Reject
from fusion.live.server import FusionServer, ServerConfig
from fusion.merge.causal import fuse_causal
from fusion.topology import K4ABT, KINECT_V2
from tests.fusion.live.fakes import arrivals, session


def _listen(endpoint, out, **kw):
    subscriber = Subscriber(endpoint, **kw)
    thread = threading.Thread(target=lambda: out.update(c=collect(subscriber, idle_timeout_s=10.0)))
    time.sleep(0.3)  # the subscription reaches the publisher before the first frame
    thread.start()
    return thread


def test_a_streamed_recording_fuses_as_offline_frame_for_frame():
    recording, calibration = session(rng=np.random.default_rng(11), n_cameras=3, seconds=2.0)
    endpoint = Endpoint.free_loopback()
    options = EngineOptions(deadline_s=np.inf, silent_after_s=np.inf)
    server = FusionServer(ServerConfig(endpoint), options, calibration, rng=np.random.default_rng(0))
    got = {}
    listener = _listen(endpoint, got)
    sent = replay(recording, endpoint, speed=0.0)
    deadline = time.perf_counter() + 30
    while not server.done() and time.perf_counter() < deadline:
        time.sleep(0.05)
    result = server.stop()
    listener.join()
    assert sum(sent.sent.values()) == sum(c.skeleton.n_frames for c in recording.cameras)
    assert got["c"].ended and len(got["c"].frames) == len(result.frames)
    live = frames_recording(got["c"].frames, got["c"].topology).cameras[0].skeleton
    offline = fuse_causal(recording, calibration, options.fuse).to_stream(recording.topology)
    assert np.array_equal(live.timestamps, offline.timestamps)
    assert np.array_equal(np.isnan(live.positions), np.isnan(offline.positions))
    assert np.nanmax(np.abs(live.positions - offline.positions)) <= 1e-9
    assert np.array_equal(live.states, offline.states)
    assert result.status["counts"]["dropped_queue"] == 0


def test_faults_during_a_stream_are_survived_and_reported():
    """A client killed and restarted, 1,000 malformed messages, a clock stepped by 100 ms, a camera
    that goes silent: all during one real-time stream of four cameras."""
    recording, calibration = session(rng=np.random.default_rng(12), n_cameras=4, seconds=4.0)
    endpoint = Endpoint.free_loopback()
    server = FusionServer(ServerConfig(endpoint), EngineOptions(deadline_s=0.1, silent_after_s=0.5), calibration,
                          rng=np.random.default_rng(0))
    got = {}
    listener = _listen(endpoint, got)
    clients = {c.name: CameraClient(endpoint, c.name) for c in recording.cameras}
    rogue = zmq.Context.instance().socket(zmq.PUSH)
    rogue.connect(endpoint.frames_url())
    garbage = [b"\xc1", b"\x93\x01\x02\x03", b"\x00" * 70000, b'\x81\xa1v\x09']  # bad byte, array, oversized, version
    start, t0 = time.perf_counter() + 0.2, recording.camera("cam1").skeleton.timestamps[0]
    malformed = 0
    for arrival, (name, k) in arrivals(recording):
        stream = recording.camera(name).skeleton
        t = stream.timestamps[k]
        wait = start + (arrival - t0) - time.perf_counter()
        if wait > 0:
            time.sleep(wait)
        if name == "cam3" and 1.0 <= t < 1.8:
            if clients["cam3"] is not None:
                clients["cam3"].close(abrupt=True)  # killed
                clients["cam3"] = None
            continue
        if name == "cam3" and clients["cam3"] is None:
            clients["cam3"] = CameraClient(endpoint, "cam3")  # restarted
        if name == "cam4" and t >= 2.5:
            continue  # silent from here on
        while malformed < 1000 and t >= 1.2 and malformed < 1000 * (t - 1.2) / 1.5 + 1:
            rogue.send(garbage[malformed % len(garbage)])
            malformed += 1
        clients[name].send(stream.topology, t + (0.1 if name == "cam2" and t >= 1.5 else 0.0),
                           stream.positions[k], stream.states[k])
    for name, client in clients.items():
        if name != "cam4":
            client.bye()
        client.close()
    rogue.close(linger=1000)
    time.sleep(0.5)
    result = server.stop()
    listener.join()
    status = result.status
    counts = status["counts"]
    rejected = {r: counts[f"rejected_{r.value}"] for r in Reject}
    assert malformed == 1000 and sum(rejected.values()) == 1000
    assert rejected[Reject.OVERSIZED] == 250 and rejected[Reject.UNDECODABLE] == 500 and rejected[Reject.VERSION] == 250
    times = np.array([f.time for f in got["c"].frames])
    assert np.all(np.diff(times) > 0) and times[-1] > 3.8  # the fused stream went on to the end
    assert len(times) >= 0.9 * recording.camera("cam1").skeleton.n_frames
    during_kill = [f for f in got["c"].frames if 1.2 < f.time < 1.7]
    assert during_kill and all("cam3" not in f.cameras for f in during_kill)
    assert any("cam3" in f.cameras for f in got["c"].frames if f.time > 2.0)  # back after the restart
    cams = status["cameras"]
    assert all("cam4" not in f.cameras for f in got["c"].frames if f.time > 2.6)  # silent: not awaited
    assert cams["cam4"]["silent"] and not cams["cam4"]["ended"] and cams["cam4"]["last_time_s"] < 2.5
    assert cams["cam4"]["since_last_s"] > cams["cam1"]["since_last_s"] + 1.0
    assert abs(status["clock_steps_s"]["cam2"] + 0.1) < 0.03  # the 100 ms step, reported
    assert all(abs(status["clock_steps_s"][n]) < 0.03 for n in ("cam1", "cam3"))


def test_one_frame_of_another_joint_set_first_does_not_lock_the_session():
    recording, calibration = session(rng=np.random.default_rng(14), n_cameras=2, seconds=1.0)
    other = K4ABT if recording.topology != K4ABT else KINECT_V2
    endpoint = Endpoint.free_loopback()
    options = EngineOptions(deadline_s=np.inf, silent_after_s=np.inf)
    server = FusionServer(ServerConfig(endpoint), options, calibration, rng=np.random.default_rng(0))
    stray = CameraClient(endpoint, "cam1")
    stray.send(other, -1.0, np.full((other.n_joints, 3), 2.0), np.full(other.n_joints, 2))
    stray.close()
    time.sleep(0.2)
    replay(recording, endpoint, speed=0.0)
    deadline = time.perf_counter() + 30
    while not server.done() and time.perf_counter() < deadline:
        time.sleep(0.05)
    result = server.stop()
    assert result.topology == recording.topology
    assert result.status["engine"]["wrong_topology"] == 1
    offline = fuse_causal(recording, calibration, options.fuse)
    assert len(result.frames) == len(offline.times)  # before, the stray frame fixed the joint set: 0 fused


def test_a_token_keeps_clients_without_it_out():
    recording, calibration = session(rng=np.random.default_rng(13), n_cameras=2, seconds=0.5)
    endpoint = Endpoint.free_loopback()
    server = FusionServer(ServerConfig(endpoint, token="s3cret"), EngineOptions(), calibration,
                          rng=np.random.default_rng(0))
    stream = recording.camera("cam1").skeleton
    good = CameraClient(endpoint, "cam1", token="s3cret")
    bad = CameraClient(endpoint, "cam2", token="guess", send_timeout_s=0.2)
    stranger = CameraClient(endpoint, "cam2", send_timeout_s=0.2)
    for k in range(5):
        for client in (good, bad, stranger):
            client.send(stream.topology, stream.timestamps[k], stream.positions[k], stream.states[k])
    time.sleep(0.5)
    for client in (good, bad, stranger):
        client.close(abrupt=True)
    status = server.stop().status
    assert status["counts"]["accepted"] == 5 and status["counts"]["received"] == 5


def test_listening_beyond_loopback_needs_a_token():
    with pytest.raises(BadInputError, match="token"):
        ServerConfig(Endpoint("0.0.0.0", 5570))
    assert ServerConfig(Endpoint("0.0.0.0", 5570), token="t").token == "t"  # nothing is bound by a config


def _part(recording, lo, hi):
    from fusion.recording import CameraRecording, Recording

    return Recording(tuple(CameraRecording(c.name, c.intrinsics, c.skeleton.subset(
        (c.skeleton.timestamps >= lo) & (c.skeleton.timestamps < hi))) for c in recording.cameras))


def test_without_a_calibration_the_server_calibrates_from_the_body_and_then_fuses():
    from fusion.live.autocal import AutoCalibrationOptions

    recording, _ = session(rng=np.random.default_rng(14), n_cameras=3, seconds=10.0)
    endpoint = Endpoint.free_loopback()
    server = FusionServer(ServerConfig(endpoint), EngineOptions(), None, AutoCalibrationOptions(every_s=3.0),
                          rng=np.random.default_rng(0))
    replay(_part(recording, 0.0, 6.0), endpoint, speed=3.0)
    deadline = time.perf_counter() + 60
    while server.status()["calibration"].get("quality") is None and time.perf_counter() < deadline:
        time.sleep(0.1)  # the first attempt runs in the background
    replay(_part(recording, 6.0, 10.0), endpoint, speed=3.0)  # the cameras reconnect and go on
    time.sleep(0.3)
    result = server.stop()
    cal = result.status["calibration"]
    assert cal["source"] == "body" and cal["attempts"] >= 1 and cal["quality"]["pairs"]
    assert set(cal["cameras"]) == {"cam1", "cam2", "cam3"}
    times = np.array([f.time for f in result.frames])
    assert times.size > 60 and times[0] >= 3.0 and times[-1] > 9.5  # fused once calibrated, to the end
