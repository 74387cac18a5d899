"""Compiled per-pixel steps of the ray-casting depth camera (:class:`sim.depth_camera.DepthCamera`).

Three loops over pixels that numpy would run as a dozen full passes with temporaries:
:func:`cone_mask` marks the pixels whose ray can reach a body geom's bounding sphere,
:func:`jittered_rays` turns (jittered) pixel positions into world rays, and :func:`hit_depths` turns
the rays' first hits into z-depth and incidence angle.
"""

from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, error_model="numpy")
def cone_mask(dir_cam_img, lo, hi, axes, cos_cone, cos_near, mask, near):
    """Mark the pixels inside S cones, in place.

    ``dir_cam_img`` (H, W, 3) unit pixel rays, camera frame; per cone ``s`` the pixel box
    ``lo[s] <= (u, v) < hi[s]`` (S, 2) that holds it (clipped to the image), its unit axis ``axes`` (S, 3) and the cosines of
    two half-angles, ``cos_cone`` and ``cos_near`` (S,). Sets ``mask[v, u]`` (H, W) where a pixel's ray
    is within the first half-angle, and ``near[v, u]`` (H, W, or empty to skip) within the second.
    """
    use_near = near.shape[0] > 0
    height, width = mask.shape
    for s in range(lo.shape[0]):
        ax, ay, az = axes[s, 0], axes[s, 1], axes[s, 2]
        for v in range(max(lo[s, 1], 0), min(hi[s, 1], height)):
            for u in range(max(lo[s, 0], 0), min(hi[s, 0], width)):
                cos = dir_cam_img[v, u, 0] * ax + dir_cam_img[v, u, 1] * ay + dir_cam_img[v, u, 2] * az
                if cos >= cos_cone[s]:
                    mask[v, u] = True
                if use_near and cos >= cos_near[s]:
                    near[v, u] = True


@numba.njit(cache=True, nogil=True, error_model="numpy")
def jittered_rays(pix, shift, near, pad, width, uv_to_world):
    """World rays of pixels ``pix`` (N,) (flat indices) shifted by ``shift`` (N, 2) [px] (or (0, 2): none).

    ``near`` (H + 2 pad, W + 2 pad) bool, or (0, 0) to keep every ray: a ray is kept only where the
    padded mask is True at its shifted position's nearest pixel. ``uv_to_world`` (3, 3) maps
    (u, v, 1) to a world-frame ray whose camera-frame z is 1. Returns the kept rays' indices into
    ``pix`` (K,), unit world directions (K, 3) and camera-frame z of the unit directions (K,).
    """
    n = pix.shape[0]
    keep = np.empty(n, dtype=np.intp)
    dirs = np.empty((n, 3))
    z_cam = np.empty(n)
    jitter, check = shift.shape[0] > 0, near.shape[0] > 0
    k = 0
    for i in range(n):
        u, v = float(pix[i] % width), float(pix[i] // width)
        if jitter:
            u += shift[i, 0]
            v += shift[i, 1]
        if check and not near[int(np.rint(v)) + pad, int(np.rint(u)) + pad]:
            continue
        x = uv_to_world[0, 0] * u + uv_to_world[0, 1] * v + uv_to_world[0, 2]
        y = uv_to_world[1, 0] * u + uv_to_world[1, 1] * v + uv_to_world[1, 2]
        z = uv_to_world[2, 0] * u + uv_to_world[2, 1] * v + uv_to_world[2, 2]
        norm = math.sqrt(x * x + y * y + z * z)
        keep[k] = i
        dirs[k, 0], dirs[k, 1], dirs[k, 2] = x / norm, y / norm, z / norm
        z_cam[k] = 1.0 / norm
        k += 1
    return keep[:k], dirs[:k], z_cam[:k]


@numba.njit(cache=True, nogil=True, error_model="numpy")
def hit_depths(pix, dirs, z_cam, dist, normal, floor_height, dir_world, dir_cam_z, cos_grazing_end):
    """z-depth [m] and incidence [rad] of the body hits of rays ``dirs`` (K, 3) through pixels ``pix`` (K,).

    ``dist`` (K,) ray lengths [m] (inf: no hit), ``normal`` (K, 3) world normals at the hits, ``z_cam``
    (K,) the rays' camera-frame z. A hit counts where it lies before the floor (the plane z = 0,
    ``floor_height`` [m] below the camera; inf: no floor). ``dir_world`` (P, 3) and ``dir_cam_z``
    (P,) are the pixel-centre rays: where the centre ray meets the surface less obliquely than
    ``cos_grazing_end``, the depth is the surface's along the centre ray and the incidence is the
    centre ray's; otherwise the shifted ray's own. Returns the pixels seen, their depths and incidences.
    """
    n = pix.shape[0]
    seen, depth, theta = np.empty(n, dtype=np.intp), np.empty(n), np.empty(n)
    k = 0
    for i in range(n):
        if not dist[i] < math.inf:
            continue
        if dirs[i, 2] < 0.0 and not dist[i] < floor_height / -dirs[i, 2]:
            continue  # the floor occludes it
        p = pix[i]
        cos_s = -(normal[i, 0] * dirs[i, 0] + normal[i, 1] * dirs[i, 1] + normal[i, 2] * dirs[i, 2])
        cos_c = -(normal[i, 0] * dir_world[p, 0] + normal[i, 1] * dir_world[p, 1] + normal[i, 2] * dir_world[p, 2])
        if cos_c > cos_grazing_end:
            depth[k] = dist[i] * cos_s / cos_c * dir_cam_z[p]
            cos = cos_c
        else:
            depth[k] = dist[i] * z_cam[i]
            cos = cos_s
        theta[k] = math.acos(min(max(cos, 0.0), 1.0))
        seen[k] = p
        k += 1
    return seen[:k], depth[:k], theta[:k]
