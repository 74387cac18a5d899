"""The cross-camera residual, and its parts: what stays put, what fluctuates, and its far tail.

A camera pair's residual of one joint over a recording (:func:`cross_camera_residuals`) is a series of
vectors. Its median vector is the *steady* part (the two cameras' view-dependent biases and the
calibration's error at that joint); the robust spread about it is the *fluctuating* part. The far tail
(:func:`tracked_tail`) is where a tracker reports a joint at full confidence far from where the other
camera puts it, as body trackers do with a limb they cannot see.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from fusion.recording import Recording
from fusion.topology import Landmark, Topology, TrackingState
from fusion.transforms import apply

TAIL_M = 0.08
"""Residual [m] beyond which a sample is in the far tail: the body calibration's inlier threshold."""

TAIL_JOINTS = ("elbow", "wrist")
"""Landmark stems (both sides) whose far tail is measured: the arm joints a body hides most."""


def cross_camera_residuals(recording: Recording, T_world_cam: Mapping[str, np.ndarray], reference: str,
                           period: float, *, min_state: TrackingState = TrackingState.NOT_TRACKED) -> list[np.ndarray]:
    """Where each other camera puts the reference camera's joints, under a calibration.

    Parameters
    ----------
    recording : cameras with skeleton streams.
    T_world_cam : camera -> (4, 4) calibration; cameras it lacks are skipped.
    reference : camera the others are compared with.
    period : frame period [s]; frames are paired by timestamp within half of it.
    min_state : a joint counts only where its state is at least this in both cameras.

    Returns
    -------
    list of np.ndarray
        One (T_ref, J, 3) array [m] per other camera: reference joint minus the other camera's, in
        the world frame, per frame of the reference camera; NaN where unpaired, absent or below
        ``min_state``.
    """
    cams = {c.name: c for c in recording.cameras if c.skeleton is not None}
    ref = cams[reference].skeleton
    p_ref = apply(T_world_cam[reference], ref.positions)
    out = []
    for name, cam in cams.items():
        if name == reference or name not in T_world_cam:
            continue
        s = cam.skeleton
        idx = np.clip(np.searchsorted(s.timestamps, ref.timestamps), 1, s.n_frames - 1)
        idx = np.where(np.abs(s.timestamps[idx - 1] - ref.timestamps) < np.abs(s.timestamps[idx] - ref.timestamps),
                       idx - 1, idx)
        near = np.abs(s.timestamps[idx] - ref.timestamps) < 0.5 * period
        keep = near[:, None] & (ref.states >= min_state) & (s.states[idx] >= min_state)
        p_other = apply(T_world_cam[name], s.positions[idx])
        out.append(np.where(keep[..., None], p_ref - p_other, np.nan))
    return out


def tracked_tail(parts: list[np.ndarray], topology: Topology) -> float:
    """Share of the :data:`TAIL_JOINTS` samples of ``parts`` (residual series (T, J, 3) [m], NaN where the
    joint was not Tracked in both cameras: ``cross_camera_residuals(..., min_state=TRACKED)``) beyond
    :data:`TAIL_M`; NaN without any."""
    cols = [topology.index(Landmark(f"{stem}_{side}")) for stem in TAIL_JOINTS for side in ("left", "right")]
    r = np.concatenate([np.linalg.norm(p[:, cols], axis=-1).ravel() for p in parts]) if parts else np.zeros(0)
    r = r[np.isfinite(r)]
    return float(np.mean(r > TAIL_M)) if r.size else float("nan")


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
