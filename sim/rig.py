"""Camera rigs: rings of depth cameras around the subject, or explicit camera poses.

World frame: z up, floor at z = 0, the subject starts at the origin facing +x. Ring angles are
measured counter-clockwise (seen from above) from the subject's front; cameras are numbered from 1
counter-clockwise, as in the paper. Camera frames use the Kinect v2 convention
(+z forward, +y up, +x to the sensor's left).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fusion.camera import KINECT_V2_DEPTH, AxisConvention, Intrinsics
from fusion.errors import BadInputError
from fusion.transforms import make_transform, validate_transform


@dataclass(frozen=True, eq=False)
class CameraPlacement:
    """One camera of a rig: its name, true pose ``T_world_cam`` (4, 4) and intrinsics."""

    name: str
    T_world_cam: np.ndarray
    intrinsics: Intrinsics = KINECT_V2_DEPTH

    def __post_init__(self) -> None:
        T = validate_transform(self.T_world_cam, f"T_world_cam of {self.name}").copy()
        T.setflags(write=False)
        object.__setattr__(self, "T_world_cam", T)

    @property
    def position(self) -> np.ndarray:
        """Camera centre in the world frame, (3,) metres."""
        return self.T_world_cam[:3, 3]


@dataclass(frozen=True)
class Rig:
    """An ordered set of cameras with unique names."""

    cameras: tuple[CameraPlacement, ...]

    def __post_init__(self) -> None:
        object.__setattr__(self, "cameras", tuple(self.cameras))
        names = [c.name for c in self.cameras]
        if not names:
            raise BadInputError("a rig needs at least one camera")
        if len(set(names)) != len(names):
            raise BadInputError(f"camera names must be unique, got {names}")

    @property
    def names(self) -> tuple[str, ...]:
        """Camera names in rig order."""
        return tuple(c.name for c in self.cameras)


def look_at(position: np.ndarray, target: np.ndarray, up: np.ndarray | None = None) -> np.ndarray:
    """``T_world_cam`` (4, 4) of a Kinect-convention camera at ``position`` looking at ``target``.

    Parameters
    ----------
    position, target : (3,) world points [m].
    up : (3,), optional
        Direction the camera's +y (the top of its image) points to; only its part across the
        view counts. None: +y as close to world up (+z) as the view allows, i.e. no roll.

    Raises
    ------
    BadInputError
        Coinciding points, a view straight up or down without ``up``, or ``up`` along the view.
    """
    position = np.asarray(position, dtype=float)
    z = np.asarray(target, dtype=float) - position
    norm = np.linalg.norm(z)
    if not np.isfinite(norm) or norm < 1e-9:
        raise BadInputError("camera position and target must be distinct finite points")
    z /= norm
    if up is None:
        if abs(z[2]) > 0.999:
            raise BadInputError("a camera looking straight up or down has no defined roll; tilt it less or give up")
        up = np.array([0.0, 0.0, 1.0])
    x = np.cross(np.asarray(up, dtype=float), z)  # sensor's left = up x forward
    if not np.all(np.isfinite(x)) or np.linalg.norm(x) < 1e-6 * max(np.linalg.norm(up), 1e-300):
        raise BadInputError(f"the camera's up direction {list(up)} lies along its view; give one across it")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return make_transform(np.stack([x, y, z], axis=1), position)


def view_of(T_world_cam: np.ndarray, axes: AxisConvention) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centre, viewing direction and image-up direction of a camera pose in its native axes.

    ``look_at(centre, centre + forward, up)`` gives the pose back in Kinect v2 axes, whatever
    ``axes`` is (:func:`as_azure_kinect` turns it into OpenCV axes again).

    Parameters
    ----------
    T_world_cam : (4, 4) pose [m], in the camera's ``axes``.
    axes : the camera frame's axis convention (Kinect v2: +y up; OpenCV: +y down).

    Returns
    -------
    centre, forward, up : (3,) each, world frame; metres and unit vectors.
    """
    T = validate_transform(T_world_cam, "T_world_cam")
    up = T[:3, 1] if AxisConvention(axes) is AxisConvention.KINECT_V2 else -T[:3, 1]
    return T[:3, 3].copy(), T[:3, 2].copy(), up.copy()


def ring_rig(
    n_cameras: int,
    *,
    radius_m: float = 2.0,
    height_m: float = 1.0,
    target_height_m: float = 1.0,
    start_deg: float = 0.0,
    angles_deg: list[float] | None = None,
    subset: list[int] | None = None,
    intrinsics: Intrinsics = KINECT_V2_DEPTH,
) -> Rig:
    """A ring of cameras around the origin, each looking at ``(0, 0, target_height_m)``.

    Parameters
    ----------
    n_cameras : cameras evenly spaced on the ring (ignored when ``angles_deg`` is given).
    radius_m, height_m : ring radius and camera height [m].
    target_height_m : height of the point every camera looks at [m]; sets the tilt.
    start_deg : angle of camera 1 from the subject's front [deg], counter-clockwise.
    angles_deg : explicit angles [deg] instead of an even spacing.
    subset : 1-based camera numbers to keep, e.g. ``[1, 3, 5]``; names keep their ring number.
    intrinsics : intrinsics of every camera.
    """
    if angles_deg is None:
        if n_cameras < 1:
            raise BadInputError(f"n_cameras must be >= 1, got {n_cameras}")
        angles = start_deg + 360.0 * np.arange(n_cameras) / n_cameras
    else:
        angles = np.asarray(angles_deg, dtype=float)
    if radius_m <= 0 or not np.all(np.isfinite(angles)):
        raise BadInputError("ring radius must be positive and angles finite")
    numbers = list(range(1, len(angles) + 1))
    if subset is not None:
        bad = [k for k in subset if k not in numbers]
        if bad or len(set(subset)) != len(subset):
            raise BadInputError(f"subset {subset} must name distinct cameras among {numbers}")
        numbers = sorted(subset)
    cams = []
    for k in numbers:
        a = np.radians(angles[k - 1])
        pos = np.array([radius_m * np.cos(a), radius_m * np.sin(a), height_m])
        cams.append(CameraPlacement(f"cam{k}", look_at(pos, [0.0, 0.0, target_height_m]), intrinsics))
    return Rig(tuple(cams))


def vary_intrinsics(base: Intrinsics, *, rng: np.random.Generator) -> Intrinsics:
    """Per-unit intrinsics around ``base`` with the spread of real Kinect v2 units (fx 355-367,
    cx 253-267, cy 199-208 for the default 365.5 / 255.5 / 211.5), scaled to ``base``'s image size."""
    f = base.fx * rng.uniform(355.0, 367.0) / 365.5
    sx, sy = base.width / 512.0, base.height / 424.0
    return Intrinsics(
        width=base.width, height=base.height, fx=f, fy=f * rng.uniform(0.998, 1.002),
        cx=base.cx + sx * rng.uniform(-2.5, 11.5), cy=base.cy + sy * rng.uniform(-12.5, -3.5),
        min_depth_m=base.min_depth_m, max_depth_m=base.max_depth_m, axes=base.axes,
    )


AZURE_KINECT_NFOV = Intrinsics(width=640, height=576, fx=504.0, fy=504.0, cx=319.5, cy=287.5, min_depth_m=0.5,
                               max_depth_m=3.86, axes=AxisConvention.OPENCV)
"""Azure Kinect / Orbbec Femto narrow-field-of-view unbinned depth mode (typical values)."""

_KINECT_TO_OPENCV = np.diag([-1.0, -1.0, 1.0, 1.0])
"""``T_kinect_opencv``: the OpenCV-convention camera frame (x right, y down) expressed in Kinect v2 axes."""


def as_azure_kinect(placement: CameraPlacement, intrinsics: Intrinsics = AZURE_KINECT_NFOV) -> CameraPlacement:
    """The same camera as an Azure Kinect / Orbbec sensor: OpenCV axes (+x right, +y down, +z forward),
    as the K4ABT body tracker reports, and Azure Kinect depth intrinsics."""
    if intrinsics.axes is not AxisConvention.OPENCV:
        raise BadInputError("Azure Kinect intrinsics must use the OpenCV axis convention")
    return CameraPlacement(placement.name, placement.T_world_cam @ _KINECT_TO_OPENCV, intrinsics)
