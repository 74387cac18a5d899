"""The cross-camera residual split into what stays put and what fluctuates.

A camera pair's residual of one joint over a recording (:func:`fusion.merge.sensor_stats.cross_camera_residuals`)
is a series of vectors. Its median vector is the *steady* part (the two cameras' view-dependent biases
and the calibration's error at that joint); the robust spread about it is the *fluctuating* part.
"""

from __future__ import annotations

import numpy as np


def steady_vectors(parts: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Per camera pair and joint, the median residual vector (P, J, 3) [mm] (NaN with fewer than two
    samples) and the robust per-axis spread about it (P, J) [mm] (RMS of 1.4826 median absolute
    deviations), from ``parts``, one (T, J, 3) residual series [m] per camera pair; outliers move neither."""
    if not parts:
        return np.zeros((0, 0, 3)), np.zeros((0, 0))
    vec = np.stack([p * 1e3 for p in parts])
    ok = np.isfinite(vec[..., 0]).sum(axis=1) >= 2
    vec = np.where(ok[:, None, :, None], vec, 0.0)
    centre = np.nanmedian(vec, axis=1)
    spread = 1.4826 * np.nanmedian(np.abs(vec - centre[:, None]), axis=1)
    fluct = np.where(ok, np.sqrt(np.mean(spread**2, axis=-1)), np.nan)
    return np.where(ok[..., None], centre, np.nan), fluct
