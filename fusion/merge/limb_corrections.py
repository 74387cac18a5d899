"""The joints moved onto the limb axes that :func:`fusion.merge.limb_axes.limb_axes` fitted.

Each joint of a counted segment goes to the point nearest, in the least-squares sense, to the counted
axes through it, pulled toward its own position with weight ``pull``: onto one axis it moves across
it; between two axes at an angle (a bent elbow or knee) it goes to where they pass closest. A shoulder
or hip with a functional centre (:mod:`fusion.merge.pivots`), or a hand found in the clouds
(:mod:`fusion.merge.hand_ends`), is pulled toward that point as well, with weight ``anchor_pull``: along
its axis where one counted, toward the point alone where none did. The
corrections are found at the depth instants and interpolated in time onto the skeleton's frames.
Applied to every camera's measurements before fusing (:func:`with_limb_axes`), and again to a
kinematic fit's result (:func:`onto_axes`), whose constant bone lengths pull the joints off the axes.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from fusion.calibrate.sync import nearest_index
from fusion.errors import BadInputError
from fusion.merge.pivots import Pivot
from fusion.merge.views import CameraViews
from fusion.topology import Topology


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
    pivots : the shoulders' and hips' functional centres tried (:class:`~fusion.merge.pivots.Pivot`).
    anchors : (K, J, 3) [m] where the counting pivots and the hands from the clouds put their joints at
        each instant (NaN elsewhere).
    anchor_pull : weight [1] of the anchors (per unit projector).
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
    pivots: tuple[Pivot, ...] = ()
    anchors: np.ndarray | None = None
    anchor_pull: float = 0.0

    def counted_share(self) -> dict[str, float]:
        """Per segment, the share of depth instants whose fit counted."""
        share = self.counted.mean(axis=0) if self.counted.size else np.zeros(len(self.names))
        return {n: float(s) for n, s in zip(self.names, share)}

    def anchored_share(self, topology: Topology) -> dict[str, float]:
        """Per joint that has an anchor at some instant, the share of depth instants at which it has one."""
        if self.anchors is None or not self.anchors.size:
            return {}
        share = np.isfinite(self.anchors).all(axis=-1).mean(axis=0)
        return {topology.joints[j]: float(share[j]) for j in np.flatnonzero(share > 0)}

    def pivot_summary(self, topology: Topology) -> dict[str, dict[str, object]]:
        """Per joint tried, its pivot in the trunk frame [mm] (None when it did not count), the
        spread of its axes, their RMS distance from it [mm] (None with too few axes), how many instants
        gave it, and whether the point is its twin's mirrored."""
        return {topology.joints[p.joint]: {
            "point_mm": [float(x) * 1e3 for x in p.point] if p.counts else None, "spread": p.spread,
            "rms_mm": p.rms_m * 1e3 if np.isfinite(p.rms_m) else None, "instants": p.instants, "twin": p.twin}
            for p in self.pivots}


def joint_offsets(targets: np.ndarray, segments: np.ndarray, centres: np.ndarray, directions: np.ndarray,
                   counted: np.ndarray, pull: float, anchors: np.ndarray | None = None,
                   anchor_pull: float = 0.0) -> np.ndarray:
    """(K, J, 3) [m] per instant each joint's move onto the counted axes through it, pulled toward its
    finite ``anchors`` (K, J, 3) with weight ``anchor_pull`` (module docstring); NaN where no counted
    axis passes through the joint or it was not measured."""
    K, J = targets.shape[:2]
    out = np.full((K, J, 3), np.nan)
    d = np.where(counted[..., None], directions, 0.0)
    proj = np.where(counted[..., None, None], np.eye(3) - d[..., :, None] * d[..., None, :], 0.0)  # (K, S, 3, 3)
    pc = np.einsum("ksij,ksj->ksi", proj, np.nan_to_num(centres))
    anchored = [] if anchors is None or anchor_pull <= 0 else np.flatnonzero(np.isfinite(anchors).all(axis=-1).any(axis=0))
    for j in np.union1d(segments, anchored).astype(int):
        lines = np.flatnonzero((segments == j).any(axis=1))
        M = proj[:, lines].sum(axis=1) + pull * np.eye(3)
        rhs = pc[:, lines].sum(axis=1) + pull * np.nan_to_num(targets[:, j])
        a = np.zeros(K, dtype=bool)
        if anchors is not None and anchor_pull > 0:
            a = np.isfinite(anchors[:, j]).all(axis=-1)
            M = M + (anchor_pull * a)[:, None, None] * np.eye(3)
            rhs = rhs + anchor_pull * np.where(a[:, None], anchors[:, j], 0.0)
        x = np.linalg.solve(M, rhs[..., None])[..., 0]
        ok = (counted[:, lines].any(axis=1) | a) & np.isfinite(targets[:, j]).all(axis=-1)
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
    moved onto the counted axes (module docstring); the constants as :class:`~fusion.merge.limb_axis_options.LimbAxisOptions`'s."""
    k = nearest_index(times, axes.times)
    near = np.abs(times[k] - axes.times) <= tolerance_s
    at = np.where(near[:, None, None], positions[k], np.nan)
    off = joint_offsets(at, axes.segments, axes.centres, axes.directions, axes.counted, pull, axes.anchors,
                        axes.anchor_pull)
    return positions + offsets_on_frames(axes.times, off, times, max_gap_s)
