"""A sensor's population fitted on replicas of simulated sessions of two people, and the re-tracking of
a replica as one person."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

from fusion.errors import BadInputError
from scenarios.config import load_scenario
from scenarios.runner import build_simulation
from scenarios.sensors.fit import body_calibration, measure
from scenarios.sensors.fit_population import check_labs, fit_population, person_of
from scenarios.sensors.population_report import population_lines
from scenarios.sensors.replica_case import (
    ReplicaCase,
    prepare_case,
    retrack,
    retracked_stats,
)
from sim.sensor_population import Family, Spread, apply_factors, population_keys
from sim.sensor_profile import load_profile, profile_from_dict, profile_to_toml
from sim.session import simulate_session

DURATION_S = 8.0
"""Long enough for the body calibration of ``azure_2cam_45`` (the person turns and lifts the arms)."""

PEOPLE = {
    "A": ({Family.NOISE: 0.4, Family.BIAS: 0.3, Family.BONE: 0.3, Family.CONFIDENCE: 0.15}, 11),
    "B": ({Family.NOISE: -0.3, Family.BIAS: -0.3, Family.BONE: -0.3, Family.CONFIDENCE: -0.15}, 12),
}
"""Per person label the factors of its tracker and its person seed."""

SESSIONS = (("A", 1), ("A", 2), ("B", 3), ("B", 4))
"""(person, seed) of each 'real' session."""


def _bias_only(profile):
    """``profile`` whose tracker has only its static bias (no jitter, wobble, outliers, guesses, body scale or
    trunk turn)."""
    quiet = {"jitter_m": 0.0, "wobble_m": 0.0, "outlier_rate": 0.0, "low_confidence": (0.0, 0.0),
             "hidden_low_confidence": 0.0}
    groups = {g: dataclasses.replace(n, **quiet) for g, n in profile.tracker.groups.items()}
    return dataclasses.replace(profile, tracker=dataclasses.replace(profile.tracker, groups=groups, flip_enabled=False,
                                                                     body_scale_sd=0.0, trunk_turn_sd_deg=0.0))


@pytest.fixture(scope="module")
def cases():
    """Four short two-camera K4ABT sessions, two of each person of :data:`PEOPLE`, as replica cases."""
    typical = load_profile("azure_kinect").tracker
    out = []
    for who, seed in SESSIONS:
        factors, person_seed = PEOPLE[who]
        sim = build_simulation(load_scenario("azure_2cam_45").replace(duration_s=DURATION_S, seed=seed))
        sensors = dataclasses.replace(sim.sensors, depth_rate_hz=0.0, tracker=apply_factors(typical, factors))
        rec, _ = simulate_session(sim.humanoid, sim.motion, sim.rig, sensors, seed=seed, duration_s=DURATION_S,
                                  person_seed=person_seed)
        # the replicas' cameras stand where the cameras truly were: calibrated from these 8 s of a body, one
        # session put its second camera about 50 deg round the person (yaw to it 72 deg, truly 21 deg)
        calibration = dataclasses.replace(body_calibration(rec, rng=np.random.default_rng(0)),
                                          T_world_cam={p.name: p.T_world_cam for p in sim.rig.cameras})
        real = measure(rec, calibration.T_world_cam, n_boot=0, rng=np.random.default_rng(0))
        out.append(prepare_case(f"{who}_{seed}", rec, calibration, real))
    return out


@pytest.fixture(scope="module")
def fitted(cases):
    persons = {c.name: person_of(c.name) for c in cases}
    return fit_population(load_profile("azure_kinect"), cases, persons, seed=0, jobs=1)


def test_retrack_keeps_a_persons_view_bias_across_seeds(cases) -> None:
    profile = _bias_only(load_profile("azure_kinect"))
    case = cases[0]

    def positions(seed: int, person_seed: int | None) -> list[np.ndarray]:
        return [c.skeleton.positions for c in retrack(case, profile, seed=seed, person_seed=person_seed).cameras]

    for a, b in zip(positions(1, 7), positions(2, 7), strict=True):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(positions(1, 7), positions(1, 8), strict=True):
        assert np.sqrt(np.nanmean((a - b) ** 2)) > 0.005  # another person, another bias
    for a, b in zip(positions(1, None), positions(2, None), strict=True):
        assert np.sqrt(np.nanmean((a - b) ** 2)) > 0.005  # without a person: the seed's bias
    for a, b in zip(positions(3, None), positions(3, None), strict=True):
        np.testing.assert_array_equal(a, b)


def test_retrack_draws_the_person_as_a_session_does() -> None:
    """A case holding a session's own true joints, re-tracked as the session's person, reports what the
    session reported (with only the static bias, nothing else differs between the two)."""
    sim = build_simulation(load_scenario("azure_2cam_45").replace(duration_s=3.0))
    profile = _bias_only(load_profile("azure_kinect"))
    sensors = dataclasses.replace(sim.sensors, depth_rate_hz=0.0, tracker=profile.tracker)
    rec, truth = simulate_session(sim.humanoid, sim.motion, sim.rig, sensors, seed=4, duration_s=3.0, person_seed=9)
    poses = {p.name: p.T_world_cam for p in sim.rig.cameras}
    stats = measure(rec, poses, n_boot=0, rng=np.random.default_rng(0))  # not used by retrack
    case = ReplicaCase("s", stats, stats, tuple(sim.rig.cameras), tuple(c.skeleton.timestamps for c in rec.cameras),
                       tuple(t.joints_world for t in truth.cameras), tuple(t.facing_yaw for t in truth.cameras),
                       tuple(t.visible for t in truth.cameras), {})
    again = retrack(case, profile, seed=0, person_seed=9)
    for a, b in zip(rec.cameras, again.cameras, strict=True):
        np.testing.assert_allclose(b.skeleton.positions, a.skeleton.positions, atol=1e-12)
    other = retrack(case, profile, seed=0)
    assert not np.allclose(other.cameras[0].skeleton.positions, rec.cameras[0].skeleton.positions, equal_nan=True)


def test_fit_population_of_two_people(cases, fitted) -> None:
    population = fitted.profile.population
    assert population is not None and set(population.spreads) == set(Family)
    for fam, spread in population.spreads.items():
        assert np.isfinite([spread.mean, spread.person_sd, spread.session_sd]).all()
        assert 0 <= spread.person_sd <= 3 and 0 <= spread.session_sd <= 3
        assert spread.person_df == 1.0  # Student-t with people - 1 degrees of freedom
        assert Spread(spread.mean, spread.person_sd, spread.session_sd, spread.person_df) == spread
        assert fitted.families[fam].note == "" and fitted.families[fam].elasticity > 0.05
        assert spread.mean == fitted.families[fam].spread.mean  # the mixed model's intercept is the mean person
    for key in population_keys(population):
        assert fitted.profile.provenance[key].strip(), key
    assert "2 people (A, B)" in fitted.profile.provenance["population.noise_person_sd"]
    assert fitted.profile.provenance["population.bone_person_df"].startswith("people - 1 = 1: ")
    assert dict(fitted.persons) == {c.name: c.name[0] for c in cases}
    # the typical tracker is kept; the profile round-trips with its population
    assert fitted.profile.tracker == load_profile("azure_kinect").tracker
    assert profile_from_dict(tomllib.loads(profile_to_toml(fitted.profile))) == fitted.profile


def test_fit_population_tells_the_people_apart(fitted) -> None:
    """Person A's tracker is noisier, more biased, looser and less confident than person B's: each family's
    mean factors differ by at least a quarter of the true difference (8 s sessions: the steady residual
    behind the bias family is the noisiest; it gave 0.20 and 0.49 of the true 0.6 with two fits of
    ``azure_kinect``)."""
    (a_true, _), (b_true, _) = PEOPLE["A"], PEOPLE["B"]
    for fam in Family:
        factors = fitted.families[fam].factors
        a = np.mean([v for k, v in factors.items() if k.startswith("A")])
        b = np.mean([v for k, v in factors.items() if k.startswith("B")])
        assert a - b > 0.25 * (a_true[fam] - b_true[fam]), fam


def test_fit_population_refuses_bad_input(cases) -> None:
    profile = load_profile("azure_kinect")
    with pytest.raises(BadInputError, match="at least two sessions, got 1"):
        fit_population(profile, cases[:1], {cases[0].name: "A"})
    with pytest.raises(BadInputError, match="at least two sessions, got 0"):
        fit_population(profile, [], {})
    persons = {c.name: c.name[0] for c in cases[:3]}
    with pytest.raises(BadInputError, match=f"no person given for session\\(s\\) {cases[3].name}"):
        fit_population(profile, cases, persons)


def test_person_of() -> None:
    assert person_of("alice_2024-01-01") == "alice"
    assert person_of("bob") == "bob"


def test_a_known_first_re_tracking_is_not_made_again(cases, fitted) -> None:
    """The refinement's last re-tracking (same profile, same seed) stands in for the first seed's."""
    profile = load_profile("azure_kinect")
    known = [retracked_stats(c, profile, 0) for c in cases]
    persons = {c.name: person_of(c.name) for c in cases}
    again = fit_population(profile, cases, persons, seed=0, jobs=1, retracked=known)
    for fam, ff in fitted.families.items():
        assert again.families[fam].factors == pytest.approx(ff.factors, rel=1e-12), fam
    assert again.profile.population == fitted.profile.population
    with pytest.raises(BadInputError, match="3 re-trackings given for 4 sessions"):
        fit_population(profile, cases, persons, retracked=known[:3])


def test_fit_population_of_two_labs(cases) -> None:
    """Person A of lab ``x``; B and C (A's sessions under other names) of lab ``y``:
    each lab's mean person is its people's mean factor, and a new person of a lab is drawn with the
    spread of the people about their lab's mean (one degree of freedom: three people, two labs)."""
    labs = {"A": "x", "B": "y", "C": "y"}
    more = [dataclasses.replace(c, name="C" + c.name[1:]) for c in cases if c.name.startswith("A")]
    both = [dataclasses.replace(c, lab=labs[c.name[0]]) for c in [*cases, *more]]
    fit = fit_population(load_profile("azure_kinect"), both, {c.name: c.name[0] for c in both}, seed=0)
    population = fit.profile.population
    assert set(population.labs) == {"x", "y"} and dict(fit.labs) == {c.name: labs[c.name[0]] for c in both}
    for fam in Family:
        factors = fit.families[fam].factors
        mean = {p: np.mean([v for k, v in factors.items() if k[0] == p]) for p in labs}
        s_w = abs(mean["B"] - mean["C"]) / np.sqrt(2)  # A alone in its lab adds nothing
        x, y = population.labs["x"].spread(fam), population.labs["y"].spread(fam)
        assert x.mean == pytest.approx(mean["A"], abs=1e-6) and y.mean == pytest.approx((mean["B"] + mean["C"]) / 2, abs=1e-6)
        assert x.person_sd == pytest.approx(min(s_w * np.sqrt(2), 3.0)) and y.person_sd == pytest.approx(min(s_w * np.sqrt(1.5), 3.0))
        assert x.person_df == y.person_df == 1.0 and x.session_sd == y.session_sd == population.spread(fam).session_sd
    for key in population_keys(population):
        assert fit.profile.provenance[key].strip(), key
    assert "labs.y.noise_mean" in " ".join(population_keys(population))
    assert profile_from_dict(tomllib.loads(profile_to_toml(fit.profile))) == fit.profile
    # a person of a known lab is drawn from its people; of another lab, from the population
    assert population.for_lab("y") is population.labs["y"] and population.for_lab("z") is population
    assert population.for_lab(None) is population
    table = "\n".join(population_lines(fit))  # the report's lab table: each lab, its people, its families
    assert "| x | A | " in table and "| y | B, C | " in table
    assert f"{population.labs['y'].spread(Family.NOISE).mean:+.3f}" in table


def test_labs_need_every_session_named_and_one_lab_per_person(cases) -> None:
    profile = load_profile("azure_kinect")
    persons = {c.name: c.name[0] for c in cases}
    one_unnamed = [dataclasses.replace(c, lab=None if k == 0 else c.name[0]) for k, c in enumerate(cases)]
    with pytest.raises(BadInputError, match=f"session\\(s\\) {cases[0].name} name no lab while others do"):
        fit_population(profile, one_unnamed, persons)
    split = [dataclasses.replace(c, lab=str(k % 2)) for k, c in enumerate(cases)]
    with pytest.raises(BadInputError, match="person 'A' has sessions of labs 0, 1; a person is of one lab"):
        fit_population(profile, split, persons)
    # one lab named (or none) fits no lab level
    assert check_labs({c.name: "x" for c in cases}, persons) == {}
    two = check_labs({c.name: c.name[0] for c in cases}, persons)
    assert two == {c.name: c.name[0] for c in cases}
