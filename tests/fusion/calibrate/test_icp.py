"""ICP refinement and calibration-point selection on synthetic depth frames.

The scene is a body made of ellipsoids (torso, head, legs, feet, arms; one arm moves between
instants) standing on a floor, ray-cast with Open3D into Kinect v2 depth frames with labels and
seeded depth noise.
"""

import numpy as np
import open3d as o3d
import pytest
from scipy.spatial.transform import Rotation

from fusion.calibrate.icp import IcpLimits, refine_pair_icp
from fusion.calibrate.icp_points import select_calibration_points
from fusion.calibrate.icp_result import IcpResult
from fusion.calibrate.options import IcpMethod
from fusion.camera import KINECT_V2_DEPTH, AxisConvention, Intrinsics
from fusion.depth import Label, depth_to_points
from fusion.errors import BadInputError
from fusion.transforms import (
    apply,
    compose,
    invert,
    make_transform,
    transform_difference,
)
from sim.rig import look_at

K = KINECT_V2_DEPTH
ARM_ANGLES = (0.0, 1.2)
NOISE_M = 0.003
# (semi-axes, centre) of the ellipsoids in the world frame (z up, floor z = 0, subject faces -y).
BODY = [
    ([0.17, 0.11, 0.30], [0.0, 0.0, 1.15]),
    ([0.09, 0.10, 0.12], [0.0, 0.01, 1.60]),
    ([0.07, 0.07, 0.40], [0.09, 0.0, 0.45]),
    ([0.07, 0.07, 0.40], [-0.09, 0.0, 0.45]),
    ([0.05, 0.12, 0.03], [0.09, -0.05, 0.03]),
    ([0.05, 0.12, 0.03], [-0.09, -0.05, 0.03]),
    ([0.05, 0.05, 0.32], [-0.22, 0.0, 1.08]),
]
JOINTS_WORLD = np.array([
    [0, 0, 0.95], [0, 0, 1.2], [0, 0, 1.42], [0, 0.01, 1.6], [0.2, 0, 1.4], [-0.2, 0, 1.4], [-0.22, 0, 1.1],
    [-0.22, 0, 0.8], [0.09, 0, 0.85], [-0.09, 0, 0.85], [0.09, 0, 0.45], [-0.09, 0, 0.45], [0.09, 0, 0.08],
    [-0.09, 0, 0.08], [0.09, -0.1, 0.04], [-0.09, -0.1, 0.04],
])


def _ellipsoid(axes, centre, R=np.eye(3)):
    mesh = o3d.geometry.TriangleMesh.create_sphere(1.0, resolution=20)
    mesh.vertices = o3d.utility.Vector3dVector((np.asarray(mesh.vertices) * axes) @ R.T + centre)
    return mesh


def _arm(angle):
    R = Rotation.from_euler("y", angle).as_matrix()
    return _ellipsoid([0.05, 0.05, 0.32], np.array([0.22, 0.0, 1.38]) + R @ [0, 0, -0.3], R)


def camera_pose(azimuth_deg, distance=2.5, height=1.0):
    """T_world_cam of a Kinect v2 camera (+z forward, +y up, +x left) aimed at the subject."""
    a = np.radians(azimuth_deg)
    return look_at(np.array([distance * np.sin(a), -distance * np.cos(a), height]), np.array([0.0, 0.0, 0.9]))


def render(T_world_cam, arm_angle, rng):
    """Noisy (H, W) uint16 depth [mm] and labels of the scene seen from ``T_world_cam``."""
    body = o3d.geometry.TriangleMesh()
    for axes, centre in BODY:
        body += _ellipsoid(axes, centre)
    body += _arm(arm_angle)
    floor = o3d.geometry.TriangleMesh(
        o3d.utility.Vector3dVector([[-3, -3, 0], [3, -3, 0], [3, 3, 0], [-3, 3, 0]]),
        o3d.utility.Vector3iVector([[0, 1, 2], [0, 2, 3]]),
    )
    scene = o3d.t.geometry.RaycastingScene()
    body_id = scene.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(body))
    floor_id = scene.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(floor))
    dirs = K.pixel_rays().reshape(-1, 3) @ T_world_cam[:3, :3].T  # z = 1 in the camera: t_hit is depth
    rays = np.hstack([np.broadcast_to(T_world_cam[:3, 3], dirs.shape), dirs]).astype(np.float32)
    hit = scene.cast_rays(o3d.core.Tensor(rays))
    z = hit["t_hit"].numpy().reshape(K.height, K.width).astype(float)
    ids = hit["geometry_ids"].numpy().reshape(K.height, K.width)
    valid = np.isfinite(z) & (z < K.max_depth_m)
    z = np.where(valid, z + rng.normal(0.0, NOISE_M, z.shape), 0.0)
    labels = np.full(z.shape, Label.NONE, np.uint8)
    labels[valid & (ids == body_id)] = Label.BODY
    labels[valid & (ids == floor_id)] = Label.FLOOR
    return np.round(z * 1e3).astype(np.uint16), labels


@pytest.fixture(scope="module")
def scene():
    rng = np.random.default_rng(42)
    T_world_a, T_world_b = camera_pose(0.0), camera_pose(60.0)
    frames = {name: [render(T, angle, rng) for angle in ARM_ANGLES] for name, T in (("a", T_world_a), ("b", T_world_b))}
    clouds = {
        name: [select_calibration_points(d, lab, K, rng=rng) for d, lab in frames[name]] for name in frames
    }
    floors = {  # the floor within 1 m of the subject
        name: [_near_subject(_labelled_points(d, lab, Label.FLOOR), T) for d, lab in frames[name]]
        for name, T in (("a", T_world_a), ("b", T_world_b))
    }
    return dict(T_a_b=compose(invert(T_world_a), T_world_b), T_world_a=T_world_a, T_world_b=T_world_b,
                frames=frames, clouds=clouds, floors=floors)


def _labelled_points(depth, labels, label):
    points, point_labels = depth_to_points(depth, K, labels)
    return points[point_labels == label]


def _near_subject(points_cam, T_world_cam, radius_m=1.0):
    return points_cam[np.linalg.norm(apply(T_world_cam, points_cam)[:, :2], axis=1) < radius_m]


def _about_centroid(T_a_b, centroid_b, rotvec, shift):
    """``T_a_b`` perturbed by a rotation about the subject (``centroid_b``) and a shift [m]."""
    R = Rotation.from_rotvec(rotvec).as_matrix()
    return compose(T_a_b, make_transform(R, centroid_b - R @ centroid_b + shift))


def _errors(T_a_b, T_true, points_b):
    """Rotation error [deg] and RMS displacement [m] of the b points."""
    shift = np.sqrt(np.mean(np.sum((apply(T_a_b, points_b) - apply(T_true, points_b)) ** 2, axis=1)))
    return float(transform_difference(T_a_b, T_true)[0]), float(shift)


@pytest.mark.parametrize(
    ("method", "axis"),
    [(IcpMethod.POINT_TO_PLANE, [0.0, 0.6, 0.8]), (IcpMethod.POINT_TO_PLANE, [1.0, 0.0, 0.0]),
     (IcpMethod.SYMMETRIC, [0.0, 0.6, 0.8])],
)
def test_recovers_from_2_degrees_and_3_cm(scene, method, axis):
    body_b = np.vstack(scene["clouds"]["b"])
    start = _about_centroid(scene["T_a_b"], body_b.mean(axis=0), np.radians(2.0) * np.array(axis),
                            0.03 * np.array([0.6, -0.8, 0.0]))
    result = refine_pair_icp(scene["clouds"]["a"], scene["clouds"]["b"], start, method=method)
    assert isinstance(result, IcpResult)
    assert result.accepted and result.converged, result.reason
    rot, shift = _errors(result.T_a_b, scene["T_a_b"], body_b)
    assert rot < 0.2 and shift < 0.003
    assert result.fitness > result.initial_fitness and result.inlier_rmse_m < result.initial_inlier_rmse_m
    assert result.rotation_change_deg == pytest.approx(2.0, abs=0.3)
    assert result.opposite_fraction < 0.01
    assert np.array_equal(result.T_a_b, result.T_a_b_icp)


def test_exact_start_is_kept_within_accuracy(scene):
    result = refine_pair_icp(scene["clouds"]["a"], scene["clouds"]["b"], scene["T_a_b"])
    assert result.accepted, result.reason
    rot, shift = _errors(result.T_a_b, scene["T_a_b"], np.vstack(scene["clouds"]["b"]))
    assert rot < 0.2 and shift < 0.003


def test_refuses_a_bad_initialisation(scene):
    body_b = np.vstack(scene["clouds"]["b"])
    start = _about_centroid(scene["T_a_b"], body_b.mean(axis=0), np.radians(25.0) * np.array([0, 1.0, 0]),
                            np.array([0.2, 0.0, 0.1]))
    result = refine_pair_icp(scene["clouds"]["a"], scene["clouds"]["b"], start, voxel_m=0.02)
    assert not result.accepted
    assert np.array_equal(result.T_a_b, result.T_a_b_init)
    assert result.reason.startswith("rejected")


def test_refuses_a_plane_alone(scene):
    floor_a, floor_b = scene["floors"]["a"], scene["floors"]["b"]
    start = _about_centroid(scene["T_a_b"], np.vstack(floor_b).mean(axis=0), np.radians(1.0) * np.array([0, 1.0, 0]),
                            np.array([0.02, 0.0, 0.0]))
    result = refine_pair_icp(floor_a, floor_b, start, voxel_m=0.02,
                             limits=IcpLimits(max_rotation_deg=180, max_translation_m=10))
    assert not result.accepted
    assert "degenerate" in result.reason
    assert result.constraint_ratio < IcpLimits().min_constraint_ratio
    assert np.array_equal(result.T_a_b, start)


def test_refuses_to_match_opposite_sides_of_the_body(scene):
    """Cameras facing each other share no surface: ICP slides front onto back, even from the truth."""
    rng = np.random.default_rng(5)
    T_world_c = camera_pose(180.0)
    cloud_c = select_calibration_points(*render(T_world_c, ARM_ANGLES[0], rng), K, rng=rng)
    result = refine_pair_icp(scene["clouds"]["a"][:1], [cloud_c], compose(invert(scene["T_world_a"]), T_world_c))
    assert not result.accepted and "opposite sides" in result.reason
    assert result.opposite_fraction > IcpLimits().max_opposite_fraction


def test_too_few_points_are_reported_not_run():
    rng = np.random.default_rng(0)
    cloud = rng.uniform(-0.5, 0.5, (30, 3)) + [0, 0, 2.5]
    result = refine_pair_icp([cloud], [cloud], np.eye(4))
    assert not result.accepted and "too few points" in result.reason
    assert not result.converged and result.n_points_a <= 30
    assert np.array_equal(result.T_a_b, np.eye(4))


def test_bad_inputs_raise():
    cloud = np.zeros((200, 3))
    with pytest.raises(BadInputError):
        refine_pair_icp([cloud, cloud], [cloud], np.eye(4))
    with pytest.raises(BadInputError):
        refine_pair_icp([], [], np.eye(4))
    with pytest.raises(BadInputError):
        refine_pair_icp(cloud, cloud, np.eye(4))
    with pytest.raises(BadInputError):
        refine_pair_icp([np.zeros((200, 2))], [cloud], np.eye(4))
    with pytest.raises(BadInputError):
        refine_pair_icp([cloud], [cloud], 2 * np.eye(4))
    with pytest.raises(BadInputError):
        refine_pair_icp([cloud], [cloud], np.eye(4), max_corr_m=(0.02, 0.05))
    with pytest.raises(BadInputError):
        refine_pair_icp([cloud], [cloud], np.eye(4), method="point_to_plane")
    with pytest.raises(BadInputError):
        refine_pair_icp([cloud], [cloud], np.eye(4), voxel_m=0.0)
    with pytest.raises(BadInputError):
        IcpLimits(max_rotation_deg=-1.0)


def _horizontal_distance_to_feet(points_world):
    feet = np.array([c for axes, c in BODY if axes[2] < 0.05])[:, :2]
    return np.min(np.linalg.norm(points_world[:, None, :2] - feet[None], axis=2), axis=1)


def test_labelled_selection_is_body_plus_floor_near_the_feet(scene):
    depth, labels = scene["frames"]["a"][0]
    selected = select_calibration_points(depth, labels, K, rng=np.random.default_rng(0))
    body = _labelled_points(depth, labels, Label.BODY)
    floor_world = apply(scene["T_world_a"], selected[body.shape[0]:])
    np.testing.assert_array_equal(selected[: body.shape[0]], body)
    assert floor_world.shape[0] > 1000
    np.testing.assert_allclose(floor_world[:, 2], 0.0, atol=0.02)
    assert _horizontal_distance_to_feet(floor_world).max() < 0.6 + 0.13  # radius + foot half-length


def test_unlabelled_selection_uses_the_skeleton(scene):
    depth, labels = scene["frames"]["a"][0]
    joints_cam = apply(invert(scene["T_world_a"]), JOINTS_WORLD)
    selected = select_calibration_points(depth, None, K, rng=np.random.default_rng(0), joints_cam=joints_cam)
    points, point_labels = depth_to_points(depth, K, labels)
    label_of = dict(zip(map(tuple, points), point_labels))
    chosen_labels = np.array([label_of[tuple(p)] for p in selected])
    selected_world = apply(scene["T_world_a"], selected)
    floor = chosen_labels == Label.FLOOR
    assert np.mean(chosen_labels != Label.NONE) == 1.0
    assert np.count_nonzero(chosen_labels == Label.BODY) > 0.8 * np.count_nonzero(point_labels == Label.BODY)
    assert np.count_nonzero(floor) > 1000
    assert _horizontal_distance_to_feet(selected_world[floor]).max() < 0.6 + 0.1


def test_unlabelled_selection_without_a_visible_floor_keeps_the_body(scene):
    depth, labels = scene["frames"]["a"][0]
    depth = np.where(labels == Label.BODY, depth, 0).astype(np.uint16)
    joints_cam = apply(invert(scene["T_world_a"]), JOINTS_WORLD)
    selected = select_calibration_points(depth, None, K, rng=np.random.default_rng(0), joints_cam=joints_cam)
    assert selected.shape[0] > 0.8 * np.count_nonzero(labels == Label.BODY)


def test_selection_bad_inputs():
    depth = np.zeros((K.height, K.width), np.uint16)
    rng = np.random.default_rng(0)
    with pytest.raises(BadInputError):
        select_calibration_points(depth, None, K, rng=rng)
    with pytest.raises(BadInputError):
        select_calibration_points(depth, None, K, rng=rng, joints_cam=np.full((25, 3), np.nan))
    with pytest.raises(BadInputError):
        select_calibration_points(depth, None, K, rng=rng, joints_cam=np.zeros((25, 2)))
    with pytest.raises(BadInputError):
        select_calibration_points(depth[:10], None, K, rng=rng, joints_cam=np.zeros((25, 3)))
    with pytest.raises(BadInputError):
        select_calibration_points(depth, np.zeros((10, 10), np.uint8), K, rng=rng)
    with pytest.raises(BadInputError):
        select_calibration_points(depth, None, K, rng=rng, joints_cam=np.zeros((25, 3)), floor_radius_m=0.0)


def test_selection_up_direction_follows_the_axis_convention(scene):
    """The same frame read with OpenCV axes (y flipped) selects the same points, flipped."""
    depth, labels = scene["frames"]["a"][0]
    opencv = Intrinsics(axes=AxisConvention.OPENCV)
    joints_cam = apply(invert(scene["T_world_a"]), JOINTS_WORLD)
    flip = np.array([1.0, -1.0, 1.0])
    kinect = select_calibration_points(depth, None, K, rng=np.random.default_rng(0), joints_cam=joints_cam)
    other = select_calibration_points(depth, None, opencv, rng=np.random.default_rng(0), joints_cam=joints_cam * flip)
    np.testing.assert_allclose(np.sort(other * flip, axis=0), np.sort(kinect, axis=0), atol=1e-12)
