"""Small static MuJoCo scenes with closed-form depth, and test poses of the humanoid.

The scenes (spheres and flat walls over an optional floor) check the depth camera by
render-then-measure: each shape knows, in closed form, the z-depth every pixel of a camera sees.
Shapes are compiled into geom group :data:`sim.humanoid_model.BODY_GEOM_GROUP`, which
:class:`sim.depth_camera.DepthCamera` renders by default; the floor plane z = 0 goes in group 0.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from fusion.errors import BadInputError
from sim.coordinates import COORDINATES, INDEX
from sim.humanoid_model import BODY_GEOM_GROUP
from sim.rig import CameraPlacement

_HAND_BEHIND_BACK = {"sh_elevation_r": 0.22, "sh_rotation_r": -2.15, "elbow_flexion_r": 1.54}


def pixel_rays_world(placement: CameraPlacement) -> np.ndarray:
    """(H, W, 3) pixel-centre ray directions of a camera, scaled to camera z = 1, in the world frame."""
    return placement.intrinsics.pixel_rays() @ placement.T_world_cam[:3, :3].T


def _point(value: np.ndarray, name: str) -> np.ndarray:
    p = np.array(value, dtype=float)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise BadInputError(f"{name} must be a finite (3,) point [m], got {value!r}")
    p.setflags(write=False)
    return p


@dataclass(frozen=True, eq=False)
class Sphere:
    """A sphere.

    Attributes
    ----------
    centre_world : np.ndarray
        (3,) centre [m], world frame.
    radius_m : float
        Radius [m], positive.
    """

    centre_world: np.ndarray
    radius_m: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "centre_world", _point(self.centre_world, "centre_world"))
        if not (np.isfinite(self.radius_m) and self.radius_m > 0):
            raise BadInputError(f"radius_m must be positive, got {self.radius_m}")

    def geom(self) -> dict:
        """Keyword arguments of ``MjsBody.add_geom`` for this sphere."""
        return dict(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[self.radius_m, 0, 0], pos=list(self.centre_world))

    def depth(self, placement: CameraPlacement) -> tuple[np.ndarray, np.ndarray]:
        """Closed-form z-depth of the sphere per pixel centre of a camera.

        Returns
        -------
        z : np.ndarray
            (H, W) z-depth [m] of the first intersection; NaN where the pixel ray misses.
        rim : np.ndarray
            (H, W) angle [rad] between each pixel ray and the silhouette cone, negative inside it:
            pixels with ``|rim|`` below the lateral noise straddle the silhouette.
        """
        d = pixel_rays_world(placement)
        d_norm = np.linalg.norm(d, axis=-1)
        oc = self.centre_world - placement.position
        dist = np.linalg.norm(oc)
        b = (d @ oc) / d_norm
        disc = b**2 - (dist**2 - self.radius_m**2)
        with np.errstate(invalid="ignore"):
            t = b - np.sqrt(disc)
        z = np.where(disc >= 0, t / d_norm, np.nan)
        rim = np.arccos(np.clip(b / dist, -1, 1)) - np.arcsin(min(self.radius_m / dist, 1.0))
        return z, rim

    def image_centre(self, placement: CameraPlacement) -> np.ndarray:
        """(2,) pixel (u, v) of the centre of the sphere's image, an ellipse, by the intrinsics.

        The silhouette cone ``(d . c)^2 = |d|^2 (|c|^2 - r^2)`` (camera frame, ``c`` the centre)
        meets the image plane z = 1 in a conic whose centre is projected with the intrinsics. Off
        the optical axis it lies outward of the projected sphere centre (perspective).
        """
        c = (self.centre_world - placement.position) @ placement.T_world_cam[:3, :3]
        conic = np.outer(c, c) - (c @ c - self.radius_m**2) * np.eye(3)
        xy = np.linalg.solve(conic[:2, :2], -conic[:2, 2])
        uv, _ = placement.intrinsics.project(np.append(xy, 1.0))
        return uv


@dataclass(frozen=True, eq=False)
class Wall:
    """A flat wall (a 20 m x 20 m x 2 cm box) whose front face passes through a point.

    The front face looks along world -x, turned ``tilt_deg`` about world z (counter-clockwise seen
    from above), so a camera on the -x side looking along +x sees it at incidence ``tilt_deg`` at
    the image centre.

    Attributes
    ----------
    point_world : np.ndarray
        (3,) a point of the front face [m], world frame.
    tilt_deg : float
        Turn of the wall about world z [deg], in (-90, 90).
    """

    point_world: np.ndarray
    tilt_deg: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "point_world", _point(self.point_world, "point_world"))
        if not (np.isfinite(self.tilt_deg) and abs(self.tilt_deg) < 90):
            raise BadInputError(f"tilt_deg must lie in (-90, 90), got {self.tilt_deg}")

    @property
    def normal_world(self) -> np.ndarray:
        """(3,) unit outward normal of the front face, world frame."""
        a = np.radians(self.tilt_deg)
        return np.array([-np.cos(a), -np.sin(a), 0.0])

    def geom(self) -> dict:
        """Keyword arguments of ``MjsBody.add_geom`` for this wall."""
        a = np.radians(self.tilt_deg)
        centre = self.point_world - 0.01 * self.normal_world
        return dict(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.01, 10, 10], pos=list(centre),
                    quat=[np.cos(a / 2), 0, 0, np.sin(a / 2)])

    def depth(self, placement: CameraPlacement) -> tuple[np.ndarray, np.ndarray]:
        """Closed-form z-depth [m] and incidence angle [rad] of the front face's plane, each (H, W).

        The plane is unbounded here: pixels whose rays run past the box's edge are not masked.
        """
        n = self.normal_world
        d = pixel_rays_world(placement)
        with np.errstate(divide="ignore"):
            z = (n @ (self.point_world - placement.position)) / (d @ n)
        theta = np.arccos(np.clip(-(d @ n) / np.linalg.norm(d, axis=-1), -1.0, 1.0))
        return z, theta


def compile_scene(*shapes: Sphere | Wall, floor: bool = True) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """Compile a static world of ``shapes`` (geom group ``BODY_GEOM_GROUP``) with its kinematics done.

    Parameters
    ----------
    shapes : the spheres and walls, geom ids 1, 2, ... when ``floor`` (0, 1, ... without).
    floor : add the floor plane z = 0 (geom ``"floor"``, group 0) first.

    Returns
    -------
    model, data : ``data`` after ``mj_kinematics``, ready to render or ray-cast.
    """
    if not all(isinstance(s, (Sphere, Wall)) for s in shapes):
        raise BadInputError("compile_scene takes Sphere and Wall shapes")
    spec = mujoco.MjSpec()
    if floor:
        spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[20, 20, 0.1], group=0)
    for shape in shapes:
        spec.worldbody.add_geom(group=BODY_GEOM_GROUP, **shape.geom())
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    return model, data


def hand_behind_back() -> np.ndarray:
    """(K,) humanoid coordinates: standing, the right hand behind the lower back.

    The right wrist, hand, hand tip and thumb are hidden from a camera in front of the subject and
    seen by a camera behind.
    """
    coords = np.zeros(len(COORDINATES))
    for name, value in _HAND_BEHIND_BACK.items():
        coords[INDEX[name]] = value
    return coords
