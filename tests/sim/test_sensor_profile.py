"""Sensor profiles: built-ins load, round trip through TOML, provenance is required, scenarios pick them
and draw a person of a profile's population."""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path

import numpy as np
import pytest

from fusion.errors import BadInputError, ScenarioError
from fusion.topology import K4ABT, KINECT_V2
from scenarios.config import NoiseLevel, PopulationDraw, load_scenario
from scenarios.runner import build_simulation
from sim.sensor_population import Family, Spread, population_keys
from sim.sensor_profile import (
    builtin_profiles,
    load_profile,
    parameter_keys,
    profile_from_dict,
    profile_to_toml,
)
from sim.tracker_noise import JointGroup, TrackerNoise

POPULATION = """
[population]
noise_mean = 0.1
noise_person_sd = 0.3
noise_session_sd = 0.15
noise_person_df = inf
bias_mean = -0.2
bias_person_sd = 0.5
bias_session_sd = 0.05
bias_person_df = 4.0
bone_mean = 0.0
bone_person_sd = 0.25
bone_session_sd = 0.2
bone_person_df = inf
confidence_mean = 0.4
confidence_person_sd = 0.8
confidence_session_sd = 0.3
confidence_person_df = 2.5
"""


def _bare(name: str):
    """A built-in profile without its population (and the population's provenance)."""
    p = load_profile(name)
    return dataclasses.replace(p, population=None,
                               provenance={k: v for k, v in p.provenance.items() if not k.startswith("population.")})


def _population_doc(name: str = "azure_kinect", session_sd: float | None = None) -> dict:
    """A built-in profile's document with the [population] table above (every session_sd set to
    ``session_sd`` if given) and a provenance for each of its keys."""
    doc = tomllib.loads(profile_to_toml(_bare(name)) + POPULATION)
    if session_sd is not None:
        doc["population"].update({f"{f.value}_session_sd": session_sd for f in Family})
    doc["provenance"].update({k: "test population" for k in population_keys()})
    return doc


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


def test_limb_correlation_is_optional_and_round_trips() -> None:
    """Unset (0) it is neither written nor asked a provenance for; set, it needs one and comes back."""
    p = load_profile("azure_kinect")
    assert p.tracker.view_limb_correlation == 0.0 and "view_limb_correlation" not in profile_to_toml(p)
    assert "tracker.view_limb_correlation" not in parameter_keys(p.tracker)
    shared = dataclasses.replace(p.tracker, view_limb_correlation=0.6)
    with pytest.raises(BadInputError, match="no provenance for tracker.view_limb_correlation"):
        dataclasses.replace(p, tracker=shared)
    q = dataclasses.replace(p, tracker=shared, provenance={**p.provenance, "tracker.view_limb_correlation": "test"})
    text = profile_to_toml(q)
    assert "view_limb_correlation = 0.6" in text
    assert profile_from_dict(tomllib.loads(text)) == q
    # the other optional parts: the share of hidden frames guessed, a group's own activity exponent
    groups = {**p.tracker.groups, JointGroup.TORSO: dataclasses.replace(p.tracker.groups[JointGroup.TORSO],
                                                                        activity_exponent=0.5)}
    r = dataclasses.replace(p, tracker=dataclasses.replace(p.tracker, hidden_offset_share=0.3, groups=groups),
                            provenance={**p.provenance, "tracker.hidden_offset_share": "test",
                                        "tracker.groups.torso.activity_exponent": "test"})
    text = profile_to_toml(r)
    assert "hidden_offset_share = 0.3" in text and text.count("activity_exponent = 0.5") == 1
    assert profile_from_dict(tomllib.loads(text)) == r
    with pytest.raises(BadInputError, match="no provenance for tracker.groups.torso.activity_exponent"):
        dataclasses.replace(p, tracker=dataclasses.replace(p.tracker, groups=groups))
    aligned = dataclasses.replace(p, tracker=dataclasses.replace(p.tracker, view_bone_alignment=0.5,
                                                                 noise_bone_alignment=-0.25),
                                  provenance={**p.provenance, "tracker.view_bone_alignment": "test",
                                              "tracker.noise_bone_alignment": "test"})
    text = profile_to_toml(aligned)
    assert "view_bone_alignment = 0.5" in text and "noise_bone_alignment = -0.25" in text
    assert profile_from_dict(tomllib.loads(text)) == aligned
    sized = dataclasses.replace(p, tracker=dataclasses.replace(p.tracker, camera_scale_sd=0.02, shared_bone_lengths=0.9),
                                provenance={**p.provenance, "tracker.camera_scale_sd": "test",
                                            "tracker.shared_bone_lengths": "test"})
    text = profile_to_toml(sized)
    assert "camera_scale_sd = 0.02" in text and "shared_bone_lengths = 0.9" in text
    assert profile_from_dict(tomllib.loads(text)) == sized
    assert "camera_scale_sd" not in profile_to_toml(p)  # left out while 0


def test_population_round_trip(tmp_path: Path) -> None:
    p = profile_from_dict(_population_doc())
    assert p.population.spread(Family.BIAS) == Spread(-0.2, 0.5, 0.05, 4.0)
    assert p.population.spread(Family.NOISE).person_df == float("inf")
    assert p.provenance["population.confidence_mean"] == "test population"
    text = profile_to_toml(p)
    assert "[population]" in text and 'noise_person_sd = 0.3' in text and "noise_person_df = inf" in text
    back = profile_from_dict(tomllib.loads(text))
    assert back == p and dict(back.population.spreads) == dict(p.population.spreads)
    path = tmp_path / "pop.toml"
    path.write_text(text)
    assert load_profile(path) == p


def test_profile_without_population_simulates_its_typical_person() -> None:
    for name in builtin_profiles():
        assert load_profile(name).population is not None  # the built-ins are fitted populations
        p = _bare(name)
        assert "[population]" not in profile_to_toml(p)
        assert profile_from_dict(tomllib.loads(profile_to_toml(p))).population is None


def test_population_needs_provenance_and_known_keys() -> None:
    doc = _population_doc()
    del doc["provenance"]["population.bone_session_sd"]
    with pytest.raises(BadInputError, match="no provenance for population.bone_session_sd"):
        profile_from_dict(doc)
    doc = _population_doc()
    doc["population"]["noise_sd"] = 0.1
    with pytest.raises(BadInputError, match="x.toml \\[population\\]: unknown key 'noise_sd'"):
        profile_from_dict(doc, where="x.toml")
    doc = _population_doc()
    del doc["population"]["bias_mean"]
    with pytest.raises(BadInputError, match="give all of bias_mean, bias_person_sd, bias_session_sd, bias_person_df "
                       "or none"):
        profile_from_dict(doc)
    doc = _population_doc()
    del doc["provenance"]["population.confidence_person_df"]
    with pytest.raises(BadInputError, match="no provenance for population.confidence_person_df"):
        profile_from_dict(doc)
    doc = _population_doc()
    del doc["population"]["noise_person_df"]  # a three-key family is incomplete
    with pytest.raises(BadInputError, match="give all of noise_mean, noise_person_sd, noise_session_sd, "
                       "noise_person_df or none"):
        profile_from_dict(doc)
    doc = _population_doc()
    doc["population"]["bone_person_df"] = 0.5
    with pytest.raises(BadInputError, match="person_df must be >= 1"):
        profile_from_dict(doc)
    doc = _population_doc()
    doc["population"] = 0.3
    with pytest.raises(BadInputError, match="\\[population\\] must be a table"):
        profile_from_dict(doc)


def test_population_of_some_families_round_trips() -> None:
    doc = tomllib.loads(profile_to_toml(_bare("azure_kinect")))
    doc["population"] = {"noise_mean": 0.0, "noise_person_sd": 0.3, "noise_session_sd": 0.1, "noise_person_df": 3.0}
    fields = ("mean", "person_sd", "session_sd", "person_df")
    doc["provenance"].update({f"population.noise_{k}": "test" for k in fields})
    p = profile_from_dict(doc)
    assert set(p.population.spreads) == {Family.NOISE}
    assert "bias_mean" not in profile_to_toml(p)
    assert profile_from_dict(tomllib.loads(profile_to_toml(p))) == p


def test_missing_provenance_and_keys() -> None:
    doc = tomllib.loads(profile_to_toml(_bare("kinect_v2")))
    del doc["provenance"]["tracker.groups.limb.bone_rigidity"]
    with pytest.raises(BadInputError, match="no provenance for tracker.groups.limb.bone_rigidity"):
        profile_from_dict(doc)
    doc = tomllib.loads(profile_to_toml(_bare("kinect_v2")))
    del doc["clock"]["rate_hz"]
    with pytest.raises(BadInputError, match="missing key"):
        profile_from_dict(doc)
    doc = tomllib.loads(profile_to_toml(_bare("kinect_v2")))
    doc["tracker"]["bogus"] = 1
    with pytest.raises(BadInputError, match="unknown key 'bogus'"):
        profile_from_dict(doc)
    with pytest.raises(BadInputError, match="not found"):
        load_profile("no_such_sensor")
    assert "kinect_v2" in builtin_profiles()


def test_scenario_uses_profile_of_its_topology() -> None:
    sc = load_scenario("fma_2cam")
    sc = sc.replace(sensors=dataclasses.replace(sc.sensors, population=PopulationDraw.TYPICAL))
    sim = build_simulation(sc)
    assert sim.sensors.tracker == load_profile("kinect_v2").tracker
    k4 = sc.replace(subject=dataclasses.replace(sc.subject, topology="k4abt"))
    assert build_simulation(k4).sensors.tracker == load_profile("azure_kinect").tracker
    wrong = sc.replace(sensors=dataclasses.replace(sc.sensors, profile="azure_kinect"))
    with pytest.raises(ScenarioError, match="reports k4abt skeletons"):
        build_simulation(wrong)
    fast = sc.replace(sensors=dataclasses.replace(sc.sensors, clock_jitter_ms=0.5))
    assert build_simulation(fast).sensors.clock.jitter_sigma_s == pytest.approx(0.0005)


def _population_scenario(tmp_path: Path, seed: int, session_sd: float | None = None, **sensors):
    """fma_2cam with Azure cameras whose profile (written to ``tmp_path``) has a population."""
    path = tmp_path / f"pop_{session_sd}.toml"
    if not path.exists():
        path.write_text(profile_to_toml(profile_from_dict(_population_doc(session_sd=session_sd))))
    sc = load_scenario("fma_2cam")
    return sc.replace(seed=seed, subject=dataclasses.replace(sc.subject, topology="k4abt"),
                      sensors=dataclasses.replace(sc.sensors, profile=str(path), **sensors))


def test_scenario_draws_a_person_of_the_population(tmp_path: Path) -> None:
    typical = load_profile("azure_kinect").tracker
    a = build_simulation(_population_scenario(tmp_path, 1)).sensors.tracker
    b = build_simulation(_population_scenario(tmp_path, 2)).sensors.tracker
    assert a != b and typical not in (a, b)
    assert build_simulation(_population_scenario(tmp_path, 1)).sensors.tracker == a  # the seed fixes the draw
    for seed in (1, 2):
        sc = _population_scenario(tmp_path, seed, population=PopulationDraw.TYPICAL)
        assert build_simulation(sc).sensors.tracker == typical
    # a draw changes only the families' parameters (the body scale is the bone family's)
    assert a.body_scale_sd != typical.body_scale_sd
    assert dataclasses.replace(a, groups=typical.groups, body_scale_sd=typical.body_scale_sd) == typical
    assert [g.outlier_rate for g in a.groups.values()] == [g.outlier_rate for g in typical.groups.values()]


def test_person_seed_fixes_the_person(tmp_path: Path) -> None:
    same = [build_simulation(_population_scenario(tmp_path, seed, session_sd=0.0, person_seed=7)).sensors.tracker
            for seed in (1, 2, 3)]
    assert same[0] == same[1] == same[2] != load_profile("azure_kinect").tracker
    other = build_simulation(_population_scenario(tmp_path, 1, session_sd=0.0, person_seed=8)).sensors.tracker
    assert other != same[0]
    # without person_seed the person comes from the scenario's seed
    assert build_simulation(_population_scenario(tmp_path, 1, session_sd=0.0)).sensors.tracker != \
        build_simulation(_population_scenario(tmp_path, 2, session_sd=0.0)).sensors.tracker
    # with session_sd, each seed draws its own session of person 7
    s1, s2 = (build_simulation(_population_scenario(tmp_path, seed, person_seed=7)).sensors.tracker for seed in (1, 2))
    assert s1 != s2


def test_ideal_tracker_ignores_the_population(tmp_path: Path) -> None:
    sc = _population_scenario(tmp_path, 1, tracker_noise=NoiseLevel.NONE)
    assert build_simulation(sc).sensors.tracker == TrackerNoise.none()


def test_a_scenario_of_a_known_lab_draws_that_labs_people(tmp_path: Path) -> None:
    """A lab whose people are 2 log units noisier and do not vary: its people's tracker is the typical
    one with jitter and wobble times e^2, whatever the seed; another lab's person is the population's."""
    doc = _population_doc(session_sd=0.0)
    doc["population"]["labs"] = {"loud": {"noise_mean": 2.0, "noise_person_sd": 0.0, "noise_session_sd": 0.0,
                                          "noise_person_df": float("inf")}}
    doc["provenance"].update({f"population.labs.loud.noise_{k}": "test lab"
                              for k in ("mean", "person_sd", "session_sd", "person_df")})
    path = tmp_path / "labs.toml"
    path.write_text(profile_to_toml(profile_from_dict(doc)))
    sc = load_scenario("fma_2cam")
    sc = sc.replace(subject=dataclasses.replace(sc.subject, topology="k4abt"),
                    sensors=dataclasses.replace(sc.sensors, profile=str(path), lab="loud"))
    typical = load_profile("azure_kinect").tracker
    for seed in (1, 2):
        tracker = build_simulation(sc.replace(seed=seed)).sensors.tracker
        for g, n in tracker.groups.items():
            assert n.jitter_m == pytest.approx(typical.groups[g].jitter_m * np.exp(2.0))
            assert n.bias_m == typical.groups[g].bias_m and n.bone_rigidity == typical.groups[g].bone_rigidity
    other = sc.replace(sensors=dataclasses.replace(sc.sensors, lab="quiet"))
    nameless = sc.replace(sensors=dataclasses.replace(sc.sensors, lab=None))
    assert build_simulation(other).sensors.tracker == build_simulation(nameless).sensors.tracker != typical
