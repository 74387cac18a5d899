"""Limb axes from depth clouds: the cylinder fit, the joints' corrections, and a simulated session."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fusion.errors import BadInputError
from fusion.merge.cylinder_fit import fit_cylinders
from fusion.merge.limb_axes import limb_axes
from fusion.merge.limb_axis_options import LimbAxisOptions
from fusion.merge.limb_corrections import (
    LimbAxes,
    joint_offsets,
    offsets_on_frames,
    onto_axes,
    with_limb_axes,
)

OPTIONS = LimbAxisOptions()


def _cylinder(rng, centre, direction, radius, n=300, arc_deg=200.0, noise_m=0.002):
    """Points on a cylinder's surface, seen over an arc of ``arc_deg`` only (one side)."""
    d = direction / np.linalg.norm(direction)
    e1 = np.cross(d, [0.0, 0.0, 1.0] if abs(d[2]) < 0.9 else [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    phi = np.radians(rng.uniform(0.0, arc_deg, n))
    along = rng.uniform(-0.1, 0.1, n)
    rim = radius + rng.normal(0.0, noise_m, n)
    return centre + along[:, None] * d + rim[:, None] * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2)


def _axis_errors(c, d, centre, direction):
    direction = direction / np.linalg.norm(direction)
    angle = np.degrees(np.arccos(np.clip(abs(d @ direction), 0.0, 1.0)))
    offset = np.linalg.norm(np.cross(centre - c, d))
    return angle, offset


@pytest.mark.parametrize("free", [True, False])
def test_a_cylinder_seen_from_one_side_among_outliers_is_found(free):
    rng = np.random.default_rng(3)
    centre, direction, radius = np.array([0.3, -0.2, 1.2]), np.array([0.2, 0.5, -1.0]), 0.045
    surface = _cylinder(rng, centre, direction, radius, n=240)
    outliers = centre + rng.uniform(-0.12, 0.12, (60, 3))  # a quarter of the points off the surface
    P = np.concatenate([surface, outliers])[None]
    mask = np.ones(P.shape[:2], bool)
    d0 = direction / np.linalg.norm(direction) + np.array([0.1, -0.1, 0.05])  # about 8 degrees off
    c, d, r, rms, kept = fit_cylinders(P, mask, (centre + [0.02, 0.02, 0.0])[None], d0[None],
                                       None if free else np.array([radius]))
    angle, offset = _axis_errors(c[0], d[0], centre, direction)
    assert angle < 1.0 and offset < 0.002
    assert abs(r[0] - radius) < 0.002
    assert rms[0] < 0.004
    assert kept[0, :240].mean() > 0.95 and kept[0, 240:].mean() < 0.5


def test_a_plane_is_not_taken_for_a_limb():
    rng = np.random.default_rng(4)
    plane = np.c_[rng.uniform(-0.1, 0.1, (300, 2)), rng.normal(0.0, 0.002, 300)]
    P, mask = plane[None], np.ones((1, 300), bool)
    c, d, r, rms, kept = fit_cylinders(P, mask, np.array([[0.0, 0.0, 0.05]]), np.array([[1.0, 0.0, 0.0]]),
                                       np.array([0.045]))
    assert rms[0] > OPTIONS.max_rms_m or kept[0].sum() < OPTIONS.min_inlier_share * 300


def test_one_axis_moves_a_joint_across_it_and_two_axes_to_where_they_cross():
    # segments (0, 1) and (1, 2): joint 1 lies on both axes, joints 0 and 2 on one each
    segments = np.array([[0, 1], [1, 2]])
    centres = np.array([[[0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]])
    directions = np.array([[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]])  # crossing at the origin
    targets = np.array([[[0.3, 0.05, 0.0], [0.04, -0.03, 0.02], [0.0, 0.2, -0.05]]])
    off = joint_offsets(targets, segments, centres, directions, np.array([[True, True]]), pull=1e-4)
    moved = targets + off
    assert np.allclose(moved[0, 1], 0.0, atol=1e-3)  # the bent joint goes to the crossing
    assert np.allclose(moved[0, 0], [0.3, 0.0, 0.0], atol=1e-3)  # across the axis only
    assert np.allclose(moved[0, 2], [0.0, 0.2, 0.0], atol=1e-3)
    off = joint_offsets(targets, segments, centres, directions, np.array([[True, False]]), pull=1e-4)
    assert np.isnan(off[0, 2]).all()  # no counted axis through it
    assert np.allclose((targets + off)[0, 1], [0.04, 0.0, 0.0], atol=1e-3)  # across the one counted axis


def test_corrections_are_interpolated_between_instants_and_zero_far_from_them():
    instants = np.array([0.0, 0.1, 0.2, 1.0])
    offsets = np.zeros((4, 2, 3))
    offsets[:, 0, 0] = [0.0, 0.01, 0.02, 0.05]
    offsets[2, 1] = np.nan
    offsets[:, 1, 2] = np.where(np.isnan(offsets[:, 1, 2]), np.nan, 0.03)
    times = np.array([0.05, 0.15, 0.6, 1.0, 2.0])
    out = offsets_on_frames(instants, offsets, times, max_gap_s=0.25)
    assert np.allclose(out[:, 0, 0], [0.005, 0.015, 0.0, 0.05, 0.0])
    assert np.allclose(out[:, 1, 2], [0.03, 0.03, 0.0, 0.03, 0.0])


def test_a_skeleton_off_the_axes_is_put_back_on_them_near_the_instants_only():
    axes = LimbAxes(segments=np.array([[0, 1]]), names=("a-b",), radii_m=np.array([0.04]), times=np.array([1.0]),
                    centres=np.zeros((1, 1, 3)), directions=np.array([[[0.0, 0.0, 1.0]]]), rms_m=np.array([[0.002]]),
                    counted=np.array([[True]]), offsets=np.zeros((3, 2, 3)))
    positions = np.array([[[0.03, 0.0, 0.2], [0.03, 0.0, -0.1]]] * 3)
    times = np.array([0.99, 1.1, 2.0])
    out = onto_axes(positions, times, axes, pull=1e-4)
    assert np.allclose(out[:2, :, :2], 0.0, atol=1e-4) and np.allclose(out[:, :, 2], positions[:, :, 2])
    assert np.array_equal(out[2], positions[2])  # 1 s from the only instant


def test_options_are_checked():
    with pytest.raises(BadInputError, match="span"):
        LimbAxisOptions(span=(0.8, 0.2))
    with pytest.raises(BadInputError, match="max_rms_m"):
        LimbAxisOptions(max_rms_m=0.0)
    with pytest.raises(BadInputError, match="min_points"):
        LimbAxisOptions(min_points=0)
    with pytest.raises(BadInputError, match="anchor_pull"):
        LimbAxisOptions(anchor_pull=-1.0)
    with pytest.raises(BadInputError, match="pivot_min_spread"):
        LimbAxisOptions(pivot_min_spread=0.0)
    assert OPTIONS.without(["hands"]).hands is None and OPTIONS.without(["hands"]).pivots
    assert not OPTIONS.without(["centres"]).pivots and OPTIONS.without(["centres"]).hands == OPTIONS.hands
    assert OPTIONS.pivots == ("shoulders", "hips")
    assert OPTIONS.without(["shoulder-centres"]).pivots == ("hips",)
    assert OPTIONS.without(["hip-centres", "hands"]).pivots == ("shoulders",)
    assert OPTIONS.without(["shoulder-centres", "hip-centres"]).pivots == ()
    with pytest.raises(BadInputError, match="pivots must be a tuple of shoulders, hips"):
        LimbAxisOptions(pivots=("elbows",))
    with pytest.raises(BadInputError, match="pivots must be a tuple"):
        LimbAxisOptions(pivots=True)
    with pytest.raises(BadInputError, match="no part feet"):
        OPTIONS.without(["feet"])


@pytest.fixture(scope="module")
def salute():
    """Two Kinect v2 at +-45 degrees, one right salute with depth at 5 Hz: recording, truth, views, calibration."""
    from fusion.merge.fuse import camera_views
    from scenarios.api import true_calibration
    from scenarios.config import scenario_from_dict
    from scenarios.runner import build_simulation
    from sim.session import simulate_session

    scenario = scenario_from_dict({
        "scenario": {"name": "salute_depth", "seed": 2},
        "subject": {"topology": "kinect_v2"},
        "rig": {"angles_deg": [45.0, -45.0], "radius_m": 2.0, "height_m": 1.0, "target_height_m": 0.9},
        "sensors": {"depth_rate_hz": 5.0},
        "session": {"segment": [{"kind": "salute", "side": "right", "repetitions": 1}]},
    })
    sim = build_simulation(scenario)
    rec, truth = simulate_session(sim.humanoid, sim.motion, sim.rig, sim.sensors, seed=sim.session_seed,
                                  person_seed=sim.person_seed, duration_s=sim.motion.duration)
    cal = true_calibration(rec, truth)
    return sim, rec, truth, camera_views(rec, cal), cal


@pytest.fixture(scope="module")
def salute_axes(salute):
    _, rec, _, views, cal = salute
    return limb_axes(views, rec, cal)


def test_limb_axes_of_a_simulated_salute_find_the_limbs_and_straighten_the_elbow_error(salute, salute_axes):
    from fusion.merge.fuse import Fit, FuseOptions, fuse_views
    from fusion.merge.methods import MergeMethod
    from scenarios.skeleton_eval import skeleton_errors

    sim, rec, truth, views, cal = salute
    axes = salute_axes
    share = axes.counted_share()
    assert share["ElbowRight-WristRight"] > 0.5 and share["HipLeft-KneeLeft"] > 0.5
    model = sim.humanoid.model
    # forearm and thigh within 3-9 % of their radius for the typical person and five drawn ones, old and
    # refitted kinect_v2 alike; the saluting upper arm within 3-7 % for ten of those twelve, 21 % and 28 %
    # for the other two (this one: a tracked elbow far off the arm gathers the trunk's surface)
    for name, geom, rel in (("ElbowRight-WristRight", "forearm_r", 0.1), ("HipLeft-KneeLeft", "thigh_l", 0.1),
                            ("ShoulderRight-ElbowRight", "upper_arm_r", 0.3)):
        true_radius = model.geom(geom).size[0]
        assert axes.radii_m[axes.names.index(name)] == pytest.approx(true_radius, rel=rel)
    errors = {}
    for fit in (Fit.MERGE, Fit.KINEMATIC):
        for label, a in (("plain", None), ("axes", axes)):
            merged = fuse_views(views, FuseOptions(method=MergeMethod.AVG_FRONTAL, fit=fit), a)
            errors[fit, label] = skeleton_errors(merged.positions, cal.T_world_cam, truth, cal.reference, views.topology)
    elbow = {k: e["elbow_flexion_right_raised_error_deg"]["median"] for k, e in errors.items()}
    for fit in (Fit.MERGE, Fit.KINEMATIC):
        assert elbow[fit, "axes"] < 0.5 * elbow[fit, "plain"]
        assert errors[fit, "axes"]["joint_error_mm"]["mean"] < errors[fit, "plain"]["joint_error_mm"]["mean"]
    assert elbow[Fit.KINEMATIC, "axes"] < 2.0  # its joints put back on the axes after the fit (3 deg without)
    merged = fuse_views(with_limb_axes(views, axes), FuseOptions(method=MergeMethod.AVG_FRONTAL))
    assert np.allclose(merged.positions, fuse_views(views, FuseOptions(method=MergeMethod.AVG_FRONTAL), axes).positions,
                       equal_nan=True)


def test_the_salute_finds_the_shoulders_centre_and_pulls_the_hips_onto_theirs(salute, salute_axes):
    _, rec, truth, views, cal = salute
    from fusion.merge.fuse import FuseOptions, fuse_views
    from fusion.merge.methods import MergeMethod
    from fusion.topology import Landmark

    summary = salute_axes.pivot_summary(views.topology)
    assert summary["ShoulderRight"]["point_mm"] is not None and summary["ShoulderRight"]["spread"] > 0.05
    assert not summary["ShoulderRight"]["twin"]
    left = summary["ShoulderLeft"]  # the other arm hangs: its axes all point down, so it takes its twin's, mirrored
    assert left["spread"] < 0.01 and left["twin"]
    right = summary["ShoulderRight"]["point_mm"]
    assert left["point_mm"][:2] == pytest.approx(right[:2]) and left["point_mm"][2] < 0 < right[2]
    none = limb_axes(views, rec, cal, LimbAxisOptions(pivots=()))
    centred = [views.topology.index(Landmark[n]) for n in ("SHOULDER_RIGHT", "SHOULDER_LEFT", "HIP_RIGHT", "HIP_LEFT")]
    assert none.pivots == () and np.isnan(none.anchors[:, centred]).all()
    hips_only = limb_axes(views, rec, cal, LimbAxisOptions().without(["shoulder-centres"]))
    assert {p.joint for p in hips_only.pivots} == set(centred[2:])
    assert np.isnan(hips_only.anchors[:, centred[:2]]).all()
    np.testing.assert_allclose(hips_only.anchors[:, centred[2:]], salute_axes.anchors[:, centred[2:]])
    # the hips' centres hold in one salute (six simulated people: 51-131 mm on the axes alone, 7-37 mm with
    # the centres); the saluting shoulder's do not, its true centre moving 40 mm with the clavicle
    # (docs/studies/angle_validation.md)
    for name in ("HIP_RIGHT", "HIP_LEFT"):
        j = views.topology.index(Landmark[name])
        true = truth.camera(cal.reference).joints_world[:, j]
        error = {label: np.nanmean(np.linalg.norm(
            fuse_views(views, FuseOptions(method=MergeMethod.AVG_FRONTAL), a).positions[:, j] - true, axis=-1))
            for label, a in (("centre", salute_axes), ("axis only", none))}
        assert error["centre"] < 0.7 * error["axis only"], name


def test_the_clouds_place_the_hands_even_at_the_forehead(salute, salute_axes):
    _, rec, truth, views, cal = salute
    from fusion.merge.fuse import FuseOptions, fuse_views
    from fusion.merge.methods import MergeMethod
    from fusion.topology import Landmark

    share = salute_axes.anchored_share(views.topology)
    assert share["HandTipRight"] > 0.5 and share["HandLeft"] > 0.5 and "ThumbRight" not in share
    true = truth.camera(cal.reference).joints_world
    without = limb_axes(views, rec, cal, LimbAxisOptions(hands=None))
    hands = [views.topology.index(lm) for lm in (Landmark.HANDTIP_RIGHT, Landmark.HAND_RIGHT, Landmark.HANDTIP_LEFT,
                                                 Landmark.HAND_LEFT)]
    fused = {label: fuse_views(views, FuseOptions(method=MergeMethod.AVG_FRONTAL), a).positions[:, hands]
             for label, a in (("hands", salute_axes), ("without", without))}
    error = {label: np.nanmean(np.linalg.norm(p - true[:, hands], axis=-1)) for label, p in fused.items()}
    # 0.41-0.67 of the error without the hands for the typical person and five drawn ones, old and refitted
    # kinect_v2 alike; a single hand joint of one person may gain nothing (a hanging hand: 72 against 72 mm)
    assert error["hands"] < 0.75 * error["without"]


def test_limb_axes_need_depth_frames(salute):
    _, rec, _, views, cal = salute
    no_depth = dataclasses.replace(rec, cameras=[dataclasses.replace(c, depth=None) for c in rec.cameras])
    with pytest.raises(BadInputError, match="need depth frames"):
        limb_axes(views, no_depth, cal)


def test_corrections_must_belong_to_the_views(salute, salute_axes):
    views, axes = salute[3], salute_axes
    short = dataclasses.replace(views, times=views.times[:-1], positions=views.positions[:, :-1],
                                states=views.states[:, :-1], back_facing=views.back_facing[:, :-1])
    with pytest.raises(BadInputError, match="do not match"):
        with_limb_axes(short, axes)


def test_frames_without_labels_give_the_same_limbs(salute, salute_axes):
    _, rec, _, views, cal = salute
    plain = dataclasses.replace(rec, cameras=[dataclasses.replace(c, depth=dataclasses.replace(c.depth, labels=None))
                                              for c in rec.cameras])
    axes = limb_axes(views, plain, cal)
    both = axes.counted & salute_axes.counted
    assert both.sum() > 0.9 * salute_axes.counted.sum()
    turn = np.degrees(np.arccos(np.clip(np.einsum("ksi,ksi->ks", axes.directions, salute_axes.directions), -1, 1)))
    apart = axes.centres - salute_axes.centres
    apart -= np.einsum("ksi,ksi->ks", apart, salute_axes.directions)[..., None] * salute_axes.directions
    # the same axes: median 0.3-0.4 deg and 0.4-0.6 mm apart for the typical person and four drawn ones
    assert np.median(turn[both]) < 1.0 and np.median(np.linalg.norm(apart, axis=-1)[both]) < 0.002
    # a radius is the median of a few instants' fits, whose points the labels or the skeleton's bones
    # assign: the same people's radii differ by up to 9.9 % (the typical person's upper arms)
    assert axes.radii_m == pytest.approx(salute_axes.radii_m, rel=0.12)
    assert axes.counted_share()["HipLeft-KneeLeft"] > 0.5


def test_depth_frames_far_from_every_skeleton_frame_are_refused(salute):
    _, rec, _, views, cal = salute
    late = dataclasses.replace(rec, cameras=[dataclasses.replace(c, depth=dataclasses.replace(
        c.depth, timestamps=c.depth.timestamps + 100.0)) for c in rec.cameras])
    with pytest.raises(BadInputError, match="no depth frame"):
        limb_axes(views, late, cal)
