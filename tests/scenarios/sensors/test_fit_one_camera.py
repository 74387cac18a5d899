"""Replica refinement of a one-camera recording: a simulated frontal Kinect v2 session (a level camera
at a known place) as the 'real' recording, its level-camera calibration, and the refinement without
cross-camera residuals."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fusion.calibrate.level import FOOT_HEIGHT_M, level_camera_calibration
from fusion.errors import BadInputError
from fusion.io.recording_files import save_recording
from fusion.recording import Recording
from scenarios.cli import main
from scenarios.config import load_scenario
from scenarios.runner import build_simulation
from scenarios.sensors.fit import measure, session_calibration
from scenarios.sensors.fit_replica import loss, refine_on_replicas
from scenarios.sensors.replica_case import prepare_case, retrack
from sim.sensor_profile import load_profile
from sim.session import simulate_session
from sim.tracker_noise import JointGroup


@pytest.fixture(scope="module")
def session():
    """8 s of kimore_frontal (one level Kinect v2 at 1 m height, 2.7 m in front) and its true camera pose."""
    sim = build_simulation(load_scenario("kimore_frontal"))
    sensors = dataclasses.replace(sim.sensors, depth_rate_hz=0.0)
    rec, _ = simulate_session(sim.humanoid, sim.motion, sim.rig, sensors, seed=5, duration_s=8.0)
    return rec, sim.rig.cameras[0].T_world_cam


def test_level_calibration_finds_the_camera(session) -> None:
    rec, T_true = session
    calibration = session_calibration(rec, rng=np.random.default_rng(0))
    T = calibration.pose("cam1")
    # both level: the same up row (the world's yaw is a free choice: x along the view here)
    np.testing.assert_allclose(T[2, :3], T_true[2, :3], atol=1e-9)
    # height from the feet (foot joints 3.7-4.4 cm up, tracker bias), place from the pelvis (the subject
    # stands at the origin): within a few centimetres
    assert abs(T[2, 3] - T_true[2, 3]) < 0.05
    assert abs(np.linalg.norm(T[:2, 3]) - np.linalg.norm(T_true[:2, 3])) < 0.1
    assert calibration.info["camera_height_m"] == pytest.approx(T[2, 3])
    higher = level_camera_calibration(rec, foot_height_m=FOOT_HEIGHT_M + 0.1)
    assert higher.pose("cam1")[2, 3] == pytest.approx(T[2, 3] + 0.1)


def test_level_calibration_bad_input(session) -> None:
    rec, _ = session
    cam = rec.cameras[0]
    two = Recording((cam, dataclasses.replace(cam, name="cam2")), rec.metadata)
    with pytest.raises(BadInputError, match="one camera"):
        level_camera_calibration(two)
    with pytest.raises(BadInputError, match="finite"):
        level_camera_calibration(rec, foot_height_m=float("nan"))
    feet = [rec.topology.index(n) for n in ("FootLeft", "FootRight")]
    pos = cam.skeleton.positions.copy()
    pos[:, feet] = np.nan
    states = cam.skeleton.states.copy()
    states[:, feet] = 0
    footless = dataclasses.replace(cam, skeleton=dataclasses.replace(cam.skeleton, positions=pos, states=states))
    with pytest.raises(BadInputError, match="no frame has a foot joint"):
        level_camera_calibration(Recording((footless,), rec.metadata))


def test_refinement_without_residuals(session) -> None:
    rec, _ = session
    calibration = session_calibration(rec, rng=np.random.default_rng(0))
    real = measure(rec, calibration.T_world_cam, n_boot=0, rng=np.random.default_rng(0))
    assert real.residual_fluct_joint_mm.size == 0
    case = prepare_case("one", rec, calibration, real)
    assert len(case.placements) == 1
    truth = load_profile("kinect_v2")
    groups = {g: dataclasses.replace(n, jitter_m=3 * n.jitter_m + 0.002, wobble_m=3 * n.wobble_m + 0.002)
              for g, n in truth.tracker.groups.items()}
    wrong = dataclasses.replace(truth, tracker=dataclasses.replace(truth.tracker, groups=groups))
    speed = truth.tracker.speed_ref_m_s
    fit = refine_on_replicas(wrong, [case], iterations=3, speeds=(speed,))
    before = loss([case], [measure(retrack(case, wrong), None, n_boot=0, rng=np.random.default_rng(0))])
    assert fit.losses[speed] < 0.5 * before
    hand_fit, hand_wrong = fit.profile.tracker.groups[JointGroup.HAND], wrong.tracker.groups[JointGroup.HAND]
    assert hand_fit.wobble_m < hand_wrong.wobble_m
    # no residual: the white share of each group stays that of the start
    assert hand_fit.jitter_m / hand_fit.wobble_m == pytest.approx(hand_wrong.jitter_m / hand_wrong.wobble_m, rel=1e-6)
    assert hand_fit.bias_m == hand_wrong.bias_m


def test_cli_fits_and_compares_one_camera(session, tmp_path, capsys) -> None:
    rec, _ = session
    save_recording(rec, tmp_path / "rec")
    out = tmp_path / "p.toml"
    assert main(["sensor-fit", str(tmp_path / "rec"), "--out", str(out), "--replicas", "--iterations", "1",
                 "--bootstrap", "0"]) == 0
    assert "refined on replicas of rec" in load_profile(out).provenance["tracker.groups.hand.wobble_m"]
    assert main(["sim-to-real", str(tmp_path / "rec"), "--profile", str(out), "--bootstrap", "0",
                 "--out", str(tmp_path / "s2r")]) == 0
    text = capsys.readouterr().out
    assert "assumed level" in text and "wrist jitter" in text and "cross-camera" not in text
    assert (tmp_path / "s2r" / "replica.toml").is_file()
