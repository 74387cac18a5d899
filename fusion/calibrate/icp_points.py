"""Points of one depth frame for ICP: the body and the floor near the feet.

The paper (3.4) adds the floor points near the subject's feet to the body points to increase the
overlap between two cameras' clouds.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from fusion.calibrate.floor import fit_floor_plane, fit_plane_lstsq
from fusion.camera import AxisConvention, Intrinsics
from fusion.depth import Label, depth_to_points
from fusion.errors import BadInputError, CalibrationError


def _up_direction(intrinsics: Intrinsics) -> np.ndarray:
    """Camera-frame 'up' of a level camera: +y for Kinect v2 axes, -y for OpenCV axes."""
    return np.array([0.0, 1.0, 0.0]) if intrinsics.axes is AxisConvention.KINECT_V2 else np.array([0.0, -1.0, 0.0])


_CELL_M = 0.05
"""Grid cell [m] of :func:`within_distance`'s first pass."""


def within_distance(points: np.ndarray, tree: cKDTree, radius_m: float) -> np.ndarray:
    """(N,) bool: which of the (N, 3) ``points`` [m] lie closer than ``radius_m`` to a point of ``tree``.

    Exactly ``tree.query(points, distance_upper_bound=radius_m)[0] < radius_m``, in two passes: the
    centres of the :data:`_CELL_M` grid cells holding the points are queried first, and a cell whose
    centre's distance settles every point in it (half its diagonal away from the radius) is decided
    at once; only the points of the cells near the boundary are queried one by one. A floor of tens
    of thousands of points has a few thousand cells, and its boundary a few per cent of the points.
    """
    if points.shape[0] == 0:
        return np.zeros(0, dtype=bool)
    if not np.all(np.isfinite(points)):
        raise BadInputError("points must be finite (no NaN or infinite coordinates)")
    raw = np.floor(points / _CELL_M).astype(np.int64)
    cell = raw - raw.min(axis=0)
    span = cell.max(axis=0) + 1
    _, first, inverse = np.unique((cell[:, 0] * span[1] + cell[:, 1]) * span[2] + cell[:, 2], return_index=True,
                                  return_inverse=True)
    centres = (raw[first] + 0.5) * _CELL_M
    half = _CELL_M * np.sqrt(3.0) / 2 + 1e-9
    d = tree.query(centres, distance_upper_bound=radius_m + half)[0]
    sure_in, sure_out = (d + half < radius_m)[inverse], (d - half >= radius_m)[inverse]
    near = sure_in.copy()
    unsure = np.flatnonzero(~sure_in & ~sure_out)
    near[unsure] = tree.query(points[unsure], distance_upper_bound=radius_m)[0] < radius_m
    return near


def select_calibration_points(
    depth_mm: np.ndarray,
    labels: np.ndarray | None,
    intrinsics: Intrinsics,
    *,
    rng: np.random.Generator,
    joints_cam: np.ndarray | None = None,
    floor_radius_m: float = 0.6,
    body_radius_m: float = 0.25,
    foot_height_m: float = 0.15,
    floor_threshold_m: float = 0.02,
) -> np.ndarray:
    """Body points plus the floor points near the feet of one depth frame, for ICP.

    With labels: the BODY pixels; the feet are the body points within ``foot_height_m`` of the
    least-squares plane of the FLOOR pixels, and the floor points kept are the FLOOR pixels within
    ``floor_radius_m`` of a foot point (``joints_cam`` is not needed).

    Without labels (``joints_cam`` required): the feet are the joints within ``foot_height_m`` of
    the lowest joint, "up" being the camera's +y (Kinect v2 axes) or -y (OpenCV axes), so the camera
    should be roughly level. A plane is fitted by seeded RANSAC to the points within
    ``floor_radius_m`` of the feet; if it is floor-like (within 45 degrees of level, below the
    joints) its inliers there are the floor points. The body points are those within
    ``body_radius_m`` of a joint and more than ``floor_threshold_m`` above that plane.

    Floor points are omitted when no floor is found near the feet.

    Parameters
    ----------
    depth_mm : (H, W) uint16 depth [mm].
    labels : (H, W) uint8 :class:`~fusion.depth.Label` values, or None.
    intrinsics : the camera's intrinsics.
    rng : random source of the RANSAC floor fit (used only without labels).
    joints_cam : (J, 3) skeleton joints in the camera frame [m]; NaN rows are ignored.
    floor_radius_m, body_radius_m, foot_height_m, floor_threshold_m : distances [m], see above.

    Returns
    -------
    (N, 3) points [m] in the camera frame: body points first, then floor points.

    Raises
    ------
    BadInputError
        Malformed inputs, or neither labels nor any finite joint.
    """
    radii = (floor_radius_m, body_radius_m, foot_height_m, floor_threshold_m)
    if not all(np.isfinite(r) and r > 0 for r in radii):
        raise BadInputError(f"radii and thresholds must be positive, got {radii}")
    points, point_labels = depth_to_points(depth_mm, intrinsics, labels)
    if labels is not None:
        if np.asarray(labels).shape != np.asarray(depth_mm).shape:
            raise BadInputError(
                f"labels shape {np.asarray(labels).shape} differs from depth shape {np.asarray(depth_mm).shape}"
            )
        body = points[point_labels == Label.BODY]
        floor = points[point_labels == Label.FLOOR]
        if floor.shape[0] < 3 or body.shape[0] == 0:
            return body
        normal, offset = fit_plane_lstsq(floor)
        feet = body[np.abs(body @ normal + offset) < foot_height_m]
        if feet.shape[0] == 0:
            return body
        near = within_distance(floor, cKDTree(feet), floor_radius_m)
        return np.vstack([body, floor[near]])

    if joints_cam is None:
        raise BadInputError("without labels, joints_cam is needed to find the body and the feet")
    joints = np.asarray(joints_cam, dtype=float)
    if joints.ndim != 2 or joints.shape[1] != 3:
        raise BadInputError(f"joints_cam must have shape (J, 3), got {joints.shape}")
    joints = joints[np.all(np.isfinite(joints), axis=1)]
    if joints.shape[0] == 0:
        raise BadInputError("joints_cam has no finite joint")
    up = _up_direction(intrinsics)
    height = joints @ up
    feet = joints[height < height.min() + foot_height_m]
    near_feet = within_distance(points, cKDTree(feet), floor_radius_m)
    near_body = within_distance(points, cKDTree(joints), body_radius_m)
    above = np.ones(points.shape[0], dtype=bool)
    floor_mask = np.zeros(points.shape[0], dtype=bool)
    if np.count_nonzero(near_feet) >= 3:
        try:
            plane = fit_floor_plane(points[near_feet], rng=rng, threshold_m=floor_threshold_m)
        except CalibrationError:
            plane = None
        if plane is not None:
            dist = points @ plane.normal + plane.offset
            level = abs(plane.normal @ up) > np.cos(np.radians(45.0))
            below_joints = np.median(joints @ plane.normal + plane.offset) > 0
            if level and below_joints:
                floor_mask = near_feet & (np.abs(dist) < floor_threshold_m)
                above = dist > floor_threshold_m
    return np.vstack([points[near_body & above], points[floor_mask]])
