"""Fixtures of the sensor-fit tests."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from scenarios.config import load_scenario
from scenarios.runner import build_simulation
from scenarios.sensors.fit import body_calibration, measure
from scenarios.sensors.replica_case import prepare_case
from sim.session import simulate_session


@pytest.fixture(scope="module")
def case():
    """A 10 s two-camera K4ABT session simulated with the built-in profile, as the 'real' recording, and the
    tracker it was simulated with."""
    sc = load_scenario("azure_2cam_45").replace(duration_s=10.0)
    sim = build_simulation(sc)
    sensors = dataclasses.replace(sim.sensors, depth_rate_hz=0.0)
    rec, _ = simulate_session(sim.humanoid, sim.motion, sim.rig, sensors, seed=3, duration_s=10.0)
    calibration = body_calibration(rec, rng=np.random.default_rng(0))
    real = measure(rec, calibration.T_world_cam, n_boot=0, rng=np.random.default_rng(0))
    return prepare_case("sim", rec, calibration, real), sensors.tracker
