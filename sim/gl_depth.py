"""Noise-free depth of the body geoms rendered with MuJoCo's own OpenGL renderer (``mujoco.Renderer``).

Needs an OpenGL context: headless, ``MUJOCO_GL=egl`` (Mesa's software EGL works without a GPU) or
``MUJOCO_GL=osmesa``, set before ``mujoco`` is first imported; :mod:`sim` sets ``MUJOCO_GL=egl`` on
Linux when it is unset. :func:`probe_gl` names the context's renderer, or says why none can be made.

Camera model. MuJoCo's renderer draws a scene camera (``mjvGLCamera``) with a frustum whose top and
bottom are given at the near plane and whose left and right follow from the image's aspect ratio
around ``frustum_center``. The pinhole (fx, fy, cx, cy) maps exactly onto it when fx = fy:
``top = near (cy + 1/2) / fy``, ``bottom = near (cy - H + 1/2) / fy``,
``center = near ((W - 1) / 2 - cx) / fx`` (pixel centres at integer coordinates). The camera looks
along the sensor's +z, image-up is the sensor's -v direction, and an image that is mirrored (Kinect v2:
+x is the sensor's left) is rendered unmirrored and flipped left-right (then cx is measured from the
other side). With fx != fy the horizontal scale is off by fx / fy (at most 0.2 % for the spread of
:func:`sim.rig.vary_intrinsics`, half a pixel at the image edge).

Depth: the renderer reads the (reversed-Z, float) depth buffer and linearises it with the model's
``vis.map.znear`` / ``zfar`` times ``stat.extent`` into the distance along the optical axis [m], the
same z-depth a Kinect reports; pixels with no body geom read ``zfar``. The offscreen buffer is not
multisampled (``vis.quality.offsamples = 0``): a multisampled depth buffer is resolved by the driver,
and some (NVIDIA's) take one sample off the pixel centre, which biases the depth of sloped surfaces
by their depth gradient times that offset (:mod:`sim.gl_self_check`).
"""

from __future__ import annotations

import functools
import math

import mujoco
import numba
import numpy as np

from fusion.camera import AxisConvention
from fusion.errors import BadInputError
from sim.depth_noise import JITTER_CLIP, lateral_jitter_px
from sim.rig import CameraPlacement

TESSELLATION = (40, 20)
"""Slices and stacks MuJoCo draws round geoms with (at least). The drawn capsules are polygons inside
the true surface; against the ray caster's exact geoms, the 99th percentile of |z difference| over
the humanoid (fma_2cam, 512 x 424) measured 2.7-4.5 mm with MuJoCo's default 28 x 16, 1.5-2.3 mm
with 40 x 20 and 0.6-0.9 mm with 64 x 32; a noisy frame took 1.23, 1.25 and 1.52 times the ray
caster's time in the same runs (Mesa's software rasteriser, a loaded two-core machine)."""


@functools.cache
def probe_gl() -> tuple[str | None, str | None]:
    """What ``mujoco.Renderer`` gets here: ``(GL_RENDERER, None)`` or ``(None, why no context)``.

    Makes a context, renders a depth image and reads the context's ``GL_RENDERER`` string (e.g.
    ``"llvmpipe (LLVM 15.0.6, 256 bits)"``) with PyOpenGL, which MuJoCo's headless backends use;
    probed once per process (0.3-0.9 s with Mesa's software EGL, on this project's machines).
    """
    spec = mujoco.MjSpec()
    spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.1, 0, 0])
    try:
        with mujoco.Renderer(spec.compile(), 8, 8) as renderer:
            renderer.enable_depth_rendering()
            renderer.render()  # leaves the renderer's context current
            from OpenGL import (
                GL,  # imported after MuJoCo chose PyOpenGL's platform (PYOPENGL_PLATFORM)
            )

            name = GL.glGetString(GL.GL_RENDERER)
    except Exception as exc:  # any failure to make or use a context means "no GL here"
        return None, f"{type(exc).__name__}: {str(exc).strip().splitlines()[0] if str(exc).strip() else 'no detail'}"
    return (name.decode(errors="replace") if name else "unnamed renderer"), None


def gl_unavailable() -> str | None:
    """Why ``mujoco.Renderer`` cannot make an OpenGL context here (None when it can); see :func:`probe_gl`."""
    return probe_gl()[1]


_SHARED: dict[str, object] = {}
_OFF = (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION, mujoco.mjtRndFlag.mjRND_SKYBOX,
        mujoco.mjtRndFlag.mjRND_FOG, mujoco.mjtRndFlag.mjRND_HAZE, mujoco.mjtRndFlag.mjRND_POST_PROCESSING)


def _renderer(model: mujoco.MjModel, height: int, width: int) -> mujoco.Renderer:
    """One depth renderer per process, kept while the model and image size stay the same.

    Making an OpenGL context and uploading the model costs about half a second (Mesa's software EGL),
    more than a frame; every camera of a session renders the same model, so they share it.
    """
    if _SHARED.get("model") is not model or _SHARED.get("size") != (height, width):
        old = _SHARED.pop("renderer", None)
        if old is not None:
            old.close()
        renderer = mujoco.Renderer(model, height, width)
        renderer.enable_depth_rendering()
        for flag in _OFF:  # nothing of these reaches a depth image; shadows alone draw the scene once per light
            renderer.scene.flags[flag] = False
        _SHARED.update(model=model, size=(height, width), renderer=renderer)
    return _SHARED["renderer"]


class GLBodyDepth:
    """Renders the z-depth of one geom group as one camera sees it.

    Parameters
    ----------
    model : the scene; its offscreen buffer is enlarged to the image size if needed.
    placement : the camera's pose ``T_world_cam`` and intrinsics.
    geom_group : the MuJoCo geom group (0-5) drawn; other groups and all sites are hidden.

    Raises
    ------
    BadInputError
        No OpenGL context can be made (the message says why and what to set).
    """

    def __init__(self, model: mujoco.MjModel, placement: CameraPlacement, geom_group: int) -> None:
        reason = gl_unavailable()
        if reason is not None:
            raise BadInputError(f"MuJoCo's renderer has no OpenGL context ({reason}); set MUJOCO_GL=egl or "
                                "osmesa before mujoco is imported, or use the ray-casting depth renderer")
        intr = placement.intrinsics
        glob = model.vis.global_
        glob.offwidth, glob.offheight = max(glob.offwidth, intr.width), max(glob.offheight, intr.height)
        quality = model.vis.quality
        quality.offsamples = 0  # each pixel's depth at its centre (see the module's docstring)
        quality.numslices, quality.numstacks = max(quality.numslices, TESSELLATION[0]), max(quality.numstacks,
                                                                                            TESSELLATION[1])
        self.model = model
        self._rays = intr.pixel_rays()
        self._pixels = np.arange(intr.width * intr.height).reshape(intr.height, intr.width)  # flat indices
        self._uv = np.moveaxis(np.mgrid[0 : intr.height, 0 : intr.width][::-1], 0, -1).astype(float)  # (H, W, 2) u, v
        self._option = mujoco.MjvOption()
        self._option.geomgroup[:] = [g == geom_group for g in range(6)]
        self._option.sitegroup[:] = 0
        self._far = float(model.vis.map.zfar * model.stat.extent)
        near = float(model.vis.map.znear * model.stat.extent)

        R = placement.T_world_cam[:3, :3]
        v_sign = -1.0 if intr.axes is AxisConvention.KINECT_V2 else 1.0  # camera +y is image-up (Kinect) or down
        forward, up, image_right = R[:, 2], R[:, 1] * -v_sign, R[:, 0]
        self._mirror = bool(np.dot(np.cross(forward, up), image_right) < 0)
        cx = intr.width - 1 - intr.cx if self._mirror else intr.cx
        self._gl = dict(pos=placement.T_world_cam[:3, 3], forward=forward, up=up,
                        frustum_center=near * ((intr.width - 1) / 2 - cx) / intr.fx,
                        frustum_top=near * (intr.cy + 0.5) / intr.fy,
                        frustum_bottom=near * (intr.cy - intr.height + 0.5) / intr.fy,
                        frustum_near=near, frustum_far=self._far)

    def render(self, data: mujoco.MjData) -> np.ndarray:
        """(H, W) float64 z-depth [m] of the drawn geoms in the scene's current pose; NaN where none."""
        renderer = _renderer(self.model, *self._rays.shape[:2])
        renderer.update_scene(data, scene_option=self._option)
        for cam in renderer.scene.camera:
            for key, value in self._gl.items():
                setattr(cam, key, value)
            cam.orthographic = 0
        depth = renderer.render().astype(np.float64)
        if self._mirror:
            depth = depth[:, ::-1]
        depth[depth >= 0.999 * self._far] = np.nan
        return depth

    def body_hits(
        self, data: mujoco.MjData, floor_depth_m: np.ndarray, lateral_sigma_px: float, rng: np.random.Generator,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Pixels that see the drawn geoms, after lateral jitter, with their z-depth and incidence.

        Lateral jitter (:func:`sim.depth_noise.lateral_jitter_px`) moves each pixel near the body
        (within :data:`sim.depth_noise.JITTER_CLIP` sigmas of it) to the nearest pixel of its jittered
        position, whose rendered depth and incidence it takes.

        Parameters
        ----------
        data : the scene in its current pose.
        floor_depth_m : (H * W,) z-depth of the floor [m] per pixel (NaN where not seen): it hides geoms behind it.
        lateral_sigma_px : jitter sigma [px].
        rng : draws the jitter.

        Returns
        -------
        pix : (P,) flat pixel indices; depth : (P,) z-depth [m]; theta : (P,) incidence [rad].
        """
        intr_h, intr_w = self._rays.shape[:2]
        depth = self.render(data).ravel()
        with np.errstate(invalid="ignore"):
            depth[depth >= floor_depth_m] = np.nan
        body = np.isfinite(depth)
        if not body.any():
            return np.empty(0, dtype=np.intp), np.empty(0), np.empty(0)
        rows, cols = np.divmod(np.flatnonzero(body), intr_w)
        pad = int(np.ceil(JITTER_CLIP * lateral_sigma_px)) + 1
        r0, r1 = max(rows.min() - pad, 0), min(rows.max() + pad + 1, intr_h)
        c0, c1 = max(cols.min() - pad, 0), min(cols.max() + pad + 1, intr_w)
        theta = np.full((intr_h, intr_w), np.nan)  # normals only in the body's box (the rest is not hit)
        theta[r0:r1, c0:c1] = incidence_from_depth(depth.reshape(intr_h, intr_w)[r0:r1, c0:c1],
                                                   self._rays[r0:r1, c0:c1])
        theta = theta.ravel()
        theta[body & np.isnan(theta)] = np.pi / 2  # an isolated pixel: no surface to measure, treat as grazing
        pix = self._pixels[r0:r1, c0:c1].ravel()
        src = pix
        if lateral_sigma_px > 0:
            shift = lateral_jitter_px(pix.size, lateral_sigma_px, rng)
            shift += self._uv[r0:r1, c0:c1].reshape(-1, 2)
            uv = np.rint(shift, out=shift).clip(0, [intr_w - 1, intr_h - 1]).astype(np.intp)
            src = uv[:, 1] * intr_w + uv[:, 0]
        hit = body[src]
        return pix[hit], depth[src[hit]], theta[src[hit]]


def incidence_from_depth(depth_m: np.ndarray, rays_cam: np.ndarray) -> np.ndarray:
    """Incidence angle [rad] of the surface each pixel sees, from the normals of a depth image.

    Each pixel's tangents are the differences to its neighbours along u and v, taken on the side with
    the smaller depth step (so a silhouette does not tilt the surface behind or in front of it).

    Parameters
    ----------
    depth_m : (H, W) z-depth [m], NaN where no surface.
    rays_cam : (H, W, 3) per-pixel rays at z = 1 (:meth:`fusion.camera.Intrinsics.pixel_rays`).

    Returns
    -------
    (H, W) float64 angle between the surface normal and the ray back to the camera, in [0, pi/2];
    NaN where the pixel or both neighbours along an axis have no depth.
    """
    if depth_m.shape != rays_cam.shape[:2]:
        raise BadInputError(f"depth {depth_m.shape} and rays {rays_cam.shape} differ in image size")
    return _incidence(np.asarray(depth_m, dtype=np.float64), np.asarray(rays_cam, dtype=np.float64))


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _tangent(depth, rays, r, c, dr, dc):
    """Tangent (x, y, z) [m] at pixel (r, c) to its neighbour (r + dr, c + dc) or from (r - dr, c - dc).

    The step ahead, unless the step behind changes z less or the step ahead is NaN (then the step
    behind); at the image border the one step there is; NaN where the image is one pixel across.
    """
    height, width = depth.shape
    rb, cb, ra, ca = r - dr, c - dc, r + dr, c + dc
    has_behind, has_ahead = rb >= 0 and cb >= 0, ra < height and ca < width
    if not (has_behind or has_ahead):
        return math.nan, math.nan, math.nan
    d = depth[r, c]
    ahead = True
    if has_behind and has_ahead:
        step = depth[ra, ca] * rays[ra, ca, 2] - d * rays[r, c, 2]
        ahead = not (abs(d * rays[r, c, 2] - depth[rb, cb] * rays[rb, cb, 2]) < abs(step) or math.isnan(step))
    elif has_behind:
        ahead = False
    q, s, sign = (ra, ca, 1.0) if ahead else (rb, cb, -1.0)
    dq = depth[q, s]
    return (sign * (dq * rays[q, s, 0] - d * rays[r, c, 0]), sign * (dq * rays[q, s, 1] - d * rays[r, c, 1]),
            sign * (dq * rays[q, s, 2] - d * rays[r, c, 2]))


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _incidence(depth, rays):
    height, width = depth.shape
    theta = np.empty((height, width))
    for r in range(height):
        for c in range(width):
            ax, ay, az = _tangent(depth, rays, r, c, 1, 0)  # along rows
            bx, by, bz = _tangent(depth, rays, r, c, 0, 1)  # along columns
            nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
            rx, ry, rz = rays[r, c, 0], rays[r, c, 1], rays[r, c, 2]
            norms = (nx * nx + ny * ny + nz * nz) * (rx * rx + ry * ry + rz * rz)
            cos = abs(nx * rx + ny * ry + nz * rz) / math.sqrt(norms)
            theta[r, c] = math.nan if math.isnan(cos) else math.acos(min(cos, 1.0))
    return theta
