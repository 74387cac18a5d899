"""Depth frames, segmentation labels and their back-projection to point clouds."""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from fusion.camera import Intrinsics
from fusion.errors import BadInputError


class Label(enum.IntEnum):
    """Per-pixel segmentation of a depth frame."""

    NONE = 0
    BODY = 1
    FLOOR = 2


@dataclass(frozen=True, eq=False)
class DepthStream:
    """Depth frames of one camera.

    Attributes
    ----------
    timestamps : np.ndarray
        (N,) float64 seconds on the camera's clock, strictly increasing.
    depth_mm : np.ndarray
        (N, H, W) uint16 z-depth in millimetres; 0 where there is no return.
    labels : np.ndarray or None
        (N, H, W) uint8 :class:`Label` values, or None when the sensor gives no segmentation.
    """

    timestamps: np.ndarray
    depth_mm: np.ndarray
    labels: np.ndarray | None = None

    def __post_init__(self) -> None:
        ts = np.array(self.timestamps, dtype=np.float64)
        depth = np.asarray(self.depth_mm)
        if ts.ndim != 1 or not np.all(np.isfinite(ts)) or (ts.size > 1 and np.any(np.diff(ts) <= 0)):
            raise BadInputError("depth timestamps must be a finite, strictly increasing 1-D array")
        if depth.dtype != np.uint16 or depth.ndim != 3 or depth.shape[0] != ts.shape[0]:
            raise BadInputError(f"depth_mm must be uint16 (N, H, W) with N = {ts.shape[0]}, got {depth.dtype} {depth.shape}")
        depth = np.array(depth)
        if self.labels is not None:
            labels = np.array(self.labels)
            if labels.dtype != np.uint8 or labels.shape != depth.shape:
                raise BadInputError(f"labels must be uint8 of shape {depth.shape}, got {labels.dtype} {labels.shape}")
            labels.setflags(write=False)
            object.__setattr__(self, "labels", labels)
        for name, arr in (("timestamps", ts), ("depth_mm", depth)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def n_frames(self) -> int:
        """Number of frames N."""
        return self.timestamps.shape[0]

    def equals(self, other: "DepthStream") -> bool:
        """Exact equality of all arrays."""
        same_labels = (self.labels is None and other.labels is None) or (
            self.labels is not None and other.labels is not None and np.array_equal(self.labels, other.labels)
        )
        return same_labels and np.array_equal(self.timestamps, other.timestamps) and np.array_equal(
            self.depth_mm, other.depth_mm
        )


def depth_to_points(
    depth_mm: np.ndarray, intrinsics: Intrinsics, labels: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray | None]:
    """Back-project a depth image to a point cloud in the camera frame.

    Parameters
    ----------
    depth_mm : (H, W) uint16 depth [mm], 0 = no return.
    intrinsics : the camera's intrinsics (H, W must match).
    labels : optional (H, W) uint8 segmentation.

    Returns
    -------
    points : (N, 3) float64 [m], one per valid pixel, in row-major pixel order.
    point_labels : (N,) uint8 labels of those points, or None.
    """
    depth_mm = np.asarray(depth_mm)
    if depth_mm.shape != (intrinsics.height, intrinsics.width):
        raise BadInputError(f"depth image shape {depth_mm.shape} does not match intrinsics "
                            f"({intrinsics.height}, {intrinsics.width})")
    v, u = np.nonzero(depth_mm)
    z = depth_mm[v, u].astype(float) * 1e-3
    points = intrinsics.backproject(np.stack([u, v], axis=-1).astype(float), z)
    return points, (None if labels is None else np.asarray(labels)[v, u])
