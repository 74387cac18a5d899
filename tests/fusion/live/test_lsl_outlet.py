"""The LSL outlet on loopback: a real pylsl inlet receives the offline fused skeleton, frame for frame,
with the cameras' own frame spacing on LSL's clock, under the MoCap meta-data of the XDF conventions."""

import os
import socket
import sys
import time

import numpy as np
import pytest

from fusion.calibration import Calibration
from fusion.errors import BadInputError
from fusion.live.client import CameraClient, replay
from fusion.live.engine import EngineOptions
from fusion.live.lsl_outlet import LslOptions, LslOutlet, lsl_sample, lsl_source_id
from fusion.live.protocol import Endpoint, FusedFrame
from fusion.live.server import FusionServer, ServerConfig
from fusion.merge.causal import fuse_causal
from fusion.topology import K4ABT, KINECT_V2
from tests.fusion.live.fakes import session
from tests.fusion.live.lsl_inlet import check_samples, open_inlet, pull_all


def _name(tag):
    return f"mocap-bench-test-{tag}-{os.getpid()}"


@pytest.fixture
def pylsl():
    return pytest.importorskip("pylsl")


def test_a_streamed_recording_reaches_an_lsl_inlet_as_offline_fusion(pylsl):
    recording, calibration = session(rng=np.random.default_rng(21), n_cameras=3, seconds=2.0)
    endpoint = Endpoint.free_loopback()
    options = EngineOptions(deadline_s=np.inf, silent_after_s=np.inf)
    name = _name("server")
    server = FusionServer(ServerConfig(endpoint, lsl=LslOptions(name, KINECT_V2, 30.0)), options, calibration,
                          rng=np.random.default_rng(0))
    try:
        inlet, _ = open_inlet(pylsl, name)
        before = pylsl.local_clock()
        replay(recording, endpoint, speed=0.0)
        offline = fuse_causal(recording, calibration, options.fuse).to_stream(recording.topology)
        samples, stamps = pull_all(inlet, offline.n_frames)
        after = pylsl.local_clock()  # every frame arrived at the server by now
        deadline = time.perf_counter() + 30
        while not server.done() and time.perf_counter() < deadline:
            time.sleep(0.05)
    finally:
        result = server.stop()
    assert len(result.frames) == offline.n_frames == len(stamps)
    check_samples(samples, offline.positions, offline.states)
    offset = stamps - offline.timestamps  # one offset: the cameras' frame spacing, kept to 1 us
    assert np.ptp(offset) <= 1e-6 and np.all(np.diff(stamps) > 0)
    assert before <= stamps[0] <= after  # the first instant's arrival at the server, on LSL's clock
    lsl = result.status["lsl"]
    assert lsl["name"] == name and lsl["pushed"] == offline.n_frames
    assert abs(lsl["offset_s"] - offset[0]) <= 1e-6


def test_the_description_follows_the_mocap_conventions(pylsl):
    _, calibration = session(rng=np.random.default_rng(22), n_cameras=2, seconds=0.5)
    name = _name("desc")
    options = LslOptions(name, K4ABT, 15.0)
    outlet = LslOutlet(options, calibration, {"method": "avg_frontal"})
    try:
        _, info = open_inlet(pylsl, name)
    finally:
        outlet.close()
    J = K4ABT.n_joints
    assert info.findtext("type") == "MoCap" and info.findtext("channel_format") == "float32"
    assert int(info.findtext("channel_count")) == 4 * J and float(info.findtext("nominal_srate")) == 15.0
    assert info.findtext("source_id") == lsl_source_id(options, calibration)
    channels = info.findall("desc/channels/channel")
    assert [c.findtext("label") for c in channels[:4]] == ["PELVIS_X", "PELVIS_Y", "PELVIS_Z", "PELVIS_Confidence"]
    assert [c.findtext("label") for c in channels[4::4]] == [f"{j}_X" for j in K4ABT.joints[1:]]
    assert [c.findtext("marker") for c in channels[::4]] == list(K4ABT.joints)
    assert [c.findtext("type") for c in channels[-4:]] == ["PositionX", "PositionY", "PositionZ", "Confidence"]
    assert [c.findtext("unit") for c in channels[-4:]] == ["meters"] * 3 + ["normalized"]
    assert info.findtext("desc/acquisition/manufacturer") == "mocap-bench"
    assert info.findtext("desc/acquisition/settings/method") == "avg_frontal"
    assert info.findtext("desc/setup/topology") == "k4abt" and info.findtext("desc/setup/name") == name
    cameras = info.findall("desc/setup/cameras/camera")
    assert [c.findtext("label") for c in cameras] == list(calibration.camera_names)
    x = float(cameras[1].findtext("position/X"))
    assert abs(x - calibration.T_world_cam["cam2"][0, 3]) <= 1e-6
    markers = info.findall("desc/setup/markers/marker")
    assert markers[0].findtext("parent") == "" and markers[1].findtext("parent") == "PELVIS"


def test_the_source_id_depends_on_name_joints_and_calibration_only():
    _, calibration = session(rng=np.random.default_rng(23), n_cameras=2, seconds=0.5)
    options = LslOptions("fused")
    assert lsl_source_id(options, calibration) == lsl_source_id(LslOptions("fused"), calibration)
    moved = dict(calibration.T_world_cam) | {"cam2": calibration.T_world_cam["cam2"].copy()}
    moved["cam2"][0, 3] += 0.01
    other = Calibration(moved, calibration.intrinsics, calibration.clock_offset_s, calibration.reference)
    ids = {lsl_source_id(options, calibration), lsl_source_id(options, other), lsl_source_id(LslOptions("x"), None),
           lsl_source_id(LslOptions("fused", K4ABT), calibration)}
    assert len(ids) == 4 and lsl_source_id(options, None).endswith(":body")


def test_a_sample_is_positions_and_confidence_per_joint():
    J = KINECT_V2.n_joints
    positions = np.arange(3.0 * J).reshape(J, 3)
    positions[4] = np.nan
    states = np.full(J, 2, dtype=np.int8)
    states[4], states[5] = 0, 1
    frame = FusedFrame(0, 1.0, positions, states, np.zeros(J, np.int8), ("cam1",), True, 0.0)
    sample = lsl_sample(frame)
    assert sample.dtype == np.float32 and sample.shape == (4 * J,)
    check_samples(sample[None].astype(np.float64), positions[None], states[None])


@pytest.mark.parametrize("kwargs", [{"name": ""}, {"name": "a\nb"}, {"name": "ok", "rate_hz": 0.0},
                                    {"name": "ok", "rate_hz": float("nan")}, {"name": "ok", "topology": "kinect_v2"}])
def test_bad_options_are_refused(kwargs):
    with pytest.raises(BadInputError):
        LslOptions(**kwargs)


def test_frames_of_another_joint_set_than_the_stream_are_not_fused(pylsl):
    recording, calibration = session(rng=np.random.default_rng(24), n_cameras=2, seconds=0.5)
    endpoint = Endpoint.free_loopback()
    server = FusionServer(ServerConfig(endpoint, lsl=LslOptions(_name("k4abt"), K4ABT)), EngineOptions(), calibration,
                          rng=np.random.default_rng(0))
    stream = recording.camera("cam1").skeleton  # Kinect v2 joints
    client = CameraClient(endpoint, "cam1")
    for k in range(3):
        client.send(stream.topology, stream.timestamps[k], stream.positions[k], stream.states[k])
    deadline = time.perf_counter() + 10
    while server.status()["counts"]["accepted"] < 3 and time.perf_counter() < deadline:
        time.sleep(0.05)
    client.close()
    result = server.stop()
    assert result.status["engine"]["wrong_topology"] == 3 and result.status["lsl"]["pushed"] == 0


def test_without_pylsl_the_error_says_what_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "pylsl", None)  # import pylsl raises ImportError
    with pytest.raises(BadInputError, match=r"pip install 'mocap-bench\[lsl\]'"):
        LslOutlet(LslOptions("fused"), None, {})
    endpoint = Endpoint.free_loopback()
    with pytest.raises(BadInputError, match="pylsl"):  # before any socket is bound
        FusionServer(ServerConfig(endpoint, lsl=LslOptions("fused")), rng=np.random.default_rng(0))
    with socket.socket() as s:
        s.bind(("127.0.0.1", endpoint.port))  # still free


def test_without_liblsl_the_error_says_what_to_reinstall(monkeypatch):
    import builtins

    real = builtins.__import__

    def no_liblsl(name, *args, **kwargs):
        if name == "pylsl":
            raise RuntimeError("LSL binary library file was not found")  # what pylsl raises
        return real(name, *args, **kwargs)

    monkeypatch.delitem(sys.modules, "pylsl", raising=False)
    monkeypatch.setattr(builtins, "__import__", no_liblsl)
    with pytest.raises(BadInputError, match="could not load its liblsl library"):
        LslOutlet(LslOptions("fused"), None, {})
