"""Merged point clouds, meshes and PLY / GLB export on an analytically rendered scene.

The world has the floor at z = 0, z up. The "body" is a box (legs and trunk) under a sphere (the
head) that moves along +x; three Kinect v2 cameras around it, whose clocks are offset from the
reference clock, ray-cast it in numpy into labelled depth frames with 1 mm noise.
"""

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st

from fusion.calibration import Calibration
from fusion.camera import KINECT_V2_DEPTH
from fusion.depth import DepthStream, Label
from fusion.errors import BadInputError, RecordingError
from fusion.merge.cloud import MergedCloud, OutlierRemoval, merge_clouds
from fusion.merge.mesh import (
    MeshMethod,
    export_glb,
    export_ply,
    load_ply,
    mesh_from_cloud,
)
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, TrackingState
from fusion.transforms import apply, invert
from sim.rig import look_at

K = KINECT_V2_DEPTH
TIMES = np.array([0.0, 0.1, 0.2])  # capture times [s], reference clock
OFFSETS = {"cam1": 0.0, "cam2": 0.3, "cam3": -0.45}  # camera clock minus reference clock [s]
AZIMUTHS = {"cam1": 0.0, "cam2": 120.0, "cam3": 240.0}
SPHERE_R = 0.2
SPEED = 0.6  # of the sphere along +x [m/s]
BOX_LO, BOX_HI = np.array([-0.12, -0.10, 0.0]), np.array([0.12, 0.10, 0.82])
NOISE_M = 0.001


def sphere_centre(t):
    return np.array([SPEED * t, 0.0, 1.0])


def camera_pose(azimuth_deg, distance=2.2, height=1.3):
    """T_world_cam of a Kinect v2 camera (+z forward, +y up, +x left) aimed at the body."""
    a = np.radians(azimuth_deg)
    return look_at(np.array([distance * np.sin(a), -distance * np.cos(a), height]), np.array([0.0, 0.0, 0.8]))


POSES = {name: camera_pose(a) for name, a in AZIMUTHS.items()}


def render(T_world_cam, t, rng):
    """(H, W) uint16 depth [mm] and labels of the scene at time ``t`` seen from ``T_world_cam``."""
    d = K.pixel_rays().reshape(-1, 3) @ T_world_cam[:3, :3].T  # camera z = 1: the ray parameter is depth
    o = T_world_cam[:3, 3]
    oc = o - sphere_centre(t)
    a, b = np.sum(d * d, axis=1), d @ oc
    disc = b * b - a * (oc @ oc - SPHERE_R**2)
    with np.errstate(invalid="ignore", divide="ignore"):
        t_sphere = np.where(disc >= 0, (-b - np.sqrt(disc)) / a, np.inf)
        t1, t2 = (BOX_LO - o) / d, (BOX_HI - o) / d
        near, far = np.minimum(t1, t2).max(axis=1), np.maximum(t1, t2).min(axis=1)
        t_box = np.where((far >= near) & (near > 0), near, np.inf)
        t_floor = np.where(d[:, 2] < 0, -o[2] / d[:, 2], np.inf)
    hits = np.stack([t_sphere, t_box, t_floor])
    z = hits.min(axis=0)
    valid = (z > K.min_depth_m) & (z < K.max_depth_m)
    labels = np.where(hits.argmin(axis=0) == 2, Label.FLOOR, Label.BODY)
    labels = np.where(valid, labels, Label.NONE).astype(np.uint8)
    z = np.where(valid, z + rng.normal(0.0, NOISE_M, z.shape), 0.0)
    shape = (K.height, K.width)
    return np.round(z * 1e3).astype(np.uint16).reshape(shape), labels.reshape(shape)


def joints_world(t):
    """(25, 3) skeleton joints: 12 up the box's axis, 13 up the sphere's vertical axis."""
    box = np.column_stack([np.zeros(12), np.zeros(12), np.linspace(0.05, 0.8, 12)])
    head = sphere_centre(t) + np.column_stack([np.zeros(13), np.zeros(13), np.linspace(-0.15, 0.15, 13)])
    return np.vstack([box, head])


def surface_distance(p, t):
    """(N,) distance [m] of points to the scene's body surface at time ``t``."""
    sphere = np.abs(np.linalg.norm(p - sphere_centre(t), axis=1) - SPHERE_R)
    e = np.maximum(BOX_LO - p, p - BOX_HI)
    box = np.linalg.norm(np.maximum(e, 0.0), axis=1) + np.abs(np.minimum(e.max(axis=1), 0.0))
    return np.minimum(sphere, box)


@pytest.fixture(scope="module")
def frames():
    rng = np.random.default_rng(7)
    return {name: [render(T, t, rng) for t in TIMES] for name, T in POSES.items()}


def make_recording(frames, *, labelled=True, flying_per_frame=0, seed=0):
    """The scene's recording; optionally without labels, or with flying pixels in front of the body."""
    rng = np.random.default_rng(seed)
    cameras = []
    for name, T in POSES.items():
        depth = np.stack([f[0] for f in frames[name]])
        labels = np.stack([f[1] for f in frames[name]])
        for k in range(len(TIMES)):
            body = np.flatnonzero(labels[k] == Label.BODY)
            pick = np.unravel_index(rng.choice(body, flying_per_frame, replace=False), labels[k].shape)
            depth[k][pick] = (depth[k][pick] - rng.uniform(300, 1000, flying_per_frame)).astype(np.uint16)
        stamps = TIMES + OFFSETS[name]
        positions = np.stack([apply(invert(T), joints_world(t)) for t in TIMES])
        skeleton = SkeletonStream(KINECT_V2, stamps, positions, np.full(positions.shape[:2], TrackingState.TRACKED))
        cameras.append(CameraRecording(name, K, skeleton, DepthStream(stamps, depth, labels if labelled else None)))
    return Recording(tuple(cameras))


def make_calibration(names=tuple(POSES)):
    return Calibration({n: POSES[n] for n in names}, {n: K for n in names}, {n: OFFSETS[n] for n in names}, names[0])


@pytest.fixture(scope="module")
def recording(frames):
    return make_recording(frames)


@pytest.fixture(scope="module")
def merged(recording):
    return merge_clouds(recording, make_calibration(), 0.1, rng=np.random.default_rng(0))


def test_merged_points_lie_on_the_true_surface(merged):
    assert merged.camera_names == ("cam1", "cam2", "cam3")
    np.testing.assert_array_equal(merged.frame_index, [1, 1, 1])
    np.testing.assert_allclose(merged.frame_time_s, 0.1, atol=1e-12)
    assert merged.skipped == () and merged.notes == ()
    assert merged.points.shape == (merged.n_points, 3) and merged.n_points > 5000
    d = surface_distance(merged.points, 0.1)
    assert np.median(d) < 0.001 and np.quantile(d, 0.99) < 0.004
    assert np.all(merged.n_selected > 1000) and np.all(merged.points_per_camera > 0)
    assert merged.points_per_camera.sum() == merged.n_points
    assert merged.points[:, 2].min() > -0.005  # the floor is gone


def test_each_point_is_attributed_to_a_camera_that_sees_it(merged):
    for i, name in enumerate(merged.camera_names):
        p_cam = apply(invert(POSES[name]), merged.points[merged.camera_index == i])
        uv, z = K.project(p_cam)
        assert np.all(K.in_image(uv)) and np.all(z > K.min_depth_m)


def test_normals_point_out_of_the_body(merged):
    n = merged.normals
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-9)
    c = sphere_centre(0.1)
    on_head = (np.abs(np.linalg.norm(merged.points - c, axis=1) - SPHERE_R) < 0.003) & (merged.points[:, 2] > 1.0)
    outward = np.einsum("ij,ij->i", n[on_head], merged.points[on_head] - c) > 0
    assert on_head.sum() > 500 and outward.mean() > 0.97


def test_clock_offsets_pick_the_frames_captured_nearest_the_instant(recording):
    cloud = merge_clouds(recording, make_calibration(), 0.17, rng=np.random.default_rng(0), with_normals=False)
    np.testing.assert_array_equal(cloud.frame_index, [2, 2, 2])
    np.testing.assert_allclose(cloud.frame_time_s, 0.2, atol=1e-12)
    assert cloud.normals is None
    assert np.quantile(surface_distance(cloud.points, 0.2), 0.99) < 0.004


def test_a_wrong_clock_offset_leaves_the_camera_out(recording):
    calibration = make_calibration()
    calibration.clock_offset_s["cam2"] = -0.3
    cloud = merge_clouds(recording, calibration, 0.1, rng=np.random.default_rng(0))
    assert cloud.camera_names == ("cam1", "cam3") and cloud.skipped == ("cam2",)
    assert "cam2: no depth frame within 0.05 s" in cloud.notes[0] and "[0.600, 0.800] s" in cloud.notes[0]


def _max_per_cell(points, size, origin):
    cells = np.floor((points - origin) / size).astype(np.int64)
    return np.unique(cells, axis=0, return_counts=True)[1].max()


@settings(max_examples=6)
@given(voxel_m=st.floats(0.008, 0.05), shift=st.floats(0.0, 1.0))
def test_voxel_size_is_respected(recording, voxel_m, shift):
    cloud = merge_clouds(recording, make_calibration(), 0.1, rng=np.random.default_rng(0), voxel_m=voxel_m,
                         outlier=OutlierRemoval.NONE, with_normals=False)
    # One point (a mean) inside each voxel of a grid of this size: any such grid has at most 8 per cell.
    assert _max_per_cell(cloud.points, voxel_m, shift * voxel_m) <= 8
    assert cloud.n_points < cloud.n_selected.sum()
    assert np.quantile(surface_distance(cloud.points, 0.1), 0.95) < max(0.004, voxel_m / 4)


def test_coarser_voxels_give_fewer_points_as_on_a_surface(recording):
    counts = [merge_clouds(recording, make_calibration(), 0.1, rng=np.random.default_rng(0), voxel_m=v,
                           outlier=OutlierRemoval.NONE, with_normals=False).n_points for v in (0.01, 0.02)]
    assert 3.0 < counts[0] / counts[1] < 5.0


@pytest.mark.parametrize("outlier", [OutlierRemoval.STATISTICAL, OutlierRemoval.RADIUS])
def test_outlier_removal_removes_flying_pixels(frames, outlier):
    noisy = make_recording(frames, flying_per_frame=40)
    calibration = make_calibration()
    raw = merge_clouds(noisy, calibration, 0.1, rng=np.random.default_rng(0), outlier=OutlierRemoval.NONE)
    assert np.count_nonzero(surface_distance(raw.points, 0.1) > 0.1) > 100
    assert raw.n_outliers == 0
    clean = merge_clouds(noisy, calibration, 0.1, rng=np.random.default_rng(0), outlier=outlier)
    assert surface_distance(clean.points, 0.1).max() < 0.02
    assert 100 < clean.n_outliers < 0.1 * raw.n_points
    assert clean.n_points + clean.n_outliers == raw.n_points


def test_without_labels_the_skeleton_finds_the_body(frames, merged):
    unlabelled = make_recording(frames, labelled=False)
    cloud = merge_clouds(unlabelled, make_calibration(), 0.1, rng=np.random.default_rng(3))
    assert cloud.n_points > 0.8 * merged.n_points
    assert np.quantile(surface_distance(cloud.points, 0.1), 0.99) < 0.004
    assert cloud.points[:, 2].min() > 0.02
    again = merge_clouds(unlabelled, make_calibration(), 0.1, rng=np.random.default_rng(3))
    np.testing.assert_array_equal(cloud.points, again.points)
    np.testing.assert_array_equal(cloud.camera_index, again.camera_index)


def test_without_labels_or_skeleton_a_camera_is_skipped(frames):
    rec = make_recording(frames, labelled=False)
    cams = (CameraRecording("cam1", K, None, rec.camera("cam1").depth),) + rec.cameras[1:]
    cloud = merge_clouds(Recording(cams), make_calibration(), 0.1, rng=np.random.default_rng(0))
    assert cloud.camera_names == ("cam2", "cam3") and cloud.skipped == ("cam1",)
    assert "no skeleton" in cloud.notes[0]


def test_body_only_false_keeps_the_floor(recording):
    cloud = merge_clouds(recording, make_calibration(), 0.1, rng=np.random.default_rng(0), body_only=False,
                         voxel_m=0.03, outlier=OutlierRemoval.NONE, with_normals=False)
    assert np.count_nonzero(np.abs(cloud.points[:, 2]) < 0.005) > 1000


def test_cameras_missing_from_the_calibration_or_without_depth_are_skipped(recording):
    cams = recording.cameras[:2] + (CameraRecording("cam4", K),)
    cloud = merge_clouds(Recording(cams), make_calibration(("cam1", "cam3")), 0.1, rng=np.random.default_rng(0))
    assert cloud.camera_names == ("cam1",) and cloud.skipped == ("cam2", "cam4")
    assert "cam2: not in the calibration (calibrated: cam1, cam3)" == cloud.notes[0]
    assert "cam4: no depth frames" == cloud.notes[1]


def test_no_frame_near_the_instant_is_a_clear_error(recording):
    with pytest.raises(BadInputError, match=r"no camera has a calibrated depth frame within 0.05 s of 5.000 s") as e:
        merge_clouds(recording, make_calibration(), 5.0, rng=np.random.default_rng(0))
    for name in ("cam1", "cam2", "cam3"):
        assert name in str(e.value)
    assert "[0.000, 0.200] s" in str(e.value)
    with pytest.raises(BadInputError, match="not in the calibration"):
        merge_clouds(Recording(recording.cameras[1:]), make_calibration(("cam1",)), 0.1, rng=np.random.default_rng(0))


def test_no_body_in_view_gives_an_empty_cloud(recording, tmp_path):
    cams = tuple(CameraRecording(c.name, K, c.skeleton, DepthStream(c.depth.timestamps, c.depth.depth_mm,
                                                                   np.zeros_like(c.depth.labels)))
                 for c in recording.cameras)
    cloud = merge_clouds(Recording(cams), make_calibration(), 0.1, rng=np.random.default_rng(0))
    assert cloud.n_points == 0 and cloud.points.shape == (0, 3) and cloud.normals.shape == (0, 3)
    assert cloud.camera_names == ("cam1", "cam2", "cam3")
    np.testing.assert_array_equal(cloud.n_selected, [0, 0, 0])
    np.testing.assert_array_equal(cloud.points_per_camera, [0, 0, 0])
    with pytest.raises(BadInputError, match="no points"):
        export_ply(cloud, tmp_path / "empty.ply")
    with pytest.raises(BadInputError, match="at least 10 points"):
        mesh_from_cloud(cloud)


@pytest.mark.parametrize("kwargs", [
    dict(time_s=np.nan), dict(tolerance_s=0.0), dict(voxel_m=-0.01), dict(body_radius_m=np.inf),
    dict(floor_clearance_m=-0.1), dict(outlier="statistical"), dict(outlier_neighbours=0),
    dict(outlier_std_ratio=0.0), dict(outlier_radius_m=np.nan),
])
def test_bad_parameters_are_rejected(recording, kwargs):
    args = dict(time_s=0.1) | kwargs
    with pytest.raises(BadInputError):
        merge_clouds(recording, make_calibration(), rng=np.random.default_rng(0), **args)


def test_ply_round_trip(merged, tmp_path):
    path = export_ply(merged, tmp_path / "out" / "cloud.ply")
    assert sorted(p.name for p in path.parent.iterdir()) == ["cloud.ply"]  # no temporary file left
    np.testing.assert_array_equal(load_ply(path), merged.points)
    header = path.read_bytes()[:400]
    assert b"property double nx" in header and b"property int camera" in header


def test_load_ply_errors(tmp_path):
    with pytest.raises(RecordingError, match="does not exist"):
        load_ply(tmp_path / "missing.ply")
    (tmp_path / "text.ply").write_text("hello")
    with pytest.raises(RecordingError, match="not a PLY file"):
        load_ply(tmp_path / "text.ply")
    (tmp_path / "cut.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 100\n"
                                       b"property double x\nproperty double y\nproperty double z\nend_header\nabc")
    with pytest.raises(RecordingError, match="truncated or corrupt"):
        load_ply(tmp_path / "cut.ply")


def test_glb_round_trip_of_cloud_and_mesh(merged, tmp_path):
    scene = trimesh.load(export_glb(merged, tmp_path / "cloud.glb"))
    (points,) = scene.geometry.values()
    assert isinstance(points, trimesh.PointCloud) and len(points.vertices) == merged.n_points
    x, y, z = merged.points.T  # world z up; glTF y up: (X, Y, Z) = (x, z, -y)
    yup = np.stack([x, z, -y], axis=1)
    np.testing.assert_allclose(points.bounds, [yup.min(axis=0), yup.max(axis=0)], atol=1e-6)
    np.testing.assert_allclose(np.ptp(points.vertices[:, 1]), np.ptp(z), atol=1e-6)  # height along Y
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=0.3)
    (loaded,) = trimesh.load(export_glb(mesh, tmp_path / "mesh.glb")).geometry.values()
    assert len(loaded.faces) == len(mesh.faces)
    np.testing.assert_allclose(loaded.bounds, mesh.bounds, atol=1e-6)
    with pytest.raises(BadInputError, match="MergedCloud or a trimesh.Trimesh"):
        export_glb(merged.points, tmp_path / "bad.glb")


def sphere_cloud(n=4000, radius=0.25):
    """A merged cloud of ``n`` evenly spread points on a sphere about the origin, outward normals."""
    i = np.arange(n) + 0.5
    polar, azimuth = np.arccos(1 - 2 * i / n), np.pi * (1 + 5**0.5) * i
    normals = np.column_stack([np.cos(azimuth) * np.sin(polar), np.sin(azimuth) * np.sin(polar), np.cos(polar)])
    return MergedCloud(points=radius * normals, camera_index=np.zeros(n, np.int64), camera_names=("synthetic",),
                       frame_index=[0], frame_time_s=[0.0], n_selected=[n], time_s=0.0, normals=normals)


def test_poisson_mesh_of_a_sphere():
    cloud = sphere_cloud()
    closed = mesh_from_cloud(cloud, trim_quantile=0.0)
    assert closed.is_watertight
    assert np.abs(np.linalg.norm(closed.vertices, axis=1) - 0.25).max() < 0.002
    assert closed.volume == pytest.approx(4 / 3 * np.pi * 0.25**3, rel=0.02)
    trimmed = mesh_from_cloud(cloud)
    assert 0.9 * len(closed.vertices) < len(trimmed.vertices) < len(closed.vertices)


def test_ball_pivoting_mesh_of_a_sphere():
    mesh = mesh_from_cloud(sphere_cloud(), method=MeshMethod.BALL_PIVOTING)
    np.testing.assert_allclose(np.linalg.norm(mesh.vertices, axis=1), 0.25, atol=1e-9)
    assert mesh.area == pytest.approx(4 * np.pi * 0.25**2, rel=0.02)


def test_poisson_mesh_of_the_merged_body_stays_on_it(merged):
    mesh = mesh_from_cloud(merged, depth=7, trim_quantile=0.1)
    assert len(mesh.faces) > 1000
    assert np.median(surface_distance(mesh.vertices, 0.1)) < 0.005


def test_mesh_bad_input():
    cloud = sphere_cloud()
    with pytest.raises(BadInputError, match="MeshMethod"):
        mesh_from_cloud(cloud, method="poisson")
    with pytest.raises(BadInputError, match="no normals"):
        mesh_from_cloud(MergedCloud(cloud.points, cloud.camera_index, cloud.camera_names, [0], [0.0], [4000], 0.0))
    with pytest.raises(BadInputError, match="trim_quantile"):
        mesh_from_cloud(cloud, trim_quantile=1.0)
    with pytest.raises(BadInputError, match="ball_radii_m"):
        mesh_from_cloud(cloud, method=MeshMethod.BALL_PIVOTING, ball_radii_m=[])


@pytest.mark.parametrize("change, match", [
    (dict(points=np.full((3, 3), np.nan)), "points"),
    (dict(camera_index=np.zeros(2, np.int64)), "camera_index"),
    (dict(camera_index=np.array([0, 1, 0])), "camera_index must lie"),
    (dict(frame_time_s=[0.0, 1.0]), "frame_time_s"),
    (dict(normals=np.zeros((2, 3))), "normals"),
    (dict(camera_names=("a", "a")), "unique"),
])
def test_merged_cloud_is_validated(change, match):
    fields = dict(points=np.zeros((3, 3)), camera_index=np.zeros(3, np.int64), camera_names=("a",), frame_index=[0],
                  frame_time_s=[0.0], n_selected=[3], time_s=0.0)
    with pytest.raises(BadInputError, match=match):
        MergedCloud(**(fields | change))
