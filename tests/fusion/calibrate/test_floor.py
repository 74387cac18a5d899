import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fusion.calibrate.floor import (
    FloorPlane,
    GaugeMode,
    align_gauge,
    fit_floor_plane,
    fit_plane_lstsq,
    world_from_floor,
)
from fusion.errors import BadInputError, CalibrationError
from fusion.transforms import (
    apply,
    compose,
    invert,
    make_transform,
    rotate,
    transform_difference,
)
from tests.strategies import rotations, seeds, transforms, unit_vectors


def _noisy_plane(T_cam_plane, rng, n=3000, noise_m=0.003, outlier_fraction=0.3):
    """Points of the plane z = 0 of a local frame, seen in the camera frame, with box outliers."""
    n_out = int(n * outlier_fraction)
    inl = np.c_[rng.uniform(-1.5, 1.5, (n - n_out, 2)), rng.normal(0.0, noise_m, n - n_out)]
    out = rng.uniform([-1.5, -1.5, -0.8], [1.5, 1.5, 0.8], (n_out, 3))
    truth = np.r_[np.ones(n - n_out, bool), np.zeros(n_out, bool)]
    return apply(T_cam_plane, np.vstack([inl, out])), truth


def _true_plane(T_cam_plane):
    normal = T_cam_plane[:3, 2]
    offset = -normal @ T_cam_plane[:3, 3]
    return (normal, offset) if offset >= 0 else (-normal, -offset)


@given(rotations(), st.floats(-1, 1), st.floats(-1, 1), st.floats(0.3, 3.0), seeds)
def test_ransac_plane_within_1mm_and_a_tenth_degree_with_30_percent_outliers(R, x, y, distance, seed):
    T_cam_plane = make_transform(R, R @ [x, y, -distance])  # the camera is `distance` above the plane
    points, truth = _noisy_plane(T_cam_plane, np.random.default_rng(seed))
    plane = fit_floor_plane(points, rng=np.random.default_rng(seed + 1))
    assert np.degrees(np.arccos(np.clip(plane.normal @ R[:, 2], -1, 1))) < 0.1
    assert abs(plane.offset - distance) < 1e-3
    assert np.mean(plane.inliers[truth]) > 0.9 and np.mean(plane.inliers[~truth]) < 0.05
    assert plane.rmse_m < 0.006 and plane.n_trials == 500


def test_ransac_is_reproducible_and_seed_dependent_only_through_rng():
    points, _ = _noisy_plane(np.eye(4), np.random.default_rng(3))
    a = fit_floor_plane(points, rng=np.random.default_rng(7))
    b = fit_floor_plane(points, rng=np.random.default_rng(7))
    assert np.array_equal(a.normal, b.normal) and a.offset == b.offset and np.array_equal(a.inliers, b.inliers)


def test_lstsq_plane_matches_exact_plane():
    rng = np.random.default_rng(0)
    T = make_transform(Rotation.from_euler("xyz", [10, -20, 30], degrees=True).as_matrix(), [0.1, 0.2, -2.0])
    points = apply(T, np.c_[rng.uniform(-1, 1, (50, 2)), np.zeros(50)])
    normal, offset = fit_plane_lstsq(points)
    true_normal, true_offset = _true_plane(T)
    np.testing.assert_allclose(normal, true_normal, atol=1e-12)
    assert offset == pytest.approx(true_offset, abs=1e-12)


def test_plane_methods():
    plane = FloorPlane(normal=[0, 0, 1], offset=2.0, inliers=np.ones(3, bool), rmse_m=0.0, n_trials=1)
    np.testing.assert_allclose(plane.signed_distance([[0, 0, -2.0], [1, 1, 1]]), [0.0, 3.0])
    np.testing.assert_allclose(plane.project([1, 2, 3]), [1, 2, -2])
    with pytest.raises(ValueError):
        plane.inliers[0] = False


@pytest.mark.parametrize(
    "points",
    [np.zeros((10, 2)), np.zeros((2, 3)), np.array([[0, 0, 0], [1, 0, 0], [np.nan, 1, 0]])],
)
def test_ransac_rejects_malformed_points(points):
    with pytest.raises(BadInputError):
        fit_floor_plane(points, rng=np.random.default_rng(0))


def test_ransac_rejects_bad_parameters_and_collinear_points():
    points = np.c_[np.linspace(0, 1, 20), np.zeros(20), np.zeros(20)]
    with pytest.raises(CalibrationError):
        fit_floor_plane(points, rng=np.random.default_rng(0))
    with pytest.raises(BadInputError):
        fit_floor_plane(np.eye(3), rng=np.random.default_rng(0), threshold_m=0.0)
    with pytest.raises(BadInputError):
        fit_floor_plane(np.eye(3), rng=np.random.default_rng(0), n_trials=0)


def test_floor_plane_validation():
    with pytest.raises(BadInputError):
        FloorPlane(normal=[0, 0, 2], offset=1.0, inliers=np.ones(3, bool), rmse_m=0.0, n_trials=1)
    with pytest.raises(BadInputError):
        FloorPlane(normal=[0, 0, 1], offset=-1.0, inliers=np.ones(3, bool), rmse_m=0.0, n_trials=1)


@st.composite
def _scene(draw):
    """Camera pose in a truth world (floor z = 0), subject start above the floor, horizontal facing."""
    T_world_cam = draw(transforms(max_translation=3.0))
    start = np.array([draw(st.floats(-2, 2)), draw(st.floats(-2, 2)), draw(st.floats(0.3, 1.5))])
    heading = draw(st.floats(-np.pi, np.pi))
    return T_world_cam, start, np.array([np.cos(heading), np.sin(heading), 0.0])


@given(_scene())
def test_world_from_floor_puts_floor_at_zero_origin_under_start_and_x_along_facing(scene):
    T_world_cam, start_world, facing_world = scene
    T_cam_world = invert(T_world_cam)
    floor_world = np.c_[np.random.default_rng(0).uniform(-2, 2, (20, 2)), np.zeros(20)]
    normal, offset = fit_plane_lstsq(apply(T_cam_world, floor_world))
    plane = FloorPlane(normal=normal, offset=offset, inliers=np.ones(20, bool), rmse_m=0.0, n_trials=0)
    T = world_from_floor(plane, apply(T_cam_world, start_world), rotate(T_cam_world, facing_world))
    np.testing.assert_allclose(apply(T, apply(T_cam_world, floor_world))[:, 2], 0.0, atol=1e-9)
    np.testing.assert_allclose(apply(T, apply(T_cam_world, start_world)), [0, 0, start_world[2]], atol=1e-9)
    np.testing.assert_allclose(rotate(T, rotate(T_cam_world, facing_world)), [1, 0, 0], atol=1e-9)
    # The estimated world is the truth world moved on the floor: its z axis is the truth's.
    np.testing.assert_allclose(rotate(compose(T, T_cam_world), [0, 0, 1]), [0, 0, 1], atol=1e-9)


def test_world_from_floor_default_facing_is_toward_the_camera():
    plane = FloorPlane(normal=[0, 1, 0], offset=1.0, inliers=np.ones(3, bool), rmse_m=0.0, n_trials=0)
    start_cam = np.array([0.5, 0.0, 3.0])  # Kinect axes: floor 1 m below the camera, subject 3 m ahead
    T_world_cam = world_from_floor(plane, start_cam)
    camera_in_world = T_world_cam[:3, 3]
    assert camera_in_world[2] == pytest.approx(1.0)
    assert camera_in_world[1] == pytest.approx(0.0, abs=1e-12) and camera_in_world[0] > 0


def test_world_from_floor_rejects_vertical_facing():
    plane = FloorPlane(normal=[0, 1, 0], offset=1.0, inliers=np.ones(3, bool), rmse_m=0.0, n_trials=0)
    with pytest.raises(BadInputError):
        world_from_floor(plane, [0, 0, 3.0], [0, 2.0, 0])
    with pytest.raises(BadInputError):
        world_from_floor(plane, [0, 0, np.nan])


@given(st.lists(transforms(), min_size=1, max_size=5), transforms())
def test_align_gauge_recovers_a_rigid_gauge(T_list, T_true_est):
    est = {f"cam{i}": T for i, T in enumerate(T_list)}
    true = {name: compose(T_true_est, T) for name, T in est.items()}
    T_found, aligned = align_gauge(est, true)
    angle, dist = transform_difference(T_found, T_true_est)
    assert angle < 1e-6 and dist < 1e-6
    for name in est:
        np.testing.assert_allclose(aligned[name], true[name], atol=1e-6)


@given(st.lists(transforms(), min_size=1, max_size=5), st.floats(-np.pi, np.pi), unit_vectors())
def test_floor_gauge_fits_yaw_and_xy_only(T_list, yaw, shift):
    est = {f"cam{i}": T for i, T in enumerate(T_list)}
    gauge = make_transform(Rotation.from_euler("z", yaw).as_matrix(), shift * [2.0, 2.0, 0.0])
    T_found, aligned = align_gauge(est, {n: compose(gauge, T) for n, T in est.items()}, mode=GaugeMode.FLOOR)
    np.testing.assert_allclose(T_found, gauge, atol=1e-6)
    lifted = make_transform(np.eye(3), [0, 0, 0.5])
    T_found, _ = align_gauge(est, {n: compose(lifted, gauge, T) for n, T in est.items()}, mode=GaugeMode.FLOOR)
    np.testing.assert_allclose(T_found, gauge, atol=1e-6)  # height and tilt are not part of the floor gauge


def test_align_gauge_uses_common_cameras_and_aligns_all():
    rng = np.random.default_rng(0)
    est = {n: make_transform(Rotation.from_rotvec(rng.normal(size=3)).as_matrix(), rng.normal(size=3)) for n in "abc"}
    gauge = make_transform(Rotation.from_rotvec([0.1, 0.2, 0.3]).as_matrix(), [1, 2, 3])
    true = {n: compose(gauge, est[n]) for n in "ab"}
    T_found, aligned = align_gauge(est, true)
    np.testing.assert_allclose(T_found, gauge, atol=1e-9)
    assert set(aligned) == set("abc")
    np.testing.assert_allclose(aligned["c"], compose(gauge, est["c"]), atol=1e-9)
    with pytest.raises(BadInputError):
        align_gauge(est, {"z": np.eye(4)})
    with pytest.raises(BadInputError):
        align_gauge(est, true, mode="rigid")
