"""ICP refinement of a camera pair's skeleton calibration on body and floor point clouds.

The paper (3.4) initialises ICP with the skeleton transform (ICP alone falls into wrong minima) and
adds the floor points near the subject's feet to the body points to increase the overlap. Here the
clouds of several instants are used together, and the ICP result is checked before it replaces the
skeleton transform: it must fit at least as well, stay near the skeleton result, not match surfaces
seen from opposite sides (cameras facing each other share no surface, yet ICP will happily slide the
front of the body onto the back), and be determined by the geometry (a plane alone, for example,
leaves ICP free to slide within it).

Registration is coarse-to-fine with Open3D's own multi-scale ICP
(``open3d.t.pipelines.registration.multi_scale_icp``): the coarse scales work on voxel-averaged
copies of the clouds, the last on the clouds themselves.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import open3d as o3d

from fusion.calibrate.icp_result import IcpResult
from fusion.calibrate.options import IcpMethod
from fusion.errors import BadInputError
from fusion.transforms import apply, rotate, transform_difference, validate_transform

_reg = o3d.pipelines.registration
_treg = o3d.t.pipelines.registration

_NORMAL_RADIUS_VOXELS = 4.0
"""Normals (and GICP covariances) from neighbours within this many voxel sizes."""
_NORMAL_MAX_NN = 30
_CONVERGED_ROTATION_DEG = 0.01
_CONVERGED_TRANSLATION_M = 1e-4


@dataclass(frozen=True)
class IcpLimits:
    """When an ICP result may replace the skeleton transform it started from.

    Attributes
    ----------
    max_rotation_deg : float
        Largest plausible rotation between the initial and the ICP transform [deg].
    max_translation_m : float
        Largest plausible displacement of the b cloud's centroid between them [m].
    fitness_tolerance : float
        Allowed drop of fitness (fraction of b points with a correspondence) below the initial one.
    rmse_tolerance : float
        Allowed relative increase of the inlier RMSE over the initial one when fitness does not
        improve by more than ``fitness_tolerance``.
    max_opposite_fraction : float
        Largest accepted fraction of final correspondences whose normals (each oriented toward its own
        camera) point more than 90 degrees apart, i.e. surfaces matched to ones seen from the other
        side. Below 1 % at the true transform in synthetic tests and about 4 % for simulated Kinect
        cameras 90 degrees apart (surfaces seen edge-on); 8-9 % when cameras 150-180
        degrees apart slide their clouds into a wrong, better-"fitting" overlap.
    min_constraint_ratio : float
        Smallest accepted ratio of the weakest to the strongest eigenvalue of the point-to-plane
        information matrix (rotations scaled by the cloud's RMS radius); below it some motion is
        not determined by the geometry.
    min_points : int
        Fewest points per cloud, after voxelisation, to attempt ICP.
    """

    max_rotation_deg: float = 5.0
    max_translation_m: float = 0.10
    fitness_tolerance: float = 0.02
    rmse_tolerance: float = 0.05
    max_opposite_fraction: float = 0.06
    min_constraint_ratio: float = 1e-3
    min_points: int = 100

    def __post_init__(self) -> None:
        values = (self.max_rotation_deg, self.max_translation_m, self.fitness_tolerance, self.rmse_tolerance,
                  self.max_opposite_fraction, self.min_constraint_ratio)
        if not all(np.isfinite(v) and v >= 0 for v in values) or self.min_points < 3:
            raise BadInputError(f"ICP limits must be finite and >= 0 (min_points >= 3), got {self}")


def _as_clouds(clouds: Sequence[np.ndarray], name: str) -> list[np.ndarray]:
    if isinstance(clouds, np.ndarray) or len(clouds) == 0:
        raise BadInputError(f"{name} must be a non-empty list of (N_i, 3) arrays, one per instant")
    out = []
    for i, c in enumerate(clouds):
        c = np.asarray(c, dtype=float)
        if c.ndim != 2 or c.shape[1] != 3 or not np.all(np.isfinite(c)):
            raise BadInputError(f"{name}[{i}] must be a finite (N, 3) array, got shape {c.shape}")
        out.append(c)
    return out


_COS_MAX_VIEW_ANGLE = np.cos(np.radians(75.0))
"""Points whose surface is seen at more than 75 degrees from its normal are dropped: silhouette
edges, where flying pixels and lateral noise make depth least reliable."""


def _prepare(clouds: list[np.ndarray], voxel_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Voxelised points and unit normals ``(N, 3)`` (toward the camera) of all instants, each processed
    alone, without grazing-angle points."""
    search = o3d.geometry.KDTreeSearchParamHybrid(radius=_NORMAL_RADIUS_VOXELS * voxel_m, max_nn=_NORMAL_MAX_NN)
    points, normals = [np.empty((0, 3))], [np.empty((0, 3))]
    for c in clouds:
        pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(c)).voxel_down_sample(voxel_m)
        pcd.estimate_normals(search)
        pcd.orient_normals_towards_camera_location(np.zeros(3))
        p, n = np.asarray(pcd.points), np.asarray(pcd.normals)
        facing = np.einsum("ij,ij->i", n, -p) > _COS_MAX_VIEW_ANGLE * np.linalg.norm(p, axis=1)
        points.append(p[facing])
        normals.append(n[facing])
    return np.vstack(points), np.vstack(normals)


def _tensor_cloud(points: np.ndarray, normals: np.ndarray) -> o3d.t.geometry.PointCloud:
    pcd = o3d.t.geometry.PointCloud(o3d.core.Tensor(np.ascontiguousarray(points)))
    pcd.point.normals = o3d.core.Tensor(np.ascontiguousarray(normals))
    return pcd


_ESTIMATION = {
    IcpMethod.POINT_TO_PLANE: _treg.TransformationEstimationPointToPlane,
    IcpMethod.SYMMETRIC: _treg.TransformationEstimationSymmetric,
    IcpMethod.POINT_TO_POINT: _treg.TransformationEstimationPointToPoint,
}


def _multi_scale(source, target, T_init: np.ndarray, scales_m: np.ndarray, max_corr_m: np.ndarray,
                 max_iterations: Sequence[int], method: IcpMethod) -> tuple[np.ndarray, np.ndarray]:
    """Open3D multi-scale ICP; returns the final transform and the one before the last iteration."""
    criteria = [_treg.ICPConvergenceCriteria(relative_fitness=1e-6, relative_rmse=1e-6, max_iteration=int(n))
                for n in max_iterations]
    history: list[np.ndarray] = [T_init, T_init]

    def record(state) -> None:
        history[0], history[1] = history[1], state["transformation"].numpy()

    result = _treg.multi_scale_icp(source, target, o3d.utility.DoubleVector(list(scales_m)), criteria,
                                   o3d.utility.DoubleVector(list(max_corr_m)), o3d.core.Tensor(T_init),
                                   _ESTIMATION[method](), record)
    return np.asarray(result.transformation.numpy(), dtype=float), history[0]


def _constraint_ratio(p_src: np.ndarray, n_dst: np.ndarray) -> float:
    """Weakest / strongest eigenvalue of the point-to-plane information matrix of correspondences.

    ``p_src`` are the matched source points (already moved into the target frame) and ``n_dst`` the
    target normals they match. Rotations are about the points' centroid and scaled by their RMS
    radius so that rotation and translation eigenvalues are comparable.
    """
    if p_src.shape[0] < 6:
        return 0.0
    arm = p_src - p_src.mean(axis=0)
    radius = np.sqrt(np.mean(np.sum(arm**2, axis=1)))
    if radius <= 0:
        return 0.0
    J = np.hstack([np.cross(arm, n_dst) / radius, n_dst])
    eig = np.linalg.eigvalsh(J.T @ J)
    return float(max(eig[0], 0.0) / eig[-1]) if eig[-1] > 0 else 0.0


def _orthonormalise(T: np.ndarray) -> np.ndarray:
    """Snap the rotation part of a nearly rigid transform back onto SO(3) (float round-off)."""
    U, _, Vt = np.linalg.svd(T[:3, :3])
    out = np.array(T, dtype=float)
    out[:3, :3] = U @ Vt
    out[3] = [0.0, 0.0, 0.0, 1.0]
    return out


def _move(T_a_b_to: np.ndarray, T_a_b_from: np.ndarray, centroid_b: np.ndarray) -> tuple[float, float]:
    """Rotation [deg] and displacement of ``centroid_b`` [m] between two transforms."""
    angle = float(transform_difference(T_a_b_to, T_a_b_from)[0])
    shift = float(np.linalg.norm(apply(T_a_b_to, centroid_b) - apply(T_a_b_from, centroid_b)))
    return angle, shift


def _check_schedule(max_corr_m: Sequence[float], coarse_voxel_m: Sequence[float], voxel_m: float,
                    max_iterations: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
    """Validated (S,) correspondence distances and (S,) voxel sizes (-1: the clouds as prepared)."""
    dist = np.asarray(max_corr_m, dtype=float)
    coarse = np.asarray(coarse_voxel_m, dtype=float)
    if dist.ndim != 1 or dist.size == 0 or not np.all(np.isfinite(dist) & (dist > 0)) or np.any(np.diff(dist) > 0):
        raise BadInputError(
            f"max_corr_m must be a non-empty non-increasing sequence of positive distances, got {max_corr_m}"
        )
    if not (np.isfinite(voxel_m) and voxel_m > 0):
        raise BadInputError(f"voxel_m must be positive, got {voxel_m}")
    if coarse.ndim != 1 or coarse.size != dist.size - 1 or not np.all(np.isfinite(coarse)) or np.any(
        np.diff(np.r_[coarse, voxel_m]) >= 0
    ):
        raise BadInputError(
            f"coarse_voxel_m needs one strictly decreasing voxel size larger than voxel_m ({voxel_m}) per "
            f"coarse scale, i.e. len(max_corr_m) - 1 = {dist.size - 1} values, got {coarse_voxel_m}"
        )
    if len(max_iterations) != dist.size or min(max_iterations) < 1:
        raise BadInputError(f"max_iterations needs one positive count per scale ({dist.size}), got {max_iterations}")
    return dist, np.r_[coarse, -1.0]


def refine_pair_icp(
    clouds_a: Sequence[np.ndarray],
    clouds_b: Sequence[np.ndarray],
    T_a_b_init: np.ndarray,
    *,
    voxel_m: float = 0.02,
    coarse_voxel_m: Sequence[float] = (0.04,),
    max_corr_m: Sequence[float] = (0.05, 0.01),
    method: IcpMethod = IcpMethod.POINT_TO_PLANE,
    max_iterations: Sequence[int] = (30, 100),
    limits: IcpLimits = IcpLimits(),
) -> IcpResult:
    """Refine a camera pair's transform by ICP on point clouds of several instants.

    ``clouds_a[i]`` and ``clouds_b[i]`` are one instant seen by cameras a and b (captured at nearly
    the same time), each in its own camera frame, typically from :func:`select_calibration_points`.
    Each instant is voxelised at ``voxel_m`` and gets normals on its own (the person moves between
    instants); then the instants are concatenated and registered, b (source) onto a (target), from
    ``T_a_b_init`` by Open3D's multi-scale ICP: one scale per ``coarse_voxel_m`` (voxel-averaged
    copies of the clouds), then the prepared clouds themselves, scale ``k`` with correspondences
    within ``max_corr_m[k]``.

    The ICP transform is accepted only if, at the finest correspondence distance, it does not fit
    worse than the initial one, it stays within ``limits`` of the initial one, it does not match
    surfaces seen from opposite sides, and the geometry constrains all six degrees of freedom;
    otherwise the initial transform is kept and ``reason`` says why.

    Parameters
    ----------
    clouds_a, clouds_b : lists of (N_i, 3) and (M_i, 3) points [m], one entry per instant.
    T_a_b_init : (4, 4) initial transform (the skeleton calibration).
    voxel_m : voxel size [m] of the prepared clouds; normals use neighbours within 4 voxels.
    coarse_voxel_m : decreasing voxel sizes [m] of the coarse scales, each larger than ``voxel_m``.
    max_corr_m : non-increasing correspondence distances [m], one per scale (coarse scales, then the
        prepared clouds). Defaults measured on simulated fma_2cam sessions (six instants of body +
        floor, seeds 1 and 3): 2 cm voxels, one 4 cm scale at 5 cm and the full clouds at 1 cm (up
        to 100 iterations: from a skeleton start 1-1.5 deg / 6-9 cm away ICP creeps, and 50 left
        seed 3 at 1.1 deg) reach 0.25 deg / 6.3 mm and 0.12 deg / 3.4 mm, against 0.24 / 5.7 and
        0.26 / 6.2 for the former 1 cm, four-stage (10, 5, 2, 1 cm) schedule; a 10 cm coarse
        scale is worse (0.17 deg / 4.4 mm on seed 3, not converged).
    method : error metric.
    max_iterations : iterations per scale.
    limits : acceptance limits.

    Returns
    -------
    IcpResult

    Raises
    ------
    BadInputError
        Malformed clouds, transform or parameters.
    """
    a_list, b_list = _as_clouds(clouds_a, "clouds_a"), _as_clouds(clouds_b, "clouds_b")
    if len(a_list) != len(b_list):
        raise BadInputError(
            f"clouds_a and clouds_b need one cloud per instant each, got {len(a_list)} and {len(b_list)}"
        )
    T_a_b_init = validate_transform(T_a_b_init, "T_a_b_init")
    if not isinstance(method, IcpMethod):
        raise BadInputError(f"method must be an IcpMethod, got {method!r}")
    schedule, scales = _check_schedule(max_corr_m, coarse_voxel_m, voxel_m, max_iterations)

    p_a, n_a = _prepare(a_list, voxel_m)
    p_b, n_b = _prepare(b_list, voxel_m)
    target = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(p_a))
    source = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(p_b))
    finest = float(schedule[-1])
    initial = _reg.evaluate_registration(source, target, finest, T_a_b_init)
    common = dict(T_a_b_init=T_a_b_init, initial_fitness=initial.fitness, initial_inlier_rmse_m=initial.inlier_rmse,
                  n_points_a=p_a.shape[0], n_points_b=p_b.shape[0])

    def not_run(reason: str) -> IcpResult:
        return IcpResult(T_a_b=T_a_b_init, T_a_b_icp=T_a_b_init, accepted=False, reason=reason, fitness=initial.fitness,
                         inlier_rmse_m=initial.inlier_rmse, converged=False, constraint_ratio=0.0,
                         opposite_fraction=0.0, rotation_change_deg=0.0, translation_change_m=0.0, **common)

    if min(p_a.shape[0], p_b.shape[0]) < limits.min_points:
        return not_run(f"too few points after voxelisation ({p_a.shape[0]}, {p_b.shape[0]} < {limits.min_points}): "
                       "ICP not run, initial transform kept")

    T_a_b, T_before = _multi_scale(_tensor_cloud(p_b, n_b), _tensor_cloud(p_a, n_a), T_a_b_init, scales, schedule,
                                   max_iterations, method)
    if not (np.all(np.isfinite(T_a_b)) and np.all(np.isfinite(T_before))):
        return not_run("ICP diverged to a non-finite transform: initial transform kept")
    centroid_b = p_b.mean(axis=0)
    T_a_b = validate_transform(_orthonormalise(T_a_b), "ICP transform")
    last_rot, last_shift = _move(T_a_b, _orthonormalise(T_before), centroid_b)
    converged = last_rot < _CONVERGED_ROTATION_DEG and last_shift < _CONVERGED_TRANSLATION_M
    result = _reg.evaluate_registration(source, target, finest, T_a_b)

    corr = np.asarray(result.correspondence_set).reshape(-1, 2)
    ratio = _constraint_ratio(apply(T_a_b, p_b[corr[:, 0]]), n_a[corr[:, 1]])
    facing = np.einsum("ij,ij->i", rotate(T_a_b, n_b[corr[:, 0]]), n_a[corr[:, 1]])
    opposite = float(np.mean(facing < 0)) if corr.size else 0.0
    rot, shift = _move(T_a_b, T_a_b_init, centroid_b)

    problems = []
    if rot > limits.max_rotation_deg or shift > limits.max_translation_m:
        problems.append(f"moved implausibly far from the initial transform ({rot:.2f} deg, {shift * 1e3:.0f} mm; "
                        f"limits {limits.max_rotation_deg} deg, {limits.max_translation_m * 1e3:.0f} mm)")
    fitness_drop = result.fitness < initial.fitness - limits.fitness_tolerance
    rmse_rise = (result.inlier_rmse > initial.inlier_rmse * (1 + limits.rmse_tolerance)
                 and result.fitness <= initial.fitness + limits.fitness_tolerance)
    if fitness_drop or rmse_rise:
        problems.append(
            f"fits worse than the initial transform (fitness {initial.fitness:.3f} -> {result.fitness:.3f}, rmse "
            f"{initial.inlier_rmse * 1e3:.1f} -> {result.inlier_rmse * 1e3:.1f} mm at {finest * 1e3:.0f} mm)"
        )
    if opposite > limits.max_opposite_fraction:
        problems.append(f"{opposite:.1%} of the correspondences match surfaces seen from opposite sides "
                        f"(limit {limits.max_opposite_fraction:.1%}): the cameras share too little of the body")
    if corr.shape[0] < limits.min_points:
        problems.append(f"only {corr.shape[0]} correspondences within {finest * 1e3:.0f} mm at the end")
    elif ratio < limits.min_constraint_ratio:
        problems.append(f"degenerate geometry: the clouds do not constrain all six degrees of freedom "
                        f"(constraint ratio {ratio:.1e} < {limits.min_constraint_ratio:.0e}), e.g. a plane alone")
    accepted = not problems
    summary = (f"fitness {initial.fitness:.3f} -> {result.fitness:.3f}, rmse {initial.inlier_rmse * 1e3:.1f} -> "
               f"{result.inlier_rmse * 1e3:.1f} mm, moved {rot:.2f} deg / {shift * 1e3:.1f} mm")
    if accepted:
        reason = "accepted: " + summary + ("" if converged else "; the finest stage had not converged")
    else:
        reason = "rejected, initial transform kept: " + "; ".join(problems)
    return IcpResult(
        T_a_b=T_a_b if accepted else T_a_b_init, T_a_b_icp=T_a_b, accepted=accepted, reason=reason,
        fitness=result.fitness, inlier_rmse_m=result.inlier_rmse, converged=converged, constraint_ratio=ratio,
        opposite_fraction=opposite, rotation_change_deg=rot, translation_change_m=shift, **common,
    )
