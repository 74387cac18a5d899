"""The joints moved onto the limb axes that :func:`fusion.merge.limb_axes.limb_axes` fitted.

Each joint of a counted segment goes to the point nearest, in the least-squares sense, to the counted
axes through it, pulled toward its own position with weight ``pull``: onto one axis it moves across
it; between two axes at an angle (a bent elbow or knee) it goes to where they pass closest. The
corrections are found at the depth instants and interpolated in time onto the skeleton's frames.
Applied to every camera's measurements before fusing (:func:`with_limb_axes`), and again to a
kinematic fit's result (:func:`onto_axes`), whose constant bone lengths pull the joints off the axes.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fusion.calibrate.sync import nearest_index
from fusion.errors import BadInputError
from fusion.merge.views import CameraViews


@dataclass(frozen=True, eq=False)
class LimbAxes:
    """Result of :func:`limb_axes`.

    Attributes
    ----------
    segments : (S, 2) joint indices (proximal, distal) of the fitted segments.
    names : (S,) their names, the topology's joint names joined by ``-`` (``"ShoulderLeft-ElbowLeft"`` ...).
    radii_m : (S,) [m] each segment's radius; NaN where none could be measured (never fitted).
    times : (K,) [s] the depth instants, reference clock.
    centres : (K, S, 3) [m] a point of each fitted axis (NaN where not fitted).
    directions : (K, S, 3) unit axis directions, proximal to distal.
    rms_m : (K, S) [m] RMS distance of the kept points from the cylinder.
    counted : (K, S) bool, the fit passed the checks.
    offsets : (T, J, 3) [m] the correction of every joint on the views' frames (zero where none).
    """

    segments: np.ndarray
    names: tuple[str, ...]
    radii_m: np.ndarray
    times: np.ndarray
    centres: np.ndarray
    directions: np.ndarray
    rms_m: np.ndarray
    counted: np.ndarray
    offsets: np.ndarray

    def counted_share(self) -> dict[str, float]:
        """Per segment, the share of depth instants whose fit counted."""
        share = self.counted.mean(axis=0) if self.counted.size else np.zeros(len(self.names))
        return {n: float(s) for n, s in zip(self.names, share)}


def joint_offsets(targets: np.ndarray, segments: np.ndarray, centres: np.ndarray, directions: np.ndarray,
                   counted: np.ndarray, pull: float) -> np.ndarray:
    """(K, J, 3) [m] per instant each joint's move onto the counted axes through it (module docstring);
    NaN where no counted axis passes through the joint or it was not measured."""
    K, J = targets.shape[:2]
    out = np.full((K, J, 3), np.nan)
    d = np.where(counted[..., None], directions, 0.0)
    proj = np.where(counted[..., None, None], np.eye(3) - d[..., :, None] * d[..., None, :], 0.0)  # (K, S, 3, 3)
    pc = np.einsum("ksij,ksj->ksi", proj, np.nan_to_num(centres))
    for j in np.unique(segments):
        lines = np.flatnonzero((segments == j).any(axis=1))
        M = proj[:, lines].sum(axis=1) + pull * np.eye(3)
        rhs = pc[:, lines].sum(axis=1) + pull * np.nan_to_num(targets[:, j])
        x = np.linalg.solve(M, rhs[..., None])[..., 0]
        ok = counted[:, lines].any(axis=1) & np.isfinite(targets[:, j]).all(axis=-1)
        out[ok, j] = (x - targets[:, j])[ok]
    return out


def offsets_on_frames(instants: np.ndarray, offsets: np.ndarray, times: np.ndarray, max_gap_s: float) -> np.ndarray:
    """(T, J, 3) the per-instant offsets (K, J, 3) interpolated linearly onto ``times`` (T,), zero
    farther than ``max_gap_s`` from an instant that has one."""
    out = np.zeros((times.size, *offsets.shape[1:]))
    for j in range(offsets.shape[1]):
        ok = np.isfinite(offsets[:, j]).all(axis=-1)
        if not ok.any():
            continue
        t = instants[ok]
        near = np.abs(times - t[nearest_index(t, times)]) <= max_gap_s
        for c in range(3):
            out[near, j, c] = np.interp(times[near], t, offsets[ok, j, c])
    return out


def with_limb_axes(views: CameraViews, axes: LimbAxes) -> CameraViews:
    """``views`` with every camera's measurement of each joint moved by the limb axes' correction."""
    if axes.offsets.shape != views.positions.shape[1:]:
        raise BadInputError(f"limb-axis corrections {axes.offsets.shape} do not match the views' frames and joints "
                            f"{views.positions.shape[1:]}; fit the limb axes on these views")
    return replace(views, positions=views.positions + axes.offsets[None])


def onto_axes(positions: np.ndarray, times: np.ndarray, axes: LimbAxes, *, pull: float = 0.05,
              tolerance_s: float = 0.02, max_gap_s: float = 0.25) -> np.ndarray:
    """(T, J, 3) [m] a skeleton's positions (T, J, 3) at ``times`` (T,) [s] with its limb joints
    moved onto the counted axes (module docstring); the constants as :class:`~fusion.merge.limb_axes.LimbAxisOptions`'s."""
    k = nearest_index(times, axes.times)
    near = np.abs(times[k] - axes.times) <= tolerance_s
    at = np.where(near[:, None, None], positions[k], np.nan)
    off = joint_offsets(at, axes.segments, axes.centres, axes.directions, axes.counted, pull)
    return positions + offsets_on_frames(axes.times, off, times, max_gap_s)
