"""Virtual Kinect v2 depth camera: headless rendering with the sensor's noise model.

Two renderers give the body's depth (:class:`DepthRenderer`): MuJoCo's own OpenGL renderer
(:mod:`sim.gl_depth`, where a context can be made, e.g. ``MUJOCO_GL=egl``) or a ray caster that needs
no OpenGL; ``auto`` takes the first on hardware-accelerated OpenGL, the second on a software
rasteriser or without a context. The floor is the same for both.

Ray casting. Pixel rays are fixed per camera, so the floor (the plane z = 0, seen from
above) is intersected analytically once, at construction: its depth, incidence angle, axial sigma
and dropout probability are cached. Per frame, only rays near the person are cast with
:func:`sim.raycast.cast_rays`: the body geoms (geom group ``body_group``) are covered by spheres
(a row of them along each limb), each sphere becomes a cone of pixel rays widened by the largest
lateral jitter, and the union of the cones is cast against that geom group alone. Ray lengths are
converted to z-depth. The per-pixel loops are compiled (:mod:`sim.camera_rays`).

MuJoCo renderer. The body geom group is drawn in one pass; lateral jitter resamples the rendered
depth at the nearest pixel of each jittered position, and the incidence angle comes from the depth
image's normals (:func:`sim.gl_depth.incidence_from_depth`).

The noise model (lateral jitter, grazing dropouts, axial noise, flying pixels, offset, range
dropouts, rounding) is described and parameterised in :mod:`sim.depth_noise` and applied to a frame
in one compiled pass by :func:`sim.noisy_depth.measure_frame`.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from fusion.depth import Label
from fusion.errors import BadInputError
from sim.camera_rays import cone_mask, hit_depths, jittered_rays
from sim.depth_noise import JITTER_CLIP, DepthNoise, lateral_jitter_px, sigma_axial_mm
from sim.depth_renderer import DepthRenderer
from sim.gl_depth import GLBodyDepth
from sim.noisy_depth import measure_frame
from sim.raycast import cast_rays
from sim.rig import CameraPlacement

_MAX_PIECES = 8  # most bounding spheres per geom


# geom types whose cross-sections across the longest box axis lie within max(other half sizes) of it
_ROUND = (mujoco.mjtGeom.mjGEOM_SPHERE, mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_CYLINDER,
          mujoco.mjtGeom.mjGEOM_ELLIPSOID)


_CUBE = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], dtype=float)


_HALF_PI = 0.5 * np.pi
_NO_SHIFT = np.empty((0, 2))  # no lateral jitter (sim.camera_rays.jittered_rays)
_NO_MASK = np.empty((0, 0), dtype=bool)  # keep every ray, or skip the mask (sim.camera_rays)


@dataclass(frozen=True, eq=False)
class DepthRender:
    """One rendered depth frame with its noise-free truth.

    Attributes
    ----------
    depth_mm : np.ndarray
        (H, W) uint16 measured z-depth [mm]; 0 = no return.
    labels : np.ndarray
        (H, W) uint8 :class:`fusion.depth.Label` of the surface each returned pixel sees; NONE where
        ``depth_mm`` is 0.
    depth_ideal_m : np.ndarray
        (H, W) float64 noise-free z-depth [m] of the surface the pixel sees (after lateral jitter,
        before dropouts, axial noise, flying pixels, offset and quantisation); NaN where no surface.
    incidence_rad : np.ndarray
        (H, W) float64 incidence angle of that surface [rad] in [0, pi/2]; NaN where no surface.
    """

    depth_mm: np.ndarray
    labels: np.ndarray
    depth_ideal_m: np.ndarray
    incidence_rad: np.ndarray

    def __post_init__(self) -> None:
        depth = np.ascontiguousarray(self.depth_mm)
        labels = np.ascontiguousarray(self.labels)
        ideal = np.ascontiguousarray(self.depth_ideal_m, dtype=np.float64)
        theta = np.ascontiguousarray(self.incidence_rad, dtype=np.float64)
        if depth.dtype != np.uint16 or depth.ndim != 2:
            raise BadInputError(f"depth_mm must be (H, W) uint16, got {depth.dtype} {depth.shape}")
        if labels.dtype != np.uint8 or labels.shape != depth.shape:
            raise BadInputError(f"labels must be uint8 of shape {depth.shape}, got {labels.dtype} {labels.shape}")
        if ideal.shape != depth.shape or theta.shape != depth.shape:
            raise BadInputError(f"depth_ideal_m and incidence_rad must have shape {depth.shape}")
        for name, arr in (("depth_mm", depth), ("labels", labels), ("depth_ideal_m", ideal), ("incidence_rad", theta)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)


class DepthCamera:
    """A virtual depth camera at a fixed pose that renders frames of a MuJoCo scene by ray casting.

    Parameters
    ----------
    placement : the camera's name, ``T_world_cam`` (4, 4) and intrinsics (image size, range).
    noise : the sensor noise model; :meth:`DepthNoise.none` for an ideal sensor.
    body_group : MuJoCo geom group (0-5) of the geoms labelled BODY; other groups are invisible.
    floor : whether the floor plane z = 0 (world frame) is seen, labelled FLOOR.
    renderer : what renders the body (``AUTO`` is resolved here, see :meth:`DepthRenderer.resolve`).
    """

    def __init__(
        self, placement: CameraPlacement, noise: DepthNoise = DepthNoise(), *, body_group: int = 1, floor: bool = True,
        renderer: DepthRenderer = DepthRenderer.RAYCAST,
    ) -> None:
        if not isinstance(placement, CameraPlacement) or not isinstance(noise, DepthNoise):
            raise BadInputError("DepthCamera needs a CameraPlacement and a DepthNoise")
        if isinstance(body_group, bool) or body_group not in range(6):
            raise BadInputError(f"body_group must be a MuJoCo geom group 0-5, got {body_group!r}")
        if not isinstance(renderer, DepthRenderer):
            raise BadInputError(f"renderer must be a DepthRenderer, got {renderer!r}")
        self._placement = placement
        self._noise = noise
        self._body_group = int(body_group)
        self._renderer = renderer.resolve()
        self._gl: GLBodyDepth | None = None
        intr = placement.intrinsics
        self._R_world_cam = placement.T_world_cam[:3, :3]
        self._origin = placement.T_world_cam[:3, 3]
        self._geomgroup = tuple(g == self._body_group for g in range(6))
        self._cos_grazing_end = np.cos(np.radians(noise.grazing_end_deg))
        self._jitter_rad = JITTER_CLIP * noise.lateral_sigma_px / min(intr.fx, intr.fy)
        self._jitter_pad = int(np.ceil(JITTER_CLIP * noise.lateral_sigma_px)) + 1  # px a jittered ray may stray
        self._pixel_rad = 1.0 / min(intr.fx, intr.fy)  # rays through points within 0.71 px are closer than this

        rays = intr.pixel_rays()
        self._dir_cam_img = rays / np.linalg.norm(rays, axis=-1, keepdims=True)  # (H, W, 3) unit
        self._dir_cam = self._dir_cam_img.reshape(-1, 3)
        self._dir_world = self._dir_cam @ self._R_world_cam.T
        self._dir_cam_z = np.ascontiguousarray(self._dir_cam[:, 2])
        at = intr.backproject(np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]), np.ones(3))  # affine in (u, v)
        self._uv_to_world = self._R_world_cam @ np.column_stack([at[1] - at[0], at[2] - at[0], at[0]])

        n_pix = intr.width * intr.height
        self._floor_depth = np.full(n_pix, np.nan)
        self._floor_theta = np.full(n_pix, np.nan)
        self._floor_label = np.full(n_pix, Label.NONE, dtype=np.uint8)
        dz = self._dir_world[:, 2]
        self._floor_seen = bool(floor and self._origin[2] > 0)
        if self._floor_seen:
            seen = np.flatnonzero(dz < 0)
            self._floor_depth[seen] = -self._origin[2] / dz[seen] * self._dir_cam[seen, 2]
            self._floor_theta[seen] = np.arccos(np.clip(-dz[seen], 0.0, 1.0))
            self._floor_label[seen] = Label.FLOOR
        self._floor_sigma_m = np.full(n_pix, np.nan)
        finite = np.isfinite(self._floor_depth)
        self._floor_sigma_m[finite] = 1e-3 * sigma_axial_mm(self._floor_depth[finite], self._floor_theta[finite], noise)
        self._floor_drop_p = noise.grazing_drop_prob(self._floor_theta)

    @property
    def placement(self) -> CameraPlacement:
        """The camera's name, pose and intrinsics."""
        return self._placement

    @property
    def noise(self) -> DepthNoise:
        """The sensor noise model."""
        return self._noise

    @property
    def renderer(self) -> DepthRenderer:
        """RAYCAST or MUJOCO: what renders the body."""
        return self._renderer

    @property
    def body_group(self) -> int:
        """MuJoCo geom group of the geoms labelled BODY."""
        return self._body_group

    def render(self, model: mujoco.MjModel, data: mujoco.MjData, *, rng: np.random.Generator) -> DepthRender:
        """Render one depth frame of the scene in its current pose.

        Parameters
        ----------
        model, data : the scene; ``data`` must hold current kinematics (``mj_kinematics`` or
            ``mj_forward``).
        rng : source of all noise in this frame.

        Returns
        -------
        DepthRender
            (H, W) measured depth [mm], labels and the noise-free depth and incidence angle.

        Raises
        ------
        BadInputError
            ``data`` not of ``model``, body geoms with non-finite or un-computed poses, or ``rng``
            not a ``np.random.Generator``.
        """
        if not isinstance(rng, np.random.Generator):
            raise BadInputError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        geoms = self._body_geoms(model, data)
        noise, intr = self.noise, self.placement.intrinsics
        if self._renderer is DepthRenderer.MUJOCO:
            if self._gl is None or self._gl.model is not model:
                self._gl = GLBodyDepth(model, self.placement, self.body_group)
            body_pix, body_depth, body_theta = self._gl.body_hits(data, self._floor_depth, noise.lateral_sigma_px, rng,
                                                                  self._body_box(model, data, geoms))
        else:
            body_pix, body_depth, body_theta = self._cast_body(model, data, *self._candidate_pixels(model, data, geoms),
                                                               rng)
        depth, theta = self._floor_depth.copy(), self._floor_theta.copy()
        depth[body_pix], theta[body_pix] = body_depth, body_theta
        box = (0, 0, 0, 0)  # where flying pixels are looked for: the body's pixels and a pixel around them
        if body_pix.size:
            cols = body_pix % intr.width
            box = (body_pix[0] // intr.width - 1, body_pix[-1] // intr.width + 2, cols.min() - 1, cols.max() + 2)
        depth_mm, label = measure_frame(
            depth.reshape(intr.height, intr.width), self._floor_sigma_m, self._floor_drop_p, self._floor_label,
            body_pix, 1e-3 * sigma_axial_mm(body_depth, body_theta, noise), noise.grazing_drop_prob(body_theta), box,
            (noise.edge_jump_min_m, noise.edge_jump_rel), (noise.flying_prob, noise.flying_spread),
            (1e-3 * noise.offset_mm, intr.min_depth_m, intr.max_depth_m), (np.uint8(Label.BODY), np.uint8(Label.NONE)),
            rng)
        shape = (intr.height, intr.width)
        return DepthRender(depth_mm.reshape(shape), label.reshape(shape), depth.reshape(shape), theta.reshape(shape))

    def _body_geoms(self, model: mujoco.MjModel, data: mujoco.MjData) -> np.ndarray:
        """Ids of the body geoms after checking the scene's state."""
        if not isinstance(model, mujoco.MjModel) or not isinstance(data, mujoco.MjData):
            raise BadInputError("render needs a mujoco.MjModel and its mujoco.MjData")
        if data.geom_xpos.shape[0] != model.ngeom or data.qpos.shape[0] != model.nq:
            raise BadInputError("data does not belong to model (geom or coordinate counts differ)")
        geoms = np.flatnonzero(model.geom_group == self.body_group)
        xpos, xmat = data.geom_xpos[geoms], data.geom_xmat[geoms]
        if not (np.all(np.isfinite(xpos)) and np.all(np.isfinite(xmat))):
            raise BadInputError("body geoms have non-finite poses; check the pose (qpos) for NaN")
        if np.any(np.abs(np.einsum("gi,gi->g", xmat, xmat) - 3.0) > 1e-6):
            raise BadInputError("body geom orientations are not rotations; run mujoco.mj_kinematics first")
        return geoms

    def _cones(
        self, model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray, widen_rad: float,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None:
        """The cones from the camera round the body geoms' bounding spheres, widened by ``widen_rad``.

        Returns the spheres' unit directions (S, 3) in the camera frame, the half-angles of the
        spheres (S,) [rad], the cones' half-angles (S,) [rad] and their pixel boxes ``lo``, ``hi``
        (S, 2) (u, v; ``hi`` exclusive); None where some cone is a half-space or wider (a plane, or a
        geom around or beside the camera), so that any pixel may see it.
        """
        intr = self.placement.intrinsics
        centres_world, radii = _bounding_spheres(model, data, geoms)
        c = (centres_world - self._origin) @ self._R_world_cam  # camera frame
        dist = np.linalg.norm(c, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            bound = np.where((radii > 0) & (radii < dist), np.arcsin(radii / dist), np.pi)
        alpha = bound + widen_rad
        if np.any(alpha >= _HALF_PI):
            return None
        corners = c[:, None, :] + (dist * np.sin(alpha))[:, None, None] * _CUBE  # a sphere subtending each cone
        in_front = corners[:, :, 2].min(axis=1) > 0
        uv, _ = intr.project(np.where(in_front[:, None, None], corners, 1.0))
        uv = uv.clip(-1.0, [intr.width + 1.0, intr.height + 1.0])
        lo = np.where(in_front[:, None], np.floor(uv.min(axis=1)), 0).astype(int)
        hi = np.where(in_front[:, None], np.ceil(uv.max(axis=1)) + 1, [intr.width, intr.height]).astype(int)
        return c / dist[:, None], bound, alpha, lo, hi

    def _body_box(self, model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray) -> tuple[int, int, int, int]:
        """Image rows and columns ``(r0, r1, c0, c1)`` that can see a body geom, with the lateral
        jitter's reach (:attr:`_jitter_pad` pixels) around them: what MuJoCo's renderer draws."""
        intr = self.placement.intrinsics
        cones = self._cones(model, data, geoms, self._pixel_rad)
        if cones is None or not geoms.size:
            return 0, intr.height, 0, intr.width
        lo, hi = cones[3].min(axis=0) - self._jitter_pad, cones[4].max(axis=0) + self._jitter_pad
        r0, r1, c0, c1 = max(lo[1], 0), min(hi[1], intr.height), max(lo[0], 0), min(hi[0], intr.width)
        return (r0, r1, c0, c1) if r0 < r1 and c0 < c1 else (0, 1, 0, 1)

    def _candidate_pixels(
        self, model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """Pixels whose (jittered) ray can hit one of the body geoms' bounding spheres.

        Returns their flat indices and a mask of the pixels within a pixel of a ray that can hit a
        bounding sphere, padded on every side by the farthest a jittered ray can stray off the image
        (padding True): a jittered ray whose nearest pixel is outside the mask misses every body geom.
        The mask is None where it would not thin the rays (jitter under a pixel, or every pixel cast).
        """
        intr = self.placement.intrinsics
        cones = self._cones(model, data, geoms, self._jitter_rad)
        if cones is None:  # cast every pixel
            return np.arange(intr.width * intr.height), None
        axes, bound, alpha, lo, hi = cones
        mask = np.zeros((intr.height, intr.width), dtype=bool)
        near, inner = None, _NO_MASK
        if self._jitter_rad >= self._pixel_rad:
            near = np.pad(np.zeros_like(mask), self._jitter_pad, constant_values=True)
            inner = near[self._jitter_pad : -self._jitter_pad, self._jitter_pad : -self._jitter_pad]
        cone_mask(self._dir_cam_img, lo, hi, axes, np.cos(alpha), np.cos(bound + self._pixel_rad), mask, inner)
        return np.flatnonzero(mask), near

    def _cast_body(
        self, model: mujoco.MjModel, data: mujoco.MjData, pix: np.ndarray, near: np.ndarray | None,
        rng: np.random.Generator,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Cast the (jittered) rays of pixels ``pix`` at the body geoms.

        ``near`` is the mask of :meth:`_candidate_pixels`: rays whose nearest pixel lies outside it
        are not cast (they miss). Returns the pixels that see a body geom before the floor, their
        z-depth [m] and incidence [rad].
        """
        shift = _NO_SHIFT
        if self.noise.lateral_sigma_px > 0:
            shift = lateral_jitter_px(pix.size, self.noise.lateral_sigma_px, rng)
        keep, dirs, z_cam = jittered_rays(pix, shift, _NO_MASK if near is None else near, self._jitter_pad,
                                          self.placement.intrinsics.width, self._uv_to_world)
        hits = cast_rays(model, data, self._origin, dirs, geomgroup=self._geomgroup, cutoff_m=np.inf, check=False)
        floor_height = self._origin[2] if self._floor_seen else np.inf
        return hit_depths(pix[keep], dirs, z_cam, hits.dist, hits.normal_world, floor_height, self._dir_world,
                          self._dir_cam_z, self._cos_grazing_end)


def _bounding_spheres(model: mujoco.MjModel, data: mujoco.MjData, geoms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Spheres covering the geoms: centres (P, 3) world frame [m] and radii (P,) [m], P >= len(geoms).

    An elongated geom (a limb capsule) gets a row of spheres along the longest axis of its bounding
    box, one per slice, when their summed cross-sections are smaller than its bounding sphere's;
    other geoms keep MuJoCo's bounding sphere (radius 0 for planes: unbounded).
    """
    rbound = model.geom_rbound[geoms]
    box_centre, half = model.geom_aabb[geoms, :3], model.geom_aabb[geoms, 3:]
    longest = np.argmax(half, axis=1)
    h = np.sort(half, axis=1)
    cross = np.where(np.isin(model.geom_type[geoms], _ROUND), h[:, 1], np.hypot(h[:, 0], h[:, 1]))
    with np.errstate(divide="ignore", invalid="ignore"):
        n = np.nan_to_num(np.ceil(h[:, 2] / h[:, 1]), nan=1.0).clip(1, _MAX_PIECES).astype(int)
    slice_half = h[:, 2] / n
    piece_r = np.hypot(cross, slice_half)
    split = n * piece_r**2 < rbound**2
    n = np.where(split, n, 1)
    g = np.repeat(np.arange(geoms.size), n)
    i = np.arange(g.size) - np.repeat(np.cumsum(n) - n, n)  # slice index within its geom
    local = np.where(split[g, None], box_centre[g], 0.0)  # rbound is about the geom origin
    local[np.arange(g.size), longest[g]] += np.where(split[g], (2 * i + 1 - n[g]) * slice_half[g], 0.0)
    xmat = data.geom_xmat[geoms].reshape(-1, 3, 3)[g]
    centres = data.geom_xpos[geoms][g] + np.einsum("pij,pj->pi", xmat, local)
    return centres, np.where(split[g], piece_r[g], rbound[g])
