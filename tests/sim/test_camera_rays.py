"""The depth camera's compiled per-pixel passes against their numpy definitions, and the whole frame
rendered through the compiled primitives against the same frame rendered through ``mj_multiRay``."""

from __future__ import annotations

import numpy as np
import pytest

import sim.raycast
from fusion.depth import Label
from sim.camera_rays import cone_mask, hit_depths, jittered_rays
from sim.depth_camera import DepthCamera
from sim.depth_noise import DepthNoise
from sim.noisy_depth import measure_frame


def _rays(width=40, height=30):
    v, u = np.mgrid[0:height, 0:width].astype(float)
    d = np.stack([(u - 19.5) / 30.0, (v - 14.5) / 30.0, np.ones_like(u)], axis=-1)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def test_cone_mask_marks_the_pixels_within_each_cone_and_clips_boxes_to_the_image():
    rays = _rays()
    rng = np.random.default_rng(0)
    axes = rays[rng.integers(0, 30, 6), rng.integers(0, 40, 6)]
    cos_cone, cos_near = np.cos(rng.uniform(0.02, 0.2, 6)), np.cos(rng.uniform(0.02, 0.2, 6))
    lo, hi = np.full((6, 2), -3), np.array([[43, 33]] * 6)  # boxes past every edge
    mask, near = np.zeros((30, 40), bool), np.zeros((30, 40), bool)
    cone_mask(rays, lo, hi, axes, cos_cone, cos_near, mask, near)
    cos = np.einsum("hwi,si->shw", rays, axes)
    assert np.array_equal(mask, np.any(cos >= cos_cone[:, None, None], axis=0))
    assert np.array_equal(near, np.any(cos >= cos_near[:, None, None], axis=0))
    assert 0 < mask.sum() < mask.size
    skip = np.zeros((30, 40), bool)
    cone_mask(rays, lo, hi, axes, cos_cone, cos_near, skip, np.empty((0, 0), bool))
    assert np.array_equal(skip, mask)


def test_jittered_rays_are_the_unit_rays_through_the_shifted_pixels():
    width, pad = 40, 3
    rng = np.random.default_rng(1)
    pix = np.sort(rng.choice(1200, 300, replace=False))
    shift = rng.uniform(-2.0, 2.0, (300, 2))
    R = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    k_inv = np.array([[1 / 30.0, 0, -19.5 / 30.0], [0, 1 / 30.0, -14.5 / 30.0], [0, 0, 1]])
    near = np.ones((30 + 2 * pad, 40 + 2 * pad), bool)
    near[pad : pad + 15] = False  # the upper half of the image is out of reach
    keep, dirs, z_cam = jittered_rays(pix, shift, near, pad, width, R @ k_inv)
    uv = np.column_stack([pix % width, pix // width]) + shift
    reach = near[np.rint(uv[:, 1]).astype(int) + pad, np.rint(uv[:, 0]).astype(int) + pad]
    assert np.array_equal(keep, np.flatnonzero(reach))
    cam = np.column_stack([uv, np.ones(300)]) @ k_inv.T
    cam /= np.linalg.norm(cam, axis=1, keepdims=True)
    np.testing.assert_allclose(dirs, cam[reach] @ R.T, atol=1e-12)
    np.testing.assert_allclose(z_cam, cam[reach, 2], atol=1e-12)
    keep, dirs, _ = jittered_rays(pix, np.empty((0, 2)), np.empty((0, 0), bool), pad, width, R @ k_inv)
    assert np.array_equal(keep, np.arange(300))
    np.testing.assert_allclose(dirs, (cam := np.column_stack([pix % width, pix // width, np.ones(300)]) @ k_inv.T)
                               / np.linalg.norm(cam, axis=1, keepdims=True) @ R.T, atol=1e-12)


def test_hit_depths_follow_their_definition():
    rng = np.random.default_rng(2)
    n, p = 500, 1000
    dir_world = rng.normal(size=(p, 3))
    dir_world /= np.linalg.norm(dir_world, axis=1, keepdims=True)
    dir_cam_z = rng.uniform(0.8, 1.0, p)
    pix = rng.integers(0, p, n)
    dirs = dir_world[pix] + rng.normal(scale=0.01, size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    normal = -dirs + rng.normal(scale=0.6, size=(n, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    dist = np.where(rng.random(n) < 0.2, np.inf, rng.uniform(1.0, 4.0, n))
    z_cam = rng.uniform(0.8, 1.0, n)
    height, cos_end = 1.2, np.cos(np.radians(80.0))
    seen, depth, theta = hit_depths(pix, dirs, z_cam, dist, normal, height, dir_world, dir_cam_z, cos_end)

    with np.errstate(divide="ignore", invalid="ignore"):
        floor = np.where(dirs[:, 2] < 0, height / -dirs[:, 2], np.inf)
    k = np.flatnonzero(np.isfinite(dist) & (dist < floor))
    cos_s = -np.einsum("ij,ij->i", normal[k], dirs[k])
    cos_c = -np.einsum("ij,ij->i", normal[k], dir_world[pix[k]])
    centre = cos_c > cos_end
    want = np.where(centre, dist[k] * cos_s / cos_c * dir_cam_z[pix[k]], dist[k] * z_cam[k])
    assert np.array_equal(seen, pix[k]) and 0 < k.size < n
    np.testing.assert_allclose(depth, want, rtol=1e-12)
    np.testing.assert_allclose(theta, np.arccos(np.clip(np.where(centre, cos_c, cos_s), 0, 1)), atol=1e-12)
    none = hit_depths(pix, dirs, z_cam, dist, normal, np.inf, dir_world, dir_cam_z, cos_end)[0]
    assert none.size == np.isfinite(dist).sum()  # no floor: every hit counts


def _measure(depth, floor_sigma, floor_p, body_pix, body_sigma, body_p, *, box=(0, 0, 0, 0), fly=(0.0, 1.0),
             range_m=(0.0, 0.5, 8.0), seed=3):
    floor_label = np.where(np.isnan(depth.ravel()), Label.NONE, Label.FLOOR).astype(np.uint8)
    return measure_frame(depth, floor_sigma, floor_p, floor_label, body_pix, body_sigma, body_p, box, (0.05, 0.0),
                         fly, range_m, (np.uint8(Label.BODY), np.uint8(Label.NONE)), np.random.default_rng(seed))


def test_measure_frame_drops_and_spreads_as_the_model_says():
    h, w = 400, 500
    n = h * w
    depth = np.full((h, w), 2.0)
    depth[-2:] = np.nan  # nothing seen
    p = np.where(np.arange(n) < n // 2, 0.0, 0.3)
    p[:1000] = 1.0
    body = np.arange(n // 4, n // 4 + 5000)
    depth_mm, label = _measure(depth, np.full(n, 0.004), p, body, np.full(body.size, 0.008), np.zeros(body.size))
    back = np.setdiff1d(np.arange(n), body)
    assert np.all(depth_mm[:1000] == 0) and np.all(depth_mm[-2 * w :] == 0)
    assert np.all(label[depth_mm == 0] == Label.NONE)
    assert np.all(label[body] == Label.BODY) and np.all(label[back][depth_mm[back] > 0] == Label.FLOOR)
    floor_half = back[(back >= 1000) & (back < n // 2)]
    assert np.all(depth_mm[floor_half] > 0)
    assert np.mean(depth_mm[n // 2 : -2 * w] == 0) == pytest.approx(0.3, abs=0.01)
    assert np.std(depth_mm[floor_half] - 2000.0) == pytest.approx(np.sqrt(16 + 1 / 12), rel=0.02)  # 4 mm and rounding
    assert np.std(depth_mm[body] - 2000.0) == pytest.approx(np.sqrt(64 + 1 / 12), rel=0.04)
    again = _measure(depth, np.full(n, 0.004), p, body, np.full(body.size, 0.008), np.zeros(body.size))
    assert np.array_equal(again[0], depth_mm) and np.array_equal(again[1], label)
    with pytest.raises(ValueError, match="ascending"):
        _measure(depth, np.full(n, 0.004), p, body[::-1], np.full(body.size, 0.008), np.zeros(body.size))


def test_measure_frame_moves_only_edge_pixels_across_their_jump():
    depth = np.full((20, 30), 3.0)
    depth[5:15, 10:20] = 2.0  # a box 1 m in front of a wall
    body = np.flatnonzero(depth.ravel() == 2.0)
    zero = np.zeros(600)
    depth_mm, _ = _measure(depth, zero, zero, body, zero[: body.size], zero[: body.size], box=(-5, 40, -5, 50),
                           fly=(1.0, 1.0))
    moved = (depth_mm.reshape(20, 30) != 1e3 * depth)
    edge = np.zeros((20, 30), bool)
    edge[4:16, 9:21] = True
    edge[6:14, 11:19] = False  # the box's border and the wall's ring around it
    edge[[4, 4, 15, 15], [9, 20, 9, 20]] = False  # diagonal corners have no 4-neighbour across the jump
    assert np.array_equal(moved, edge)
    step = depth_mm.reshape(20, 30) - 1e3 * depth
    assert np.all(step[moved] * (2.5 - depth[moved]) > 0) and np.all(np.abs(step[moved]) <= 1000)
    inside = _measure(depth, zero, zero, body, zero[: body.size], zero[: body.size], box=(0, 10, 0, 30),
                      fly=(1.0, 1.0))[0].reshape(20, 30)
    assert np.array_equal(inside[10:] != 1e3 * depth[10:], np.zeros((10, 30), bool))  # only within the box


def test_measure_frame_offsets_limits_and_rounds():
    depth = np.array([[0.4985, 1.2334, 1.2336, 7.9989, 9.0, np.nan]])
    zero = np.zeros(6)
    depth_mm, label = _measure(depth, zero, zero, np.array([1]), zero[:1], zero[:1], range_m=(0.001, 0.5, 8.0))
    assert list(depth_mm) == [0, 1234, 1235, 8000, 0, 0]
    assert list(label) == [Label.NONE, Label.BODY, Label.FLOOR, Label.FLOOR, Label.NONE, Label.NONE]


@pytest.mark.parametrize("noise", [DepthNoise.none(), DepthNoise()])
def test_humanoid_frame_through_compiled_primitives_equals_mujocos(noise, monkeypatch):
    """The frame is the same whichever caster answers: same pixels, depths within a nanometre."""
    from sim.anthropometry import Anthropometry
    from sim.coordinates import COORDINATES
    from sim.humanoid_model import BODY_GEOM_GROUP, build_humanoid
    from sim.rig import ring_rig

    human = build_humanoid(Anthropometry(height_m=1.7))
    human.set_pose(np.random.default_rng(6).normal(scale=0.4, size=len(COORDINATES)))  # limbs crossing
    camera = DepthCamera(ring_rig(3, radius_m=2.2, height_m=1.1).cameras[1], noise, body_group=BODY_GEOM_GROUP)
    fast = camera.render(human.model, human.data, rng=np.random.default_rng(5))
    monkeypatch.setattr(sim.raycast, "primitive_geoms", lambda model, group: None)
    slow = camera.render(human.model, human.data, rng=np.random.default_rng(5))
    assert np.array_equal(fast.labels, slow.labels) and (fast.labels == Label.BODY).sum() > 3000
    np.testing.assert_allclose(fast.depth_ideal_m, slow.depth_ideal_m, atol=1e-9)
    assert np.abs(fast.depth_mm.astype(int) - slow.depth_mm).max() <= 1
