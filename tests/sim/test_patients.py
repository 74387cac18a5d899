"""The literature-based patient model: severity bands, item-score consistency, ipsilesional deficits."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats

from fusion.errors import BadInputError
from sim.patient_motion import FMA_UE_MAX, Group, Movement, Side, SubjectProfile
from sim.patients import (
    ANCHOR_SCORES,
    GROUP_BANDS,
    POSTACUTE_FMA,
    RT_HEALTHY_MS,
    ModelPart,
    PatientModel,
    SeverityDistribution,
    draw_fma,
    draw_subject,
    parameter_mean,
    sample_patient,
    severity_fraction,
)
from sim.scoring import item_scores

PATIENTS = (Group.MILD, Group.MODERATE_SEVERE)


def _other(side):
    return Side.LEFT if side is Side.RIGHT else Side.RIGHT


def test_smoke_and_shapes():
    p = sample_patient(Group.MILD, rng=np.random.default_rng(0))
    assert isinstance(p, SubjectProfile) and p.group is Group.MILD and isinstance(p.affected_side, Side)
    lo, hi = GROUP_BANDS[Group.MILD]
    assert lo <= p.fma_ue <= hi and p.fma_ue == round(p.fma_ue)
    assert p.initiation_delay >= 0.0


@given(seed=st.integers(0, 2**32 - 1), group=st.sampled_from(PATIENTS), frac=st.floats(0.0, 1.0))
def test_item_scores_never_lose_more_points_than_the_fma_total(seed, group, frac):
    lo, hi = GROUP_BANDS[group]
    fma = float(round(lo + frac * (hi - lo)))
    p = sample_patient(group, rng=np.random.default_rng(seed), fma_ue=fma)
    affected = item_scores(p, p.affected_side)
    assert 14 - affected.total <= FMA_UE_MAX - fma
    assert item_scores(p, _other(p.affected_side)).total == 14  # clinical scales: the other arm scores full
    assert p.fma_ue == fma


def test_a_full_score_patient_earns_every_item():
    for seed in range(30):
        p = sample_patient(Group.MILD, rng=np.random.default_rng(seed), fma_ue=66)
        assert item_scores(p, p.affected_side).total == 14


def test_item_classes_are_not_degenerate_within_a_group():
    for group in PATIENTS:
        lifts, salutes = set(), set()
        for seed in range(150):
            p = sample_patient(group, rng=np.random.default_rng(seed))
            s = item_scores(p, p.affected_side)
            lifts.add(s.hand_lift)
            salutes.add(s.salute)
        assert len(lifts) >= 2 and len(salutes) >= 2, group


def test_parameter_means_pass_through_the_anchors_and_are_monotonic():
    anchors = (5.0, 2.25, 1.2)
    assert [parameter_mean(anchors, s) for s in ANCHOR_SCORES] == list(anchors)
    assert parameter_mean(anchors, 10.0) == 5.0 and parameter_mean(anchors, 35.0) == pytest.approx(3.625)
    assert severity_fraction(66) == 0.0 and severity_fraction(20) == 1.0 and severity_fraction(0) == 1.0
    assert severity_fraction(43) == pytest.approx(0.5)


def _mean_affected(group, fma, attr, movement=Movement.HAND_LIFT, n=60):
    vals = []
    for seed in range(n):
        p = sample_patient(group, rng=np.random.default_rng(seed), fma_ue=fma)
        vals.append(getattr(p.movement(movement, p.affected_side), attr))
    return float(np.mean(vals))


def test_affected_arm_worsens_with_severity():
    assert _mean_affected(Group.MODERATE_SEVERE, 22, "rise_time") > _mean_affected(Group.MILD, 62, "rise_time")
    assert _mean_affected(Group.MODERATE_SEVERE, 22, "trunk_forward") > _mean_affected(Group.MILD, 62, "trunk_forward")
    assert (_mean_affected(Group.MODERATE_SEVERE, 22, "peak_elevation", Movement.SALUTE)
            < _mean_affected(Group.MILD, 62, "peak_elevation", Movement.SALUTE))


def test_ipsilesional_slowing_grows_with_severity():
    def ratio(group, fma):
        r = []
        for seed in range(80):
            p = sample_patient(group, rng=np.random.default_rng(seed), fma_ue=fma)
            r.append(p.movement(Movement.HAND_LIFT, _other(p.affected_side)).rise_time)
        return float(np.mean(r))

    healthy = 1.2  # mid of the healthy 0.9-1.5 s range the ipsilesional side starts from
    full = ratio(Group.MILD, 66)
    assert full == pytest.approx(healthy, abs=0.06)  # no severity, no slowing
    assert ratio(Group.MODERATE_SEVERE, 20) > ratio(Group.MODERATE_SEVERE, 45) > full


def test_initiation_delay_follows_the_response_times_of_the_paretic_side():
    def mean_delay(side):
        return np.mean([sample_patient(Group.MILD, rng=np.random.default_rng(s), affected_side=side).initiation_delay
                        for s in range(300)])

    right, left = mean_delay(Side.RIGHT), mean_delay(Side.LEFT)
    assert right > left > 0.0
    # E[max(0, RT - 332 ms)] of N(474, 144) ms, the oracle of the right-hemiplegia group
    mu, sd, h = 474.0, 144.0, RT_HEALTHY_MS[0]
    z = (mu - h) / sd
    pdf, cdf = math.exp(-0.5 * z * z) / math.sqrt(2 * math.pi), 0.5 * (1 + math.erf(z / math.sqrt(2)))
    expected = ((mu - h) * cdf + sd * pdf) / 1000.0
    assert right == pytest.approx(expected, rel=0.1)


@given(seed=st.integers(0, 2**32 - 1))
def test_draw_fma_stays_in_the_band(seed):
    for group in PATIENTS:
        for dist in SeverityDistribution:
            lo, hi = GROUP_BANDS[group]
            assert lo <= draw_fma(group, dist, rng=np.random.default_rng(seed)) <= hi


def test_postacute_severity_leans_towards_its_mean():
    rng = np.random.default_rng(1)
    uniform = np.mean([draw_fma(Group.MILD, SeverityDistribution.UNIFORM, rng=rng) for _ in range(2000)])
    postacute = np.mean([draw_fma(Group.MILD, SeverityDistribution.POSTACUTE, rng=rng) for _ in range(2000)])
    assert uniform == pytest.approx(58.0, abs=0.5)
    mu, sd = POSTACUTE_FMA  # oracle: the normal truncated to the band (integers: +-0.5 around it)
    expected = stats.truncnorm.mean((49.5 - mu) / sd, (66.5 - mu) / sd, loc=mu, scale=sd)
    assert postacute == pytest.approx(expected, abs=0.3) and postacute < uniform - 0.5


def test_reproducible():
    a = sample_patient(Group.MODERATE_SEVERE, rng=np.random.default_rng(5))
    b = sample_patient(Group.MODERATE_SEVERE, rng=np.random.default_rng(5))
    assert a == b


def test_draw_subject_models():
    rng = np.random.default_rng(2)
    assert draw_subject(Group.HEALTHY, PatientModel.LITERATURE, SeverityDistribution.UNIFORM, rng=rng).fma_ue is None
    assert draw_subject(Group.MILD, PatientModel.RANGES, SeverityDistribution.UNIFORM, rng=rng).fma_ue is None
    assert draw_subject(Group.MILD, PatientModel.LITERATURE, SeverityDistribution.UNIFORM, rng=rng).fma_ue >= 50


def test_bad_input():
    rng = np.random.default_rng(0)
    with pytest.raises(BadInputError, match="MILD or Group.MODERATE_SEVERE"):
        sample_patient(Group.HEALTHY, rng=rng)
    with pytest.raises(BadInputError, match=r"\[20, 49\]"):
        sample_patient(Group.MODERATE_SEVERE, rng=rng, fma_ue=55)
    with pytest.raises(BadInputError, match="SeverityDistribution"):
        sample_patient(Group.MILD, rng=rng, distribution="uniform")
    with pytest.raises(BadInputError, match="affected_side"):
        sample_patient(Group.MILD, rng=rng, affected_side="left")
    with pytest.raises(BadInputError, match="patient group"):
        draw_fma(Group.HEALTHY, SeverityDistribution.UNIFORM, rng=rng)
    with pytest.raises(BadInputError, match="PatientModel"):
        draw_subject(Group.MILD, "literature", SeverityDistribution.UNIFORM, rng=rng)
    healthy = SubjectProfile.healthy()
    with pytest.raises(BadInputError, match="fma_ue"):
        SubjectProfile(healthy.group, None, healthy.salute_left, healthy.salute_right, healthy.hand_lift_left,
                       healthy.hand_lift_right, fma_ue=70.0)
    with pytest.raises(BadInputError, match="initiation_delay"):
        SubjectProfile(healthy.group, None, healthy.salute_left, healthy.salute_right, healthy.hand_lift_left,
                       healthy.hand_lift_right, initiation_delay=-1.0)


def test_mean_kinematics_agree_with_every_score(monkeypatch):
    import sim.patients

    monkeypatch.setattr(sim.patients, "MAX_REDRAWS", 0)  # the first and only draw is the noiseless mean
    for fma in range(20, 67):
        group = Group.MILD if fma >= 50 else Group.MODERATE_SEVERE
        p = sample_patient(group, rng=np.random.default_rng(fma), fma_ue=fma)
        assert 14 - item_scores(p, p.affected_side).total <= FMA_UE_MAX - fma, fma


def test_ablation_switches_one_part_off_and_keeps_the_rest_of_the_draw():
    def draw(seed, ablate=frozenset()):
        return sample_patient(Group.MODERATE_SEVERE, rng=np.random.default_rng(seed), fma_ue=30, ablate=ablate)

    trunk = ("trunk_forward", "trunk_lateral", "trunk_rotation", "shoulder_hiking")
    changed = 0
    for seed in range(20):
        full, ablated = draw(seed), draw(seed, frozenset({ModelPart.TRUNK}))
        side = full.affected_side
        assert ablated.affected_side is side and ablated.initiation_delay == full.initiation_delay
        for movement in (Movement.SALUTE, Movement.HAND_LIFT):
            a, f = ablated.movement(movement, side), full.movement(movement, side)
            assert a.trunk_forward == pytest.approx(0.025) and a.shoulder_hiking == pytest.approx(0.005)
            assert a.trunk_lateral == pytest.approx(math.radians(1.5))
            if (a.rise_time, a.peak_elevation) == (f.rise_time, f.peak_elevation):  # not redrawn
                assert all(getattr(f, k) != getattr(a, k) for k in trunk)
                changed += 1
            assert ablated.movement(movement, _other(side)) == full.movement(movement, _other(side))
    assert changed >= 30  # paired: the same subjects apart from the trunk

    for seed in range(5):
        full = draw(seed)
        quiet = draw(seed, frozenset({ModelPart.IPSILESIONAL, ModelPart.INITIATION}))
        other = _other(full.affected_side)
        assert quiet.initiation_delay == 0.0 and full.initiation_delay >= 0.0
        assert quiet.movement(Movement.SALUTE, full.affected_side) == full.movement(Movement.SALUTE, full.affected_side)
        assert quiet.movement(Movement.HAND_LIFT, other).rise_time <= full.movement(Movement.HAND_LIFT, other).rise_time
    timing = draw(3, frozenset({ModelPart.TIMING, ModelPart.SYNERGY, ModelPart.ELEVATION}))
    lift = timing.movement(Movement.HAND_LIFT, timing.affected_side)
    assert (lift.rise_time, lift.n_submovements, lift.synergy_onset) == pytest.approx((1.2, 1, math.radians(70.0)))
    assert lift.peak_elevation == pytest.approx(math.radians(90.0))
    with pytest.raises(BadInputError, match="ablate"):
        sample_patient(Group.MILD, rng=np.random.default_rng(0), ablate=frozenset({"trunk"}))
    with pytest.raises(BadInputError, match="literature"):
        draw_subject(Group.MILD, PatientModel.RANGES, SeverityDistribution.UNIFORM, rng=np.random.default_rng(0),
                     ablate=frozenset({ModelPart.TRUNK}))
