"""Sensor populations: factors applied to a tracker, person and session draws, the [population] table."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from fusion.errors import BadInputError
from sim.sensor_population import (
    CLIP,
    Family,
    Population,
    Spread,
    apply_factors,
    confidence_scale,
    labelled_seed,
    person_streams,
    population_from_table,
    population_keys,
)
from sim.sensor_profile import load_profile
from sim.tracker_noise import JointGroup

SPREADS = {
    Family.NOISE: Spread(0.1, 0.3, 0.15),
    Family.BIAS: Spread(-0.2, 0.5, 0.05),
    Family.BONE: Spread(0.0, 0.25, 0.2),
    Family.CONFIDENCE: Spread(0.4, 0.8, 0.3),
}
FIELDS = ("mean", "person_sd", "session_sd", "person_df")


def _table(**changes: object) -> dict[str, object]:
    """A complete [population] table (of SPREADS) with some keys changed; a value None drops the key."""
    table = {f"{f.value}_{k}": getattr(s, k) for f, s in SPREADS.items() for k in FIELDS}
    table.update(changes)
    return {k: v for k, v in table.items() if v is not None}


@pytest.fixture(scope="module", params=["kinect_v2", "azure_kinect"])
def tracker(request):
    return load_profile(request.param).tracker


def test_zero_factors_leave_the_tracker_as_it_is(tracker) -> None:
    assert apply_factors(tracker, {}) == tracker
    assert apply_factors(tracker, {f: 0.0 for f in Family}) == tracker


def test_noise_factor_scales_jitter_and_wobble_only(tracker) -> None:
    out = apply_factors(tracker, {Family.NOISE: np.log(2.0)})
    for g in JointGroup:
        old, new = tracker.groups[g], out.groups[g]
        assert new.jitter_m == pytest.approx(2 * old.jitter_m, rel=1e-12)
        assert new.wobble_m == pytest.approx(2 * old.wobble_m, rel=1e-12)
        assert (new.bias_m, new.bone_rigidity, new.low_confidence) == (old.bias_m, old.bone_rigidity,
                                                                         old.low_confidence)
        assert (new.outlier_rate, new.outlier_m) == (old.outlier_rate, old.outlier_m)
    # the tracker's scalars are not a family's
    assert dataclasses.replace(out, groups=tracker.groups) == tracker


def test_bias_factor_scales_the_bias_range(tracker) -> None:
    out = apply_factors(tracker, {Family.BIAS: -0.5})
    for g in JointGroup:
        np.testing.assert_allclose(out.groups[g].bias_m, np.exp(-0.5) * np.array(tracker.groups[g].bias_m), rtol=1e-12)
        assert out.groups[g].jitter_m == tracker.groups[g].jitter_m


def test_bone_factor_scales_the_spread_and_keeps_rigidity_in_range(tracker) -> None:
    # rigidities where (1 - r) e^0.3 stays below 1 (the clamp at 0 is checked below)
    loose = {g: dataclasses.replace(n, bone_rigidity=float(np.clip(n.bone_rigidity, 0.3, 0.9)))
             for g, n in tracker.groups.items()}
    tracker = dataclasses.replace(tracker, groups=loose, body_scale_sd=0.0)  # the bones vary each on its own
    out = apply_factors(tracker, {Family.BONE: 0.3})
    for g in JointGroup:
        r = tracker.groups[g].bone_rigidity
        assert 1 - out.groups[g].bone_rigidity == pytest.approx((1 - r) * np.exp(0.3), rel=1e-9)
    loose = apply_factors(tracker, {Family.BONE: 5.0})  # (1 - r) e^5 > 1: no rigidity left
    assert all(loose.groups[g].bone_rigidity == 0.0 for g in JointGroup)
    stiff = apply_factors(tracker, {Family.BONE: -20.0})  # (1 - r) e^-20 ~ 0: held at 0.99
    assert all(stiff.groups[g].bone_rigidity == 0.99 for g in JointGroup)


def test_bone_factor_of_a_template_tracker_scales_its_body_scale(tracker) -> None:
    template = dataclasses.replace(tracker, body_scale_sd=0.04)
    out = apply_factors(template, {Family.BONE: 0.3})
    assert out.body_scale_sd == pytest.approx(0.04 * np.exp(0.3), rel=1e-12)
    assert dataclasses.replace(out, body_scale_sd=0.04) == template  # rigidity and the rest kept
    assert apply_factors(template, {Family.BONE: 5.0}).body_scale_sd == 0.2  # the model's bound


def test_confidence_factor_shifts_the_arcsine_scale() -> None:
    base = load_profile("kinect_v2").tracker
    shares = {JointGroup.LIMB: (0.04, 0.04, 0.5), JointGroup.FOOT: (0.2, 0.3, 0.6)}  # away from 0 and 1
    tracker = dataclasses.replace(base, groups={g: dataclasses.replace(
        n, low_confidence=shares[g][:2], hidden_low_confidence=shares[g][2]) if g in shares else n
        for g, n in base.groups.items()})
    limb = tracker.groups[JointGroup.LIMB]
    out = apply_factors(tracker, {Family.CONFIDENCE: 0.7}).groups[JointGroup.LIMB]
    p = limb.low_confidence[0]
    assert out.low_confidence[0] == pytest.approx(math.sin(math.asin(math.sqrt(p)) + 0.7) ** 2, rel=1e-12)  # by hand
    foot = tracker.groups[JointGroup.FOOT]
    down = apply_factors(tracker, {Family.CONFIDENCE: -0.3}).groups[JointGroup.FOOT]
    on_scale = [confidence_scale(x) for x in (down.low_confidence[1], foot.low_confidence[1],
                                              down.hidden_low_confidence, foot.hidden_low_confidence)]
    assert on_scale[0] - on_scale[1] == pytest.approx(-0.3, abs=1e-9)
    assert on_scale[2] - on_scale[3] == pytest.approx(-0.3, abs=1e-9)
    assert apply_factors(tracker, {Family.CONFIDENCE: -2.0}).groups[JointGroup.FOOT].low_confidence[1] == 0.0
    assert apply_factors(tracker, {Family.CONFIDENCE: 2.0}).groups[JointGroup.FOOT].low_confidence[1] == 1.0


def test_confidence_factor_keeps_shares_of_zero_and_one() -> None:
    tracker = load_profile("kinect_v2").tracker  # torso: low_confidence (0, 0); limb: hidden share 1
    out = apply_factors(tracker, {Family.CONFIDENCE: 1.0})
    assert out.groups[JointGroup.TORSO].low_confidence == (0.0, 0.0)
    assert out.groups[JointGroup.LIMB].hidden_low_confidence == 1.0


def test_zero_factors_leave_any_rigidity_as_it_is() -> None:
    tracker = load_profile("kinect_v2").tracker
    groups = {g: dataclasses.replace(n, bone_rigidity=0.1) for g, n in tracker.groups.items()}
    tracker = dataclasses.replace(tracker, groups=groups)
    assert apply_factors(tracker, {}) == tracker


def test_draws_are_reproducible_from_the_seed() -> None:
    pop = Population(SPREADS)
    a = pop.draw_person(np.random.default_rng(3))
    assert a == pop.draw_person(np.random.default_rng(3))
    assert a != pop.draw_person(np.random.default_rng(4))
    s = pop.draw_session(a, np.random.default_rng(9))
    assert s == pop.draw_session(a, np.random.default_rng(9))
    assert s != pop.draw_session(a, np.random.default_rng(10))
    assert set(a) == set(s) == set(Family)


def test_person_and_session_statistics() -> None:
    pop = Population(SPREADS)
    rng = np.random.default_rng(0)
    n = 4000
    people = [pop.draw_person(rng) for _ in range(n)]
    sessions = [pop.draw_session(p, rng) for p in people]
    for f, s in SPREADS.items():
        person = np.array([p[f] for p in people])
        session = np.array([x[f] for x in sessions])
        assert person.mean() == pytest.approx(s.mean, abs=0.05 * s.person_sd + 1e-12)
        assert person.std() == pytest.approx(s.person_sd, rel=0.05)
        assert (session - person).mean() == pytest.approx(0.0, abs=0.05 * s.session_sd)
        assert (session - person).std() == pytest.approx(s.session_sd, rel=0.05)
        assert session.std() == pytest.approx(np.hypot(s.person_sd, s.session_sd), rel=0.05)


def test_sessions_of_one_person_share_the_person_part() -> None:
    pop = Population(SPREADS)
    person = pop.draw_person(np.random.default_rng(11))
    rng = np.random.default_rng(12)
    sessions = [pop.draw_session(person, rng) for _ in range(4000)]
    for f, s in SPREADS.items():
        values = np.array([x[f] for x in sessions])
        assert values.mean() == pytest.approx(person[f], abs=0.05 * s.session_sd)
        assert values.std() == pytest.approx(s.session_sd, rel=0.05)
    still = Population({f: dataclasses.replace(s, session_sd=0.0) for f, s in SPREADS.items()})
    assert still.draw_session(person, np.random.default_rng(1)) == person


def test_a_family_not_given_does_not_vary() -> None:
    pop = Population({Family.NOISE: Spread(0.0, 0.4, 0.2)})
    assert pop.spread(Family.BONE) == Spread()
    rng = np.random.default_rng(5)
    for _ in range(20):
        s = pop.draw_session(pop.draw_person(rng), rng)
        assert s[Family.BIAS] == s[Family.BONE] == s[Family.CONFIDENCE] == 0.0
        assert s[Family.NOISE] != 0.0


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"person_sd": -0.1}, "person_sd must lie in \\[0, 3\\]"),
        ({"session_sd": float("nan")}, "session_sd must lie in \\[0, 3\\]"),
        ({"person_sd": 3.5}, "person_sd must lie in \\[0, 3\\]"),
        ({"session_sd": float("inf")}, "session_sd must lie in \\[0, 3\\]"),
        ({"mean": float("nan")}, "mean must be finite"),
        ({"mean": float("-inf")}, "mean must be finite"),
        ({"person_df": 0.99}, "person_df must be >= 1"),
        ({"person_df": 0.0}, "person_df must be >= 1"),
        ({"person_df": -2.0}, "person_df must be >= 1"),
        ({"person_df": float("nan")}, "person_df must be >= 1"),
        ({"person_df": float("-inf")}, "person_df must be >= 1"),
    ],
)
def test_spread_refuses_bad_values(kwargs, message) -> None:
    with pytest.raises(BadInputError, match=message):
        Spread(**kwargs)


def test_spread_limits_are_allowed() -> None:
    assert Spread(-2.0, 0.0, 3.0).session_sd == 3.0
    assert Spread(0.0, 0.5, 0.0, 1.0).person_df == 1.0
    assert Spread().person_df == float("inf")  # a normal person draw unless told


def _person_draws(spread: Spread, n: int, seed: int) -> np.ndarray:
    pop = Population({Family.NOISE: spread})
    rng = np.random.default_rng(seed)
    return np.array([pop.draw_person(rng)[Family.NOISE] for _ in range(n)])


def test_t_person_draws_have_heavier_tails_than_normal() -> None:
    mean, sd, n = 0.2, 0.5, 4000
    normal = (_person_draws(Spread(mean, sd, 0.0), n, 1) - mean) / sd
    heavy = (_person_draws(Spread(mean, sd, 0.0, 2.0), n, 1) - mean) / sd
    # beyond 2 scale units: 4.6 % of a normal, 18 % of a Student-t with 2 degrees of freedom
    assert np.mean(np.abs(normal) > 2) == pytest.approx(0.046, abs=0.015)
    assert np.mean(np.abs(heavy) > 2) > 0.12
    assert np.median(np.abs(heavy)) == pytest.approx(0.816, abs=0.06)  # t(2): median |t| = sqrt(2/3)
    assert np.max(np.abs(heavy)) <= CLIP + 1e-12  # never beyond CLIP person_sd from the mean
    assert np.mean(np.abs(heavy) > CLIP - 1e-9) > 0.06  # t(2): P(|t| > 3) = 9.5 %, all held at the clip


def test_cauchy_person_draws_are_clipped() -> None:
    mean, sd = -0.3, 0.4
    heavy = _person_draws(Spread(mean, sd, 0.0, 1.0), 2000, 2)  # Cauchy: P(|t| > 4) = 16 %
    assert np.max(np.abs(heavy - mean)) <= CLIP * sd + 1e-12
    assert np.sum(np.isclose(np.abs(heavy - mean), CLIP * sd, rtol=0, atol=1e-12)) > 100  # held at the clip


class _Extreme:
    """A generator whose every normal draw is ``z`` and chi-square draw nearly 0 (a huge t)."""

    def __init__(self, z: float) -> None:
        self.z = z

    def standard_normal(self, n: int) -> np.ndarray:
        return np.full(n, self.z)

    def chisquare(self, df: float) -> float:
        return 1e-9


@pytest.mark.parametrize("z", [50.0, -50.0])
def test_extreme_draws_stop_at_the_clip(z) -> None:
    spreads = {Family.NOISE: Spread(0.1, 0.3, 0.2), Family.BIAS: Spread(-0.2, 0.5, 0.05, 3.0)}
    pop = Population(spreads)
    person = pop.draw_person(_Extreme(z))
    sign = np.sign(z)
    assert person[Family.NOISE] == pytest.approx(0.1 + sign * CLIP * 0.3, abs=1e-12)
    assert person[Family.BIAS] == pytest.approx(-0.2 + sign * CLIP * 0.5, abs=1e-12)
    assert person[Family.BONE] == 0.0
    session = pop.draw_session(person, _Extreme(z))
    assert session[Family.NOISE] - person[Family.NOISE] == pytest.approx(sign * CLIP * 0.2, abs=1e-12)
    assert session[Family.BIAS] - person[Family.BIAS] == pytest.approx(sign * CLIP * 0.05, abs=1e-12)


def test_person_streams_are_reproducible_and_distinct_per_camera() -> None:
    def sample(streams):
        factors, model, views = streams
        return factors.random(4).tolist(), model.random(4).tolist(), [v.random(4).tolist() for v in views]

    a = sample(person_streams(7, 3))
    assert a == sample(person_streams(7, 3))
    factors, model, views = a
    assert len(views) == 3
    streams = [factors, model, *views]
    assert all(x != y for i, x in enumerate(streams) for y in streams[i + 1:])  # each its own stream
    b = sample(person_streams(8, 3))
    assert all(x != y for x, y in zip(a[:2] + tuple(a[2]), b[:2] + tuple(b[2])))
    # the cameras by their place: another camera leaves the person and the first cameras alone
    c = sample(person_streams(7, 4))
    assert c[:2] == a[:2] and c[2][:3] == a[2]


def test_population_from_table() -> None:
    pop = population_from_table(_table(), "p.toml")
    assert dict(pop.spreads) == SPREADS
    partial = population_from_table({"bone_mean": 0, "bone_person_sd": 0.2, "bone_session_sd": 0.1,
                                     "bone_person_df": 3}, "p.toml")
    assert set(partial.spreads) == {Family.BONE} and partial.spread(Family.BONE) == Spread(0.0, 0.2, 0.1, 3.0)
    assert population_from_table({}, "p.toml").spreads == {}
    assert len(population_keys()) == 16 and "population.confidence_person_df" in population_keys()
    assert population_keys(partial) == [f"population.bone_{k}" for k in FIELDS]


@pytest.mark.parametrize(
    "table, message",
    [
        (_table(noise_sd=0.1), "p.toml \\[population\\]: unknown key 'noise_sd'; allowed: noise_mean"),
        (_table(bias_session_sd=None), "give all of bias_mean, bias_person_sd, bias_session_sd, bias_person_df or "),
        (_table(noise_person_df=None), "give all of noise_mean, noise_person_sd, noise_session_sd, noise_person_df "),
        ({"bone_mean": 0.0}, "give all of bone_mean, bone_person_sd, bone_session_sd, bone_person_df or none"),
        (_table(noise_person_sd="wide"), "noise_mean, noise_person_sd, noise_session_sd, noise_person_df must be "),
        (_table(confidence_mean=[0.1]), "confidence_mean, confidence_person_sd, confidence_session_sd, "
                                        "confidence_person_df must be numbers"),
        (_table(bias_person_df="inf"), "bias_person_df must be numbers"),
        (_table(bone_person_df=0.5), "person_df must be >= 1"),
    ],
)
def test_population_table_refuses_bad_tables(table, message) -> None:
    with pytest.raises(BadInputError, match=message):
        population_from_table(table, "p.toml")


def test_population_table_names_an_sd_out_of_range() -> None:
    with pytest.raises(BadInputError, match="person_sd must lie in \\[0, 3\\]"):
        population_from_table(_table(bone_person_sd=-0.2), "p.toml")


@pytest.mark.parametrize("value", ["0.5", True])
def test_population_table_refuses_text_and_booleans(value) -> None:
    with pytest.raises(BadInputError, match="must be numbers"):
        population_from_table(_table(noise_mean=value), "p.toml")


def test_a_population_of_labs_reads_and_refuses() -> None:
    table = {"noise_mean": 0.0, "noise_person_sd": 0.3, "noise_session_sd": 0.2, "noise_person_df": 6.0,
             "labs": {"ui_prmd": {"noise_mean": -0.1, "noise_person_sd": 0.2, "noise_session_sd": 0.2,
                                  "noise_person_df": 5.0}}}
    population = population_from_table(table, "p")
    lab = population.for_lab("ui_prmd")
    assert lab.spread(Family.NOISE) == Spread(-0.1, 0.2, 0.2, 5.0) and not lab.labs
    assert population.for_lab("kimore") is population and population.for_lab(None) is population
    assert population.lab_words("ui_prmd") == ", of lab ui_prmd's people"
    assert "not among its labs, ui_prmd" in population.lab_words("kimore") and population.lab_words(None) == ""
    assert population_keys(population)[-4:] == [f"population.labs.ui_prmd.noise_{k}" for k in FIELDS]
    with pytest.raises(BadInputError, match=r"\[population.labs.ui_prmd\]: unknown key 'labs'"):
        population_from_table(table | {"labs": {"ui_prmd": {"labs": {}}}}, "p")
    with pytest.raises(BadInputError, match=r"one table per lab"):
        population_from_table(table | {"labs": {"ui_prmd": 1.0}}, "p")
    with pytest.raises(BadInputError, match="a lab name must be"):
        Population({}, {"a.b": Population({})})
    with pytest.raises(BadInputError, match="knows no labs"):
        Population({}, {"a": population})


def test_a_labelled_seed_is_stable_and_its_own():
    assert labelled_seed(3, "s01") == labelled_seed(3, "s01")
    assert len({labelled_seed(3, "s01"), labelled_seed(3, "s02"), labelled_seed(4, "s01")}) == 3
