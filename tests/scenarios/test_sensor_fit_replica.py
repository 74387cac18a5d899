"""Simulation-based refinement of a sensor profile on replicas: a simulated 'real' session with a
known tracker model, a start profile that is wrong, and the refinement moving toward the truth."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from scenarios.cli import main
from scenarios.config import load_scenario
from scenarios.runner import build_simulation
from scenarios.sensor_fit import body_calibration, measure
from scenarios.sensor_fit_replica import fit_confidence, loss, prepare_case, refine_on_replicas, retrack
from sim.sensor_profile import load_profile
from sim.session import simulate_session
from sim.tracker_noise import JointGroup


@pytest.fixture(scope="module")
def case():
    """A 10 s two-camera K4ABT session simulated with the built-in profile, as the 'real' recording."""
    sc = load_scenario("azure_2cam_45").replace(duration_s=10.0)
    sim = build_simulation(sc)
    sensors = dataclasses.replace(sim.sensors, depth_rate_hz=0.0)
    rec, _ = simulate_session(sim.humanoid, sim.motion, sim.rig, sensors, seed=3, duration_s=10.0)
    calibration = body_calibration(rec, rng=np.random.default_rng(0))
    real = measure(rec, calibration.T_world_cam, n_boot=0, rng=np.random.default_rng(0))
    return prepare_case("sim", rec, calibration, real), sensors.tracker


def test_case_holds_the_replica(case) -> None:
    c, _ = case
    assert len(c.placements) == 2 and c.joints_world[0].shape[1:] == (32, 3)
    assert all(0.0 <= v <= 1.0 for v in c.hidden_share.values() if np.isfinite(v))
    assert c.real.residual_static_joint_mm.shape == (32,) and np.isfinite(c.real.residual_fluct_joint_mm).all()
    # the ideal tracker's own jitter is the motion's: far below the noisy tracker's
    assert c.motion.jitter_mm["head"].value < c.real.jitter_mm["head"].value
    rec = retrack(c, load_profile("azure_kinect"), seed=1)
    assert [cam.name for cam in rec.cameras] == [p.name for p in c.placements]


def test_refinement_moves_toward_the_truth(case) -> None:
    c, truth = case
    start = load_profile("azure_kinect")
    groups = {g: dataclasses.replace(n, wobble_m=4 * n.wobble_m + 0.004) for g, n in start.tracker.groups.items()}
    wrong = dataclasses.replace(start, tracker=dataclasses.replace(start.tracker, groups=groups))
    fit = refine_on_replicas(wrong, [c], iterations=4, speeds=(truth.speed_ref_m_s,))
    before = loss([c], [measure(retrack(c, wrong), None, n_boot=0, rng=np.random.default_rng(0))])
    assert fit.losses[truth.speed_ref_m_s] < 0.5 * before
    limb = JointGroup.LIMB
    assert abs(np.log(fit.profile.tracker.groups[limb].wobble_m / truth.groups[limb].wobble_m)) < \
        abs(np.log(wrong.tracker.groups[limb].wobble_m / truth.groups[limb].wobble_m))
    assert "refined on replicas of sim" in fit.profile.provenance["tracker.groups.limb.wobble_m"]


def test_confidence_shares_in_bounds(case) -> None:
    c, _ = case
    fitted = fit_confidence(load_profile("azure_kinect"), [c])
    for n in fitted.tracker.groups.values():
        assert 0.0 <= n.hidden_low_confidence <= 1.0 and 0.0 <= n.low_confidence[0] <= 1.0


def test_cli_refuses_two_refinements(tmp_path, capsys) -> None:
    code = main(["sensor-fit", str(tmp_path / "rec"), "--out", str(tmp_path / "p.toml"), "--replicas",
                 "--scenario", "azure_2cam_45"])
    assert code != 0 and "choose one" in capsys.readouterr().err
    assert not (tmp_path / "p.toml").exists()
