"""Replay segments, the retarget command's errors, and replicas (clips of a known motion:
test_retarget_clips.py)."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fusion.calibration import Calibration
from fusion.errors import BadInputError, ScenarioError
from fusion.io.export import export_trc
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, TrackingState
from fusion.transforms import make_transform
from scenarios.cli import main
from scenarios.config import (
    SegmentKind,
    load_scenario,
    scenario_from_dict,
    scenario_toml,
)
from scenarios.runner import build_simulation, simulate
from scenarios.sensors.replica import build_replica, write_replica
from sim.anthropometry import Anthropometry
from sim.humanoid_model import build_humanoid
from sim.motions import hand_lift
from sim.patient_motion import Movement, Side, SubjectProfile
from sim.replay import load_motion


@pytest.fixture(scope="module")
def known():
    """A right-arm hand lift of a 1.68 m subject: (times, coordinates, joint positions)."""
    motion = hand_lift(Side.RIGHT, 1, SubjectProfile.healthy().movement(Movement.HAND_LIFT, Side.RIGHT),
                       rng=np.random.default_rng(2))
    t = np.arange(0.0, min(3.0, motion.duration), 1 / 30)
    coords = motion.sample(t)
    joints = build_humanoid(Anthropometry(height_m=1.68)).joint_positions(coords, KINECT_V2)
    return t, coords, joints


def _stream(t, joints) -> SkeletonStream:
    return SkeletonStream(KINECT_V2, t, joints, np.full(joints.shape[:2], TrackingState.TRACKED, np.int8))


def test_retarget_command_reports_bad_units_and_names(tmp_path, known, capsys):
    t, _, joints = known
    clip = export_trc(_stream(t, joints), tmp_path / "clip.trc", units="mm")
    assert main(["retarget", str(clip), "--out", str(tmp_path / "m.npz"), "--units", "m"]) == 2
    assert "implausible" in capsys.readouterr().err
    assert main(["retarget", str(clip), "--out", str(tmp_path / "m.npz"), "--marker-map", "body25"]) == 2
    assert "available" in capsys.readouterr().err


def _replay_doc(source, **replay):
    return {"scenario": {"name": "r"}, "session": {"segment": [{"kind": "replay", "replay": {"source": str(source)}
                                                                | replay}]},
            "sensors": {"depth_rate_hz": 0.0}}


def test_replay_segment_config_is_checked(tmp_path):
    s = scenario_from_dict(_replay_doc(tmp_path / "m.npz", start_s=1.0, end_s=2.0, position_m=[1.0, 0.0]))
    assert s.session[0].kind is SegmentKind.REPLAY and s.session[0].replay.end_s == 2.0
    with pytest.raises(ScenarioError, match="position_m"):
        scenario_from_dict(_replay_doc("x", position_m=[1.0]))
    with pytest.raises(ScenarioError, match="end_s"):
        scenario_from_dict(_replay_doc("x", start_s=2.0, end_s=1.0))
    with pytest.raises(ScenarioError, match="unknown key 'speed'"):
        scenario_from_dict(_replay_doc("x", speed=2.0))
    doc = _replay_doc("x")
    del doc["session"]["segment"][0]["replay"]
    with pytest.raises(ScenarioError, match="replay"):
        scenario_from_dict(doc)
    with pytest.raises(ScenarioError, match="does not exist"):
        build_simulation(scenario_from_dict(_replay_doc(tmp_path / "missing.npz")))


def test_a_scenario_replays_a_motion_file_without_refitting(tmp_path, known):
    t, _, joints = known
    clip = export_trc(_stream(t, joints), tmp_path / "clip.trc")
    assert main(["retarget", str(clip), "--out", str(tmp_path / "m.npz")]) == 0
    scenario = scenario_from_dict(_replay_doc(tmp_path / "m.npz", start_s=0.5, end_s=2.5))
    sim = build_simulation(scenario)
    assert sim.motion.duration == pytest.approx(2.0, abs=1e-6)
    assert sim.humanoid.anthro.height_m == pytest.approx(1.68, abs=0.01)
    recording, truth = simulate(scenario, progress=False)
    # the simulated truth replays the known motion (sampled on the reference track from 0.5 s on)
    expected = joints[15 : 15 + truth.times.size]
    err = np.linalg.norm(truth.joints_world - expected, axis=-1)
    assert np.median(err) < 0.01
    assert recording.topology == KINECT_V2


def test_retarget_keeps_an_existing_motion_file_unless_overwrite(tmp_path, known, capsys):
    t, _, joints = known
    clip = export_trc(_stream(t[:20], joints[:20]), tmp_path / "clip.trc")
    out = tmp_path / "m.npz"
    assert main(["retarget", str(clip), "--out", str(out)]) == 0
    before = out.read_bytes()
    capsys.readouterr()
    assert main(["retarget", str(clip), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert str(out) in err and "choose another path or pass --overwrite" in err
    assert out.read_bytes() == before
    assert main(["retarget", str(clip), "--out", str(out), "--overwrite"]) == 0
    assert load_motion(out).times.size == 20


def test_replica_places_cameras_and_replays_the_session(tmp_path):
    base = load_scenario("fma_2cam").replace(duration_s=4.0)
    recording, truth = simulate(base.replace(sensors=dataclasses.replace(base.sensors, depth_rate_hz=0.0)),
                                progress=False)
    ref = truth.cameras[0]
    # a calibration whose cameras are rolled about their optical axes by 7 and -11 degrees
    rolled = {c.name: c.T_world_cam @ make_transform(Rotation.from_euler("z", roll, degrees=True).as_matrix(),
                                                       np.zeros(3))
              for c, roll in zip(truth.cameras, (7.0, -11.0))}
    calib = Calibration(rolled, {c.name: c.intrinsics for c in recording.cameras},
                        {c.name: c.clock_offset_s - ref.clock_offset_s for c in truth.cameras}, ref.name)
    replica = build_replica(recording, calib, name="rep", motion_path=tmp_path / "rep.motion.npz")
    scenario_path, motion_path = write_replica(replica, tmp_path / "rep.toml")
    s = load_scenario(scenario_path)
    for cam, placed in zip(s.rig.camera, truth.cameras):
        np.testing.assert_allclose(cam.position_m, placed.T_world_cam[:3, 3], atol=1e-9)
        np.testing.assert_allclose(np.subtract(cam.target_m, cam.position_m), placed.T_world_cam[:3, 2], atol=1e-9)
        np.testing.assert_allclose(cam.up_m, rolled[cam.name][:3, 1], atol=1e-9)
    assert s.subject.topology == "kinect_v2" and s.session[0].replay.source == str(motion_path)
    assert tomllib.loads(scenario_toml(s))["scenario"]["name"] == "rep"
    sim = build_simulation(s)
    for placed in sim.rig.cameras:  # the simulated cameras are exactly the calibrated ones, roll included
        np.testing.assert_allclose(placed.T_world_cam, rolled[placed.name], atol=1e-9)
    assert sim.humanoid.anthro == load_motion(motion_path).anthropometry
    assert replica.result.failed_frames.size < replica.result.times.size // 10


def test_replica_refuses_a_calibration_missing_a_camera_and_an_unknown_or_foreign_profile(tmp_path):
    recording, truth = simulate(load_scenario("fma_2cam").replace(duration_s=1.0), progress=False)
    calib = Calibration({c.name: c.T_world_cam for c in truth.cameras}, {c.name: c.intrinsics for c in recording.cameras},
                        {c.name: 0.0 for c in truth.cameras}, truth.cameras[0].name)
    one = Calibration({"cam1": calib.pose("cam1")}, {"cam1": calib.intrinsics["cam1"]}, {"cam1": 0.0}, "cam1")
    with pytest.raises(BadInputError, match="lacks recording camera"):  # before: a one-camera twin, silently
        build_replica(recording, one, name="r", motion_path=tmp_path / "m.npz")
    with pytest.raises(BadInputError, match="kinect_v9.*not found"):  # before: written into the scenario
        build_replica(recording, calib, name="r", motion_path=tmp_path / "m.npz", profile="kinect_v9")
    with pytest.raises(BadInputError, match="for k4abt skeletons"):
        build_replica(recording, calib, name="r", motion_path=tmp_path / "m.npz", profile="azure_kinect")
