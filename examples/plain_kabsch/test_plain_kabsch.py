"""Property-based tests of the plain Kabsch calibration, written only against the public API:
``scenarios.api`` (simulate, score), ``scenarios.testing`` (strategies, checks) and the plugin's
``mocap_session`` fixture."""

from __future__ import annotations

import dataclasses

import numpy as np
from hypothesis import given, settings
from plain_kabsch import calibrate

from scenarios import api
from scenarios.testing import properties
from scenarios.testing import strategies as mb

ALGORITHM = "examples/plain_kabsch/plain_kabsch.py:calibrate"
"""How ``--algorithm`` names this calibration, used in the reproduction command of a failure."""

# Two or three cameras on an arc in front of the subject: the rigs a body calibration without
# back-facing checks can handle (opposite cameras see mirrored skeletons).
front_rigs = mb.ring_rigs(2, 3, arc_deg=(60.0, 100.0))


def exact(sensor: api.SensorConfig) -> api.SensorConfig:
    """The same sensor without tracker noise, clock offsets, jitter or dropped frames."""
    return dataclasses.replace(sensor, tracker_noise=api.NoiseLevel.NONE, clock_offset_sd_ms=0.0,
                               clock_jitter_ms=0.0, drop_probability=0.0)


# Noise-free skeletons still differ by the joints' motion between two cameras' frames (up to half a
# frame apart): 0.6 deg and 19 mm at most over 30 drawn cases.
@settings(max_examples=12, deadline=None, derandomize=True)
@given(mb.scenarios(rig=front_rigs, sensors=mb.sensor_conditions().map(exact), patients=False))
def test_close_on_noise_free_skeletons(scenario):
    session = api.simulate(scenario)
    poses = calibrate(session.recording, rng=np.random.default_rng(0))
    properties.check_calibration(api.calibration_from_poses(session.recording, poses), session,
                                 max_rotation_deg=1.0, max_translation_mm=30.0, algorithm=ALGORITHM)


# The Kinect v2's tracker noise without outlier rejection: over 150 drawn cases the worst was 16.0 deg
# and 599 mm (90th percentile 8.3 deg, 295 mm).
@settings(max_examples=12, deadline=None, derandomize=True)
@given(mb.scenarios(rig=front_rigs, sensors=mb.sensor_conditions(["kinect_v2"], noise=False,
                                                                 max_clock_offset_sd_ms=5.0)))
def test_within_bounds_on_noisy_sensors(scenario):
    session = api.simulate(scenario)
    poses = calibrate(session.recording, rng=np.random.default_rng(0))
    properties.check_calibration(api.calibration_from_poses(session.recording, poses), session,
                                 max_rotation_deg=20.0, max_translation_mm=800.0, algorithm=ALGORITHM)


def test_default_session_from_the_plugin(mocap_session):
    poses = calibrate(mocap_session.recording, rng=np.random.default_rng(0))
    scores = api.score_calibration(api.calibration_from_poses(mocap_session.recording, poses), mocap_session.truth)
    assert scores.summary()["rotation_error_deg"]["max"] < 20.0
