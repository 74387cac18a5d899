"""Frames, axis conventions and length units shared by the stages: z-up world, y-up tools, upright
camera frames.

The world frame of a fused recording has z up, the floor at z = 0, metres. A camera's own frame
follows its :class:`~fusion.camera.AxisConvention` (Kinect v2: +y up; OpenCV / Azure Kinect: +y down).
"""

from __future__ import annotations

import enum

import numpy as np

from fusion.camera import AxisConvention
from fusion.transforms import apply, make_transform


class LengthUnit(enum.Enum):
    """A length unit of positions in files (read or written)."""

    M = "m"
    MM = "mm"
    CM = "cm"

    @property
    def metres(self) -> float:
        """The size of this unit in metres."""
        return {LengthUnit.M: 1.0, LengthUnit.MM: 1e-3, LengthUnit.CM: 1e-2}[self]

    @property
    def per_metre(self) -> float:
        """How many of this unit make one metre."""
        return 1.0 / self.metres


class UpAxis(enum.Enum):
    """Vertical axis of exported positions (the stream's frame has z up)."""

    Z = "z"
    """Positions as in the stream: x forward, y left, z up."""
    Y = "y"
    """OpenSim convention: ``(X, Y, Z) = (x, z, -y)``, i.e. x forward, y up, z to the right."""


T_YUP_ZUP = make_transform(np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]), np.zeros(3))
"""A z-up frame seen in y-up axes (OpenSim, glTF): ``(X, Y, Z) = (x, z, -y)``."""
_T_ZUP_CAMERA = {
    AxisConvention.KINECT_V2: make_transform(np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
                                             np.zeros(3)),
    AxisConvention.OPENCV: make_transform(np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]]),
                                          np.zeros(3)),
}


def T_upright_camera(camera_axes: AxisConvention) -> np.ndarray:
    """(4, 4) transform of a camera frame of that axis layout into its upright frame: ``(x, y, z) =
    (forward, left, up)`` of the camera, assuming it stands level (no pitch, no roll)."""
    return _T_ZUP_CAMERA[AxisConvention(camera_axes)].copy()


def z_up_positions(positions: np.ndarray, camera_axes: AxisConvention | None) -> np.ndarray:
    """Positions (..., 3) [m] in a z-up frame.

    ``camera_axes=None``: the positions are in the world frame already (z up) and are returned as they
    are. Otherwise they are in a camera frame of that axis layout (Kinect v2: +y up; OpenCV: +y down)
    and become ``(x, y, z) = (forward, left, up)`` of the camera, assuming it stands upright.
    """
    if camera_axes is None:
        return np.asarray(positions, dtype=float)
    return apply(T_upright_camera(camera_axes), positions)
