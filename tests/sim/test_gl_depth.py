"""MuJoCo's OpenGL depth renderer against closed forms and against the ray caster.

Tests that render with OpenGL skip, with the reason, where no context can be made (set MUJOCO_GL=egl
or osmesa); the choice of renderer and the normals from a depth image need no OpenGL.
"""

from __future__ import annotations

import dataclasses
import logging

import numpy as np
import pytest

from fusion.camera import Intrinsics
from fusion.depth import Label
from fusion.errors import BadInputError
from sim import gl_depth, gl_self_check
from sim.depth_camera import DepthCamera
from sim.depth_noise import DepthNoise
from sim.depth_renderer import DepthRenderer, auto_choice, software_gl
from sim.rig import CameraPlacement, as_azure_kinect, look_at
from sim.scenes import Sphere, Wall, compile_scene

NO_GL = gl_depth.gl_unavailable()
needs_gl = pytest.mark.skipif(NO_GL is not None, reason=f"no OpenGL context for mujoco.Renderer: {NO_GL}")
IDEAL = DepthNoise.none()
# an off-centre principal point, so a wrong frustum shift shows
OFF_CENTRE = Intrinsics(fx=365.5, fy=365.5, cx=262.0, cy=203.0)


@needs_gl
@pytest.mark.parametrize("kinect", [True, False], ids=["kinect_mirrored", "azure_opencv"])
def test_sphere_lands_where_the_intrinsics_predict(kinect):
    placement = CameraPlacement("cam", look_at([0.0, 0.0, 1.5], [1.0, 0.0, 1.5]), OFF_CENTRE)
    placement = placement if kinect else as_azure_kinect(placement)
    sphere = Sphere(np.array([2.5, 0.4, 1.2]), 0.2)
    model, data = compile_scene(sphere, floor=False)
    model.vis.quality.numslices, model.vis.quality.numstacks = 128, 64  # fine facets: this tests the camera model
    cam = DepthCamera(placement, IDEAL, floor=False, renderer=DepthRenderer.MUJOCO)
    r = cam.render(model, data, rng=np.random.default_rng(0))
    z_true, rim = sphere.depth(placement)
    body = r.labels == Label.BODY
    v, u = np.nonzero(body)
    np.testing.assert_allclose([u.mean(), v.mean()], sphere.image_centre(placement), atol=0.1)
    clear = np.abs(rim) > 2e-3  # pixel centres clear of the (faceted) silhouette
    np.testing.assert_array_equal(body[clear], (rim < 0)[clear])
    both = body & (rim < 0)
    err = np.abs(r.depth_ideal_m[both] - z_true[both])  # the sphere is drawn as facets: worst near the rim
    assert np.median(err) < 0.3e-3 and np.percentile(err, 99) < 2e-3


@needs_gl
def test_incidence_on_a_tilted_wall():
    placement = CameraPlacement("cam", look_at([0.0, 0.0, 1.5], [1.0, 0.0, 1.5]))
    wall = Wall([2.5, 0.0, 1.5], 60.0)
    model, data = compile_scene(wall, floor=False)
    cam = DepthCamera(placement, IDEAL, floor=False, renderer=DepthRenderer.MUJOCO)
    r = cam.render(model, data, rng=np.random.default_rng(0))
    z, theta = wall.depth(placement)
    win = (slice(150, 275), slice(200, 312))
    np.testing.assert_allclose(r.depth_ideal_m[win], z[win], atol=2e-4)
    np.testing.assert_allclose(r.incidence_rad[win], theta[win], atol=np.radians(0.5))


def _humanoid(topology_azure: bool):
    from scenarios.config import load_scenario
    from scenarios.runner import build_simulation

    sim = build_simulation(load_scenario("fma_2cam"))
    placement = sim.rig.cameras[0]
    return sim, as_azure_kinect(placement) if topology_azure else placement


@needs_gl
@pytest.mark.parametrize("azure", [False, True], ids=["kinect_v2_512x424", "azure_640x576"])
def test_mujoco_and_ray_caster_agree_on_the_humanoid(azure):
    """Ideal depth of the humanoid in three poses: 99th percentile |diff| of pixels both see under 2 mm."""
    sim, placement = _humanoid(azure)
    cams = [DepthCamera(placement, IDEAL, renderer=r) for r in (DepthRenderer.RAYCAST, DepthRenderer.MUJOCO)]
    for x in sim.humanoid.qpos(sim.motion.sample(np.array([1.0, 12.0, 20.0]))):
        sim.humanoid.set_qpos(x)
        ray, gl = (c.render(sim.humanoid.model, sim.humanoid.data, rng=np.random.default_rng(0)) for c in cams)
        body_ray, body_gl = ray.labels == Label.BODY, gl.labels == Label.BODY
        assert body_ray.sum() > 5000
        assert abs(int(body_gl.sum()) - int(body_ray.sum())) < 0.01 * body_ray.sum()
        valid = (ray.depth_mm > 0) & (gl.depth_mm > 0)
        diff = np.abs(ray.depth_mm[valid].astype(int) - gl.depth_mm[valid].astype(int))
        assert valid.sum() > 0.9 * (ray.depth_mm > 0).sum()
        assert np.percentile(diff, 99) <= 2.0


@needs_gl
@pytest.mark.parametrize("azure", [False, True], ids=["kinect_v2_mirrored", "azure_opencv"])
def test_rendering_the_body_box_is_rendering_the_whole_image(monkeypatch, azure):
    """A frame renders only the image box round the body; rendering the whole image gives the same
    frame: same labels and returns, depths within 0.1 mm (the rasteriser's rounding differs)."""
    sim, placement = _humanoid(azure)
    placement = dataclasses.replace(placement, intrinsics=dataclasses.replace(
        placement.intrinsics, cx=placement.intrinsics.cx + 7.0, cy=placement.intrinsics.cy - 5.0))
    cam = DepthCamera(placement, sim.sensors.depth, renderer=DepthRenderer.MUJOCO)
    model, data = sim.humanoid.model, sim.humanoid.data
    whole = (0, placement.intrinsics.height, 0, placement.intrinsics.width)
    for x in sim.humanoid.qpos(sim.motion.sample(np.array([2.0, 14.0]))):
        sim.humanoid.set_qpos(x)
        box = cam.render(model, data, rng=np.random.default_rng(3))
        with monkeypatch.context() as m:
            m.setattr(DepthCamera, "_body_box", lambda self, *args: whole)
            full = cam.render(model, data, rng=np.random.default_rng(3))
        assert np.sum(box.labels == Label.BODY) > 5000
        np.testing.assert_array_equal(box.labels, full.labels)
        np.testing.assert_allclose(box.depth_ideal_m, full.depth_ideal_m, atol=1e-4)
        assert np.mean(box.depth_mm != full.depth_mm) < 1e-3  # a rounding to the other millimetre


@needs_gl
def test_noise_on_the_rendered_body_is_seeded_and_close_to_the_ray_caster():
    sim, placement = _humanoid(False)
    sim.humanoid.set_qpos(sim.humanoid.qpos(sim.motion.sample(np.array([5.0])))[0])
    noise = sim.sensors.depth
    gl = DepthCamera(placement, noise, renderer=DepthRenderer.MUJOCO)
    ray = DepthCamera(placement, noise, renderer=DepthRenderer.RAYCAST)
    a, b = (gl.render(sim.humanoid.model, sim.humanoid.data, rng=np.random.default_rng(s)) for s in (4, 4))
    c = gl.render(sim.humanoid.model, sim.humanoid.data, rng=np.random.default_rng(5))
    assert np.array_equal(a.depth_mm, b.depth_mm) and not np.array_equal(a.depth_mm, c.depth_mm)
    r = ray.render(sim.humanoid.model, sim.humanoid.data, rng=np.random.default_rng(4))
    n_gl, n_ray = np.sum(a.labels == Label.BODY), np.sum(r.labels == Label.BODY)
    assert abs(int(n_gl) - int(n_ray)) < 0.03 * n_ray  # jitter and grazing dropouts thin both alike


def test_incidence_from_depth_of_a_plane():
    intr = Intrinsics(width=40, height=30, fx=30.0, fy=30.0, cx=19.5, cy=14.5)
    rays = intr.pixel_rays()
    n = np.array([0.0, np.sin(np.radians(40.0)), -np.cos(np.radians(40.0))])  # plane n . p = -2
    depth = -2.0 / (rays @ n)
    depth[0, 0] = np.nan
    theta = gl_depth.incidence_from_depth(depth, rays)
    expected = np.arccos(np.abs(rays @ n) / np.linalg.norm(rays, axis=-1))
    np.testing.assert_allclose(theta[1:, 1:], expected[1:, 1:], atol=1e-9)
    assert np.isnan(theta[0, 0])
    assert np.isnan(gl_depth.incidence_from_depth(depth[:1], rays[:1])).all()  # one row: no tangent along v
    with pytest.raises(BadInputError, match="image size"):
        gl_depth.incidence_from_depth(depth[:-1], rays)


def test_incidence_at_a_silhouette_is_the_near_surfaces():
    """Edge pixels take their tangents on the side of the smaller depth step: a head-on square in front
    of a tilted wall keeps its own incidence up to its border, and so does the wall around it."""
    intr = Intrinsics(width=40, height=30, fx=30.0, fy=30.0, cx=19.5, cy=14.5)
    rays = intr.pixel_rays()
    n = np.array([0.0, np.sin(np.radians(40.0)), -np.cos(np.radians(40.0))])
    depth = -4.0 / (rays @ n)  # the wall, 40 degrees
    depth[10:20, 12:28] = 1.5  # the square, facing the camera
    theta = gl_depth.incidence_from_depth(depth, rays)
    square = np.arccos(1.0 / np.linalg.norm(rays, axis=-1))  # a plane z = const seen along each ray
    np.testing.assert_allclose(theta[10:20, 12:28], square[10:20, 12:28], atol=1e-9)
    wall = np.arccos(np.abs(rays @ n) / np.linalg.norm(rays, axis=-1))
    ring = np.zeros((30, 40), bool)
    ring[9:21, 11:29] = True
    ring[10:20, 12:28] = False
    np.testing.assert_allclose(theta[ring], wall[ring], atol=1e-9)


def test_renderer_choice(monkeypatch, caplog):
    monkeypatch.setattr(gl_depth, "probe_gl", lambda: (None, "RuntimeError: no display"))
    with pytest.raises(BadInputError, match="no display.*MUJOCO_GL=egl"):
        DepthRenderer.MUJOCO.resolve()
    with caplog.at_level(logging.INFO):
        assert DepthRenderer.AUTO.resolve() is DepthRenderer.RAYCAST
    assert caplog.records[-1].levelno == logging.WARNING
    assert "no display" in caplog.text and "depth by ray casting" in caplog.text
    caplog.clear()
    monkeypatch.setattr(gl_depth, "probe_gl", lambda: ("llvmpipe (LLVM 12.0.0, 128 bits)", None))
    with caplog.at_level(logging.INFO):
        assert DepthRenderer.AUTO.resolve() is DepthRenderer.RAYCAST
    assert "software OpenGL (llvmpipe (LLVM 12.0.0, 128 bits)): depth by ray casting" in caplog.text
    assert DepthRenderer.MUJOCO.resolve() is DepthRenderer.MUJOCO  # forced, software or not
    monkeypatch.setattr(gl_depth, "probe_gl", lambda: ("NVIDIA GeForce RTX 3060/PCIe/SSE2", None))
    monkeypatch.setattr(gl_self_check, "depth_self_check", lambda: None)
    with caplog.at_level(logging.INFO):
        assert DepthRenderer.AUTO.resolve() is DepthRenderer.MUJOCO
    assert "hardware OpenGL (NVIDIA GeForce RTX 3060/PCIe/SSE2): depth by MuJoCo's renderer" in caplog.text
    with pytest.raises(BadInputError, match="DepthRenderer"):
        DepthCamera(CameraPlacement("cam", look_at([0.0, 0.0, 1.5], [1.0, 0.0, 1.5])), renderer="mujoco")


@pytest.mark.parametrize("name, software", [
    ("llvmpipe (LLVM 15.0.6, 256 bits)", True),
    ("softpipe", True),
    ("Mesa DRI swrast", True),
    ("Software Rasterizer", True),
    ("Apple Software Renderer", True),
    ("Google SwiftShader", True),
    ("D3D12 (Microsoft Basic Render Driver)", True),
    ("GDI Generic", True),
    ("zink Vulkan 1.3(llvmpipe (LLVM 15.0.7, 256 bits) (MESA_LLVMPIPE))", True),
    ("NVIDIA GeForce RTX 3060/PCIe/SSE2", False),
    ("Mesa Intel(R) UHD Graphics 620 (KBL GT2)", False),
    ("AMD Radeon RX 6800 (radeonsi, navi21, LLVM 15.0.7, DRM 3.49, 6.1.0)", False),
    ("Apple M1", False),
])
def test_software_gl_is_told_by_the_renderer_string(name, software):
    assert software_gl(name) is software
    choice, reason = auto_choice(name, None)
    assert choice is (DepthRenderer.RAYCAST if software else DepthRenderer.MUJOCO)
    assert name in reason


def test_no_probe_where_no_opengl_is_needed(monkeypatch):
    """The OpenGL probe (a context, a fraction of a second per process) runs only for frames MuJoCo might render."""
    from scenarios.config import load_scenario
    from scenarios.runner import build_simulation
    from sim.session import simulate_session

    def probe():
        raise AssertionError("probed OpenGL")

    monkeypatch.setattr(gl_depth, "probe_gl", probe)
    assert DepthRenderer.RAYCAST.resolve() is DepthRenderer.RAYCAST
    DepthCamera(CameraPlacement("cam", look_at([0.0, 0.0, 1.5], [1.0, 0.0, 1.5])), renderer=DepthRenderer.RAYCAST)
    sim = build_simulation(load_scenario("single"))
    sensors = dataclasses.replace(sim.sensors, depth_rate_hz=0.0, depth_renderer=DepthRenderer.AUTO)
    recording, _ = simulate_session(sim.humanoid, sim.motion, sim.rig, sensors, seed=0, duration_s=1.0)
    assert "depth_renderer" not in recording.metadata
