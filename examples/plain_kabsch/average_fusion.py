"""A textbook fusion, written against the mocap-bench API only: every camera's tracked joints
brought into the world frame and averaged at the reference camera's nearest frame; no back-facing
check, no confidence weighting. ``fuse(recording, calibration)`` is the interface ``--algorithm``
calls."""

from __future__ import annotations

import numpy as np
from plain_kabsch import TRACKED

from scenarios.api import Calibration, Recording


def fuse(recording: Recording, calibration: Calibration) -> np.ndarray:
    """(T, J, 3) world positions [m] on the reference camera's frames; NaN where no camera tracked a joint."""
    ref = recording.camera(calibration.reference).skeleton
    total = np.zeros(ref.positions.shape)
    count = np.zeros(ref.positions.shape[:2])
    for cam in recording.cameras:
        s = cam.skeleton
        t = s.timestamps - calibration.clock_offset_s[cam.name]
        k = np.clip(np.searchsorted(t, ref.timestamps - calibration.clock_offset_s[calibration.reference]),
                    0, len(t) - 1)
        T = calibration.T_world_cam[cam.name]
        p = s.positions[k] @ T[:3, :3].T + T[:3, 3]
        ok = s.states[k] == TRACKED
        total[ok] += p[ok]
        count += ok
    with np.errstate(invalid="ignore"):
        return np.where(count[..., None] > 0, total / count[..., None], np.nan)
