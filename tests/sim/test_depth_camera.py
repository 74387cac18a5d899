"""Render-then-measure tests of the ray caster and the virtual depth camera.

Oracles are closed forms: ray-sphere and ray-plane intersections, the intrinsics' projection and
Fankhauser's sigma. Scenes are the small MjSpec worlds of :mod:`sim.scenes` (spheres, box walls, a
floor plane), which carry those closed forms; one test renders the humanoid.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fusion.depth import Label, depth_to_points
from fusion.errors import BadInputError
from fusion.transforms import apply, invert, make_transform
from sim.depth_camera import DepthCamera, DepthRender
from sim.depth_noise import KINECT_V2_OFFSET_MM, DepthNoise, sigma_axial_mm
from sim.raycast import RayHits, cast_rays
from sim.rig import CameraPlacement, look_at
from sim.scenes import Sphere, Wall, compile_scene, pixel_rays_world

BODY_ONLY = (False, True, False, False, False, False)
IDEAL = DepthNoise.none()


def _edges(z: np.ndarray, noise: DepthNoise) -> np.ndarray:
    """(H, W) bool: a 4-neighbour's depth differs by more than max(edge_jump_min_m, edge_jump_rel * z)."""
    p = np.pad(z, 1, constant_values=np.nan)
    nbs = np.stack([p[:-2, 1:-1], p[2:, 1:-1], p[1:-1, :-2], p[1:-1, 2:]])
    with np.errstate(invalid="ignore"):
        return np.any(np.abs(nbs - z) > np.maximum(noise.edge_jump_min_m, noise.edge_jump_rel * z), axis=0)


# A camera 1.5 m above the floor looking along +x, and a sphere off-centre in its view.
CAM = CameraPlacement("cam", look_at([0.0, 0.0, 1.5], [1.0, 0.0, 1.5]))
SPHERE_C, SPHERE_R = np.array([2.5, 0.4, 1.2]), 0.2
SPHERE = Sphere(SPHERE_C, SPHERE_R)
FLOORLESS_CAM = DepthCamera(CAM, IDEAL, floor=False)


@pytest.fixture(scope="module")
def sphere_scene():
    return compile_scene(SPHERE)


@pytest.fixture(scope="module")
def ideal_cam():
    return DepthCamera(CAM, IDEAL)


# --- sigma and DepthNoise -------------------------------------------------------------------------


def test_sigma_axial_reproduces_published_values():
    z = np.array([1.0, 2.5, 4.0, 2.5, 2.5])
    theta = np.radians([0.0, 0.0, 0.0, 75.0, 80.0])
    np.testing.assert_allclose(sigma_axial_mm(z, theta, DepthNoise()), [1.3, 2.125, 4.3, 12.0, 27.4], atol=0.05)
    assert sigma_axial_mm(2.0, np.pi / 2, DepthNoise()) == np.inf
    assert np.isnan(sigma_axial_mm(np.nan, 0.0, DepthNoise()))
    assert np.all(sigma_axial_mm(z, theta, IDEAL) == 0)


@pytest.mark.parametrize("z, theta", [(-1.0, 0.0), (1.0, -0.1), (1.0, 2.0), (np.inf, 0.0), (np.ones(3), np.ones(2))])
def test_sigma_axial_rejects_bad_input(z, theta):
    with pytest.raises(BadInputError):
        sigma_axial_mm(z, theta, DepthNoise())


@pytest.mark.parametrize(
    "kwargs",
    [
        dict(lateral_sigma_px=-1.0),
        dict(flying_prob=1.5),
        dict(flying_spread=-0.1),
        dict(edge_jump_min_m=-0.02),
        dict(grazing_start_deg=86.0),
        dict(grazing_end_deg=95.0),
        dict(axial_c0_mm=-1.0),
        dict(axial_c0_mm=1.0, axial_c1_mm_per_m=-3.0),  # sigma < 0 near z = 5 m
        dict(offset_mm=np.nan),
        dict(flying_prob="0.5"),
    ],
)
def test_depth_noise_rejects_bad_parameters(kwargs):
    with pytest.raises(BadInputError):
        DepthNoise(**kwargs)


def test_ideal_noise_switches_everything_off():
    n = DepthNoise.none()
    assert n.lateral_sigma_px == n.flying_prob == n.offset_mm == 0
    assert n.grazing_drop_prob(np.radians(89.9)) == 0
    assert np.isnan(n.grazing_drop_prob(np.nan))


# --- cast_rays ------------------------------------------------------------------------------------


def test_cast_rays_matches_closed_form_sphere():
    centre, radius = np.array([2.0, 0.3, 1.0]), 0.3
    model, data = compile_scene(Sphere(centre, radius))
    origin = np.array([0.0, 0.0, 1.0])
    angles = np.radians(np.linspace(-20, 20, 81))
    dirs = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
    hits = cast_rays(model, data, origin, dirs, geomgroup=BODY_ONLY, cutoff_m=np.inf)

    oc = centre - origin
    b = dirs @ oc
    disc = b**2 - (oc @ oc - radius**2)
    inside = disc > 1e-9
    assert inside.sum() > 10 and (~inside).sum() > 10
    np.testing.assert_allclose(hits.dist[inside], b[inside] - np.sqrt(disc[inside]), atol=1e-9)
    p = origin + hits.dist[inside, None] * dirs[inside]
    np.testing.assert_allclose(hits.normal_world[inside], (p - centre) / radius, atol=1e-6)
    assert np.all(hits.geom_id[inside] == 1) and np.all(hits.hit == (hits.geom_id >= 0))
    far = disc < -1e-9
    assert np.all(np.isinf(hits.dist[far])) and np.all(hits.geom_id[far] == -1)
    assert np.all(np.isnan(hits.normal_world[far]))


def test_cast_rays_respects_groups_and_cutoff():
    model, data = compile_scene(Sphere([2.0, 0.0, 1.0], 0.3))
    origin, down_forward = np.array([0.0, 0.0, 1.0]), np.array([[1.0, 0.0, 0.0], [0.6, 0.0, -0.8]])
    everything = cast_rays(model, data, origin, down_forward, geomgroup=None, cutoff_m=np.inf)
    assert list(everything.geom_id) == [1, 0]  # the sphere, then the floor plane
    np.testing.assert_allclose(everything.dist, [1.7, 1.25])
    body = cast_rays(model, data, origin, down_forward, geomgroup=BODY_ONLY, cutoff_m=np.inf)
    assert list(body.geom_id) == [1, -1]
    near = cast_rays(model, data, origin, down_forward, geomgroup=None, cutoff_m=1.5)
    assert list(near.geom_id) == [-1, 0]
    assert cast_rays(model, data, origin, np.empty((0, 3)), geomgroup=None, cutoff_m=1.0).dist.shape == (0,)


@pytest.mark.parametrize(
    "origin, dirs, kwargs",
    [
        (np.zeros(2), np.eye(3), {}),
        (np.array([0, 0, np.nan]), np.eye(3), {}),
        (np.zeros(3), np.eye(3)[:, :2], {}),
        (np.zeros(3), 2 * np.eye(3), {}),
        (np.zeros(3), np.full((1, 3), np.nan), {}),
        (np.zeros(3), np.eye(3), dict(geomgroup=(1, 1, 1))),
        (np.zeros(3), np.eye(3), dict(geomgroup=(2, 0, 0, 0, 0, 0))),
        (np.zeros(3), np.eye(3), dict(cutoff_m=0.0)),
        (np.zeros(3), np.eye(3), dict(cutoff_m=np.nan)),
    ],
)
def test_cast_rays_rejects_bad_input(origin, dirs, kwargs):
    model, data = compile_scene(Sphere([2.0, 0.0, 1.0], 0.3))
    args = dict(geomgroup=None, cutoff_m=10.0) | kwargs
    with pytest.raises(BadInputError):
        cast_rays(model, data, origin, dirs, **args)


def test_cast_rays_rejects_data_of_another_model():
    model, _ = compile_scene(Sphere([2.0, 0.0, 1.0], 0.3))
    _, other_data = compile_scene(Sphere([2.0, 0.0, 1.0], 0.3), Sphere([3.0, 0.0, 1.0], 0.3))
    with pytest.raises(BadInputError):
        cast_rays(model, other_data, np.zeros(3), np.eye(3), geomgroup=None, cutoff_m=10.0)


def test_ray_hits_validates():
    with pytest.raises(BadInputError):
        RayHits(np.array([1.0]), np.array([-1]), np.zeros((1, 3)))
    with pytest.raises(BadInputError):
        RayHits(np.zeros(2), np.zeros(2), np.zeros((3, 3)))


# --- geometry of the ideal sensor -----------------------------------------------------------------


def test_sphere_lands_where_the_intrinsics_predict(sphere_scene, ideal_cam):
    r = ideal_cam.render(*sphere_scene, rng=np.random.default_rng(0))
    assert r.depth_mm.shape == (424, 512) and r.depth_mm.dtype == np.uint16 and r.labels.dtype == np.uint8
    uv, z = CAM.intrinsics.project(apply(invert(CAM.T_world_cam), SPHERE_C))
    v, u = np.nonzero(r.labels == Label.BODY)
    np.testing.assert_allclose([u.mean(), v.mean()], uv, atol=0.5)
    np.testing.assert_allclose([u.mean(), v.mean()], SPHERE.image_centre(CAM), atol=0.1)  # perspective-exact
    assert abs(r.depth_mm[v, u].min() - 1e3 * (z - SPHERE_R)) <= 1.0

    z_true, rim = SPHERE.depth(CAM)
    clear = np.abs(rim) > 1e-4  # pixel centres not straddling the silhouette
    np.testing.assert_array_equal((r.labels == Label.BODY)[clear], (rim < 0)[clear])
    body = r.labels == Label.BODY
    assert np.max(np.abs(r.depth_mm[body] - 1e3 * z_true[body])) <= 0.5 + 1e-6
    np.testing.assert_allclose(r.depth_ideal_m[body], z_true[body], atol=1e-9)


@given(
    dist=st.floats(0.8, 4.2),
    az=st.floats(-30.0, 30.0),
    el=st.floats(-25.0, 25.0),
    radius=st.floats(0.03, 0.3),
)
def test_any_sphere_in_view_has_closed_form_depth(dist, az, el, radius):
    a, e = np.radians(az), np.radians(el)
    centre = CAM.position + dist * np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    model, data = compile_scene(Sphere(centre, radius), floor=False)
    r = FLOORLESS_CAM.render(model, data, rng=np.random.default_rng(0))
    z_true, rim = Sphere(centre, radius).depth(CAM)
    clear = np.abs(rim) > 1e-4
    in_range = (z_true >= 0.5) & (z_true <= 4.5)
    np.testing.assert_array_equal((r.depth_mm > 0)[clear], ((rim < 0) & in_range)[clear])
    seen = r.depth_mm > 0
    assert np.max(np.abs(r.depth_mm[seen] - 1e3 * z_true[seen]), initial=0) <= 0.5 + 1e-6


def test_floor_and_sphere_are_labelled(sphere_scene, ideal_cam):
    r = ideal_cam.render(*sphere_scene, rng=np.random.default_rng(0))
    uv, _ = CAM.intrinsics.project(apply(invert(CAM.T_world_cam), SPHERE_C))
    assert r.labels[round(uv[1]), round(uv[0])] == Label.BODY
    # floor: closed-form ray-plane depth for every in-range floor pixel outside the sphere
    d = pixel_rays_world(CAM)
    with np.errstate(divide="ignore"):
        z_floor = np.where(d[..., 2] < 0, -CAM.position[2] / d[..., 2], np.nan)
    z_sphere, _ = SPHERE.depth(CAM)
    floor = (z_floor >= 0.5) & (z_floor <= 4.5) & np.isnan(z_sphere)
    assert floor.sum() > 30000
    assert np.all(r.labels[floor] == Label.FLOOR)
    assert np.max(np.abs(r.depth_mm[floor] - 1e3 * z_floor[floor])) <= 0.5 + 1e-6
    assert np.all(r.labels[0] == Label.NONE) and np.all(r.depth_mm[0] == 0)  # above the horizon
    assert set(np.unique(r.labels)) == {Label.NONE, Label.BODY, Label.FLOOR}
    assert np.all((r.labels == Label.NONE) == (r.depth_mm == 0))


def test_backprojected_sphere_pixels_lie_on_the_sphere(sphere_scene, ideal_cam):
    r = ideal_cam.render(*sphere_scene, rng=np.random.default_rng(0))
    points, labels = depth_to_points(r.depth_mm, CAM.intrinsics, r.labels)
    p_world = apply(CAM.T_world_cam, points[labels == Label.BODY])
    assert len(p_world) > 500
    assert np.max(np.abs(np.linalg.norm(p_world - SPHERE_C, axis=1) - SPHERE_R)) <= 2e-3


def test_offset_shifts_every_depth(sphere_scene):
    noise = dataclasses.replace(IDEAL, offset_mm=KINECT_V2_OFFSET_MM)
    r = DepthCamera(CAM, noise).render(*sphere_scene, rng=np.random.default_rng(0))
    seen = r.depth_mm > 0
    np.testing.assert_allclose(r.depth_mm[seen], np.rint(1e3 * r.depth_ideal_m[seen] - 18.0), atol=1.0 + 1e-9)
    assert np.mean(r.depth_mm[seen] - 1e3 * r.depth_ideal_m[seen]) == pytest.approx(-18.0, abs=0.1)


# --- noise ----------------------------------------------------------------------------------------

WALL_CAM = CameraPlacement("wall", look_at([0.0, 0.0, 1.5], [1.0, 0.0, 1.5]))
CENTRE_ROWS, CENTRE_COLS = slice(112, 313), slice(246, 267)  # 201 x 21 px; tilt varies theta along columns


def _wall(dist: float, tilt_deg: float) -> Wall:
    """A wall ``dist`` metres in front of WALL_CAM, turned ``tilt_deg`` about the vertical."""
    return Wall([dist, 0.0, 1.5], tilt_deg)


@pytest.mark.parametrize("dist, tilt_deg", [(1.0, 0.0), (2.5, 0.0), (4.0, 0.0), (2.5, 60.0), (2.5, 75.0)])
def test_wall_depth_noise_follows_fankhauser(dist, tilt_deg):
    """Residual std over the central window within 15 % of the model's.

    Depth is rounded to whole mm, which adds a variance of 1/12 mm^2 (Sheppard; sigma >= 1.3 mm here,
    far above the 1 mm step), so the measured std is compared with sqrt(mean(sigma^2) + 1/12). The
    default noise is on, lateral jitter included: on a plane it must not add depth noise.
    """
    model, data = compile_scene(_wall(dist, tilt_deg))
    z, theta = _wall(dist, tilt_deg).depth(WALL_CAM)
    cam = DepthCamera(WALL_CAM, DepthNoise())
    rng = np.random.default_rng(7)
    residuals = []
    for _ in range(3):
        r = cam.render(model, data, rng=rng)
        win = r.depth_mm[CENTRE_ROWS, CENTRE_COLS].astype(float)
        assert np.all(win > 0) and np.all(r.labels[CENTRE_ROWS, CENTRE_COLS] == Label.BODY)
        residuals.append(win - 1e3 * z[CENTRE_ROWS, CENTRE_COLS])
    residuals = np.concatenate(residuals).ravel()
    sigma = sigma_axial_mm(z[CENTRE_ROWS, CENTRE_COLS], theta[CENTRE_ROWS, CENTRE_COLS], DepthNoise())
    expected = np.sqrt(np.mean(sigma**2) + 1 / 12)
    assert residuals.std() == pytest.approx(expected, rel=0.15)
    assert abs(residuals.mean()) < 0.1 * expected


@pytest.mark.parametrize("tilt_deg, dropped", [(70.0, (0.0, 0.0)), (82.5, (0.35, 0.65)), (87.0, (1.0, 1.0))])
def test_grazing_incidence_drops_returns(tilt_deg, dropped):
    """Over the window's pixels that see the wall: at 87 degrees a few see the floor beside its edge, and
    those can return as flying pixels pulled from the far floor towards the wall."""
    model, data = compile_scene(_wall(2.5, tilt_deg))
    r = DepthCamera(WALL_CAM, DepthNoise()).render(model, data, rng=np.random.default_rng(3))
    floor = DepthCamera(WALL_CAM, DepthNoise.none()).render(*compile_scene(), rng=np.random.default_rng(0))
    wall = ~np.isclose(r.depth_ideal_m, floor.depth_ideal_m)[CENTRE_ROWS, CENTRE_COLS]
    assert wall.mean() > 0.98
    frac = np.mean(r.depth_mm[CENTRE_ROWS, CENTRE_COLS][wall] == 0)
    assert dropped[0] <= frac <= dropped[1]


def test_hard_grazing_threshold():
    noise = dataclasses.replace(IDEAL, grazing_start_deg=80.0, grazing_end_deg=80.0)
    _, theta = _wall(2.5, 80.0).depth(WALL_CAM)
    model, data = compile_scene(_wall(2.5, 80.0))
    r = DepthCamera(WALL_CAM, noise).render(model, data, rng=np.random.default_rng(0))
    win = (slice(112, 313), slice(150, 360))
    np.testing.assert_array_equal(r.depth_mm[win] == 0, theta[win] > np.radians(80.0))
    assert 0 < np.mean(r.depth_mm[win] == 0) < 1


def test_returns_outside_the_depth_range_are_missing():
    near = np.array([0.35, 0.0, 1.5])
    model, data = compile_scene(Sphere(near, 0.05), _wall(5.0, 0.0))
    for noise in (IDEAL, DepthNoise()):
        r = DepthCamera(WALL_CAM, noise).render(model, data, rng=np.random.default_rng(1))
        uv, _ = WALL_CAM.intrinsics.project(apply(invert(WALL_CAM.T_world_cam), near))
        assert r.depth_ideal_m[round(uv[1]), round(uv[0])] == pytest.approx(0.30, abs=1e-3)
        assert r.depth_mm[round(uv[1]), round(uv[0])] == 0
        assert np.all(r.depth_mm[:150] == 0)  # the wall at 5 m, above the floor
        seen = r.depth_mm[r.depth_mm > 0]
        assert seen.size > 10000 and seen.min() >= 500 and seen.max() <= 4500  # near floor in range, far floor not


def test_flying_pixels_only_at_depth_edges():
    noise = dataclasses.replace(DepthNoise(), flying_prob=1.0)
    model, data = compile_scene(Sphere([2.0, 0.0, 1.5], 0.3), _wall(3.5, 0.0))
    r = DepthCamera(WALL_CAM, noise).render(model, data, rng=np.random.default_rng(5))
    seen = r.depth_mm > 0
    sigma = sigma_axial_mm(r.depth_ideal_m[seen], np.minimum(r.incidence_rad[seen], np.pi / 2 - 1e-6), noise)
    outlier = np.zeros_like(seen)
    outlier[seen] = np.abs(r.depth_mm[seen] - 1e3 * r.depth_ideal_m[seen]) > 6 * sigma + 1
    edges = _edges(r.depth_ideal_m, noise)
    assert outlier.sum() > 100
    assert not np.any(outlier & ~edges)
    assert outlier.sum() > 0.8 * (edges & seen).sum()
    # each flying depth lies between foreground (sphere, nearest 1.7 m) and background (wall, 3.5 m)
    # up to the pixel's own axial noise (6 sigma; 10 mm sigma on the sphere's grazing rim)
    six_sigma = np.zeros(seen.shape)
    six_sigma[seen] = 6 * sigma
    assert np.all((r.depth_mm[outlier] > 1700 - six_sigma[outlier]) & (r.depth_mm[outlier] < 3500 + six_sigma[outlier]))

    no_flying = dataclasses.replace(noise, flying_prob=0.0)
    quiet = DepthCamera(WALL_CAM, no_flying).render(model, data, rng=np.random.default_rng(5))
    seen = quiet.depth_mm > 0
    sigma = sigma_axial_mm(quiet.depth_ideal_m[seen], np.minimum(quiet.incidence_rad[seen], np.pi / 2 - 1e-6), noise)
    assert np.all(np.abs(quiet.depth_mm[seen] - 1e3 * quiet.depth_ideal_m[seen]) <= 6 * sigma + 1)


def test_lateral_noise_frays_silhouettes_only(sphere_scene):
    noise = dataclasses.replace(IDEAL, lateral_sigma_px=1.6)
    r = DepthCamera(CAM, noise).render(*sphere_scene, rng=np.random.default_rng(2))
    _, rim = SPHERE.depth(CAM)
    changed = (r.labels == Label.BODY) != (rim < 0)
    assert changed.sum() > 50
    # the jitter's length is clipped at 4 sigma: no pixel further than that from the true rim changes
    assert np.max(np.abs(rim[changed])) * CAM.intrinsics.fx <= 4 * 1.6 + 0.1


def test_same_seed_same_frame_other_seed_other_frame(sphere_scene):
    cam = DepthCamera(CAM, DepthNoise())
    a = cam.render(*sphere_scene, rng=np.random.default_rng(11))
    b = cam.render(*sphere_scene, rng=np.random.default_rng(11))
    c = cam.render(*sphere_scene, rng=np.random.default_rng(12))
    assert np.array_equal(a.depth_mm, b.depth_mm) and np.array_equal(a.labels, b.labels)
    assert np.array_equal(a.depth_ideal_m, b.depth_ideal_m, equal_nan=True)
    assert not np.array_equal(a.depth_mm, c.depth_mm)


# --- bad input ------------------------------------------------------------------------------------


def _free_sphere() -> tuple[mujoco.MjModel, mujoco.MjData]:
    spec = mujoco.MjSpec()
    body = spec.worldbody.add_body(pos=[2.0, 0.0, 1.5])
    body.add_freejoint()
    body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.2, 0, 0], group=1)
    model = spec.compile()
    return model, mujoco.MjData(model)


def test_nan_pose_is_rejected():
    model, data = _free_sphere()
    data.qpos[:] = np.nan
    mujoco.mj_kinematics(model, data)
    with pytest.raises(BadInputError, match="NaN"):
        DepthCamera(WALL_CAM).render(model, data, rng=np.random.default_rng(0))


def test_missing_kinematics_is_rejected():
    model, data = _free_sphere()  # mj_kinematics never ran: geom orientations are all zero
    with pytest.raises(BadInputError, match="mj_kinematics"):
        DepthCamera(WALL_CAM).render(model, data, rng=np.random.default_rng(0))


def test_bad_render_arguments_are_rejected(sphere_scene):
    model, data = sphere_scene
    _, other_data = _free_sphere()
    cam = DepthCamera(CAM)
    with pytest.raises(BadInputError):
        cam.render(model, other_data, rng=np.random.default_rng(0))
    with pytest.raises(BadInputError):
        cam.render(model, data, rng=np.random.RandomState(0))
    with pytest.raises(BadInputError):
        DepthCamera(CAM.T_world_cam)
    with pytest.raises(BadInputError):
        DepthCamera(CAM, body_group=6)
    with pytest.raises(BadInputError):
        CameraPlacement("nan", make_transform(np.eye(3), [np.nan, 0.0, 1.0]))


def test_depth_render_validates_shapes():
    z = np.zeros((4, 5))
    with pytest.raises(BadInputError):
        DepthRender(np.zeros((4, 5), np.float32), np.zeros((4, 5), np.uint8), z, z)
    with pytest.raises(BadInputError):
        DepthRender(np.zeros((4, 5), np.uint16), np.zeros((5, 4), np.uint8), z, z)
    with pytest.raises(BadInputError):
        DepthRender(np.zeros((4, 5), np.uint16), np.zeros((4, 5), np.uint8), z, np.zeros(3))


# --- the humanoid ---------------------------------------------------------------------------------


def test_humanoid_seen_from_a_ring_camera():
    from sim.anthropometry import Anthropometry
    from sim.coordinates import COORDINATES
    from sim.humanoid_model import BODY_GEOM_GROUP, build_humanoid
    from sim.rig import ring_rig

    human = build_humanoid(Anthropometry(height_m=1.75))
    human.set_pose(np.zeros(len(COORDINATES)))
    placement = ring_rig(4, radius_m=2.5, height_m=1.0).cameras[0]
    r = DepthCamera(placement, body_group=BODY_GEOM_GROUP).render(human.model, human.data, rng=np.random.default_rng(0))
    body = r.labels == Label.BODY
    assert body.sum() > 5000 and (r.labels == Label.FLOOR).sum() > 20000
    z = r.depth_mm[body] * 1e-3
    assert np.median(z) == pytest.approx(2.4, abs=0.15) and np.mean(np.abs(z - 2.4) < 0.5) > 0.95
    # back-projected body pixels lie on the person: within a 0.5 m column about the origin, 0-1.8 m high
    points, labels = depth_to_points(r.depth_mm, placement.intrinsics, r.labels)
    p = apply(placement.T_world_cam, points[labels == Label.BODY])
    assert np.mean((np.linalg.norm(p[:, :2], axis=1) < 0.5) & (p[:, 2] > -0.05) & (p[:, 2] < 1.85)) > 0.95
    # and the head is where the intrinsics put it
    head = human.data.geom_xpos[mujoco.mj_name2id(human.model, mujoco.mjtObj.mjOBJ_GEOM, "head")]
    uv, _ = placement.intrinsics.project(apply(invert(placement.T_world_cam), head))
    assert body[round(uv[1]), round(uv[0])]
