"""A rig calibration: each camera's pose in the world frame, its intrinsics and clock offset.

The TOML file format is :mod:`fusion.io.calibration_file`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fusion.camera import Intrinsics
from fusion.errors import BadInputError, UnknownNameError
from fusion.transforms import validate_transform

WORLD = "floor z = 0, z up, origin under the subject's start, x along its initial facing"


@dataclass(frozen=True, eq=False)
class Calibration:
    """A rig calibration as stored on disk.

    Attributes
    ----------
    T_world_cam : camera name -> (4, 4) pose [m].
    intrinsics : camera name -> intrinsics.
    clock_offset_s : camera name -> clock offset to the reference camera [s].
    reference : the reference camera.
    info : the remaining file fields (methods, quality figures, pairs, notes).
    """

    T_world_cam: dict[str, np.ndarray]
    intrinsics: dict[str, Intrinsics]
    clock_offset_s: dict[str, float]
    reference: str
    info: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.T_world_cam:
            raise BadInputError("a calibration needs at least one camera")
        if self.reference not in self.T_world_cam:
            raise UnknownNameError("reference camera", self.reference, self.T_world_cam)
        for name in self.T_world_cam:
            T = validate_transform(self.T_world_cam[name], f"T_world_cam of {name}").copy()
            T.setflags(write=False)
            self.T_world_cam[name] = T
            if name not in self.intrinsics or name not in self.clock_offset_s:
                raise BadInputError(f"camera {name} lacks intrinsics or a clock offset")

    @property
    def camera_names(self) -> tuple[str, ...]:
        """Calibrated cameras, in file order."""
        return tuple(self.T_world_cam)

    def pose(self, name: str) -> np.ndarray:
        """``T_world_cam`` of one camera."""
        if name not in self.T_world_cam:
            raise UnknownNameError("calibrated camera", name, self.T_world_cam)
        return self.T_world_cam[name]
