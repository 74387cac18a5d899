"""Pinhole depth-camera intrinsics, projection and back-projection.

Camera frames are the sensor's native camera space. Depth images store z (distance from the camera
plane, not ray length) in millimetres. Pixel (u, v) has u to the right in the image and v down.
For the Kinect v2 camera space (+x to the sensor's left, +y up, +z forward) a point projects to
``u = cx + fx * x / z`` and ``v = cy - fy * y / z``: Kinect v2 depth images are mirrored, as the
``depthX``/``depthY`` columns of real recordings confirm. For Azure Kinect space (+x right, +y
down) ``u = cx + fx * x / z``, ``v = cy + fy * y / z``. :class:`Intrinsics` carries which applies.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from fusion.errors import BadInputError


class AxisConvention(enum.Enum):
    """Axis layout of a camera frame."""

    KINECT_V2 = "kinect_v2"
    """+x to the sensor's left, +y up, +z forward (out of the sensor)."""
    OPENCV = "opencv"
    """+x right, +y down, +z forward (Azure Kinect / Orbbec, OpenCV)."""


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics of a depth camera.

    Attributes
    ----------
    width, height : int
        Image size [px].
    fx, fy : float
        Focal lengths [px].
    cx, cy : float
        Principal point [px].
    min_depth_m, max_depth_m : float
        Reliable depth range [m]; returns outside are missing.
    axes : AxisConvention
        Axis layout of the camera frame these intrinsics project from.
    """

    width: int = 512
    height: int = 424
    fx: float = 365.5
    fy: float = 365.5
    cx: float = 255.5
    cy: float = 211.5
    min_depth_m: float = 0.5
    max_depth_m: float = 4.5
    axes: AxisConvention = AxisConvention.KINECT_V2

    def __post_init__(self) -> None:
        vals = (self.fx, self.fy, self.cx, self.cy, self.min_depth_m, self.max_depth_m)
        if not all(np.isfinite(vals)):
            raise BadInputError(f"intrinsics must be finite, got {self}")
        if self.width <= 0 or self.height <= 0 or self.fx <= 0 or self.fy <= 0:
            raise BadInputError(f"intrinsics need positive size and focal length, got {self}")
        if not 0 < self.min_depth_m < self.max_depth_m:
            raise BadInputError(f"need 0 < min_depth_m < max_depth_m, got {self.min_depth_m}, {self.max_depth_m}")

    @property
    def _v_sign(self) -> float:
        return -1.0 if self.axes is AxisConvention.KINECT_V2 else 1.0

    def project(self, p_cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates ``(..., 2)`` (u, v) [px] and depth z ``(...)`` [m] of points ``(..., 3)``.

        Points with z <= 0 get NaN pixel coordinates.
        """
        p_cam = np.asarray(p_cam, dtype=float)
        if p_cam.shape[-1:] != (3,):
            raise BadInputError(f"points must have shape (..., 3), got {p_cam.shape}")
        z = p_cam[..., 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = np.where(z > 0, 1.0 / z, np.nan)
        u = self.cx + self.fx * p_cam[..., 0] * inv
        v = self.cy + self._v_sign * self.fy * p_cam[..., 1] * inv
        return np.stack([u, v], axis=-1), z

    def backproject(self, uv: np.ndarray, z: np.ndarray) -> np.ndarray:
        """Points ``(..., 3)`` [m] from pixels ``(..., 2)`` [px] and depths z ``(...)`` [m]."""
        uv = np.asarray(uv, dtype=float)
        z = np.asarray(z, dtype=float)
        x = (uv[..., 0] - self.cx) * z / self.fx
        y = self._v_sign * (uv[..., 1] - self.cy) * z / self.fy
        return np.stack([x, y, z], axis=-1)

    def pixel_rays(self) -> np.ndarray:
        """Per-pixel ray directions at z = 1, shape (height, width, 3), for pixel centres."""
        v, u = np.mgrid[0 : self.height, 0 : self.width].astype(float)
        return self.backproject(np.stack([u, v], axis=-1), np.ones((self.height, self.width)))

    def in_image(self, uv: np.ndarray) -> np.ndarray:
        """Boolean mask ``(...)`` of pixel coordinates inside the image."""
        uv = np.asarray(uv, dtype=float)
        with np.errstate(invalid="ignore"):
            return (uv[..., 0] >= -0.5) & (uv[..., 0] < self.width - 0.5) & (uv[..., 1] >= -0.5) & (
                uv[..., 1] < self.height - 0.5
            )

    def to_dict(self) -> dict:
        """Plain-type dictionary for files."""
        d = {k: getattr(self, k) for k in ("width", "height", "fx", "fy", "cx", "cy", "min_depth_m", "max_depth_m")}
        d["axes"] = self.axes.value
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "Intrinsics":
        """Inverse of :meth:`to_dict`; unknown keys are an error."""
        d = dict(d)
        try:
            axes = AxisConvention(d.pop("axes", AxisConvention.KINECT_V2.value))
        except ValueError:
            raise BadInputError(f"unknown axes convention; use one of {[a.value for a in AxisConvention]}") from None
        unknown = set(d) - {"width", "height", "fx", "fy", "cx", "cy", "min_depth_m", "max_depth_m"}
        if unknown:
            raise BadInputError(f"unknown intrinsics keys: {sorted(unknown)}")
        return cls(axes=axes, **d)


KINECT_V2_DEPTH = Intrinsics()
"""Default Kinect v2 depth intrinsics (512 x 424, fx = fy = 365.5)."""
