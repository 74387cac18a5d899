"""Simulation-based refinement of a sensor profile on replicas: a simulated 'real' session with a
known tracker model, a start profile that is wrong, and the refinement moving toward the truth."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fusion.calibrate.level import level_camera_calibration
from fusion.errors import BadInputError
from fusion.topology import KINECT_V2, UI_PRMD
from scenarios.cli import main
from scenarios.config import load_scenario
from scenarios.runner import build_simulation
from scenarios.sensors.fit import measure
from scenarios.sensors.fit_confidence import fit_confidence
from scenarios.sensors.fit_replica import (
    activity_slope,
    loss,
    pooled_ratio,
    refine_on_replicas,
    update_profile,
)
from scenarios.sensors.fit_structure import (
    BONE_STEP_SLOPE,
    CAMERA_SCALE_SLOPE,
    COSINE_SLOPE,
    DAMPING,
    SHARED_BONES_SLOPE,
    STRUCTURE_PARTS,
    TAIL_SLOPE,
    TURN_SLOPE,
    VIEW_SHARE_SLOPE,
    group_activity_slopes,
    shares_people,
    statistic_gap,
    structure_keys,
    turn_spread,
)
from scenarios.sensors.replica_case import prepare_case, retrack
from scenarios.sensors.replica_ratios import measured_on_own_joints
from sim.sensor_profile import load_profile
from sim.session import simulate_session
from sim.tracker_noise import JointGroup


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


def test_pooled_ratio_ignores_one_unlike_recording() -> None:
    ratios = np.array([[1.2, 1.1], [1.25, 1.15], [1.15, 1.2], [1.2, 1.05], [10.0, 12.0]])
    geometric_mean = float(np.exp(np.log(ratios).mean()))
    assert abs(np.log(pooled_ratio(ratios) / 1.16)) < 0.03 and geometric_mean > 1.7
    # two recordings: the geometric mean of all; missing entries are skipped
    assert np.isclose(pooled_ratio(ratios[:2]), np.exp(np.log(ratios[:2]).mean()))
    assert np.isclose(pooled_ratio(np.array([[2.0, np.nan], [0.0, 3.0]])), np.sqrt(6.0))
    assert pooled_ratio(np.full((2, 3), np.nan)) == 1.0


def test_update_not_moved_by_one_unlike_recording(case) -> None:
    """Four recordings matched by their simulation and a fifth with a ten times larger steady residual
    and bone spread: the update stays put (a geometric mean would move them by 10^(0.8/5) = 1.44)."""
    c, _ = case
    real = c.real
    bones = {b: dataclasses.replace(v, value=10 * v.value) for b, v in real.bone_std_mm.items()}
    unlike = dataclasses.replace(c, real=dataclasses.replace(
        real, residual_static_joint_mm=10 * real.residual_static_joint_mm, bone_std_mm=bones))
    start = load_profile("azure_kinect")
    updated = update_profile(start, [c] * 4 + [unlike], [real] * 5)
    for g in (JointGroup.LIMB, JointGroup.HAND):
        before, after = start.tracker.groups[g], updated.tracker.groups[g]
        assert abs(np.log(after.bias_m[1] / before.bias_m[1])) < 0.05
        assert abs(after.bone_rigidity - before.bone_rigidity) < 0.05
        assert abs(np.log(after.wobble_m / before.wobble_m)) < 0.05


def test_loss_not_dominated_by_one_recording(case) -> None:
    c, _ = case
    off = loss([c], [c.motion])
    assert off > 1.0
    assert loss([c] * 5, [c.real] * 4 + [c.motion]) == 0.0
    # one or two recordings: the sum of their terms
    assert np.isclose(loss([c, c], [c.real, c.motion]), off)


def test_cli_refuses_two_refinements(tmp_path, capsys) -> None:
    code = main(["sensor-fit", str(tmp_path / "rec"), "--out", str(tmp_path / "p.toml"), "--replicas",
                 "--scenario", "azure_2cam_45"])
    assert code != 0 and "choose one" in capsys.readouterr().err
    assert not (tmp_path / "p.toml").exists()
    code = main(["sensor-fit", str(tmp_path / "rec"), "--out", str(tmp_path / "p.toml"), "--structure", "hidden-offsets"])
    assert code != 0 and "add --replicas or --population" in capsys.readouterr().err
    assert not (tmp_path / "p.toml").exists()


def test_activity_exponent_recovered(case) -> None:
    """The same replica played at 1.5 and 2 times its speed is that much more active; a 'real' tracker
    whose errors grow with the activity (exponent 1) makes the slope of the log-ratios 1 and the
    refinement find it."""
    c, _ = case
    faster = [dataclasses.replace(c, name=f"x{f}", timestamps=tuple(t / f for t in c.timestamps)) for f in (1.5, 2)]
    assert faster[1].activity == pytest.approx(2 * c.activity, rel=1e-6)
    start = load_profile("azure_kinect")
    start = dataclasses.replace(start, tracker=dataclasses.replace(start.tracker, activity_exponent=0.0))
    truth = dataclasses.replace(start, tracker=dataclasses.replace(
        start.tracker, activity_exponent=1.0, activity_ref_m_s=1.5 * c.activity,
        activity_range_m_s=(c.activity, 2 * c.activity)))
    cases = [dataclasses.replace(k, real=measure(retrack(k, truth, seed=5), None, n_boot=0,
                                                 rng=np.random.default_rng(0))) for k in (c, *faster)]
    sims = [measure(retrack(k, start), None, n_boot=0, rng=np.random.default_rng(0)) for k in cases]
    assert activity_slope(cases, sims) == pytest.approx(1.0, abs=0.35)
    assert activity_slope(cases[:2], sims[:2]) is None  # two recordings: nothing to tell activity from
    fit = refine_on_replicas(start, cases, iterations=4, speeds=(start.tracker.speed_ref_m_s,))
    assert fit.profile.tracker.activity_exponent == pytest.approx(1.0, abs=0.35)
    assert fit.profile.tracker.activity_ref_m_s == pytest.approx(1.5 * c.activity, rel=1e-6)
    assert fit.profile.tracker.activity_range_m_s == pytest.approx((c.activity, 2 * c.activity), rel=1e-6)


def test_structure_parts_follow_their_statistics(case) -> None:
    c, _ = case
    start = load_profile("azure_kinect")
    higher = dataclasses.replace(c, real=dataclasses.replace(
        c.real, residual_limb_cosine=c.real.residual_limb_cosine + 0.3, residual_tail=c.real.residual_tail + 0.02))
    assert statistic_gap([higher] * 3, [c.real] * 3, "residual_limb_cosine") == pytest.approx(0.3)
    assert update_profile(start, [higher], [c.real]).tracker == update_profile(start, [c], [c.real]).tracker  # not asked
    moved = update_profile(start, [higher], [c.real], structure=("limb-sharing",))
    assert moved.tracker.view_limb_correlation == pytest.approx(DAMPING * 0.3 / COSINE_SLOPE)
    assert moved.tracker.hidden_offset_share == 0.0
    assert "limb cosine" in moved.provenance["tracker.view_limb_correlation"]
    both = update_profile(start, [higher], [c.real], structure=("limb-sharing", "hidden-offsets"))
    assert both.tracker.hidden_offset_share == pytest.approx(DAMPING * 0.02 / TAIL_SLOPE)
    assert "beyond 8 cm" in both.provenance["tracker.hidden_offset_share"]
    unseen = dataclasses.replace(c.real, residual_limb_cosine=float("nan"), residual_tail=float("nan"))  # one camera
    assert statistic_gap([c], [unseen], "residual_tail") is None
    kept = update_profile(start, [c], [unseen], structure=STRUCTURE_PARTS).tracker
    assert kept.view_limb_correlation == 0.0 and kept.hidden_offset_share == 0.0
    with pytest.raises(BadInputError, match="unknown model part"):
        update_profile(start, [c], [c.real], structure=("limbs",))


def test_bone_parts_and_outlier_sizes_follow_their_statistics(case) -> None:
    """More of the real residual and steps along the bones move the alignments by the gap over the slope;
    real spikes half as long halve the outliers (damped) of the groups measured on their own joints."""
    c, _ = case
    start = load_profile("azure_kinect")
    spikes = {k: dataclasses.replace(v, value=0.5 * v.value) for k, v in c.real.spike_mm.items()}
    real = dataclasses.replace(c.real, residual_bone_share=c.real.residual_bone_share + 0.1,
                               bone_step_share=c.real.bone_step_share + 0.05, spike_mm=spikes)
    moved = update_profile(start, [dataclasses.replace(c, real=real)], [c.real],
                           structure=("bone-view", "bone-noise", "outlier-size"))
    tr = moved.tracker
    assert tr.view_bone_alignment == pytest.approx(DAMPING * 0.1 / VIEW_SHARE_SLOPE)
    assert tr.noise_bone_alignment == pytest.approx(DAMPING * 0.05 / BONE_STEP_SLOPE)
    for g in (JointGroup.LIMB, JointGroup.HAND):
        assert tr.groups[g].outlier_m == pytest.approx(tuple(0.5**DAMPING * v for v in start.tracker.groups[g].outlier_m))
    assert tr.groups[JointGroup.HIP].outlier_m == start.tracker.groups[JointGroup.HIP].outlier_m
    assert "second differences over 5 cm" in moved.provenance["tracker.groups.hand.outlier_m"]
    assert {"tracker.view_bone_alignment", "tracker.groups.hand.outlier_m"} <= set(
        structure_keys(("bone-view", "outlier-size")))


def test_size_parts_follow_their_statistics(case) -> None:
    """A real second camera seeing the person 1 % further from the first's size, and agreeing 1 % better on
    the proportions, moves the camera scale and the shared bone lengths by the gap over the slope."""
    c, _ = case
    start = load_profile("azure_kinect")
    real = dataclasses.replace(c.real, camera_scale=c.real.camera_scale + 0.01,
                               bone_ratio_spread=c.real.bone_ratio_spread - 0.01)
    moved = update_profile(start, [dataclasses.replace(c, real=real)], [c.real], structure=("camera-scale", "shared-bones"))
    assert moved.tracker.camera_scale_sd == pytest.approx(DAMPING * 0.01 / CAMERA_SCALE_SLOPE)
    assert moved.tracker.shared_bone_lengths == pytest.approx(DAMPING * -0.01 / SHARED_BONES_SLOPE)
    assert "proportions" not in moved.provenance["tracker.camera_scale_sd"]
    assert "spread over the limb bones" in moved.provenance["tracker.shared_bone_lengths"]


def test_the_trunk_turn_follows_its_spread_over_a_persons_sessions(case) -> None:
    """Real trunk turns spreading 1 deg about a person's mean, simulated ones 0.5 deg: the turn's variance
    grows by the damped gap of the squared spreads over the slope; without people nothing moves."""
    c, _ = case
    start = load_profile("azure_kinect")
    turns = np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]) + [0.3, 0.2, 0.1]
    real = [dataclasses.replace(c, name=f"s{k}", person="p", real=dataclasses.replace(c.real, trunk_turn_deg=t[None]))
            for k, t in enumerate(turns)]
    sims = [dataclasses.replace(c.real, trunk_turn_deg=0.5 * t[None]) for t in turns]
    assert turn_spread(real, [x.real for x in real]) == pytest.approx(1.0)
    moved = update_profile(start, real, sims, structure=("trunk-turn",))
    sd = start.tracker.trunk_turn_sd_deg
    assert moved.tracker.trunk_turn_sd_deg == pytest.approx(np.sqrt(sd**2 + DAMPING * (1.0 - 0.25) / TURN_SLOPE))
    assert "trunk turn" in moved.provenance["tracker.trunk_turn_sd_deg"]
    assert "tracker.trunk_turn_sd_deg" in structure_keys(("trunk-turn",))
    assert shares_people(("limb-sharing", "trunk-turn")) and not shares_people(("limb-sharing",))
    alone = [dataclasses.replace(x, person=None) for x in real]  # no one known to have two sessions
    assert update_profile(start, alone, sims, structure=("trunk-turn",)).tracker.trunk_turn_sd_deg == sd


def test_the_trunk_turn_recovered(case) -> None:
    """Four sessions of one person whose tracker turns the trunk (1.5 deg per axis): the refinement, started
    without a turn, re-tracks them as one simulated person and finds it."""
    c, _ = case
    start = load_profile("azure_kinect")
    start = dataclasses.replace(start, tracker=dataclasses.replace(start.tracker, trunk_turn_sd_deg=0.0))
    truth = dataclasses.replace(start, tracker=dataclasses.replace(start.tracker, trunk_turn_sd_deg=1.5),
                                provenance={**start.provenance, "tracker.trunk_turn_sd_deg": "test"})
    cases = [dataclasses.replace(c, name=f"s{k}", person="p", real=measure(
        retrack(c, truth, seed=k, person_seed=7), None, n_boot=0, rng=np.random.default_rng(0))) for k in range(4)]
    fit = refine_on_replicas(start, cases, iterations=4, speeds=(start.tracker.speed_ref_m_s,), structure=("trunk-turn",))
    assert 0.8 < fit.profile.tracker.trunk_turn_sd_deg < 3.0


@pytest.mark.parametrize("key, value, part, said, least", [
    ("view_limb_correlation", 0.8, "limb-sharing", "limb cosine", 0.5),  # the view bias shared along the limbs
    ("noise_bone_alignment", 2.0, "bone-noise", "cosine", 0.5),  # the noise running along the bones
    ("shared_bone_lengths", 1.0, "shared-bones", "spread over the limb bones", 0.5),  # one set of proportions
    ("camera_scale_sd", 0.05, "camera-scale", "absolute log ratio", 0.02),  # cameras disagreeing on the size
])
def test_optional_part_recovered(case, key, value, part, said, least) -> None:
    """Recordings of a tracker with an optional part set: the refinement, started without it, finds it."""
    c, _ = case
    start = load_profile("azure_kinect")
    truth = dataclasses.replace(start, tracker=dataclasses.replace(start.tracker, **{key: value}),
                                provenance={**start.provenance, f"tracker.{key}": "test"})
    cases = [dataclasses.replace(c, name=f"s{k}", real=measure(
        retrack(c, truth, seed=k), None, n_boot=0, rng=np.random.default_rng(0))) for k in range(3)]
    fit = refine_on_replicas(start, cases, iterations=4, speeds=(start.tracker.speed_ref_m_s,), structure=(part,))
    assert getattr(fit.profile.tracker, key) > least
    assert said in fit.profile.provenance[f"tracker.{key}"]


def test_a_groups_own_activity_exponent_recovered(case) -> None:
    """The replica played at 1, 1.5 and 2 times its speed by a 'real' tracker whose torso jitter alone grows
    with the activity (exponent 1): the slopes find the torso's, the others' stay near 0, and the
    refinement with group-activity fits it."""
    c, _ = case
    start = load_profile("azure_kinect")
    groups = {**start.tracker.groups, JointGroup.TORSO: dataclasses.replace(start.tracker.groups[JointGroup.TORSO],
                                                                            activity_exponent=1.0)}
    truth = dataclasses.replace(start, tracker=dataclasses.replace(
        start.tracker, groups=groups, activity_ref_m_s=1.5 * c.activity, activity_range_m_s=(c.activity, 2 * c.activity)),
        provenance={**start.provenance, "tracker.groups.torso.activity_exponent": "test"})
    faster = [c] + [dataclasses.replace(c, name=f"x{f}", timestamps=tuple(t / f for t in c.timestamps)) for f in (1.5, 2)]
    cases = [dataclasses.replace(k, real=measure(retrack(k, truth, seed=5), None, n_boot=0,
                                                 rng=np.random.default_rng(0))) for k in faster]
    common = dataclasses.replace(truth, tracker=dataclasses.replace(truth.tracker, groups=start.tracker.groups))
    sims = [measure(retrack(k, common, seed=5), None, n_boot=0, rng=np.random.default_rng(0)) for k in cases]
    slopes = group_activity_slopes(cases, sims, start.topology)
    assert JointGroup.HIP not in slopes  # its statistic is the pelvis's, not its own joints'
    assert slopes[JointGroup.TORSO] == pytest.approx(1.0, abs=0.35)
    assert abs(slopes[JointGroup.HAND]) < 0.35
    fit = refine_on_replicas(start, cases, iterations=4, speeds=(start.tracker.speed_ref_m_s,),
                             structure=("group-activity",))
    assert fit.profile.tracker.groups[JointGroup.TORSO].activity_exponent == pytest.approx(1.0, abs=0.4)
    assert "log activity" in fit.profile.provenance["tracker.groups.torso.activity_exponent"]


@pytest.mark.parametrize("speeds", [(), (0.1, -0.2), (float("nan"),)])
def test_refinement_refuses_bad_reference_speeds(case, speeds) -> None:
    with pytest.raises(BadInputError, match="reference speeds must be one or more finite values >= 0"):
        refine_on_replicas(load_profile("azure_kinect"), [case], speeds=speeds)


def test_update_keeps_the_outlier_rate_its_statistic_cannot_see(case) -> None:
    """The real pelvis spikes ten times more than its simulation: the hands' rate would follow its own
    statistic, the hips' (informed by the pelvis, a torso joint) is kept, where it used to grow every
    iteration."""
    c, _ = case
    spikes = {k: dataclasses.replace(v, value=10 * v.value + 0.01) for k, v in c.real.spikes.items()}
    noisier = dataclasses.replace(c, real=dataclasses.replace(c.real, spikes=spikes))
    start = load_profile("azure_kinect")
    updated = update_profile(start, [noisier], [c.real])
    assert measured_on_own_joints(start.topology) == {g: g is not JointGroup.HIP for g in JointGroup}
    assert updated.tracker.groups[JointGroup.HIP].outlier_rate == start.tracker.groups[JointGroup.HIP].outlier_rate
    assert updated.tracker.groups[JointGroup.HAND].outlier_rate > 2 * start.tracker.groups[JointGroup.HAND].outlier_rate


def test_refinement_of_one_speed_in_parallel_is_the_same(case) -> None:
    """One reference speed and two processes: the cases are re-tracked at once, the fit unchanged."""
    c, truth = case
    start = load_profile("azure_kinect")
    one = refine_on_replicas(start, [c, c], iterations=1, speeds=(truth.speed_ref_m_s,), jobs=1)
    two = refine_on_replicas(start, [c, c], iterations=1, speeds=(truth.speed_ref_m_s,), jobs=2)
    assert one.profile == two.profile and one.losses == two.losses


def test_a_reduced_joint_set_is_refined_as_the_tracker_it_came_from() -> None:
    """A UI-PRMD-like recording (a Kinect v2 reduced to the ``ui_prmd`` joints, no confidences) is
    replicated as a Kinect v2 and measured as the reduced set, without the joint it never reports: the
    statistics it lacks (the hands, the confidence shares) are absent or unmeasured, not a crash, and
    the refinement fits the Kinect v2."""
    sim = build_simulation(load_scenario("kimore_frontal").replace(duration_s=6.0))
    sensors = dataclasses.replace(sim.sensors, depth_rate_hz=0.0)
    full, _ = simulate_session(sim.humanoid, sim.motion, sim.rig, sensors, seed=2, duration_s=6.0)
    reduced = full.as_joint_set(UI_PRMD)
    toes = np.isin(np.arange(UI_PRMD.n_joints), UI_PRMD.indices(["ToesLeft"]))
    rec = dataclasses.replace(reduced.without_joints([toes]),  # a joint the real recording never reports
                              metadata={"confidence": "assumed_tracked", "fixed_rate": True})
    real = measure(rec, None, n_boot=0, rng=np.random.default_rng(0))
    assert "hand" not in real.jitter_mm and np.isnan(real.confidence2["all"].value)
    assert real.jitter_mm["wrist"].value == measure(full, None, n_boot=0, rng=np.random.default_rng(0)).jitter_mm["wrist"].value
    c = prepare_case("ui", rec, level_camera_calibration(rec), real)
    assert c.topology == UI_PRMD and "hand" not in c.motion.jitter_mm
    kinect = load_profile("kinect_v2")
    retracked = retrack(c, kinect, seed=1).cameras[0].skeleton
    assert retracked.topology == UI_PRMD and np.isnan(retracked.positions[:, toes]).all()
    assert np.isfinite(retracked.positions[:, ~toes]).any(axis=0).all()
    fit = refine_on_replicas(kinect, [c], iterations=1, speeds=(0.4,))
    assert fit.profile.topology == KINECT_V2 and np.isfinite(fit.losses[0.4])
    assert "hand" not in fit.sims[0].jitter_mm
