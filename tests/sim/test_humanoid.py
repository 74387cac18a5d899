"""Tests of sim.anthropometry and sim.humanoid: construction, sign conventions, MuJoCo oracle."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from fusion.errors import BadInputError, UnknownNameError
from fusion.topology import K4ABT, KINECT_V2, Landmark
from sim.anthropometry import Anthropometry, Build, sample_anthropometry
from sim.coordinates import COORDINATES, INDEX, ROOT
from sim.humanoid import Humanoid
from sim.humanoid_model import BODY_GEOM_GROUP, build_humanoid

K = len(COORDINATES)
TOPOLOGIES = (KINECT_V2, K4ABT)
MIRROR_NEGATED = ("root_y", "root_yaw", "trunk_lateral", "trunk_rotation", "neck_rotation")
LEFT_COORDINATES = tuple(c for c in COORDINATES if c.endswith("_l"))

anthropometries = st.builds(
    Anthropometry,
    height_m=st.floats(1.2, 2.2),
    build=st.sampled_from(Build),
    **{
        name: st.floats(0.5, 2.0)
        for name in ("trunk", "upper_arm", "forearm", "hand", "thigh", "shank", "foot", "girth")
    },
)


def motions(max_frames: int = 6) -> st.SearchStrategy[np.ndarray]:
    """(T, K) coordinate arrays with every value in [-pi, pi] (radians, or metres for root_x/y)."""
    return st.integers(1, max_frames).flatmap(
        lambda t: arrays(np.float64, (t, K), elements=st.floats(-np.pi, np.pi, allow_subnormal=False))
    )


@pytest.fixture(scope="module")
def humanoid() -> Humanoid:
    return build_humanoid(Anthropometry())


def pose(**coords: float) -> np.ndarray:
    """(1, K) coordinates, zero except the given ones."""
    row = np.zeros((1, K))
    for name, value in coords.items():
        row[0, INDEX[name]] = value
    return row


def joints(humanoid: Humanoid, coords: np.ndarray, topology=KINECT_V2) -> dict[str, np.ndarray]:
    """Joint name -> (3,) world position for a single-frame pose."""
    return dict(zip(topology.joints, humanoid.joint_positions(coords, topology)[0]))


def random_motion(n_frames: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    coords = rng.uniform(-np.pi, np.pi, (n_frames, K))
    coords[:, [INDEX["root_x"], INDEX["root_y"]]] = rng.uniform(-2.0, 2.0, (n_frames, 2))
    return coords


def mirror_coords(coords: np.ndarray) -> np.ndarray:
    """Coordinates of the pose mirrored about the world xz plane."""
    out = coords.copy()
    for i, name in enumerate(COORDINATES):
        if name.endswith("_l"):
            out[:, i], out[:, INDEX[name[:-1] + "r"]] = coords[:, INDEX[name[:-1] + "r"]], coords[:, i]
    for name in MIRROR_NEGATED:
        out[:, INDEX[name]] *= -1
    return out


def lowest_foot_z(humanoid: Humanoid) -> float:
    """Lowest z of the foot box corners in humanoid.data, by brute force over corners."""
    m, d = humanoid.model, humanoid.data
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    lows = []
    for side in ("l", "r"):
        g = m.geom(f"foot_{side}").id
        pts = d.geom_xpos[g] + (corners * m.geom_size[g]) @ d.geom_xmat[g].reshape(3, 3).T
        lows.append(pts[:, 2].min())
    return min(lows)


# --- anthropometry ---------------------------------------------------------------------------


def test_default_anthropometry_stature_is_height():
    anthro = Anthropometry()
    assert anthro.dimensions.stature == pytest.approx(1.75, abs=1e-12)
    assert anthro.girth_factor == 1.0
    assert Anthropometry(build=Build.HEAVY).girth_factor > 1.0 > Anthropometry(build=Build.SLIM).girth_factor


@pytest.mark.parametrize(
    "kwargs",
    [
        {"height_m": 1.1},
        {"height_m": 2.3},
        {"height_m": float("nan")},
        {"height_m": "1.7"},
        {"height_m": True},
        {"build": "slim"},
        {"trunk": 0.0},
        {"forearm": -1.0},
        {"girth": float("nan")},
        {"foot": float("inf")},
    ],
)
def test_anthropometry_rejects_bad_values(kwargs):
    with pytest.raises(BadInputError):
        Anthropometry(**kwargs)


def test_anthropometry_error_message_names_field():
    with pytest.raises(BadInputError, match="height_m.*1.2, 2.2"):
        Anthropometry(height_m=2.5)


def test_multiplier_scales_segment():
    base, longer = Anthropometry().dimensions, Anthropometry(thigh=1.1).dimensions
    assert longer.thigh == pytest.approx(1.1 * base.thigh)
    assert longer.stature == pytest.approx(base.stature + 0.1 * base.thigh)


def test_sample_anthropometry_is_seeded_and_varied():
    a = [sample_anthropometry(rng=np.random.default_rng(s)) for s in range(20)]
    b = [sample_anthropometry(rng=np.random.default_rng(s)) for s in range(20)]
    assert a == b
    assert len({x.height_m for x in a}) == 20
    assert all(1.2 <= x.height_m <= 2.2 for x in a)


@pytest.mark.parametrize("kwargs", [{"height_mean": 3.0}, {"height_sd": -0.1}, {"limb_sd": float("nan")}])
def test_sample_anthropometry_rejects_bad_parameters(kwargs):
    with pytest.raises(BadInputError):
        sample_anthropometry(rng=np.random.default_rng(0), **kwargs)


# --- model structure ---------------------------------------------------------------------------


@given(anthro=anthropometries)
def test_model_compiles_and_stands_on_floor(anthro):
    hu = build_humanoid(anthro)
    m = hu.model
    assert m.nq == 7 + K - len(ROOT)
    hu.set_pose(np.zeros(K))
    assert lowest_foot_z(hu) == pytest.approx(0.0, abs=1e-12)
    head = m.geom("head").id
    top = hu.data.geom_xpos[head][2] + m.geom_size[head][2]
    assert top == pytest.approx(anthro.dimensions.stature, abs=1e-9)


def test_head_top_at_stature(humanoid):
    humanoid.set_pose(np.zeros(K))
    head = humanoid.model.geom("head").id
    top = humanoid.data.geom_xpos[head][2] + humanoid.model.geom_size[head][2]
    assert top == pytest.approx(humanoid.anthro.height_m, abs=1e-9)


def test_joints_named_after_coordinates(humanoid):
    m = humanoid.model
    assert m.jnt_type[m.joint("root").id] == mujoco.mjtJoint.mjJNT_FREE
    for name in COORDINATES:
        if name not in ROOT:
            j = m.joint(name)
            assert m.jnt_type[j.id] == mujoco.mjtJoint.mjJNT_HINGE
            assert humanoid.qpos_adr[name] == m.jnt_qposadr[j.id]
    assert set(humanoid.qpos_adr) == set(COORDINATES)


def test_geoms_floor_and_groups(humanoid):
    m = humanoid.model
    floor = humanoid.floor_geom_id
    assert m.geom(floor).name == "floor"
    assert m.geom_type[floor] == mujoco.mjtGeom.mjGEOM_PLANE and m.geom_group[floor] == 0
    assert m.geom_pos[floor][2] == 0.0
    ids = humanoid.body_geom_ids
    assert floor not in ids and len(ids) == m.ngeom - 1
    for g in ids:
        assert m.geom_group[g] == BODY_GEOM_GROUP
        assert m.geom(g).name.startswith(m.body(m.geom_bodyid[g]).name)


@pytest.mark.parametrize("topology", TOPOLOGIES)
def test_sites_for_every_joint(humanoid, topology):
    ids = humanoid.site_ids(topology)
    assert ids.shape == (topology.n_joints,)
    names = [humanoid.model.site(i).name for i in ids]
    assert names == [f"{topology.name}/{j}" for j in topology.joints]


@pytest.mark.parametrize(
    ("site", "body"),
    [
        ("kinect_v2/ShoulderLeft", "upper_arm_l"),
        ("kinect_v2/HandTipRight", "hand_r"),
        ("kinect_v2/SpineBase", "pelvis"),
        ("k4abt/CLAVICLE_LEFT", "clavicle_l"),
        ("k4abt/EAR_RIGHT", "head"),
        ("k4abt/FOOT_LEFT", "foot_l"),
    ],
)
def test_sites_on_the_right_body(humanoid, site, body):
    m = humanoid.model
    assert m.body(m.site_bodyid[m.site(site).id]).name == body


def test_neutral_stance(humanoid):
    j = joints(humanoid, pose())
    a = humanoid.anthro.dimensions
    for side, sign in (("Left", 1), ("Right", -1)):
        sh, wr, tip, th = (j[f"{n}{side}"] for n in ("Shoulder", "Wrist", "HandTip", "Thumb"))
        assert sign * sh[1] > 0  # subject's left on world +y
        np.testing.assert_allclose(wr[:2], sh[:2], atol=1e-12)  # arm hanging
        assert sh[2] - tip[2] == pytest.approx(a.upper_arm + a.forearm + a.hand)
        assert th[0] > wr[0] + 0.02  # thumb forward
        assert sign * (th[1] - wr[1]) < 0  # thumb on the palm side, palm towards the thigh
        np.testing.assert_allclose(j[f"Ankle{side}"][:2], j[f"Hip{side}"][:2], atol=1e-12)  # feet under hips
        assert j[f"Foot{side}"][0] > j[f"Ankle{side}"][0]  # toes forward
    assert j["SpineBase"][2] < j["SpineMid"][2] < j["SpineShoulder"][2] < j["Neck"][2] < j["Head"][2]
    assert j["SpineShoulder"][2] < j["ShoulderLeft"][2] < j["Neck"][2]
    np.testing.assert_allclose(j["SpineBase"], (j["HipLeft"] + j["HipRight"]) / 2, atol=1e-12)
    k = joints(humanoid, pose(), K4ABT)
    assert k["NOSE"][0] > k["EYE_LEFT"][0] > k["HEAD"][0] > k["EAR_LEFT"][0]
    assert k["EYE_LEFT"][1] > 0 > k["EYE_RIGHT"][1]


# --- oracle, invariants ------------------------------------------------------------------------


@pytest.mark.parametrize("topology", TOPOLOGIES)
def test_joint_positions_match_mujoco(humanoid, topology):
    coords = random_motion(25, seed=1)
    got = humanoid.joint_positions(coords, topology)
    qpos = humanoid.qpos(coords)
    ids = humanoid.site_ids(topology)
    data = mujoco.MjData(humanoid.model)
    for t in range(len(coords)):
        data.qpos[:] = qpos[t]
        mujoco.mj_forward(humanoid.model, data)
        np.testing.assert_allclose(got[t], data.site_xpos[ids], atol=1e-12)
    humanoid.set_pose(coords[-1])
    np.testing.assert_allclose(humanoid.data.site_xpos[ids], got[-1], atol=1e-12)


@given(coords=motions())
def test_grounding_puts_lowest_foot_point_on_floor(humanoid, coords):
    qpos = humanoid.qpos(coords)
    assert qpos.shape == (len(coords), humanoid.model.nq)
    for t in range(len(coords)):
        humanoid.set_pose(coords[t])
        np.testing.assert_array_equal(humanoid.data.qpos, qpos[t])
        assert lowest_foot_z(humanoid) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("topology", TOPOLOGIES)
def test_bone_lengths_constant(topology):
    hu = build_humanoid(sample_anthropometry(rng=np.random.default_rng(7)))
    p = hu.joint_positions(random_motion(300, seed=2), topology)
    bones = topology.bones
    lengths = np.linalg.norm(p[:, bones[:, 1]] - p[:, bones[:, 0]], axis=-1)
    assert np.ptp(lengths, axis=0).max() < 1e-9


@given(coords=motions())
def test_mirrored_coordinates_give_mirrored_skeleton(humanoid, coords):
    for topology in TOPOLOGIES:
        p = humanoid.joint_positions(coords, topology)
        q = humanoid.joint_positions(mirror_coords(coords), topology)
        np.testing.assert_allclose(q[:, topology.mirror], p * [1, -1, 1], atol=1e-9)


@given(angles=arrays(np.float64, len(LEFT_COORDINATES), elements=st.floats(-np.pi, np.pi)))
def test_same_coordinates_on_both_sides_are_symmetric(humanoid, angles):
    coords = pose(trunk_flexion=0.3, neck_flexion=-0.2)
    for name, value in zip(LEFT_COORDINATES, angles):
        coords[0, INDEX[name]] = coords[0, INDEX[name[:-1] + "r"]] = value
    p = humanoid.joint_positions(coords, KINECT_V2)
    np.testing.assert_allclose(p[:, KINECT_V2.mirror], p * [1, -1, 1], atol=1e-9)


# --- sign conventions --------------------------------------------------------------------------

SIDES = (("l", "Left", 1.0), ("r", "Right", -1.0))


@pytest.mark.parametrize(("s", "side", "lateral"), SIDES)
def test_shoulder_flexion_plane_puts_hand_forward(humanoid, s, side, lateral):
    j = joints(humanoid, pose(**{f"sh_plane_{s}": np.pi / 2, f"sh_elevation_{s}": np.pi / 2}))
    d = j[f"Hand{side}"] - j[f"Shoulder{side}"]
    assert d[0] > 0.4
    np.testing.assert_allclose(d[1:], 0.0, atol=1e-9)


@pytest.mark.parametrize(("s", "side", "lateral"), SIDES)
def test_shoulder_abduction_plane_puts_hand_sideways(humanoid, s, side, lateral):
    j = joints(humanoid, pose(**{f"sh_elevation_{s}": np.pi / 2}))
    d = j[f"Hand{side}"] - j[f"Shoulder{side}"]
    assert lateral * d[1] > 0.4
    np.testing.assert_allclose(d[[0, 2]], 0.0, atol=1e-9)
    up = joints(humanoid, pose(**{f"sh_elevation_{s}": np.pi}))
    assert up[f"Hand{side}"][2] - up[f"Shoulder{side}"][2] > 0.4


@pytest.mark.parametrize(("s", "side", "lateral"), SIDES)
def test_arm_hinge_signs(humanoid, s, side, lateral):
    def moved(name, value, joint, ref, **extra):
        j = joints(humanoid, pose(**{f"{name}_{s}": value, **{f"{k}_{s}": v for k, v in extra.items()}}))
        return j[f"{joint}{side}"] - j[f"{ref}{side}"]

    assert moved("elbow_flexion", np.pi / 2, "Wrist", "Elbow")[0] > 0.2  # forearm forward
    ext = moved("sh_rotation", np.pi / 2, "Wrist", "Elbow", elbow_flexion=np.pi / 2)
    assert lateral * ext[1] > 0.2  # external rotation: forearm outward
    sup = moved("forearm_rotation", np.pi / 2, "Thumb", "Wrist")
    assert lateral * sup[1] > 0.02  # supination: thumb outward
    flex = moved("wrist_flexion", np.pi / 2, "HandTip", "Wrist")
    assert -lateral * flex[1] > 0.1  # palmar flexion: towards the thigh side of the palm
    neutral = joints(humanoid, pose())[f"Shoulder{side}"]
    assert joints(humanoid, pose(**{f"clav_elevation_{s}": 0.3}))[f"Shoulder{side}"][2] > neutral[2] + 0.02
    assert joints(humanoid, pose(**{f"clav_retraction_{s}": 0.3}))[f"Shoulder{side}"][0] < neutral[0] - 0.02


@pytest.mark.parametrize(("s", "side", "lateral"), SIDES)
def test_leg_hinge_signs(humanoid, s, side, lateral):
    def rel(joint, ref, **kw):
        j = joints(humanoid, pose(**{f"{k}_{s}": v for k, v in kw.items()}))
        return j[f"{joint}{side}"] - j[f"{ref}{side}"]

    assert rel("Knee", "Hip", hip_flexion=np.pi / 2)[0] > 0.3
    assert lateral * rel("Knee", "Hip", hip_abduction=0.5)[1] > 0.1
    assert lateral * rel("Foot", "Ankle", hip_rotation=np.pi / 2)[1] > 0.05  # external: toes out
    assert rel("Ankle", "Knee", knee_flexion=np.pi / 2)[0] < -0.3
    assert rel("Foot", "Ankle", ankle_flexion=np.pi / 2)[2] > 0.1  # dorsiflexion: toes up


def test_trunk_and_neck_signs(humanoid):
    base = joints(humanoid, pose())
    assert joints(humanoid, pose(trunk_flexion=0.5))["Head"][0] > base["Head"][0] + 0.2
    assert joints(humanoid, pose(trunk_lateral=0.5))["Head"][1] < -0.2
    rot = joints(humanoid, pose(trunk_rotation=0.5))
    assert rot["ShoulderLeft"][0] < -0.05 < 0.05 < rot["ShoulderRight"][0]
    k0, kf, kr = (joints(humanoid, c, K4ABT) for c in (pose(), pose(neck_flexion=0.5), pose(neck_rotation=0.5)))
    assert kf["NOSE"][2] < k0["NOSE"][2] - 0.02
    assert kr["NOSE"][1] > 0.03


def test_root_moves_and_turns_the_subject(humanoid):
    base = humanoid.joint_positions(pose(), KINECT_V2)[0]
    shifted = humanoid.joint_positions(pose(root_x=1.5, root_y=-0.5), KINECT_V2)[0]
    np.testing.assert_allclose(shifted - base, np.broadcast_to([1.5, -0.5, 0.0], base.shape), atol=1e-12)
    turned = joints(humanoid, pose(root_yaw=np.pi / 2), K4ABT)
    assert turned["NOSE"][1] > turned["HEAD"][1] + 0.05  # faces +y
    assert turned["SHOULDER_LEFT"][0] < -0.1  # left side towards -x
    assert humanoid.facing_yaw(pose(root_yaw=np.pi / 2))[0] == pytest.approx(np.pi / 2)


@given(yaw=st.floats(-3.0, 3.0), rotation=st.floats(-1.5, 1.5), flexion=st.floats(-1.5, 1.5))
def test_facing_yaw_follows_root_yaw_and_trunk_rotation(humanoid, yaw, rotation, flexion):
    coords = pose(root_yaw=yaw, trunk_rotation=rotation, trunk_flexion=flexion, neck_rotation=1.0)
    got = humanoid.facing_yaw(coords)
    assert got.shape == (1,)
    # thorax left axis: Rz(yaw) Ry(flexion) Rz(rotation) e_y, seen from above
    expected = yaw + np.arctan2(np.sin(rotation) * np.cos(flexion), np.cos(rotation))
    assert np.angle(np.exp(1j * (got[0] - expected))) == pytest.approx(0.0, abs=1e-9)


# --- shapes and bad input ----------------------------------------------------------------------


def test_empty_motion(humanoid):
    empty = np.zeros((0, K))
    assert humanoid.qpos(empty).shape == (0, humanoid.model.nq)
    assert humanoid.joint_positions(empty, K4ABT).shape == (0, 32, 3)
    assert humanoid.facing_yaw(empty).shape == (0,)


@pytest.mark.parametrize(
    "coords",
    [np.zeros(K), np.zeros((3, K + 1)), np.zeros((2, 3, K)), [["a"] * K], pose(sh_plane_l=np.nan), pose(root_x=np.inf)],
)
def test_bad_coordinates_raise(humanoid, coords):
    for call in (humanoid.qpos, humanoid.facing_yaw, lambda c: humanoid.joint_positions(c, KINECT_V2)):
        with pytest.raises(BadInputError):
            call(coords)


def test_nan_message_names_frame_and_coordinate(humanoid):
    coords = np.zeros((4, K))
    coords[2, INDEX["elbow_flexion_r"]] = np.nan
    with pytest.raises(BadInputError, match="frame 2.*elbow_flexion_r"):
        humanoid.qpos(coords)


@pytest.mark.parametrize("row", [np.zeros((1, K)), np.zeros(K - 1), np.full(K, np.nan)])
def test_set_pose_rejects_bad_row(humanoid, row):
    with pytest.raises(BadInputError):
        humanoid.set_pose(row)


def test_unknown_topology_raises(humanoid):
    other = dataclasses.replace(KINECT_V2, name="other")
    with pytest.raises(UnknownNameError, match="kinect_v2"):
        humanoid.joint_positions(pose(), other)


def test_build_rejects_non_anthropometry():
    with pytest.raises(BadInputError):
        build_humanoid(1.75)


def test_landmarks_resolve_to_sites(humanoid):
    for topology in TOPOLOGIES:
        p = joints(humanoid, pose(), topology)
        assert p[topology.landmarks[Landmark.HEAD]][2] > p[topology.landmarks[Landmark.NECK]][2]
