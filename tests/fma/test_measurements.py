import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fma.measurements import (
    MEASUREMENT_NAMES,
    TABLE4_MEASUREMENT_NAMES,
    AngleDefinitions,
    Side,
    compute_measurements,
    measurement_names,
)
from fusion.errors import BadInputError
from fusion.topology import K4ABT, KINECT_V2, Landmark

ANGLES = [i for i, n in enumerate(MEASUREMENT_NAMES) if n.startswith("Angle")]
DISTANCES = [i for i, n in enumerate(MEASUREMENT_NAMES) if n.startswith("Distance")]
HEIGHTS = [i for i, n in enumerate(MEASUREMENT_NAMES) if n.startswith("Height")]

finite = st.floats(-3.0, 3.0, allow_nan=False)


def body(topology, seed, n_frames=5):
    """A random standing skeleton (T, J, 3): every joint jittered around a plausible place."""
    rng = np.random.default_rng(seed)
    base = {
        "PELVIS": (0, 0, 1.0), "SPINE_MID": (0, 0, 1.2), "SPINE_SHOULDER": (0, 0, 1.45), "NECK": (0, 0, 1.5),
        "HEAD": (0, 0, 1.65), "SHOULDER": (0.18, 0, 1.42), "ELBOW": (0.2, 0, 1.15), "WRIST": (0.22, 0.05, 0.9),
        "HAND": (0.22, 0.07, 0.82), "HANDTIP": (0.22, 0.1, 0.75), "THUMB": (0.2, 0.1, 0.85), "HIP": (0.1, 0, 0.95),
        "KNEE": (0.1, 0.02, 0.5), "ANKLE": (0.1, 0, 0.1), "FOOT": (0.1, 0.1, 0.02),
    }
    pos = np.zeros((topology.n_joints, 3))
    for lm in Landmark:
        key, _, s = lm.name.rpartition("_")
        if s in ("LEFT", "RIGHT"):
            x, y, z = base[key]
            pos[topology.index(lm)] = (x if s == "LEFT" else -x, y, z)
        else:
            pos[topology.index(lm)] = base[lm.name]
    return pos + rng.normal(0, 0.05, (n_frames, topology.n_joints, 3))


def known_pose():
    """One frame: upright trunk, the right arm straight out sideways."""
    pos = body(KINECT_V2, 0, 1)
    idx = {lm: KINECT_V2.index(lm) for lm in Landmark}
    pos[0, idx[Landmark.SPINE_SHOULDER]] = (0, 0, 1.4)
    pos[0, idx[Landmark.SPINE_MID]] = (0, 0, 1.1)
    pos[0, idx[Landmark.HEAD]] = (0, 0, 1.7)
    pos[0, idx[Landmark.SHOULDER_RIGHT]] = (-0.2, 0, 1.4)
    pos[0, idx[Landmark.ELBOW_RIGHT]] = (-0.5, 0, 1.4)  # arm straight out sideways
    pos[0, idx[Landmark.WRIST_RIGHT]] = (-0.75, 0, 1.4)
    pos[0, idx[Landmark.HAND_RIGHT]] = (-0.8, 0, 1.4)
    pos[0, idx[Landmark.HIP_RIGHT]] = (-0.2, 0, 0.9)
    pos[0, idx[Landmark.KNEE_RIGHT]] = (-0.2, 0, 0.5)
    pos[0, idx[Landmark.PELVIS]] = (0, 0, 0.9)
    pos[0, idx[Landmark.SHOULDER_LEFT]] = (0.2, 0, 1.4)
    pos[0, idx[Landmark.HIP_LEFT]] = (0.2, 0, 0.9)
    return pos


def test_shapes_names_and_units_on_a_known_pose():
    pos = known_pose()
    m = compute_measurements(pos, KINECT_V2, "right", camera_position=np.array([-0.2, 2.0, 1.4]),
                             angles=AngleDefinitions.TABLE4)
    assert m.shape == (1, 13) and len(TABLE4_MEASUREMENT_NAMES) == 13
    got = dict(zip(TABLE4_MEASUREMENT_NAMES, m[0]))
    assert got["Angle(Shoulder-Elbow-Wrist)"] == pytest.approx(180.0)
    assert got["Angle(SpineShoulder-Shoulder-Elbow)"] == pytest.approx(180.0)
    assert got["Angle(Hip-Shoulder-Elbow)"] == pytest.approx(90.0)
    assert got["Angle(Shoulder-SpineShoulder-SpineMid)"] == pytest.approx(90.0)
    assert got["Angle(Knee-Hip-SpineMid)"] == pytest.approx(180 - np.degrees(np.arctan2(0.2, 0.2)))
    assert got["Height(Elbow)"] == pytest.approx(1.4)
    assert got["Distance(Head-Hand)"] == pytest.approx(np.hypot(0.8, 0.3))
    assert got["Distance(Head-Elbow)"] == pytest.approx(np.hypot(0.5, 0.3))
    assert got["Distance(Hand-Knee)"] == pytest.approx(np.hypot(0.6, 0.9))
    assert got["Distance(Wrist-Hip)"] == pytest.approx(np.hypot(0.55, 0.5))
    assert got["Distance(Camera-Shoulder)"] == pytest.approx(2.0)


@pytest.mark.parametrize("side", list(Side))
def test_isb_angles_on_a_known_pose(side):
    pos = known_pose()
    if side is Side.LEFT:  # the mirror image: the left arm out sideways
        pos = pos[:, KINECT_V2.mirror] * [-1, 1, 1]
    isb = dict(zip(MEASUREMENT_NAMES, compute_measurements(pos, KINECT_V2, side)[0]))
    table4 = dict(zip(TABLE4_MEASUREMENT_NAMES, compute_measurements(pos, KINECT_V2, side, angles=AngleDefinitions.TABLE4)[0]))
    assert MEASUREMENT_NAMES == measurement_names(AngleDefinitions.ISB) != TABLE4_MEASUREMENT_NAMES
    np.testing.assert_allclose([isb["Angle(ElbowFlexion)"], isb["Angle(HTElevation)"], isb["Angle(HTPlaneOfElevation)"],
                                isb["Angle(TrunkFlexion)"], isb["Angle(TrunkLateralLean)"]], [0, 90, 0, 0, 0], atol=1e-9)
    assert {k: v for k, v in isb.items() if not k.startswith("Angle")} == pytest.approx(
        {k: v for k, v in table4.items() if not k.startswith("Angle")}, nan_ok=True)
    # leaning the trunk toward the moving arm reads positive on either side
    lean = pos.copy()
    upper = [KINECT_V2.index(lm) for lm in Landmark if lm.name.startswith(("SPINE_SHOULDER", "SHOULDER", "ELBOW",
                                                                                "WRIST", "HAND", "HEAD", "NECK", "THUMB"))]
    lean[:, upper, 0] += 0.1 * (1.0 if side is Side.LEFT else -1.0) * (lean[:, upper, 2] - 0.9)
    leaned = dict(zip(MEASUREMENT_NAMES, compute_measurements(lean, KINECT_V2, side)[0]))
    assert leaned["Angle(TrunkLateralLean)"] == pytest.approx(np.degrees(np.arctan(0.1)), abs=1e-6)


@given(seed=st.integers(0, 2**32 - 1), rotvec=st.tuples(finite, finite, finite), shift=st.tuples(finite, finite, finite),
       side=st.sampled_from(list(Side)), topology=st.sampled_from([KINECT_V2, K4ABT]))
def test_angles_and_distances_invariant_under_rigid_motion(seed, rotvec, shift, side, topology):
    pos = body(topology, seed)
    cam = np.array([1.0, 2.0, 1.5])
    R, t = Rotation.from_rotvec(rotvec).as_matrix(), np.array(shift)
    before = compute_measurements(pos, topology, side, camera_position=cam, angles=AngleDefinitions.TABLE4)
    after = compute_measurements(pos @ R.T + t, topology, side, camera_position=R @ cam + t,
                                 angles=AngleDefinitions.TABLE4)
    cols = ANGLES + DISTANCES  # the ISB trunk angles take the world's up: invariant under yaw only (below)
    np.testing.assert_allclose(after[:, cols], before[:, cols], atol=1e-6)


@given(seed=st.integers(0, 2**32 - 1), yaw=st.floats(-np.pi, np.pi), dx=finite, dy=finite,
       tilt=st.floats(0.2, 1.2))
def test_heights_invariant_only_under_yaw_and_horizontal_shift(seed, yaw, dx, dy, tilt):
    pos = body(KINECT_V2, seed)
    before = compute_measurements(pos, KINECT_V2, Side.LEFT)
    R = Rotation.from_euler("z", yaw).as_matrix()
    after = compute_measurements(pos @ R.T + [dx, dy, 0.0], KINECT_V2, Side.LEFT)
    np.testing.assert_allclose(after, before, atol=1e-9, equal_nan=True)
    tilted = compute_measurements(pos @ Rotation.from_euler("x", tilt).as_matrix().T, KINECT_V2, Side.LEFT)
    assert not np.allclose(tilted[:, HEIGHTS], before[:, HEIGHTS], atol=1e-3)
    lifted = compute_measurements(pos + [0, 0, 0.5], KINECT_V2, Side.LEFT)
    np.testing.assert_allclose(lifted[:, HEIGHTS], before[:, HEIGHTS] + 0.5)


def test_nan_joints_and_missing_camera():
    pos = body(KINECT_V2, 3)
    pos[2, KINECT_V2.index(Landmark.ELBOW_LEFT)] = np.nan
    m = compute_measurements(pos, KINECT_V2, "LEFT")
    assert np.all(np.isnan(m[:, MEASUREMENT_NAMES.index("Distance(Camera-Shoulder)")]))
    uses_elbow = [i for i, n in enumerate(MEASUREMENT_NAMES) if "Elbow" in n or n.startswith("Angle(HT")]
    assert np.all(np.isnan(m[2, uses_elbow]))
    plane = MEASUREMENT_NAMES.index("Angle(HTPlaneOfElevation)")  # NaN: the arm hangs
    assert np.all(np.isfinite(np.delete(m[[0, 1, 3, 4]][:, :12], plane, axis=1)))
    assert np.isfinite(m[2, MEASUREMENT_NAMES.index("Height(Hand)")])


def test_sides_mirror():
    pos = body(KINECT_V2, 4)
    mirrored = pos[:, KINECT_V2.mirror] * [-1, 1, 1]
    np.testing.assert_allclose(compute_measurements(mirrored, KINECT_V2, Side.RIGHT),
                               compute_measurements(pos, KINECT_V2, Side.LEFT), equal_nan=True)


def test_bad_input():
    pos = body(KINECT_V2, 5)
    with pytest.raises(BadInputError):
        compute_measurements(pos[:, :10], KINECT_V2, Side.LEFT)
    with pytest.raises(BadInputError):
        compute_measurements(pos, KINECT_V2, "middle")
    with pytest.raises(BadInputError):
        compute_measurements(pos, KINECT_V2, Side.LEFT, camera_position=np.zeros(2))
