"""The tracker's trunk bias: offsets of known coefficients in the thorax frame at the higher arm's
elevation, their turning with the body, validation, the model bias, the tracker and the profile."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fusion.errors import BadInputError
from fusion.topology import KINECT_V2, Landmark
from fusion.transforms import apply
from sim.rig import CameraPlacement, look_at
from sim.sensor_profile import load_profile, profile_from_dict, profile_to_toml
from sim.tracker import track
from sim.tracker_arm_bias import POWERS
from sim.tracker_bias import TrackerBias, tracker_with
from sim.tracker_model_bias import sample_model_bias
from sim.tracker_noise import TrackerNoise
from sim.tracker_trunk_bias import TRUNK_JOINTS, TrunkBias, trunk_offsets
from tests.sim.test_tracker_arm_bias import THORAX_RIGHT, skeleton

TOPO = KINECT_V2
TRUNK = [TOPO.index(Landmark[j.upper()]) for j in TRUNK_JOINTS]
V = np.array([[0.01, -0.10, -0.01], [-0.03, -0.02, 0.0], [-0.01, -0.01, -0.015]])
"""Per trunk joint (pelvis, spine-mid, spine-shoulder) a thorax-frame vector [m] (X fwd, Y up, Z right)."""


def _knot(knot: int, values: np.ndarray = V) -> np.ndarray:
    c = np.zeros((len(TRUNK_JOINTS), POWERS, 3))
    c[:, knot] = values
    return c


@pytest.mark.parametrize("knot, elevation", [(0, 0.0), (1, 90.0), (2, 150.0)])
def test_a_knots_value_is_the_offset_at_the_higher_arms_elevation(knot, elevation):
    P = skeleton((10.0, elevation) if elevation > 10.0 else elevation)
    out = trunk_offsets(P, TOPO, _knot(knot))
    np.testing.assert_allclose(out[0, TRUNK], V @ THORAX_RIGHT.T, atol=1e-12)
    others = np.setdiff1d(np.arange(TOPO.n_joints), TRUNK)
    np.testing.assert_array_equal(out[:, others], 0.0)
    for other in set(range(POWERS)) - {knot}:
        np.testing.assert_allclose(trunk_offsets(P, TOPO, _knot(other)), 0.0, atol=1e-12)


def test_the_offsets_turn_with_the_body():
    P = skeleton((0.0, 60.0))
    R = Rotation.from_euler("zyx", [70.0, 15.0, -10.0], degrees=True).as_matrix()
    coefficients = _knot(0) + _knot(1, 0.5 * V) + _knot(2, -V)
    turned = trunk_offsets(P @ R.T + [0.3, -1.0, 0.2], TOPO, coefficients)
    np.testing.assert_allclose(turned, trunk_offsets(P, TOPO, coefficients) @ R.T, atol=1e-12)


def test_no_arms_no_offset_rather_than_nan():
    P = skeleton(0.0, 2)
    P[:, [TOPO.index(Landmark.ELBOW_LEFT), TOPO.index(Landmark.ELBOW_RIGHT)]] = np.nan
    np.testing.assert_array_equal(trunk_offsets(P, TOPO, _knot(0)), 0.0)


def test_trunk_bias_validation_names_the_trunk():
    with pytest.raises(BadInputError, match="trunk bias mean_m"):
        TrunkBias(np.zeros((3, 2, 3)), [])
    with pytest.raises(BadInputError, match="trunk bias person_modes_m holds a value over 0.5 m"):
        TrunkBias(np.zeros((3, 3, 3)), [np.full((3, 3, 3), 0.9)])
    with pytest.raises(BadInputError, match="TrunkBias"):
        TrackerNoise(trunk_bias=np.zeros((3, 3, 3)))


BIAS = TrunkBias(_knot(0), [_knot(1, 0.2 * V)])


def test_model_bias_zeroes_the_trunk_joints_and_draws_after_the_arm():
    noise = dataclasses.replace(TrackerNoise(), trunk_bias=BIAS)
    with_trunk = sample_model_bias(TOPO, noise, rng=np.random.default_rng(5))
    without = sample_model_bias(TOPO, TrackerNoise(), rng=np.random.default_rng(5))
    np.testing.assert_array_equal(with_trunk.offsets_body[TRUNK], 0.0)
    others = np.setdiff1d(np.arange(TOPO.n_joints), TRUNK)
    np.testing.assert_array_equal(with_trunk.offsets_body[others], without.offsets_body[others])
    assert without.trunk_coefficients is None
    drawn = (with_trunk.trunk_coefficients - np.asarray(BIAS.mean_m))[:, 1]
    z = drawn[V != 0] / (0.2 * V[V != 0])  # one standard normal times the one mode
    assert np.allclose(z, z[0]) and z[0] != 0.0 and np.all(drawn[V == 0] == 0.0)


@pytest.mark.parametrize("bias, kept", [
    (TrackerBias.ON, True), (TrackerBias.OFF, False), (TrackerBias.MODEL_OFF, False),
    (TrackerBias.VIEW_OFF, True), (TrackerBias.ARMS_OFF, True),
])
def test_tracker_with_keeps_the_trunk_bias_only_with_the_model_part(bias, kept):
    out = tracker_with(dataclasses.replace(TrackerNoise(), trunk_bias=BIAS), bias)
    assert (out.trunk_bias is BIAS) if kept else out.trunk_bias is None


def test_quiet_tracker_reports_the_trunk_joints_at_truth_plus_trunk_offsets():
    T = 5
    P = np.stack([skeleton((0.0, e))[0] for e in np.linspace(0.0, 140.0, T)])
    camera = CameraPlacement("cam", look_at([2.5, 0.0, 1.0], [0.0, 0.0, 1.0]))
    noise = dataclasses.replace(TrackerNoise.none(), trunk_bias=TrunkBias(_knot(0) + _knot(2, -V), []))
    rng = np.random.default_rng(0)
    model_bias = sample_model_bias(TOPO, noise, rng=rng)
    stream, _ = track(P, np.zeros(T), np.arange(T) / 30.0, camera, TOPO, noise, model_bias, rng=rng)
    seen = apply(camera.T_world_cam, stream.positions)
    np.testing.assert_allclose(seen, P + trunk_offsets(P, TOPO, model_bias.trunk_coefficients), atol=1e-9)
    assert np.linalg.norm(seen[0, TRUNK] - P[0, TRUNK], axis=-1) == pytest.approx(np.linalg.norm(V, axis=-1))


def test_round_trip_of_a_profile_with_a_trunk_bias():
    base = load_profile("kinect_v2")
    keys = {"tracker.trunk_bias.mean_m": "test", "tracker.trunk_bias.person_modes_m": "test"}
    profile = dataclasses.replace(base, tracker=dataclasses.replace(base.tracker, trunk_bias=BIAS),
                                  provenance={**base.provenance, **keys})
    text = profile_to_toml(profile)
    assert "[tracker.trunk_bias]" in text
    again = profile_from_dict(tomllib.loads(text))
    np.testing.assert_allclose(again.tracker.trunk_bias.mean_m, BIAS.mean_m)
    np.testing.assert_allclose(again.tracker.trunk_bias.person_modes_m, BIAS.person_modes_m)
    with pytest.raises(BadInputError, match="trunk_bias"):
        profile_from_dict(tomllib.loads(text.replace('"tracker.trunk_bias.mean_m"', '"unrelated"')))
