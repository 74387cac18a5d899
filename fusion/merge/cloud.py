"""The merged full-body point cloud of one instant (paper 3.7), its mesh, and PLY / GLB export.

Every camera's depth frame nearest to the instant is back-projected, reduced to the body, mapped
into the calibration's world frame (floor z = 0, z up) and concatenated; the merged cloud is then
voxel-downsampled and cleaned of outliers with Open3D.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np
import open3d as o3d

from fusion.calibrate.icp_points import select_calibration_points
from fusion.calibration import Calibration
from fusion.depth import Label, depth_to_points
from fusion.errors import BadInputError
from fusion.recording import CameraRecording, Recording
from fusion.transforms import apply

NORMAL_RADIUS_VOXELS = 4.0
"""Normals from the neighbours within this many voxel sizes."""
NORMAL_MAX_NN = 30


class OutlierRemoval(enum.Enum):
    """How :func:`merge_clouds` removes isolated points after voxelisation (Open3D, deterministic)."""

    NONE = "none"
    STATISTICAL = "statistical"
    """Drop points whose mean distance to their ``outlier_neighbours`` nearest neighbours exceeds the
    cloud's mean of that distance by more than ``outlier_std_ratio`` standard deviations."""
    RADIUS = "radius"
    """Drop points with fewer than ``outlier_neighbours`` other points within ``outlier_radius_m``."""


def _float_rows(a) -> np.ndarray:
    """A float64 copy of ``a``, an empty one shaped (0, 3)."""
    a = np.array(a, dtype=np.float64)
    return a.reshape(0, 3) if a.size == 0 else a


@dataclass(frozen=True, eq=False)
class MergedCloud:
    """A point cloud in the world frame merged from several cameras at one instant.

    Attributes
    ----------
    points : np.ndarray
        (N, 3) float64 points [m], world frame.
    camera_index : np.ndarray
        (N,) int64 index into ``camera_names`` of the camera each point came from (after voxelisation:
        the camera most of the voxel's points came from).
    camera_names : tuple of str
        (C,) the cameras whose depth frame was merged.
    frame_index : np.ndarray
        (C,) int64 index of the depth frame used in each camera's depth stream.
    frame_time_s : np.ndarray
        (C,) float64 capture time [s] of each frame used, on the reference clock.
    n_selected : np.ndarray
        (C,) int64 points each camera contributed before voxelisation and outlier removal.
    time_s : float
        The requested instant [s], reference clock.
    normals : np.ndarray or None
        (N, 3) float64 unit normals, each oriented toward the camera its point came from.
    n_outliers : int
        Points the outlier removal dropped (after voxelisation).
    skipped : tuple of str
        Cameras of the recording that contributed no frame.
    notes : tuple of str
        Why each skipped camera was skipped.
    """

    points: np.ndarray
    camera_index: np.ndarray
    camera_names: tuple[str, ...]
    frame_index: np.ndarray
    frame_time_s: np.ndarray
    n_selected: np.ndarray
    time_s: float
    normals: np.ndarray | None = None
    n_outliers: int = 0
    skipped: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        points = _float_rows(self.points)
        index = np.array(self.camera_index)
        names = tuple(self.camera_names)
        n, c = points.shape[0], len(names)
        if points.ndim != 2 or points.shape[1] != 3 or not np.all(np.isfinite(points)):
            raise BadInputError(f"points must be a finite (N, 3) array, got shape {points.shape}")
        if index.shape != (n,) or (n and not np.issubdtype(index.dtype, np.integer)):
            raise BadInputError(f"camera_index must be an integer array of shape ({n},), "
                                f"got {index.dtype} {index.shape}")
        if len(set(names)) != c:
            raise BadInputError(f"camera_names must be unique, got {names}")
        if n and (index.min() < 0 or index.max() >= c):
            raise BadInputError(f"camera_index must lie in 0..{c - 1} (one per camera name)")
        per_camera = {}
        for name, dtype in (("frame_index", np.int64), ("frame_time_s", np.float64), ("n_selected", np.int64)):
            arr = np.array(getattr(self, name))
            if arr.shape != (c,) or not np.all(np.isfinite(arr)):
                raise BadInputError(f"{name} must be a finite ({c},) array, one per camera, got shape {arr.shape}")
            per_camera[name] = arr.astype(dtype)
        if not np.isfinite(self.time_s):
            raise BadInputError(f"time_s must be finite, got {self.time_s}")
        if self.normals is not None:
            normals = _float_rows(self.normals)
            if normals.shape != (n, 3) or not np.all(np.isfinite(normals)):
                raise BadInputError(f"normals must be a finite ({n}, 3) array, got shape {normals.shape}")
            normals.setflags(write=False)
            object.__setattr__(self, "normals", normals)
        if len(self.skipped) != len(self.notes):
            raise BadInputError(f"one note per skipped camera: {len(self.skipped)} skipped, {len(self.notes)} notes")
        if self.n_outliers < 0 or np.any(per_camera["n_selected"] < 0) or np.any(per_camera["frame_index"] < 0):
            raise BadInputError("n_outliers, n_selected and frame_index must be >= 0")
        arrays = {"points": points, "camera_index": index.astype(np.int64), **per_camera}
        for name, arr in arrays.items():
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "camera_names", names)
        object.__setattr__(self, "skipped", tuple(self.skipped))
        object.__setattr__(self, "notes", tuple(self.notes))
        object.__setattr__(self, "time_s", float(self.time_s))
        object.__setattr__(self, "n_outliers", int(self.n_outliers))

    @property
    def n_points(self) -> int:
        """Number of points N."""
        return self.points.shape[0]

    @property
    def points_per_camera(self) -> np.ndarray:
        """(C,) int64 points of the merged cloud attributed to each camera."""
        return np.bincount(self.camera_index, minlength=len(self.camera_names)).astype(np.int64)


@dataclass(frozen=True)
class CameraFrame:
    """One camera's depth frame nearest an instant, as world points (before merging).

    Attributes
    ----------
    name : the camera.
    frame_index : index of the frame in the camera's depth stream.
    frame_time_s : its capture time [s] on the reference clock.
    points_world : (M, 3) [m] its (body) points in the world frame.
    centre_world : (3,) [m] the camera's centre in the world frame.
    """

    name: str
    frame_index: int
    frame_time_s: float
    points_world: np.ndarray
    centre_world: np.ndarray


def _check_positive(name: str, value: float) -> None:
    if not (np.isfinite(value) and value > 0):
        raise BadInputError(f"{name} must be positive and finite, got {value}")


def _nearest_frame(cam: CameraRecording, calibration: Calibration, time_s: float,
                   tolerance_s: float) -> tuple[int | None, str | None]:
    """Index of the camera's depth frame captured nearest to ``time_s`` (reference clock), or (None, why not)."""
    if cam.depth is None or cam.depth.n_frames == 0:
        return None, f"{cam.name}: no depth frames"
    if cam.name not in calibration.T_world_cam:
        return None, f"{cam.name}: not in the calibration (calibrated: {', '.join(calibration.camera_names)})"
    ts = cam.depth.timestamps - calibration.clock_offset_s[cam.name]
    k = int(np.argmin(np.abs(ts - time_s)))
    if abs(ts[k] - time_s) > tolerance_s:
        return None, (f"{cam.name}: no depth frame within {tolerance_s} s of {time_s:.3f} s (nearest "
                      f"{abs(ts[k] - time_s):.3f} s away; depth spans [{ts[0]:.3f}, {ts[-1]:.3f}] s on the "
                      "reference clock)")
    return k, None


def _frame_points(cam: CameraRecording, k: int, body_only: bool, body_radius_m: float, tolerance_s: float,
                  rng: np.random.Generator) -> tuple[np.ndarray | None, str | None]:
    """Points (M, 3) [m] of depth frame ``k`` in the camera frame, or (None, why not).

    All points, or with ``body_only`` the BODY pixels or, without labels,
    :func:`~fusion.calibrate.icp.select_calibration_points` of the skeleton frame nearest in time (which
    include the floor near the feet).
    """
    depth = cam.depth
    if not body_only:
        return depth_to_points(depth.depth_mm[k], cam.intrinsics)[0], None
    if depth.labels is not None:
        points, labels = depth_to_points(depth.depth_mm[k], cam.intrinsics, depth.labels[k])
        return points[labels == Label.BODY], None
    skeleton = cam.skeleton
    if skeleton is None or skeleton.n_frames == 0:
        return None, f"{cam.name}: no segmentation labels and no skeleton to find the body with"
    j = int(np.argmin(np.abs(skeleton.timestamps - depth.timestamps[k])))
    joints = skeleton.positions[j]
    if abs(skeleton.timestamps[j] - depth.timestamps[k]) > tolerance_s or not np.isfinite(joints).all(axis=1).any():
        return None, (f"{cam.name}: no segmentation labels and no skeleton within {tolerance_s} s of depth frame {k} "
                      "to find the body with")
    return select_calibration_points(depth.depth_mm[k], None, cam.intrinsics, rng=rng, joints_cam=joints,
                                     body_radius_m=body_radius_m), None


def frames_at(recording: Recording, calibration: Calibration, time_s: float, tolerance_s: float, body_only: bool,
              body_radius_m: float, floor_clearance_m: float,
              rng: np.random.Generator) -> tuple[list[CameraFrame], list[str], list[str]]:
    """Each usable camera's frame nearest ``time_s`` in the world (parameters as :func:`merge_clouds`), the
    skipped cameras and why they were skipped.

    Raises BadInputError when no camera has a calibrated depth frame near ``time_s``.
    """
    frames, skipped, notes, n_near = [], [], [], 0
    for cam in recording.cameras:
        k, why = _nearest_frame(cam, calibration, time_s, tolerance_s)
        if k is not None:
            n_near += 1
            points, why = _frame_points(cam, k, body_only, body_radius_m, tolerance_s, rng)
        if why is not None:
            skipped.append(cam.name)
            notes.append(why)
            continue
        T_world_cam = calibration.T_world_cam[cam.name]
        points_world = apply(T_world_cam, points)
        if body_only and cam.depth.labels is None:
            points_world = points_world[points_world[:, 2] > floor_clearance_m]
        frame_time_s = float(cam.depth.timestamps[k] - calibration.clock_offset_s[cam.name])
        frames.append(CameraFrame(cam.name, k, frame_time_s, points_world, T_world_cam[:3, 3].copy()))
    if n_near == 0:
        raise BadInputError(f"no camera has a calibrated depth frame within {tolerance_s} s of {time_s:.3f} s "
                            "(reference clock): " + "; ".join(notes))
    return frames, skipped, notes


def _remove_outliers(pcd: o3d.geometry.PointCloud, outlier: OutlierRemoval, neighbours: int, std_ratio: float,
                     radius_m: float) -> np.ndarray:
    """(N,) int64 indices of the points that are kept."""
    if outlier is OutlierRemoval.NONE or len(pcd.points) == 0:
        return np.arange(len(pcd.points), dtype=np.int64)
    if outlier is OutlierRemoval.STATISTICAL:
        kept = pcd.remove_statistical_outlier(nb_neighbors=neighbours, std_ratio=std_ratio)[1]
    else:
        kept = pcd.remove_radius_outlier(nb_points=neighbours, radius=radius_m)[1]
    return np.asarray(kept, dtype=np.int64)


def merge_clouds(
    recording: Recording,
    calibration: Calibration,
    time_s: float,
    *,
    rng: np.random.Generator,
    tolerance_s: float = 0.05,
    voxel_m: float = 0.01,
    body_only: bool = True,
    body_radius_m: float = 0.25,
    floor_clearance_m: float = 0.02,
    outlier: OutlierRemoval = OutlierRemoval.STATISTICAL,
    outlier_neighbours: int = 20,
    outlier_std_ratio: float = 2.0,
    outlier_radius_m: float = 0.05,
    with_normals: bool = True,
) -> MergedCloud:
    """Merge the cameras' depth frames nearest to one instant into one world-frame point cloud.

    For each camera with depth frames and a pose in ``calibration``, the frame captured nearest to
    ``time_s`` (its timestamp minus the camera's clock offset), if within ``tolerance_s``, is
    back-projected. With ``body_only`` the body is kept: the BODY pixels when the frame has labels;
    otherwise the points within ``body_radius_m`` of the joints of the camera's skeleton frame
    nearest in time and above the floor fitted near the feet
    (:func:`~fusion.calibrate.icp.select_calibration_points`), less the points within ``floor_clearance_m``
    of the world floor z = 0. The points are mapped into the world with ``T_world_cam``,
    concatenated, voxel-downsampled (one point per occupied voxel, the mean of its points),
    cleaned of outliers, and given normals oriented toward their cameras.

    Parameters
    ----------
    recording : the cameras' depth frames (and skeletons, used only for frames without labels).
    calibration : ``T_world_cam`` and the clock offset (camera clock minus reference clock) per camera.
    time_s : the instant [s] on the reference clock.
    rng : random source of the floor fit, used only for frames without labels.
    tolerance_s : largest time [s] between ``time_s`` and a frame used (and between a frame without
        labels and its skeleton frame).
    voxel_m : voxel size [m].
    body_only : keep the body alone (True) or every depth point (False).
    body_radius_m : distance [m] from a joint within which points belong to the body (frames without labels).
    floor_clearance_m : height [m] above the world floor below which points of frames without labels are dropped.
    outlier : outlier removal method.
    outlier_neighbours : neighbours averaged (STATISTICAL) or required within the radius (RADIUS).
    outlier_std_ratio : threshold [standard deviations] of STATISTICAL.
    outlier_radius_m : radius [m] of RADIUS; a few voxel sizes.
    with_normals : estimate normals (neighbours within 4 voxel sizes).

    Returns
    -------
    MergedCloud
        Possibly empty (no body in view); ``skipped`` and ``notes`` list the cameras left out and why.

    Raises
    ------
    BadInputError
        Malformed parameters, or no camera has a calibrated depth frame within ``tolerance_s`` of
        ``time_s`` (the message gives each camera's depth time span or why it has none).
    """
    if not np.isfinite(time_s):
        raise BadInputError(f"time_s must be finite, got {time_s}")
    for name, value in (("tolerance_s", tolerance_s), ("voxel_m", voxel_m), ("body_radius_m", body_radius_m),
                        ("outlier_std_ratio", outlier_std_ratio), ("outlier_radius_m", outlier_radius_m)):
        _check_positive(name, value)
    if not (np.isfinite(floor_clearance_m) and floor_clearance_m >= 0):
        raise BadInputError(f"floor_clearance_m must be finite and >= 0, got {floor_clearance_m}")
    if not isinstance(outlier, OutlierRemoval):
        raise BadInputError(f"outlier must be an OutlierRemoval, one of {[o.name for o in OutlierRemoval]}, "
                            f"got {outlier!r}")
    if outlier_neighbours < 1:
        raise BadInputError(f"outlier_neighbours must be >= 1, got {outlier_neighbours}")

    frames, skipped, notes = frames_at(recording, calibration, time_s, tolerance_s, body_only, body_radius_m,
                                     floor_clearance_m, rng)
    counts = np.array([f.points_world.shape[0] for f in frames], dtype=np.int64)
    merged = np.vstack([np.empty((0, 3))] + [f.points_world for f in frames])
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(merged))
    if counts.sum():
        # The colour channel carries the camera index through voxelisation as a class label (majority vote).
        pcd.colors = o3d.utility.Vector3dVector(np.repeat(np.arange(len(frames)), counts)[:, None].repeat(3, axis=1))
        pcd = pcd.voxel_down_sample_and_trace(voxel_m, pcd.get_min_bound() - voxel_m / 2,
                                              pcd.get_max_bound() + voxel_m / 2, True)[0]
    kept = _remove_outliers(pcd, outlier, outlier_neighbours, outlier_std_ratio, outlier_radius_m)
    n_voxels = len(pcd.points)
    pcd = pcd.select_by_index(kept)
    points = np.asarray(pcd.points).reshape(-1, 3)
    camera_index = np.asarray(pcd.colors)[:, 0].round().astype(np.int64) if points.shape[0] else np.zeros(0, np.int64)
    normals = None
    if with_normals:
        if points.shape[0]:  # Open3D warns on an empty cloud
            search = o3d.geometry.KDTreeSearchParamHybrid(radius=NORMAL_RADIUS_VOXELS * voxel_m, max_nn=NORMAL_MAX_NN)
            pcd.estimate_normals(search)
        normals = np.asarray(pcd.normals).reshape(-1, 3).copy()
        centres = np.array([f.centre_world for f in frames]).reshape(-1, 3)
        away = np.einsum("ij,ij->i", normals, centres[camera_index] - points) < 0
        normals[away] *= -1.0
    return MergedCloud(
        points=points, camera_index=camera_index, camera_names=tuple(f.name for f in frames),
        frame_index=[f.frame_index for f in frames], frame_time_s=[f.frame_time_s for f in frames],
        n_selected=counts, time_s=time_s, normals=normals, n_outliers=n_voxels - points.shape[0],
        skipped=tuple(skipped), notes=tuple(notes),
    )
