"""Floor plane: a seeded RANSAC fit, the world frame it defines, and gauge alignment against truth.

World frame convention (:func:`world_from_floor`): right-handed, metres, +z up (along the floor
normal), the floor is z = 0, the origin is the floor point under the subject's start position, and
+x is the subject's initial facing direction projected on the floor (+y is then the subject's left).
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from fusion.calibrate.kabsch import kabsch
from fusion.errors import BadInputError, CalibrationError
from fusion.transforms import apply, compose, invert, make_transform, validate_transform

_SCORE_CHUNK = 8192
"""Points scored against all RANSAC hypotheses at once (bounds memory to chunk x n_trials)."""
_MAX_REFITS = 5


@dataclass(frozen=True, eq=False)
class FloorPlane:
    """A plane ``normal . p + offset = 0`` in the frame of the points it was fitted to.

    Attributes
    ----------
    normal : np.ndarray
        (3,) unit normal, oriented toward the frame's origin (``offset >= 0``): for a floor fitted
        in a camera frame it points up, toward the camera.
    offset : float
        Distance of the frame origin from the plane [m].
    inliers : np.ndarray
        (N,) bool, the fitted points within the threshold of the plane.
    rmse_m : float
        Root mean square distance of the inliers from the plane [m].
    n_trials : int
        RANSAC hypotheses drawn.
    """

    normal: np.ndarray
    offset: float
    inliers: np.ndarray
    rmse_m: float
    n_trials: int

    def __post_init__(self) -> None:
        normal = np.array(self.normal, dtype=float)
        inliers = np.array(self.inliers, dtype=bool)
        if normal.shape != (3,) or not np.all(np.isfinite(normal)) or abs(np.linalg.norm(normal) - 1) > 1e-9:
            raise BadInputError(f"normal must be a finite unit (3,) vector, got {self.normal!r}")
        if not np.isfinite(self.offset) or self.offset < 0:
            raise BadInputError(f"offset must be finite and >= 0 (normal toward the origin), got {self.offset}")
        if inliers.ndim != 1:
            raise BadInputError(f"inliers must be a (N,) bool mask, got shape {inliers.shape}")
        if not (np.isfinite(self.rmse_m) and self.rmse_m >= 0) or self.n_trials < 0:
            raise BadInputError(f"rmse_m must be finite >= 0 and n_trials >= 0, got {self.rmse_m}, {self.n_trials}")
        for name, arr in (("normal", normal), ("inliers", inliers)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "offset", float(self.offset))
        object.__setattr__(self, "rmse_m", float(self.rmse_m))

    def signed_distance(self, p: np.ndarray) -> np.ndarray:
        """Signed distances ``(...)`` [m] of points ``(..., 3)``, positive on the normal's side."""
        return np.asarray(p, dtype=float) @ self.normal + self.offset

    def project(self, p: np.ndarray) -> np.ndarray:
        """Orthogonal projections ``(..., 3)`` [m] of points ``(..., 3)`` onto the plane."""
        p = np.asarray(p, dtype=float)
        return p - self.signed_distance(p)[..., None] * self.normal


def _as_points(points: np.ndarray, name: str, min_points: int = 1) -> np.ndarray:
    p = np.asarray(points, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3:
        raise BadInputError(f"{name} must have shape (N, 3), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise BadInputError(f"{name} contains NaN or infinite coordinates; drop them first")
    if p.shape[0] < min_points:
        raise BadInputError(f"{name} needs at least {min_points} points, got {p.shape[0]}")
    return p


def _as_vector(v: np.ndarray, name: str) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise BadInputError(f"{name} must be a finite (3,) vector, got {v!r}")
    return v


def fit_plane_lstsq(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares (orthogonal distance) plane through points ``(N >= 3, 3)`` [m].

    Returns the unit normal ``(3,)``, oriented toward the frame origin, and the offset ``d >= 0``
    [m] of the plane ``normal . p + d = 0``.
    """
    p = _as_points(points, "points", min_points=3)
    centroid = p.mean(axis=0)
    normal = np.linalg.svd(p - centroid, full_matrices=False)[2][2]
    offset = -float(normal @ centroid)
    if offset < 0:
        normal, offset = -normal, -offset
    return normal, offset


def fit_floor_plane(
    points: np.ndarray, *, rng: np.random.Generator, threshold_m: float = 0.01, n_trials: int = 500
) -> FloorPlane:
    """Fit the dominant plane of a point cloud: seeded RANSAC, then a least-squares refit.

    Each hypothesis is the plane through three random points; the one with the most points within
    ``threshold_m`` wins (ties: the first drawn). The plane is then refitted by least squares to its
    inliers, and the inliers recomputed, until they no longer change (at most 5 refits).

    Parameters
    ----------
    points : (N, 3) points [m], N >= 3, finite.
    rng : source of the random samples.
    threshold_m : inlier distance [m].
    n_trials : number of RANSAC hypotheses.

    Returns
    -------
    FloorPlane
        In the frame of ``points``, normal toward that frame's origin.

    Raises
    ------
    BadInputError
        Malformed points or parameters.
    CalibrationError
        No hypothesis was supported by three or more points (for example, all points collinear).
    """
    p = _as_points(points, "points", min_points=3)
    if not (np.isfinite(threshold_m) and threshold_m > 0):
        raise BadInputError(f"threshold_m must be positive, got {threshold_m}")
    if n_trials < 1:
        raise BadInputError(f"n_trials must be >= 1, got {n_trials}")
    samples = p[rng.integers(0, p.shape[0], size=(n_trials, 3))]
    normals = np.cross(samples[:, 1] - samples[:, 0], samples[:, 2] - samples[:, 0])
    lengths = np.linalg.norm(normals, axis=1)
    scale = np.ptp(p, axis=0).max()
    valid = lengths > 1e-9 * max(scale, 1e-12) ** 2
    normals[valid] /= lengths[valid, None]
    offsets = -np.einsum("ij,ij->i", normals, samples[:, 0])
    counts = np.zeros(n_trials, dtype=np.int64)
    for start in range(0, p.shape[0], _SCORE_CHUNK):
        dist = np.abs(p[start : start + _SCORE_CHUNK] @ normals.T + offsets)
        counts += np.count_nonzero(dist < threshold_m, axis=0)
    counts[~valid] = -1
    best = int(np.argmax(counts))
    if counts[best] < 3:
        raise CalibrationError("no plane found: the points are degenerate (collinear or coincident)")
    inliers = np.abs(p @ normals[best] + offsets[best]) < threshold_m
    for _ in range(_MAX_REFITS):
        normal, offset = fit_plane_lstsq(p[inliers])
        refit = np.abs(p @ normal + offset) < threshold_m
        if np.array_equal(refit, inliers) or refit.sum() < 3:
            break
        inliers = refit
    normal, offset = fit_plane_lstsq(p[inliers])
    rmse = float(np.sqrt(np.mean((p[inliers] @ normal + offset) ** 2)))
    return FloorPlane(normal=normal, offset=offset, inliers=inliers, rmse_m=rmse, n_trials=n_trials)


def world_from_floor(
    floor: FloorPlane, subject_start_cam: np.ndarray, facing_cam: np.ndarray | None = None
) -> np.ndarray:
    """The world frame defined by the floor and the subject, seen from one (reference) camera.

    Parameters
    ----------
    floor : the floor plane in the camera frame.
    subject_start_cam : (3,) a point of the subject at the start (e.g. the pelvis) [m], camera frame.
    facing_cam : optional (3,) direction the subject faces at the start, camera frame. Default:
        the subject faces the camera (the direction from the subject toward the camera origin).

    Returns
    -------
    T_world_cam : (4, 4)
        +z along the floor normal on the subject's side, floor at z = 0, origin under
        ``subject_start_cam``, +x along ``facing_cam`` projected on the floor, +y = z x x.

    Raises
    ------
    BadInputError
        Malformed vectors, or a facing direction (nearly) perpendicular to the floor.
    """
    start = _as_vector(subject_start_cam, "subject_start_cam")
    facing = -start if facing_cam is None else _as_vector(facing_cam, "facing_cam")
    z_axis = floor.normal if floor.signed_distance(start) >= 0 else -floor.normal
    x_axis = facing - (facing @ z_axis) * z_axis
    norm = np.linalg.norm(x_axis)
    if norm <= 1e-6 * np.linalg.norm(facing):
        raise BadInputError("the facing direction is zero or perpendicular to the floor; give a horizontal direction")
    x_axis = x_axis / norm
    R_cam_world = np.column_stack([x_axis, np.cross(z_axis, x_axis), z_axis])
    return invert(make_transform(R_cam_world, floor.project(start)))


class GaugeMode(enum.Enum):
    """Which rigid transforms :func:`align_gauge` may use."""

    RIGID = "rigid"
    """Any rotation and translation (6 degrees of freedom)."""
    FLOOR = "floor"
    """Rotation about the world z axis and translation in x, y: both worlds share the floor z = 0."""


def _planar_fit(p_src: np.ndarray, p_dst: np.ndarray) -> np.ndarray:
    """Least-squares transform (rotation about z, translation in x, y) with ``p_dst ~ apply(T, p_src)``."""
    c_src, c_dst = p_src[:, :2].mean(axis=0), p_dst[:, :2].mean(axis=0)
    a, b = p_src[:, :2] - c_src, p_dst[:, :2] - c_dst
    angle = np.arctan2(np.sum(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]), np.sum(a * b))
    c, s = np.cos(angle), np.sin(angle)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    t = np.zeros(3)
    t[:2] = c_dst - R[:2, :2] @ c_src
    return make_transform(R, t)


def _camera_points(T_world_cam: np.ndarray, axis_length_m: float) -> np.ndarray:
    """(4, 3) camera centre and the tips of its three axes, in the world frame [m]."""
    return apply(T_world_cam, np.vstack([np.zeros(3), axis_length_m * np.eye(3)]))


def align_gauge(
    T_world_cam_est: Mapping[str, np.ndarray],
    T_world_cam_true: Mapping[str, np.ndarray],
    *,
    mode: GaugeMode = GaugeMode.RIGID,
    axis_length_m: float = 1.0,
) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Best transform between an estimated and a true camera set, to compare them up to gauge.

    Each camera contributes its centre and the tips of its x, y, z axes at ``axis_length_m``, so
    centres and orientations both count (one camera alone fixes the transform); the transform is
    the least-squares fit of these points (Kabsch, or its planar form for ``GaugeMode.FLOOR``)
    over the cameras present in both sets.

    Parameters
    ----------
    T_world_cam_est : camera name -> (4, 4) estimated camera transform.
    T_world_cam_true : camera name -> (4, 4) true camera transform.
    mode : RIGID (6 DoF) or FLOOR (rotation about z and translation in x, y only).
    axis_length_m : weight of orientation against position [m].

    Returns
    -------
    T_true_est : (4, 4) maps the estimated world into the true world.
    aligned : camera name -> (4, 4) ``T_true_est @ T_world_cam_est[name]`` for every estimated camera.

    Raises
    ------
    BadInputError
        No camera in common, malformed transforms, or a non-positive axis length.
    """
    if not isinstance(mode, GaugeMode):
        raise BadInputError(f"mode must be a GaugeMode, got {mode!r}")
    if not (np.isfinite(axis_length_m) and axis_length_m > 0):
        raise BadInputError(f"axis_length_m must be positive, got {axis_length_m}")
    est = {name: validate_transform(T, f"T_world_cam_est[{name!r}]") for name, T in T_world_cam_est.items()}
    common = sorted(set(est) & set(T_world_cam_true))
    if not common:
        raise BadInputError(
            f"no camera in common between the estimate ({sorted(est)}) and the truth ({sorted(T_world_cam_true)})"
        )
    p_est = np.vstack([_camera_points(est[name], axis_length_m) for name in common])
    true = {name: validate_transform(T_world_cam_true[name], f"T_world_cam_true[{name!r}]") for name in common}
    p_true = np.vstack([_camera_points(true[name], axis_length_m) for name in common])
    T_true_est = kabsch(p_est, p_true) if mode is GaugeMode.RIGID else _planar_fit(p_est, p_true)
    return T_true_est, {name: compose(T_true_est, T) for name, T in est.items()}
