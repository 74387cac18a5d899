"""The trunk turned against the limbs: the tracker's part and the statistic that measures it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fusion.errors import BadInputError
from fusion.merge.residual_parts import TAIL_M, trunk_joints, trunk_turn
from fusion.topology import K4ABT, KINECT_V2, Landmark
from sim.tracker_noise import JointGroup, TrackerNoise, joint_groups
from sim.tracker_trunk_turn import turn_trunk
from tests.sim.test_tracker import quiet, run, world_joints


@pytest.mark.parametrize("topology", [KINECT_V2, K4ABT])
def test_trunk_joints_are_the_torso_and_hip_groups(topology):
    groups = joint_groups(topology)
    np.testing.assert_array_equal(trunk_joints(topology), [g in (JointGroup.TORSO, JointGroup.HIP) for g in groups])


def test_turn_moves_the_trunk_about_the_pelvis_and_leaves_the_limbs():
    P = world_joints(KINECT_V2, np.linspace(-0.5, 0.5, 20), None)
    turned = turn_trunk(P, KINECT_V2, np.radians([0.0, 0.0, 2.0]))
    trunk, pelvis = trunk_joints(KINECT_V2), KINECT_V2.index(Landmark.PELVIS)
    np.testing.assert_array_equal(turned[:, ~trunk], P[:, ~trunk])
    np.testing.assert_allclose(turned[:, pelvis], P[:, pelvis])
    head = KINECT_V2.index(Landmark.HEAD)
    np.testing.assert_allclose(np.linalg.norm(turned[:, head] - P[:, head], axis=-1),
                               2 * np.sin(np.radians(1.0)) * np.linalg.norm((P[:, head] - P[:, pelvis])[:, :2], axis=-1))


def test_the_statistic_finds_the_turn_it_was_given():
    """A second camera that sees the trunk turned by -r (about a still pelvis) and its limbs up to 5 cm off
    measures a trunk turn of r."""
    P = np.repeat(world_joints(K4ABT, np.zeros(1), None), 60, axis=0)
    P = P + np.random.default_rng(0).normal(scale=0.01, size=P.shape)  # poses that differ a little
    P[:, K4ABT.index(Landmark.PELVIS)] = P[0, K4ABT.index(Landmark.PELVIS)]
    r = np.array([0.4, -0.8, 1.5])
    other = turn_trunk(P, K4ABT, -np.radians(r))
    other[:, ~trunk_joints(K4ABT)] += np.random.default_rng(1).uniform(-0.03, 0.03, size=(60, (~trunk_joints(K4ABT)).sum(), 3))
    np.testing.assert_allclose(trunk_turn([P - other], P, K4ABT)[0], r, atol=1e-6)
    far = P - other
    far[:, trunk_joints(K4ABT)] += 2 * TAIL_M  # every trunk sample beyond the tail: nothing to fit
    assert np.isnan(trunk_turn([far], P, K4ABT)).all()


def test_the_tracker_turns_each_session_its_own_way():
    noise = dataclasses.replace(quiet(TrackerNoise.none()), trunk_turn_sd_deg=1.0)
    trunk = trunk_joints(KINECT_V2)
    base, _, _, _ = run(KINECT_V2, np.zeros(30), quiet(TrackerNoise.none()), seed=2)
    sessions = [run(KINECT_V2, np.zeros(30), noise, seed=s)[0].positions for s in (2, 3)]
    for pos in sessions:
        np.testing.assert_allclose(pos[:, ~trunk], base.positions[:, ~trunk], atol=1e-12)
        assert np.abs(pos[:, trunk] - base.positions[:, trunk]).max() > 1e-4
    assert np.abs(sessions[0][:, trunk] - sessions[1][:, trunk]).max() > 1e-4


@pytest.mark.parametrize("sd", [-0.1, 5.5, float("nan")])
def test_the_turns_size_is_bounded(sd):
    with pytest.raises(BadInputError, match="trunk_turn_sd_deg|finite"):
        TrackerNoise(trunk_turn_sd_deg=sd)
