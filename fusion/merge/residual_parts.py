"""The cross-camera residual, and its parts: what stays put, what fluctuates, and its far tail.

A camera pair's residual of one joint over a recording (:func:`cross_camera_residuals`) is a series of
vectors. Its median vector is the *steady* part (the two cameras' view-dependent biases and the
calibration's error at that joint); the robust spread about it is the *fluctuating* part. The far tail
(:func:`tracked_tail`) is where a tracker reports a joint at full confidence far from where the other
camera puts it, as body trackers do with a limb they cannot see. The trunk's turn (:func:`trunk_turn`)
is how far the cameras disagree on the trunk's orientation once they agree on the whole body: the
rotation left between their trunk joints under a calibration fitted to all joints.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from scipy.spatial.transform import Rotation

from fusion.calibrate.kabsch import kabsch
from fusion.merge.limb_sharing import LIMB_STEMS
from fusion.recording import Recording
from fusion.topology import Landmark, Topology, TrackingState
from fusion.transforms import apply

TAIL_M = 0.08
"""Residual [m] beyond which a sample is in the far tail: the body calibration's inlier threshold."""

TAIL_JOINTS = ("elbow", "wrist")
"""Landmark stems (both sides) whose far tail is measured: the arm joints a body hides most."""

MIN_TURN_SAMPLES = 30
"""Fewest paired trunk samples a camera pair's :func:`trunk_turn` is fitted on (else NaN)."""


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


def trunk_joints(topology: Topology) -> np.ndarray:
    """(J,) bool: the joints of no limb (:data:`fusion.merge.limb_sharing.LIMB_STEMS`): pelvis, spine, neck,
    head, hips, clavicles and face."""
    trunk = np.ones(topology.n_joints, dtype=bool)
    for lm in (Landmark(f"{stem}_{side}") for stem in LIMB_STEMS for side in ("left", "right")):
        if lm in topology.landmarks:
            trunk[topology.index(lm)] = False
    return trunk


def trunk_turn(parts: list[np.ndarray], reference_world: np.ndarray, topology: Topology) -> np.ndarray:
    """Per camera pair, the rotation vector [deg] (P, 3) that takes the other camera's trunk joints
    (:func:`trunk_joints`) onto the reference camera's: the Kabsch fit over their paired samples
    within :data:`TAIL_M` of each other; NaN where fewer than :data:`MIN_TURN_SAMPLES` are.

    ``parts`` are the residual series (T, J, 3) [m] of :func:`cross_camera_residuals` (Tracked in both
    cameras), ``reference_world`` (T, J, 3) [m] the reference camera's joints in the world frame. Under
    a calibration fitted to the whole body it is the trunk's own disagreement, which a calibration
    that leans on the trunk joints takes over.
    """
    trunk = trunk_joints(topology)
    out = np.full((len(parts), 3), np.nan)
    for k, res in enumerate(parts):
        ok = np.isfinite(res[..., 0]) & (np.linalg.norm(res, axis=-1) < TAIL_M) & trunk[None, :]
        if ok.sum() >= MIN_TURN_SAMPLES:
            T = kabsch(reference_world[ok] - res[ok], reference_world[ok])
            out[k] = np.degrees(Rotation.from_matrix(T[:3, :3]).as_rotvec())
    return out
