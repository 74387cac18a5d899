"""The hands from the depth clouds: which points are the hand's, its tip and hand joint, and the checks."""

from __future__ import annotations

import numpy as np
import pytest

from fusion.merge.hand_ends import HandOptions, hand_anchors, hand_end, hand_points
from fusion.topology import KINECT_V2, Landmark

OPTIONS = HandOptions()


def _box(rng, start, axis, side, length=0.18, breadth=0.08, thickness=0.025, n=600):
    """Points on the surface of a flat box from ``start`` along ``axis`` (its breadth along ``side``),
    the faces seen from one side only, with 2 mm noise."""
    normal = np.cross(axis, side)
    u = rng.uniform(0.0, length, n)
    v = rng.uniform(-breadth / 2, breadth / 2, n)
    face = np.where(rng.uniform(size=n) < 0.8, thickness / 2, rng.uniform(-thickness / 2, thickness / 2, n))
    return start + u[:, None] * axis + v[:, None] * side + face[:, None] * normal + rng.normal(0, 0.002, (n, 3))


def _arm(rng):
    """A skeleton with the left forearm pointing forward and down, the hand's box beyond the true wrist, the
    tracker's hand joints 8-12 cm off, and body points of the hand and the forearm."""
    J = len(KINECT_V2.joints)
    sk = np.full((J, 3), np.nan)
    idx = {lm: KINECT_V2.index(lm) for lm in Landmark if lm in KINECT_V2.landmarks}
    sk[idx[Landmark.SPINE_SHOULDER]] = [0.0, 0.0, 1.45]
    sk[idx[Landmark.HEAD]] = [0.0, 0.0, 1.65]
    sk[idx[Landmark.NECK]] = [0.0, 0.0, 1.55]
    sk[idx[Landmark.SHOULDER_LEFT]] = [0.0, 0.18, 1.42]
    sk[idx[Landmark.ELBOW_LEFT]] = [0.05, 0.22, 1.15]
    axis = np.array([0.8, 0.0, -0.6])
    wrist = sk[idx[Landmark.ELBOW_LEFT]] + 0.25 * axis
    sk[idx[Landmark.WRIST_LEFT]] = wrist
    sk[idx[Landmark.HAND_LEFT]] = wrist + 0.054 * axis + [0.0, 0.08, 0.05]
    sk[idx[Landmark.HANDTIP_LEFT]] = wrist + 0.18 * axis + [0.0, -0.1, 0.05]
    sk[idx[Landmark.THUMB_LEFT]] = wrist + [0.03, 0.05, 0.0]
    hand = _box(rng, wrist, axis, np.array([0.0, 1.0, 0.0]))
    t = rng.uniform(0.0, 1.0, 300)[:, None]
    forearm = sk[idx[Landmark.ELBOW_LEFT]] + t * (wrist - sk[idx[Landmark.ELBOW_LEFT]]) + rng.normal(0, 0.03, (300, 3))
    return sk, np.concatenate([hand, forearm]), wrist, axis, idx


def test_the_hands_tip_is_the_far_end_of_its_box():
    sk, points, wrist, axis, idx = _arm(np.random.default_rng(0))
    mine = hand_points(points, sk, KINECT_V2, idx[Landmark.ELBOW_LEFT], idx[Landmark.WRIST_LEFT],
                       {idx[Landmark.HAND_LEFT], idx[Landmark.HANDTIP_LEFT], idx[Landmark.THUMB_LEFT]}, OPTIONS)
    assert len(mine) > 300
    tip, hand = hand_end(mine, wrist, axis, OPTIONS)
    assert np.linalg.norm(tip - (wrist + 0.18 * axis)) < 0.015
    assert np.linalg.norm(hand - (wrist + 0.054 * axis)) < 0.01
    anchors = hand_anchors(points, sk, KINECT_V2, OPTIONS)
    assert np.allclose(anchors[idx[Landmark.HANDTIP_LEFT]], tip) and np.allclose(anchors[idx[Landmark.HAND_LEFT]], hand)
    others = [j for j in range(len(sk)) if j not in (idx[Landmark.HANDTIP_LEFT], idx[Landmark.HAND_LEFT])]
    assert np.isnan(anchors[others]).all()  # the right side has no joints here, the thumb is left to the tracker


def test_a_head_the_fingers_touch_keeps_its_points():
    rng = np.random.default_rng(1)
    sk, points, wrist, axis, idx = _arm(rng)
    centre = wrist + 0.25 * axis + [0.0, 0.0, 0.05]  # a salute: the fingertips at the head's surface
    sk[idx[Landmark.HEAD]], sk[idx[Landmark.NECK]] = centre, centre - [0.0, 0.0, 0.12]
    u = rng.normal(size=(600, 3))
    head = centre + 0.09 * u / np.linalg.norm(u, axis=1, keepdims=True)
    mine = hand_points(np.concatenate([points, head]), sk, KINECT_V2, idx[Landmark.ELBOW_LEFT],
                       idx[Landmark.WRIST_LEFT], {idx[Landmark.HAND_LEFT], idx[Landmark.HANDTIP_LEFT]}, OPTIONS)
    tip, _ = hand_end(mine, wrist, axis, OPTIONS)
    assert np.linalg.norm(tip - (wrist + 0.18 * axis)) < 0.025  # 6 cm off with the head's points kept


@pytest.mark.parametrize("case", ["few points", "turned", "no forearm"])
def test_a_hand_that_fails_its_checks_gives_nothing(case):
    rng = np.random.default_rng(2)
    sk, points, wrist, axis, idx = _arm(rng)
    if case == "few points":
        tip, hand = hand_end(points[:OPTIONS.min_points - 1], wrist, axis, OPTIONS)
    elif case == "turned":
        across = _box(rng, wrist, np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0]))
        tip, hand = hand_end(across, wrist, axis, OPTIONS)
    else:
        sk[idx[Landmark.ELBOW_LEFT]] = np.nan
        anchors = hand_anchors(points, sk, KINECT_V2, OPTIONS)
        tip, hand = anchors[idx[Landmark.HANDTIP_LEFT]], anchors[idx[Landmark.HAND_LEFT]]
    assert np.isnan(tip).all() and np.isnan(hand).all()


def test_options_are_checked():
    from fusion.errors import BadInputError

    for bad, match in (({"reach_m": 0.0}, "reach_m"), ({"quantile": 1.5}, "quantile"), ({"min_points": 2}, "min_points")):
        with pytest.raises(BadInputError, match=match):
            HandOptions(**bad)
