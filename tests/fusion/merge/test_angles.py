"""ISB joint angles: an oracle skeleton built from known rotations, invariance, continuity, NaN, offsets."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fusion.errors import BadInputError, UnknownNameError
from fusion.merge.angles import (
    AngleOptions,
    angle_names,
    humerothoracic_deg,
    joint_angles,
    mirrored,
    neutral_offsets,
    remove_offsets,
    vertex_angle_deg,
)
from fusion.topology import KINECT_V2, Landmark
from fusion.transforms import apply
from tests.strategies import transforms

ISB_IN_WORLD = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # X fwd, Y up, Z right in a z-up world


def _r(axis: str, deg: float) -> np.ndarray:
    return Rotation.from_euler(axis, deg, degrees=True).as_matrix()


def oracle_skeleton(trunk=(0.0, 0.0, 0.0), right=(30.0, 60.0, 10.0, 90.0), left=(30.0, 60.0, 10.0, 90.0), yaw=0.0):
    """(J, 3) Kinect v2 joints (others NaN) whose angles are known: trunk (flexion, lean, rotation) and
    per arm (plane of elevation, elevation, axial rotation, elbow flexion) in degrees."""
    P = np.full((KINECT_V2.n_joints, 3), np.nan)

    def put(lm, p):
        P[KINECT_V2.index(lm)] = p

    f, lean, rot = trunk
    R_pelvis = _r("z", yaw) @ ISB_IN_WORLD
    R_thorax = R_pelvis @ _r("z", -f) @ _r("x", lean) @ _r("y", rot)
    pelvis = np.array([0.3, -0.2, 1.0])
    put(Landmark.PELVIS, pelvis)
    put(Landmark.HIP_LEFT, pelvis - 0.1 * R_pelvis[:, 2])
    put(Landmark.HIP_RIGHT, pelvis + 0.1 * R_pelvis[:, 2])
    ss = pelvis + 0.5 * R_thorax[:, 1]
    put(Landmark.SPINE_SHOULDER, ss)
    put(Landmark.SPINE_MID, pelvis + 0.25 * R_thorax[:, 1])
    for side, (a, e, c, phi), sign in (("RIGHT", right, 1.0), ("LEFT", left, -1.0)):
        R_ht = _r("y", a) @ _r("x", -e) @ _r("y", c)
        if sign < 0:
            R_ht = mirrored(R_ht)
        R_h = R_thorax @ R_ht
        shoulder = ss + sign * 0.18 * R_thorax[:, 2]
        elbow = shoulder - 0.3 * R_h[:, 1]
        p = np.radians(phi)
        wrist = elbow + 0.25 * (np.sin(p) * R_h[:, 0] - np.cos(p) * R_h[:, 1])
        put(Landmark[f"SHOULDER_{side}"], shoulder)
        put(Landmark[f"ELBOW_{side}"], elbow)
        put(Landmark[f"WRIST_{side}"], wrist)
    return P


angles_st = st.tuples(st.floats(-170, 170), st.floats(25, 170), st.floats(-170, 170), st.floats(20, 160))
trunk_st = st.tuples(st.floats(-60, 60), st.floats(-60, 60), st.floats(-80, 80))


@given(trunk_st, angles_st, angles_st, st.floats(-180, 180))
def test_angles_recover_the_rotations_they_were_built_from(trunk, right, left, yaw):
    a = joint_angles(oracle_skeleton(trunk, right, left, yaw)[None], KINECT_V2)
    assert np.allclose([a["trunk_flexion"][0], a["trunk_lateral_lean"][0], a["trunk_axial_rotation"][0]], trunk, atol=1e-6)
    for side, want in (("right", right), ("left", left)):
        got = [a[f"{n}_{side}"][0] for n in ("ht_plane_of_elevation", "ht_elevation", "ht_axial_rotation", "elbow_flexion")]
        assert np.allclose(got, want, atol=1e-6), (side, got, want)


@given(transforms(), trunk_st, angles_st, angles_st)
def test_angles_are_invariant_to_a_rigid_motion_of_the_whole_body(T, trunk, right, left):
    P = oracle_skeleton(trunk, right, left)[None]
    a = joint_angles(P, KINECT_V2)
    b = joint_angles(apply(T, P), KINECT_V2, AngleOptions(up=tuple(T[:3, :3] @ [0.0, 0.0, 1.0])))
    assert np.allclose(a.degrees, b.degrees, atol=1e-6, equal_nan=True)


@given(st.floats(-150, 150), st.floats(0.0, 30.0), st.floats(-170, 170), st.floats(-1, 1), st.floats(-1, 1),
       st.floats(-1, 1))
def test_humerothoracic_angles_are_continuous_through_the_singularity(a, e, c, wx, wy, wz):
    """A 0.01 deg turn of the humerus about any axis, near and through zero elevation, moves the
    elevation and the axial rotation by a bounded multiple of it (no jump at the threshold)."""
    w = np.array([wx, wy, wz])
    if np.linalg.norm(w) < 1e-3:
        return
    R0 = _r("y", a) @ _r("x", -e) @ _r("y", c)
    R1 = R0 @ Rotation.from_rotvec(np.radians(0.01) * w / np.linalg.norm(w)).as_matrix()
    h0, h1 = humerothoracic_deg(R0), humerothoracic_deg(R1)
    d = (h1 - h0 + 180.0) % 360.0 - 180.0
    assert abs(d[1]) <= 0.01 + 1e-9
    assert abs(d[2]) <= 20 * 0.01


def test_axial_rotation_fades_to_the_total_rotation_at_zero_elevation():
    h = humerothoracic_deg(_r("y", 40.0) @ _r("x", -0.0) @ _r("y", 25.0))
    assert np.isnan(h[0]) and h[1] == pytest.approx(0.0, abs=1e-6) and h[2] == pytest.approx(65.0)
    h = humerothoracic_deg(_r("y", 40.0) @ _r("x", -20.0) @ _r("y", 25.0))
    assert np.allclose(h, [40.0, 20.0, 25.0])


def test_undefined_angles_are_nan_not_garbage():
    P = oracle_skeleton(right=(30.0, 10.0, 0.0, 90.0), left=(30.0, 60.0, 10.0, 5.0))[None]
    a = joint_angles(P, KINECT_V2)
    assert np.isnan(a["ht_plane_of_elevation_right"][0])  # elevation below the threshold
    assert np.isfinite(a["ht_axial_rotation_right"][0])
    assert np.isnan(a["ht_axial_rotation_left"][0])  # elbow too straight for the humerus frame
    assert a["ht_elevation_left"][0] == pytest.approx(60.0)
    P[0, KINECT_V2.index(Landmark.WRIST_RIGHT)] = np.nan
    a = joint_angles(P, KINECT_V2)
    assert np.isnan(a["elbow_flexion_right"][0]) and np.isnan(a["ht_axial_rotation_right"][0])
    assert a["ht_elevation_right"][0] == pytest.approx(10.0)


def test_shapes_names_and_table4_vertex_angles():
    P = np.repeat(oracle_skeleton()[None], 4, axis=0)
    a = joint_angles(P, KINECT_V2)
    assert a.degrees.shape == (4, len(angle_names())) and a.names == angle_names()
    assert set(a.as_dict()) == set(angle_names())
    j = {lm: P[:, KINECT_V2.index(lm)] for lm in Landmark}
    want = vertex_angle_deg(j[Landmark.SPINE_SHOULDER], j[Landmark.SHOULDER_RIGHT], j[Landmark.ELBOW_RIGHT])
    assert np.allclose(a["spineshoulder_shoulder_elbow_right"], want)
    assert np.allclose(180.0 - a["elbow_flexion_left"], vertex_angle_deg(
        j[Landmark.SHOULDER_LEFT], j[Landmark.ELBOW_LEFT], j[Landmark.WRIST_LEFT]))
    assert vertex_angle_deg(np.zeros(3), np.zeros(3), np.ones(3)) != vertex_angle_deg(np.zeros(3), np.zeros(3), np.ones(3))


def test_neutral_pose_offsets_are_removed():
    P = np.stack([oracle_skeleton(trunk=(8.0, -3.0, 2.0), right=(0, 10.0, 0, 20.0)),
                  oracle_skeleton(trunk=(38.0, -3.0, 2.0), right=(0, 70.0, 0, 80.0))])
    a = joint_angles(P, KINECT_V2)
    offsets = neutral_offsets(a, np.array([True, False]))
    b = remove_offsets(a, offsets)
    assert b["trunk_flexion"] == pytest.approx([0.0, 30.0])
    assert b["ht_elevation_right"] == pytest.approx([0.0, 60.0])
    assert b["elbow_flexion_right"] == pytest.approx([0.0, 60.0])
    assert np.array_equal(b.offsets, offsets)
    assert offsets[a.names.index("ht_axial_rotation_right")] == 0.0


def test_bad_input_is_rejected():
    with pytest.raises(BadInputError, match="shape"):
        joint_angles(np.zeros((3, 5, 3)), KINECT_V2)
    with pytest.raises(BadInputError, match="min_elevation_deg"):
        AngleOptions(min_elevation_deg=0.0)
    with pytest.raises(BadInputError, match="up"):
        AngleOptions(up=(0.0, 0.0, 0.0))
    a = joint_angles(oracle_skeleton()[None], KINECT_V2)
    with pytest.raises(UnknownNameError):
        a["shoulder_abduction_right"]
    with pytest.raises(BadInputError, match="mask"):
        neutral_offsets(a, np.array([0]))
    nan = joint_angles(np.full((1, KINECT_V2.n_joints, 3), np.nan), KINECT_V2)
    with pytest.raises(BadInputError, match="neutral-pose trial"):
        neutral_offsets(nan, np.array([True]))
    with pytest.raises(BadInputError, match="offsets"):
        remove_offsets(a, np.zeros(2))
