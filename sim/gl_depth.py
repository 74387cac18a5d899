"""Noise-free depth of the body geoms rendered with MuJoCo's own OpenGL renderer (``mujoco.mjr_render``).

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
other side). A box of the image (rows r0:r1, columns c0:c1) is the pinhole with ``cx - c0``, ``cy - r0``
and the box's size: a frame renders only the box round the body (:meth:`GLBodyDepth.body_hits`),
whose depths equal the whole image's within the rasteriser's rounding (0.04 mm measured). With
fx != fy the horizontal scale is off by fx / fy (at most 0.2 % for the spread of
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

_NO_SHIFT = np.empty((0, 2))  # no lateral jitter

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
_ON = (mujoco.mjtRndFlag.mjRND_SEGMENT, mujoco.mjtRndFlag.mjRND_IDCOLOR)  # flat colours: no lighting pass


class _DepthContext:
    """An OpenGL context with MuJoCo's render context and a scene, for depth images up to its size.

    Unlike ``mujoco.Renderer`` (whose viewport is the whole image) it renders any part of the image,
    so what follows the drawing (read-back, linearising, labelling) handles the body's box, not the
    whole image (the drawing itself cost about 7 ms either way with Mesa's software rasteriser). The
    depth buffer is read as reversed-Z floats (``mjDEPTH_ZEROFAR``, 0 at the far plane).
    """

    def __init__(self, model: mujoco.MjModel, height: int, width: int) -> None:
        self.gl = mujoco.GLContext(width, height)
        self.gl.make_current()
        self.mjr = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100.value)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN.value, self.mjr)
        self.mjr.readDepthMap = mujoco.mjtDepthMap.mjDEPTH_ZEROFAR
        self.scene = mujoco.MjvScene(model, maxgeom=10000)
        for flag in _OFF:  # nothing of these reaches a depth image; shadows alone draw the scene once per light
            self.scene.flags[flag] = False
        for flag in _ON:
            self.scene.flags[flag] = True
        self.camera = mujoco.MjvCamera()
        mujoco.mjv_defaultFreeCamera(model, self.camera)
        self.perturb = mujoco.MjvPerturb()

    def close(self) -> None:
        with self.gl.as_current():
            self.mjr.free()
        self.gl.free()


def _context(model: mujoco.MjModel, height: int, width: int) -> _DepthContext:
    """One depth context per process, kept while the model and image size stay the same.

    Making an OpenGL context and uploading the model costs about half a second (Mesa's software EGL),
    more than a frame; every camera of a session renders the same model, so they share it.
    """
    if _SHARED.get("model") is not model or _SHARED.get("size") != (height, width):
        old = _SHARED.pop("context", None)
        if old is not None:
            old.close()
        _SHARED.update(model=model, size=(height, width), context=_DepthContext(model, height, width))
    return _SHARED["context"]


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _linear_depth(buffer, c_coef, d_coef, far, mirror):
    """(h, w) z-depth [m] (NaN where nothing is drawn) from a reversed-Z depth buffer read bottom row first."""
    h, w = buffer.shape
    out = np.empty((h, w))
    for r in range(h):
        for c in range(w):
            z = d_coef / (np.float64(buffer[h - 1 - r, c]) + c_coef)
            out[r, w - 1 - c if mirror else c] = z if z < far else math.nan
    return out


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
        self._fx, self._fy = float(intr.fx), float(intr.fy)
        self._option = mujoco.MjvOption()
        self._option.geomgroup[:] = [g == geom_group for g in range(6)]
        self._option.sitegroup[:] = 0
        self._far = float(model.vis.map.zfar * model.stat.extent)
        near = float(model.vis.map.znear * model.stat.extent)
        # the reversed-Z projection as MuJoCo builds it (float32), undone in float64 (:func:`_linear_depth`)
        zfar, znear = np.float32(self._far), np.float32(near)
        self._unproject = (float(np.float32(-0.5) * (-(zfar + znear) / (zfar - znear)) - np.float32(0.5)),
                           float(np.float32(-0.5) * (-(np.float32(2) * zfar * znear) / (zfar - znear))))

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

    def render(self, data: mujoco.MjData, box: tuple[int, int, int, int] | None = None) -> np.ndarray:
        """Z-depth [m] of the drawn geoms in the scene's current pose, NaN where none: (H, W), or only the
        image rows ``r0:r1`` and columns ``c0:c1`` of ``box = (r0, r1, c0, c1)``, (r1 - r0, c1 - c0)."""
        height, width = self._rays.shape[:2]
        r0, r1, c0, c1 = box or (0, height, 0, width)
        h, w = r1 - r0, c1 - c0
        g0 = width - c1 if self._mirror else c0  # first column of the box in the rendered (unmirrored) image
        context = _context(self.model, height, width)
        context.gl.make_current()
        mujoco.mjv_updateScene(self.model, data, self._option, context.perturb, context.camera,
                               mujoco.mjtCatBit.mjCAT_ALL.value, context.scene)
        near, top = self._gl["frustum_near"], self._gl["frustum_top"]
        frustum = dict(self._gl, frustum_top=top - near * r0 / self._fy, frustum_bottom=top - near * r1 / self._fy,
                       frustum_center=self._gl["frustum_center"] + near * ((w - width) / 2 + g0) / self._fx)
        for cam in context.scene.camera:
            for key, value in frustum.items():
                setattr(cam, key, value)
            cam.orthographic = 0
        rect = mujoco.MjrRect(0, 0, w, h)
        mujoco.mjr_render(rect, context.scene, context.mjr)
        buffer = np.empty((h, w), dtype=np.float32)
        mujoco.mjr_readPixels(None, buffer, rect, context.mjr)
        return _linear_depth(buffer, *self._unproject, 0.999 * self._far, self._mirror)

    def body_hits(
        self, data: mujoco.MjData, floor_depth_m: np.ndarray, lateral_sigma_px: float, rng: np.random.Generator,
        box: tuple[int, int, int, int] | None = None,
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
        box : ``(r0, r1, c0, c1)``, the image rows and columns rendered (the whole image when None); it
            must hold every pixel that sees the geoms and the jitter's reach around them.

        Returns
        -------
        pix : (P,) flat pixel indices of the image; depth : (P,) z-depth [m]; theta : (P,) incidence [rad].
        """
        width = self._rays.shape[1]
        r0, r1, c0, c1 = box or (0, self._rays.shape[0], 0, width)
        depth = self.render(data, box)
        extent = _hide_behind(depth, floor_depth_m.reshape(-1, width)[r0:r1, c0:c1])
        if extent[0] > extent[1]:
            return np.empty(0, dtype=np.intp), np.empty(0), np.empty(0)
        pad = int(np.ceil(JITTER_CLIP * lateral_sigma_px)) + 1
        b0, b1 = max(extent[0] - pad, 0), min(extent[1] + pad + 1, r1 - r0)
        a0, a1 = max(extent[2] - pad, 0), min(extent[3] + pad + 1, c1 - c0)
        theta = incidence_from_depth(depth[b0:b1, a0:a1], self._rays[r0 + b0 : r0 + b1, c0 + a0 : c0 + a1])
        shift = lateral_jitter_px((b1 - b0) * (a1 - a0), lateral_sigma_px, rng) if lateral_sigma_px > 0 else _NO_SHIFT
        return _jittered_hits(depth, theta, (b0, a0), shift, (r0, c0), width)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _hide_behind(depth, floor):
    """Set NaN where ``depth`` (h, w) is not in front of ``floor`` (h, w); the rows and columns
    (first, last, first, last) of what is left, first > last where nothing is."""
    h, w = depth.shape
    r_lo, r_hi, c_lo, c_hi = h, -1, w, -1
    for r in range(h):
        for c in range(w):
            z = depth[r, c]
            if z >= floor[r, c]:
                depth[r, c] = math.nan
            elif not math.isnan(z):
                r_lo, r_hi, c_lo, c_hi = min(r_lo, r), max(r_hi, r), min(c_lo, c), max(c_hi, c)
    return r_lo, r_hi, c_lo, c_hi


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _jittered_hits(depth, theta, at, shift, origin, width):
    """Pixels of the window ``theta`` (h, w) at ``at`` (row, column) of ``depth`` (H', W') that see a
    surface after their jitter ``shift`` (h * w, 2) (u, v) [px] (none: (0, 2)), each moved to the
    nearest pixel of ``depth`` to its jittered position; their flat indices in an image ``width``
    wide in which ``depth`` starts at ``origin`` (row, column), and the depth and incidence (an
    isolated pixel's NaN incidence read as grazing) of the pixel they took."""
    height_d, width_d = depth.shape
    h, w = theta.shape
    pix, z, angle = np.empty(h * w, dtype=np.intp), np.empty(h * w), np.empty(h * w)
    k = 0
    for i in range(h * w):
        r, c = at[0] + i // w, at[1] + i % w
        sr, sc = r, c
        if shift.shape[0]:
            sc = min(max(int(np.rint(c + origin[1] + shift[i, 0])) - origin[1], 0), width_d - 1)
            sr = min(max(int(np.rint(r + origin[0] + shift[i, 1])) - origin[0], 0), height_d - 1)
        if math.isnan(depth[sr, sc]):
            continue
        pix[k] = (r + origin[0]) * width + c + origin[1]
        z[k] = depth[sr, sc]
        t = theta[sr - at[0], sc - at[1]] if at[0] <= sr < at[0] + h and at[1] <= sc < at[1] + w else math.nan
        angle[k] = math.pi / 2 if math.isnan(t) else t
        k += 1
    return pix[:k], z[:k], angle[:k]


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
            if math.isnan(depth[r, c]):  # no surface: NaN, as its tangents would give
                theta[r, c] = math.nan
                continue
            ax, ay, az = _tangent(depth, rays, r, c, 1, 0)  # along rows
            bx, by, bz = _tangent(depth, rays, r, c, 0, 1)  # along columns
            nx, ny, nz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
            rx, ry, rz = rays[r, c, 0], rays[r, c, 1], rays[r, c, 2]
            norms = (nx * nx + ny * ny + nz * nz) * (rx * rx + ry * ry + rz * rz)
            cos = abs(nx * rx + ny * ry + nz * rz) / math.sqrt(norms)
            theta[r, c] = math.nan if math.isnan(cos) else math.acos(min(cos, 1.0))
    return theta
