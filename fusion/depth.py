"""Depth frames, segmentation labels and their back-projection to point clouds.

Frames are held either in memory (a numpy array) or lazily by a :class:`FrameArray`, an object that
reads frame ``k`` on ``frames[k]`` (the recording format's chunked depth store does this), so a long
many-camera recording never has to fit in memory.
"""

from __future__ import annotations

import enum
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from fusion.camera import Intrinsics
from fusion.errors import BadInputError


class Label(enum.IntEnum):
    """Per-pixel segmentation of a depth frame."""

    NONE = 0
    BODY = 1
    FLOOR = 2


@runtime_checkable
class FrameArray(Protocol):
    """A lazily read stack of images: ``shape`` (N, H, W), ``dtype``, and ``frames[k]`` -> (H, W) array."""

    @property
    def shape(self) -> tuple[int, ...]: ...

    @property
    def dtype(self) -> np.dtype: ...

    def __getitem__(self, index): ...


class FrameChain:
    """Several frame stacks of one image size and type read as one, lazily (frames in order).

    Parameters
    ----------
    parts : (N_i, H, W) arrays or :class:`FrameArray` objects of one dtype and image size.
    """

    def __init__(self, parts: Sequence[np.ndarray | FrameArray]) -> None:
        if not parts:
            raise BadInputError("FrameChain needs at least one frame stack")
        shapes = {tuple(p.shape[1:]) for p in parts}
        dtypes = {np.dtype(p.dtype) for p in parts}
        if len(shapes) != 1 or len(dtypes) != 1 or any(len(p.shape) != 3 for p in parts):
            raise BadInputError(f"frame stacks to chain must share image size and type, got {shapes} {dtypes}")
        self._parts = tuple(parts)
        self._starts = np.cumsum([0] + [p.shape[0] for p in parts])
        self.shape = (int(self._starts[-1]), *shapes.pop())
        self.dtype = dtypes.pop()
        self.ndim = 3

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, index) -> np.ndarray:
        return read_frames(self, index, self._frame)

    def _frame(self, k: int) -> np.ndarray:
        part = int(np.searchsorted(self._starts, k, side="right")) - 1
        return np.asarray(self._parts[part][k - self._starts[part]])

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        return np.concatenate([np.asarray(p) for p in self._parts]).astype(dtype or self.dtype, copy=False)


def read_frames(frames: FrameArray, index, read_one) -> np.ndarray:
    """``frames[index]`` for a lazy stack: an int gives (H, W), a slice or int array (n, H, W).

    ``read_one(k)`` reads frame ``k`` (0 <= k < N); negative indices count from the end.
    """
    n = frames.shape[0]
    if isinstance(index, (int, np.integer)):
        k = int(index) + n if index < 0 else int(index)
        if not 0 <= k < n:
            raise IndexError(f"frame {index} out of range for {n} frames")
        return read_one(k)
    if isinstance(index, slice):
        ks = range(*index.indices(n))
    else:
        ks = np.asarray(index)
        if ks.dtype == bool:
            ks = np.flatnonzero(ks)
        if ks.ndim != 1 or not np.issubdtype(ks.dtype, np.integer):
            raise BadInputError(f"index frames by an int, a slice or a 1-D int array, got {index!r}")
        ks = np.where(ks < 0, ks + n, ks)
        if np.any((ks < 0) | (ks >= n)):
            raise IndexError(f"frame index out of range for {n} frames")
    out = np.empty((len(ks), *frames.shape[1:]), dtype=frames.dtype)
    for i, k in enumerate(ks):
        out[i] = read_one(int(k))
    return out


def _frames(arr, name: str, n: int, dtype: type) -> np.ndarray | FrameArray:
    """``arr`` as read-only frames: a numpy copy, or a lazy stack as it is (checked for type and length)."""
    if not isinstance(arr, np.ndarray) and isinstance(arr, FrameArray):
        frames = arr
    else:
        frames = np.array(arr)
        frames.setflags(write=False)
    if np.dtype(frames.dtype) != dtype or len(frames.shape) != 3 or frames.shape[0] != n:
        raise BadInputError(f"{name} must be {np.dtype(dtype).name} (N, H, W) with N = {n}, "
                            f"got {frames.dtype} {frames.shape}")
    return frames


@dataclass(frozen=True, eq=False)
class DepthStream:
    """Depth frames of one camera.

    Attributes
    ----------
    timestamps : np.ndarray
        (N,) float64 seconds on the camera's clock, strictly increasing.
    depth_mm : np.ndarray or FrameArray
        (N, H, W) uint16 z-depth in millimetres; 0 where there is no return. In memory, or a lazy
        :class:`FrameArray` (``depth_mm[k]`` reads frame k).
    labels : np.ndarray, FrameArray or None
        (N, H, W) uint8 :class:`Label` values, or None when the sensor gives no segmentation.
    """

    timestamps: np.ndarray
    depth_mm: np.ndarray
    labels: np.ndarray | None = None

    def __post_init__(self) -> None:
        ts = np.array(self.timestamps, dtype=np.float64)
        if ts.ndim != 1 or not np.all(np.isfinite(ts)) or (ts.size > 1 and np.any(np.diff(ts) <= 0)):
            raise BadInputError("depth timestamps must be a finite, strictly increasing 1-D array")
        ts.setflags(write=False)
        object.__setattr__(self, "timestamps", ts)
        depth = _frames(self.depth_mm, "depth_mm", ts.shape[0], np.uint16)
        object.__setattr__(self, "depth_mm", depth)
        if self.labels is not None:
            labels = _frames(self.labels, "labels", ts.shape[0], np.uint8)
            if labels.shape != depth.shape:
                raise BadInputError(f"labels must have the depth frames' shape {depth.shape}, got {labels.shape}")
            object.__setattr__(self, "labels", labels)

    @property
    def n_frames(self) -> int:
        """Number of frames N."""
        return self.timestamps.shape[0]

    @property
    def image_shape(self) -> tuple[int, int]:
        """(H, W) of every frame [px]."""
        return tuple(self.depth_mm.shape[1:])

    def equals(self, other: "DepthStream") -> bool:
        """Exact equality of all arrays (lazy frames are compared one at a time)."""
        if (self.labels is None) != (other.labels is None) or not np.array_equal(self.timestamps, other.timestamps):
            return False
        pairs = [(self.depth_mm, other.depth_mm)] + ([] if self.labels is None else [(self.labels, other.labels)])
        return all(a.shape == b.shape and all(np.array_equal(a[k], b[k]) for k in range(a.shape[0]))
                   for a, b in pairs)


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
