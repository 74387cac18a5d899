"""Retargeting: round trip on the humanoid's own landmarks, limits, weights, gaps, scaling, bad input."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fusion.errors import BadInputError
from fusion.io.mocap import LandmarkTrajectory
from fusion.topology import K4ABT, KINECT_V2
from sim.anthropometry import Anthropometry
from sim.coordinates import INDEX
from sim.humanoid_model import build_humanoid
from sim.joint_limits import coordinate_limits
from sim.motions import hand_lift, salute
from sim.patient_motion import Movement, Side, SubjectProfile
from sim.retarget import RetargetOptions, bridge_gaps, joint_groups, retarget
from sim.retarget_scale import estimate_anthropometry
from sim.retarget_seed import arm_angles
from sim.timeline import compose


@pytest.fixture(scope="module")
def humanoid():
    return build_humanoid(Anthropometry(height_m=1.68))


@pytest.fixture(scope="module")
def truth(humanoid):
    motion = salute(Side.LEFT, 1, SubjectProfile.healthy().movement(Movement.SALUTE, Side.LEFT),
                    rng=np.random.default_rng(1))
    t = np.arange(0.0, min(motion.duration, 3.0), 1 / 30)
    return t, motion.sample(t)


def _traj(humanoid, t, coords, topology=KINECT_V2):
    joints = humanoid.joint_positions(coords, topology)
    return LandmarkTrajectory(topology, t, joints, np.ones(joints.shape[:2]), "truth")


@pytest.fixture(scope="module")
def both_arms():
    """Salute and hand lift of each arm: every arm rises from hanging (the gimbal-locked shoulder) and
    lowers back into it, in the flexion and in the abduction plane."""
    rng = np.random.default_rng(1)
    healthy = SubjectProfile.healthy()
    motion = compose([move(side, 1, healthy.movement(movement, side), rng=rng)
                      for side in (Side.LEFT, Side.RIGHT)
                      for move, movement in ((salute, Movement.SALUTE), (hand_lift, Movement.HAND_LIFT))])
    t = np.arange(0.0, motion.duration, 1 / 30)
    return t, motion.sample(t)


@pytest.mark.parametrize("topology", [KINECT_V2, K4ABT])
def test_round_trip_on_own_landmarks(humanoid, both_arms, topology):
    t, coords = both_arms
    traj = _traj(humanoid, t, coords, topology)
    r = retarget(humanoid, traj)
    back = humanoid.joint_positions(r.coords, topology)
    err = np.linalg.norm(back - traj.positions, axis=-1)
    assert np.median(err) < 0.001 and err.max() < 0.005
    assert r.coords.shape == coords.shape and r.errors.shape == err.shape and r.frame_rms.shape == t.shape
    for side in "lr":
        for name in (f"sh_elevation_{side}", f"elbow_flexion_{side}"):
            e = np.abs(r.coords[:, INDEX[name]] - coords[:, INDEX[name]])
            assert np.median(e) < np.radians(0.05), name
            assert e.max() < np.radians(2.0), name  # every frame, not only the typical one
    assert r.converged.all() and r.failed_frames.size == 0
    assert set(r.group_stats()) == {"trunk", "left arm", "right arm", "left leg", "right leg"}


def test_arm_angles_solve_the_arm_in_closed_form(humanoid):
    rng = np.random.default_rng(3)
    for _ in range(20):
        coords = np.zeros((1, len(INDEX)))
        for side in "lr":
            coords[0, INDEX[f"clav_elevation_{side}"]] = rng.uniform(-0.2, 0.6)
            coords[0, INDEX[f"clav_retraction_{side}"]] = rng.uniform(-0.5, 0.5)
            coords[0, INDEX[f"sh_plane_{side}"]] = rng.uniform(-1.2, 2.5)
            coords[0, INDEX[f"sh_elevation_{side}"]] = rng.uniform(0.3, 2.8)
            coords[0, INDEX[f"sh_rotation_{side}"]] = rng.uniform(-3.0, 3.0)
            coords[0, INDEX[f"elbow_flexion_{side}"]] = rng.uniform(0.4, 2.5)
        coords[0, INDEX["trunk_flexion"]], coords[0, INDEX["root_yaw"]] = rng.uniform(-0.3, 0.8), rng.uniform(-3, 3)
        target = humanoid.joint_positions(coords, KINECT_V2)[0]
        qpos = humanoid.qpos(coords)[0]
        humanoid.set_qpos(qpos)
        for side in "lr":
            body = mujoco.mj_name2id(humanoid.model, mujoco.mjtObj.mjOBJ_BODY, f"clavicle_{side}")
            R = humanoid.data.xmat[body].reshape(3, 3)
            arm = arm_angles(target, np.ones(25), KINECT_V2, side, R)
            for name, value in (("sh_plane", arm.sh_plane), ("sh_elevation", arm.sh_elevation),
                                ("elbow_flexion", arm.elbow_flexion), ("sh_rotation", arm.sh_rotation)):
                want = coords[0, INDEX[f"{name}_{side}"]]
                assert np.angle(np.exp(1j * (value - want))) == pytest.approx(0.0, abs=1e-9), (name, side)


def test_fit_respects_joint_limits(humanoid, truth):
    t, coords = truth
    traj = _traj(humanoid, t[:10], coords[:10])
    pos = np.array(traj.positions)
    elbow, wrist = KINECT_V2.index("ElbowLeft"), KINECT_V2.index("WristLeft")
    pos[:, wrist] = 2 * pos[:, elbow] - pos[:, wrist] + np.array([0.0, 0.0, 0.6])  # needs a hyperextended elbow
    r = retarget(humanoid, LandmarkTrajectory(KINECT_V2, traj.times, pos, traj.confidence))
    lo, hi = coordinate_limits()
    assert np.all(r.coords >= lo - 1e-9) and np.all(r.coords <= hi + 1e-9)


def test_zero_confidence_landmarks_are_ignored(humanoid, truth):
    t, coords = truth
    traj = _traj(humanoid, t[:8], coords[:8])
    pos, conf = np.array(traj.positions), np.array(traj.confidence)
    knee = KINECT_V2.index("KneeRight")
    pos[:, knee] += 0.5
    conf[:, knee] = 0.0
    r = retarget(humanoid, LandmarkTrajectory(KINECT_V2, traj.times, pos, conf))
    fitted = humanoid.joint_positions(r.coords, KINECT_V2)
    err = np.linalg.norm(fitted - traj.positions, axis=-1)
    assert np.median(np.delete(err, knee, axis=1)) < 0.002
    assert err[:, knee].max() < 0.05  # the displaced knee target (0.87 m away) did not pull
    assert np.isnan(r.errors[:, knee]).all()


def test_bridge_gaps_interpolates_short_gaps_only():
    t = np.arange(10) / 10.0
    pos = np.zeros((10, KINECT_V2.n_joints, 3))
    pos[:, 0, 0] = t
    conf = np.ones((10, KINECT_V2.n_joints))
    pos[2:4, 0] = np.nan   # 0.3 s between the neighbours: bridged
    pos[5:9, 1] = np.nan   # 0.5 s gap: kept
    out = bridge_gaps(LandmarkTrajectory(KINECT_V2, t, pos, conf), 0.35)
    np.testing.assert_allclose(out.positions[2:4, 0, 0], t[2:4])
    assert np.all(out.confidence[2:4, 0] == 0.5)
    assert np.isnan(out.positions[5:9, 1]).all()


def test_no_landmarks_is_an_error(humanoid):
    traj = LandmarkTrajectory(KINECT_V2, np.arange(3.0), np.full((3, 25, 3), np.nan), np.zeros((3, 25)))
    with pytest.raises(BadInputError, match="no landmark"):
        retarget(humanoid, traj)


def test_options_are_validated():
    with pytest.raises(BadInputError):
        RetargetOptions(max_rms_m=0.0)
    with pytest.raises(BadInputError):
        RetargetOptions(max_iterations=1)


def test_large_residuals_are_reported_as_failed_frames(humanoid, truth):
    t, coords = truth
    traj = _traj(humanoid, t[:6], coords[:6])
    pos = np.array(traj.positions)
    pos[3, KINECT_V2.index("HandLeft")] += 2.0  # a 2 m outlier no body can reach
    r = retarget(humanoid, LandmarkTrajectory(KINECT_V2, traj.times, pos, traj.confidence),
                 RetargetOptions(max_rms_m=0.1))
    assert 3 in r.failed_frames and 0 not in r.failed_frames


def test_joint_groups_follow_the_limbs():
    g = dict(zip(KINECT_V2.joints, joint_groups(KINECT_V2)))
    assert g["HandTipLeft"] == "left arm" and g["FootRight"] == "right leg" and g["Head"] == "trunk"
    g4 = dict(zip(K4ABT.joints, joint_groups(K4ABT)))
    assert g4["THUMB_RIGHT"] == "right arm" and g4["CLAVICLE_LEFT"] == "trunk"


@settings(max_examples=8, deadline=None)
@given(height=st.floats(1.5, 1.95), arm=st.floats(0.9, 1.1), shank=st.floats(0.9, 1.1))
def test_scaling_recovers_segment_lengths(height, arm, shank):
    a = Anthropometry(height_m=height, upper_arm=arm, shank=shank)
    h = build_humanoid(a)
    joints = h.joint_positions(np.zeros((2, len(INDEX))), KINECT_V2)
    est = estimate_anthropometry(LandmarkTrajectory(KINECT_V2, np.arange(2.0), joints, np.ones((2, 25))))
    b = est.anthropometry
    assert b.height_m * b.upper_arm == pytest.approx(height * arm, rel=1e-6)
    assert b.height_m * b.shank == pytest.approx(height * shank, rel=1e-6)


@settings(max_examples=12, deadline=None)
@given(height=st.floats(1.5, 1.95), legs=st.floats(0.75, 1.15), trunk=st.floats(0.9, 1.25), arm=st.floats(0.75, 1.1))
def test_stature_is_the_standing_height_of_the_fitted_body(height, legs, trunk, arm):
    # tracker-like proportions (short limbs, a long trunk) must not shrink the stature to the limbs' scale;
    # only the ankle height and the head above the head centre are not measured: they scale with the chain
    a = Anthropometry(height_m=height, thigh=legs, shank=legs, trunk=trunk, upper_arm=arm, forearm=arm)
    joints = build_humanoid(a).joint_positions(np.zeros((2, len(INDEX))), KINECT_V2)
    est = estimate_anthropometry(LandmarkTrajectory(KINECT_V2, np.arange(2.0), joints, np.ones((2, 25))))
    assert est.stature_m == pytest.approx(est.anthropometry.dimensions.stature)
    assert est.stature_m == pytest.approx(a.dimensions.stature, rel=0.05)
    uniform = build_humanoid(Anthropometry(height_m=height)).joint_positions(np.zeros((2, len(INDEX))), KINECT_V2)
    est = estimate_anthropometry(LandmarkTrajectory(KINECT_V2, np.arange(2.0), uniform, np.ones((2, 25))))
    assert est.stature_m == pytest.approx(height, rel=1e-6)


def test_implausible_stature_names_the_units_option(humanoid):
    joints = humanoid.joint_positions(np.zeros((2, len(INDEX))), KINECT_V2) * 1000.0  # millimetres
    traj = LandmarkTrajectory(KINECT_V2, np.arange(2.0), joints, np.ones((2, 25)), "clip.trc")
    with pytest.raises(BadInputError, match="implausible.*--units"):
        estimate_anthropometry(traj, units_option="--units")

