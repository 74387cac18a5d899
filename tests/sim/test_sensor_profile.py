"""Sensor profiles: built-ins load, round trip through TOML, provenance is required, scenarios pick them."""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path

import pytest

from fusion.errors import BadInputError, ScenarioError
from fusion.topology import K4ABT, KINECT_V2
from scenarios.config import load_scenario
from scenarios.runner import build_simulation
from sim.sensor_profile import (
    builtin_profiles,
    load_profile,
    parameter_keys,
    profile_from_dict,
    profile_to_toml,
)


@pytest.mark.parametrize("name,topology", [("kinect_v2", KINECT_V2), ("azure_kinect", K4ABT)])
def test_builtin_profiles_load_with_provenance(name, topology) -> None:
    p = load_profile(name)
    assert p.topology == topology and p.name == name
    assert set(parameter_keys()) <= set(p.provenance)
    assert all(p.provenance[k].strip() for k in parameter_keys())


def test_round_trip_exact(tmp_path: Path) -> None:
    p = load_profile("azure_kinect")
    text = profile_to_toml(p)
    back = profile_from_dict(tomllib.loads(text))
    assert back == p
    path = tmp_path / "x.toml"
    path.write_text(text)
    assert load_profile(path) == p


def test_missing_provenance_and_keys() -> None:
    doc = tomllib.loads(profile_to_toml(load_profile("kinect_v2")))
    del doc["provenance"]["tracker.groups.limb.bone_rigidity"]
    with pytest.raises(BadInputError, match="no provenance for tracker.groups.limb.bone_rigidity"):
        profile_from_dict(doc)
    doc = tomllib.loads(profile_to_toml(load_profile("kinect_v2")))
    del doc["clock"]["rate_hz"]
    with pytest.raises(BadInputError, match="missing key"):
        profile_from_dict(doc)
    doc = tomllib.loads(profile_to_toml(load_profile("kinect_v2")))
    doc["tracker"]["bogus"] = 1
    with pytest.raises(BadInputError, match="unknown key 'bogus'"):
        profile_from_dict(doc)
    with pytest.raises(BadInputError, match="not found"):
        load_profile("no_such_sensor")
    assert "kinect_v2" in builtin_profiles()


def test_scenario_uses_profile_of_its_topology() -> None:
    sc = load_scenario("fma_2cam")
    sim = build_simulation(sc)
    assert sim.sensors.tracker == load_profile("kinect_v2").tracker
    k4 = sc.replace(subject=dataclasses.replace(sc.subject, topology="k4abt"))
    assert build_simulation(k4).sensors.tracker == load_profile("azure_kinect").tracker
    wrong = sc.replace(sensors=dataclasses.replace(sc.sensors, profile="azure_kinect"))
    with pytest.raises(ScenarioError, match="reports k4abt skeletons"):
        build_simulation(wrong)
    fast = sc.replace(sensors=dataclasses.replace(sc.sensors, clock_jitter_ms=0.5))
    assert build_simulation(fast).sensors.clock.jitter_sigma_s == pytest.approx(0.0005)
