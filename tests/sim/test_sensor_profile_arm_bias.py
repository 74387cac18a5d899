"""A sensor profile's optional ``[tracker.arm_bias]`` table: round trip through TOML, provenance
required for it, unknown keys refused, the built-in Kinect v2 profile with or without one."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

from fusion.errors import BadInputError
from fusion.topology import KINECT_V2
from sim.sensor_profile import (
    load_profile,
    parameter_keys,
    profile_from_dict,
    profile_to_toml,
)
from sim.tracker_arm_bias import ArmBias

MEAN = np.arange(45, dtype=float).reshape(3, 5, 3) / 1000.0 - 0.022
MODES = np.stack([np.full((3, 5, 3), 0.004), np.linspace(-0.003, 0.003, 45).reshape(3, 5, 3)])
ARM_KEYS = ("tracker.arm_bias.mean_m", "tracker.arm_bias.person_modes_m")


def _with_arm_bias(name: str = "kinect_v2", modes=MODES):
    p = load_profile(name)
    provenance = {**p.provenance, **{k: "test arm bias" for k in ARM_KEYS}}
    return dataclasses.replace(p, tracker=dataclasses.replace(p.tracker, arm_bias=ArmBias(MEAN, modes)),
                               provenance=provenance)


def test_round_trip_of_a_profile_with_arm_bias():
    profile = _with_arm_bias()
    text = profile_to_toml(profile)
    assert "[tracker.arm_bias]" in text
    doc = tomllib.loads(text)
    assert set(doc["tracker"]["arm_bias"]) == {"mean_m", "person_modes_m", "yaw_scaled"}
    back = profile_from_dict(doc)
    assert back == profile
    np.testing.assert_allclose(np.asarray(back.tracker.arm_bias.mean_m), MEAN)
    np.testing.assert_allclose(np.asarray(back.tracker.arm_bias.person_modes_m), MODES)
    assert all(back.provenance[k] == "test arm bias" for k in ARM_KEYS)
    assert profile_to_toml(back) == text


def test_round_trip_of_an_arm_bias_without_modes():
    profile = _with_arm_bias(modes=[])
    text = profile_to_toml(profile)
    doc = tomllib.loads(text)
    assert doc["tracker"]["arm_bias"]["person_modes_m"] == []
    back = profile_from_dict(doc)
    assert back == profile
    assert np.asarray(back.tracker.arm_bias.person_modes_m).size == 0
    np.testing.assert_array_equal(back.tracker.arm_bias.draw(np.random.default_rng(0)), MEAN)
    assert profile_to_toml(back) == text


def test_an_arm_bias_of_the_knots_alone_loads_without_forearm_terms():
    doc = tomllib.loads(profile_to_toml(_with_arm_bias()))
    doc["tracker"]["arm_bias"]["mean_m"] = MEAN[:, :3].tolist()
    doc["tracker"]["arm_bias"]["person_modes_m"] = MODES[:, :, :3].tolist()
    bias = profile_from_dict(doc).tracker.arm_bias
    np.testing.assert_array_equal(np.asarray(bias.mean_m)[:, :3], MEAN[:, :3])
    np.testing.assert_array_equal(np.asarray(bias.mean_m)[:, 3:], 0.0)
    np.testing.assert_array_equal(np.asarray(bias.person_modes_m)[:, :, 3:], 0.0)


def test_parameter_keys_name_the_arm_bias_only_when_set():
    profile = _with_arm_bias()
    keys = parameter_keys(profile.tracker)
    assert all(k in keys for k in ARM_KEYS)
    assert not any(k.startswith("tracker.arm_bias") for k in parameter_keys())
    bare = dataclasses.replace(profile.tracker, arm_bias=None)
    assert not any(k.startswith("tracker.arm_bias") for k in parameter_keys(bare))


def test_arm_bias_without_provenance_is_refused_by_name():
    doc = tomllib.loads(profile_to_toml(_with_arm_bias()))
    del doc["provenance"]["tracker.arm_bias.person_modes_m"]
    with pytest.raises(BadInputError, match=r"no provenance for tracker\.arm_bias\.person_modes_m"):
        profile_from_dict(doc)
    doc["provenance"]["tracker.arm_bias.person_modes_m"] = "   "
    with pytest.raises(BadInputError, match=r"tracker\.arm_bias\.person_modes_m"):
        profile_from_dict(doc)


def test_unknown_or_missing_arm_bias_key_is_refused():
    doc = tomllib.loads(profile_to_toml(_with_arm_bias()))
    doc["tracker"]["arm_bias"]["session_sd_m"] = MEAN.tolist()
    with pytest.raises(BadInputError, match=r"\[tracker\.arm_bias\].*unknown key 'session_sd_m'"):
        profile_from_dict(doc)
    doc = tomllib.loads(profile_to_toml(_with_arm_bias()))
    del doc["tracker"]["arm_bias"]["person_modes_m"]
    with pytest.raises(BadInputError, match=r"\[tracker\.arm_bias\].*missing key.*person_modes_m"):
        profile_from_dict(doc)


def test_bad_arm_bias_values_are_refused():
    doc = tomllib.loads(profile_to_toml(_with_arm_bias()))
    doc["tracker"]["arm_bias"]["mean_m"] = (MEAN * 100).tolist()  # centimetres
    with pytest.raises(BadInputError, match="0.5 m"):
        profile_from_dict(doc)
    doc = tomllib.loads(profile_to_toml(_with_arm_bias()))
    doc["tracker"]["arm_bias"]["mean_m"] = MEAN[:2].tolist()
    with pytest.raises(BadInputError, match="shape"):
        profile_from_dict(doc)
    doc = tomllib.loads(profile_to_toml(_with_arm_bias()))
    doc["tracker"]["arm_bias"]["person_modes_m"] = (MODES * 200).tolist()  # not metres
    with pytest.raises(BadInputError, match="0.5 m"):
        profile_from_dict(doc)
    doc = tomllib.loads(profile_to_toml(_with_arm_bias()))
    doc["tracker"]["arm_bias"]["person_modes_m"] = MODES[0].tolist()  # one mode without its mode axis
    with pytest.raises(BadInputError, match="shape"):
        profile_from_dict(doc)
    doc = tomllib.loads(profile_to_toml(_with_arm_bias()))
    doc["tracker"]["arm_bias"] = 0.1
    with pytest.raises(BadInputError, match="must be a table"):
        profile_from_dict(doc)


def test_profile_without_arm_bias_round_trips_without_the_table():
    p = load_profile("azure_kinect")
    text = profile_to_toml(dataclasses.replace(p, tracker=dataclasses.replace(p.tracker, arm_bias=None)))
    assert "arm_bias" not in text


def test_builtin_kinect_v2_profile_loads_with_or_without_an_arm_bias():
    p = load_profile("kinect_v2")
    assert p.topology is KINECT_V2
    if p.tracker.arm_bias is None:
        assert not any(k.startswith("tracker.arm_bias") for k in parameter_keys(p.tracker))
    else:
        assert isinstance(p.tracker.arm_bias, ArmBias)
        assert np.asarray(p.tracker.arm_bias.mean_m).shape == (3, 5, 3)
        modes = np.asarray(p.tracker.arm_bias.person_modes_m)
        assert modes.size == 0 or modes.shape[1:] == (3, 5, 3)
        assert all(str(p.provenance.get(k, "")).strip() for k in ARM_KEYS)
    assert profile_from_dict(tomllib.loads(profile_to_toml(p))) == p
