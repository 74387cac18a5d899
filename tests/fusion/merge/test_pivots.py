"""Functional centres of the shoulders and hips from limb axes: the least-squares point, the trunk frame,
the check on the axes' spread, and the anchors' pull on the joints."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fusion.merge.limb_corrections import joint_offsets
from fusion.merge.pivots import Pivot, anchors, nearest_point, pivots, trunk_poses
from fusion.topology import KINECT_V2, Landmark


def _directions(rng, n, spread_deg, around=(0.0, 0.0, -1.0)):
    """``n`` unit directions within ``spread_deg`` of ``around``."""
    axis = np.asarray(around, float) / np.linalg.norm(around)
    tilt = Rotation.from_rotvec(rng.normal(size=(n, 3)) * np.radians(spread_deg) / np.sqrt(3))
    return tilt.apply(axis)


def test_lines_through_one_point_give_it_back_among_outliers():
    rng = np.random.default_rng(0)
    point = np.array([0.1, -0.2, 0.3])
    d = _directions(rng, 200, 60.0)
    c = point + rng.uniform(-0.3, 0.3, (200, 1)) * d + rng.normal(0.0, 0.003, (200, 3))
    c[:20] += rng.uniform(-0.2, 0.2, (20, 3))  # a tenth of the axes badly off
    p, spread, rms = nearest_point(c, d, huber_m=0.01)
    assert np.linalg.norm(p - point) < 0.004
    assert spread > 0.2 and rms < 0.05


def test_parallel_lines_have_no_spread():
    rng = np.random.default_rng(1)
    d = _directions(rng, 100, 2.0)
    c = rng.normal(0.0, 0.01, (100, 3))
    assert nearest_point(c, d, huber_m=0.01)[1] < 0.01


def _trunk_session(rng, K=300, arm_spread_deg=50.0):
    """A trunk that walks and turns with a shoulder fixed in it, and the upper arm's axes through that
    shoulder: targets (K, J, 3), segments, centres, directions, counted, the shoulder in the world (K, 3)."""
    J = len(KINECT_V2.joints)
    local = {Landmark.SPINE_SHOULDER: [0.0, 0.0, 0.0], Landmark.SPINE_MID: [0.0, 0.0, -0.25],
             Landmark.PELVIS: [0.0, 0.0, -0.5], Landmark.HIP_LEFT: [0.0, 0.09, -0.5], Landmark.HIP_RIGHT: [0.0, -0.09, -0.5],
             Landmark.SHOULDER_LEFT: [-0.02, 0.18, -0.03], Landmark.SHOULDER_RIGHT: [-0.02, -0.18, -0.03],
             Landmark.ELBOW_LEFT: [0.0, 0.2, -0.3]}
    yaw = np.radians(np.linspace(0.0, 90.0, K))
    R = Rotation.from_euler("z", yaw[:, None])
    origin = np.c_[np.linspace(0.0, 1.0, K), np.zeros(K), np.full(K, 1.4)]
    targets = np.full((K, J, 3), np.nan)
    for lm, x in local.items():
        targets[:, KINECT_V2.index(lm)] = origin + R.apply(x)
    shoulder = targets[:, KINECT_V2.index(Landmark.SHOULDER_LEFT)]
    d = R.apply(_directions(rng, K, arm_spread_deg))
    centres = shoulder + 0.15 * d + rng.normal(0.0, 0.002, (K, 3))
    segments = np.array([[KINECT_V2.index(Landmark.SHOULDER_LEFT), KINECT_V2.index(Landmark.ELBOW_LEFT)]])
    return targets, segments, centres[:, None], d[:, None], np.ones((K, 1), bool), shoulder


def test_trunk_frame_is_the_thorax_frame_at_the_spine_shoulder():
    targets = _trunk_session(np.random.default_rng(2))[0]
    origin, R = trunk_poses(targets, KINECT_V2)
    assert np.allclose(R.transpose(0, 2, 1) @ R, np.eye(3), atol=1e-9)
    assert np.allclose(np.linalg.det(R), 1.0)
    right = targets[:, KINECT_V2.index(Landmark.SHOULDER_RIGHT)] - targets[:, KINECT_V2.index(Landmark.SHOULDER_LEFT)]
    assert np.allclose(R[:, :, 2], right / np.linalg.norm(right, axis=-1, keepdims=True))
    assert np.allclose(origin, targets[:, KINECT_V2.index(Landmark.SPINE_SHOULDER)])


def test_a_moving_arm_gives_its_shoulder_in_the_trunk_and_a_still_one_none():
    targets, segments, centres, directions, counted, shoulder = _trunk_session(np.random.default_rng(3))
    (found,) = pivots(targets, KINECT_V2, segments, centres, directions, counted, huber_m=0.01, min_spread=0.1,
                      min_instants=30)
    assert found.counts and found.instants == len(targets)
    assert np.allclose(found.point, [-0.02, -0.03, -0.18], atol=0.004)  # forward, up, right
    world = anchors(targets, KINECT_V2, [found])
    assert np.nanmax(np.linalg.norm(world[:, found.joint] - shoulder, axis=-1)) < 0.005
    assert np.isnan(np.delete(world, found.joint, axis=1)).all()
    t, s, c, d, k, _ = _trunk_session(np.random.default_rng(3), arm_spread_deg=3.0)
    (none,) = pivots(t, KINECT_V2, s, c, d, k, huber_m=0.01, min_spread=0.1, min_instants=30)
    assert not none.counts and none.spread < 0.1
    few = pivots(targets, KINECT_V2, segments, centres, directions, counted, huber_m=0.01, min_spread=0.1,
                 min_instants=len(targets) + 1)
    assert not few[0].counts


def test_a_joint_whose_axes_fail_takes_its_twins_pivot_mirrored():
    targets, segments, centres, directions, counted, _ = _trunk_session(np.random.default_rng(5))
    right = KINECT_V2.index(Landmark.SHOULDER_RIGHT)
    shoulders = targets[:, [KINECT_V2.index(Landmark.SHOULDER_LEFT), right]]
    hanging = np.broadcast_to(np.array([0.0, 0.0, -1.0]), directions[:, 0].shape)  # the right arm never moves
    both = pivots(targets, KINECT_V2, np.r_[segments, [[right, KINECT_V2.index(Landmark.ELBOW_RIGHT)]]],
                  np.concatenate([centres, (shoulders[:, 1] + 0.15 * hanging)[:, None]], axis=1),
                  np.concatenate([directions, hanging[:, None]], axis=1), np.ones((len(targets), 2), bool),
                  huber_m=0.01, min_spread=0.1, min_instants=30)
    left, mirrored = both
    assert left.counts and not left.twin
    assert mirrored.joint == right and mirrored.twin and mirrored.spread < 0.01
    assert np.allclose(mirrored.point, left.point * [1, 1, -1])
    world = anchors(targets, KINECT_V2, both)
    assert np.nanmax(np.linalg.norm(world[:, right] - shoulders[:, 1], axis=-1)) < 0.006  # the session is symmetric


def test_the_twins_midplane_is_the_measured_pairs_not_the_spine_joints():
    targets, segments, centres, directions, counted, _ = _trunk_session(np.random.default_rng(6))
    right = KINECT_V2.index(Landmark.SHOULDER_RIGHT)
    true_right = targets[:, right].copy()
    lateral = targets[:, KINECT_V2.index(Landmark.SHOULDER_LEFT)] - true_right
    for lm in (Landmark.SPINE_SHOULDER, Landmark.SPINE_MID, Landmark.PELVIS):  # the spine 4 cm to the right
        targets[:, KINECT_V2.index(lm)] -= 0.04 * lateral / np.linalg.norm(lateral, axis=-1, keepdims=True)
    hanging = np.broadcast_to(np.array([0.0, 0.0, -1.0]), directions[:, 0].shape)
    both = pivots(targets, KINECT_V2, np.r_[segments, [[right, KINECT_V2.index(Landmark.ELBOW_RIGHT)]]],
                  np.concatenate([centres, (true_right + 0.15 * hanging)[:, None]], axis=1),
                  np.concatenate([directions, hanging[:, None]], axis=1), np.ones((len(targets), 2), bool),
                  huber_m=0.01, min_spread=0.1, min_instants=30)
    error = np.linalg.norm(anchors(targets, KINECT_V2, both)[:, right] - true_right, axis=-1)
    assert both[1].twin and np.nanmax(error) < 0.01  # 8 cm off if mirrored about the spine joint


def test_an_anchor_places_a_joint_along_its_axis_and_alone_where_no_axis_counted():
    centres, directions = np.zeros((2, 1, 3)), np.array([[[0.0, 0.0, 1.0]]] * 2)
    targets = np.array([[[0.03, 0.0, 0.2], [0.0, 0.0, -0.3]]] * 2)
    anchor = np.full((2, 2, 3), np.nan)
    anchor[:, 0] = [0.0, 0.01, 0.1]
    counted = np.array([[True], [False]])
    off = joint_offsets(targets, np.array([[0, 1]]), centres, directions, counted, 1e-6, anchor, 1.0)
    moved = targets + off
    assert moved[0, 0] == pytest.approx([0.0, 0.005, 0.1], abs=1e-4)  # on the axis, across halfway to the anchor
    assert moved[1, 0] == pytest.approx(anchor[1, 0], abs=1e-4)  # no axis at this instant: the anchor alone
    assert np.isnan(off[1, 1]).all()  # the other joint has neither
    plain = joint_offsets(targets, np.array([[0, 1]]), centres, directions, counted, 1e-6)
    assert (targets + plain)[0, 0] == pytest.approx([0.0, 0.0, 0.2], abs=1e-4)


def test_two_hip_pivots_place_the_pelvis_between_them_and_one_does_not():
    targets = _trunk_session(np.random.default_rng(4))[0]
    hl, hr, pelvis = (KINECT_V2.index(lm) for lm in (Landmark.HIP_LEFT, Landmark.HIP_RIGHT, Landmark.PELVIS))
    left = Pivot(hl, 0, np.array([0.0, -0.5, -0.09]), 0.2, 0.003, 100)
    right = Pivot(hr, 1, np.array([0.0, -0.5, 0.09]), 0.2, 0.003, 100)
    both = anchors(targets, KINECT_V2, [left, right])
    assert np.allclose(both[:, pelvis], 0.5 * (both[:, hl] + both[:, hr]))
    assert np.allclose(both[:, pelvis], targets[:, pelvis])  # the synthetic pelvis lies between its hips
    unfound = Pivot(hr, 1, np.full(3, np.nan), 0.01, 0.003, 100)
    assert np.isnan(anchors(targets, KINECT_V2, [left, unfound])[:, pelvis]).all()


def test_a_joint_set_without_the_trunk_frame_gives_no_pivots():
    import dataclasses

    reduced = dataclasses.replace(KINECT_V2, landmarks={k: v for k, v in KINECT_V2.landmarks.items()
                                                        if k is not Landmark.SPINE_SHOULDER},
                                  lacks=KINECT_V2.lacks | {Landmark.SPINE_SHOULDER})
    targets = np.zeros((5, len(reduced.joints), 3))
    segments = np.array([[reduced.index(Landmark.SHOULDER_LEFT), reduced.index(Landmark.ELBOW_LEFT)]])
    lines = np.zeros((5, 1, 3)), np.tile([0.0, 0.0, 1.0], (5, 1, 1))
    assert pivots(targets, reduced, segments, *lines, np.ones((5, 1), bool), huber_m=0.01, min_spread=0.1,
                  min_instants=1) == []
    assert np.isnan(anchors(targets, reduced, [])).all()
