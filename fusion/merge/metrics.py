"""Truth-free quality measures of a (merged) skeleton stream, as the paper measures (section 3.8.4).

- :func:`bone_length_std`: how constant the bone lengths stay over time;
- :func:`held_out_support`: how many joints seen by cameras left out of the merge lie near the
  merged joints;
- :class:`Stats`: rmse / mean / median / std / max summary of a per-frame array.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from types import MappingProxyType

import numpy as np

from fusion.errors import BadInputError
from fusion.topology import Landmark, Topology, TrackingState

_L = Landmark
PAPER_BONES: Mapping[str, tuple[tuple[Landmark, Landmark], ...]] = MappingProxyType({
    "spine_shoulder-shoulder": ((_L.SPINE_SHOULDER, _L.SHOULDER_LEFT), (_L.SPINE_SHOULDER, _L.SHOULDER_RIGHT)),
    "shoulder-elbow": ((_L.SHOULDER_LEFT, _L.ELBOW_LEFT), (_L.SHOULDER_RIGHT, _L.ELBOW_RIGHT)),
    "elbow-wrist": ((_L.ELBOW_LEFT, _L.WRIST_LEFT), (_L.ELBOW_RIGHT, _L.WRIST_RIGHT)),
})
"""The paper's three bones (Table 3), each pooled over its left and right instance."""


@dataclass(frozen=True)
class Stats:
    """Summary of the finite values of an array (NaN ignored); all NaN when there are none.

    Attributes
    ----------
    rmse, mean, median, std, max : float
        Root mean square, mean, median, population standard deviation and maximum, in the array's
        unit.
    n : int
        Number of finite values summarised.
    """

    rmse: float
    mean: float
    median: float
    std: float
    max: float
    n: int

    @classmethod
    def of(cls, values: np.ndarray) -> "Stats":
        """Summarise ``values`` of any shape (NaN entries are ignored)."""
        v = np.asarray(values, dtype=float).ravel()
        if np.any(np.isinf(v)):
            raise BadInputError("Stats.of: values contain infinite entries")
        v = v[~np.isnan(v)]
        if v.size == 0:
            return cls(np.nan, np.nan, np.nan, np.nan, np.nan, 0)
        return cls(float(np.sqrt(np.mean(v**2))), float(v.mean()), float(np.median(v)), float(v.std()),
                   float(v.max()), int(v.size))

    def as_dict(self) -> dict[str, float]:
        """The fields as a plain dict (for ``result.json``)."""
        return asdict(self)


def _positions(positions: np.ndarray, topology: Topology, name: str = "positions") -> np.ndarray:
    p = np.asarray(positions, dtype=float)
    if p.ndim != 3 or p.shape[1:] != (topology.n_joints, 3):
        raise BadInputError(f"{name} must have shape (T, {topology.n_joints}, 3), got {p.shape}")
    return p


def bone_length_std(
    positions: np.ndarray,
    topology: Topology,
    bones: Mapping[str, Sequence[tuple[Landmark | str, Landmark | str]]] = PAPER_BONES,
    *,
    valid: np.ndarray | None = None,
) -> dict[str, float]:
    """Standard deviation over time [m] of bone lengths, instances of a bone pooled.

    Each named bone lists one or more (joint, joint) instances, e.g. its left and right side.
    Pooling removes each instance's own mean length first: the result is
    ``sqrt(sum_i sum_t (l_it - mean_t l_it)^2 / sum_i n_i)``, the within-instance spread, so a
    constant difference between the left and right bone (body asymmetry, a tracker's model) does
    not count as inconsistency.

    Parameters
    ----------
    positions : np.ndarray
        (T, J, 3) joint positions [m]; NaN where absent.
    topology : Topology
        The J joints.
    bones : mapping
        Bone name -> its instances as pairs of joints (:class:`Landmark` or joint names); defaults to
        the paper's three bones.
    valid : np.ndarray or None
        (T, J) bool, the joints to use (e.g. merged reliability HIGH, the paper's "confident
        joints"); all present joints when None.

    Returns
    -------
    dict
        Bone name -> pooled standard deviation [m]; NaN for a bone never measured.
    """
    p = _positions(positions, topology)
    present = ~np.isnan(p).any(axis=-1)
    if valid is not None:
        valid = np.asarray(valid)
        if valid.shape != present.shape or valid.dtype != bool:
            raise BadInputError(f"valid must be bool of shape {present.shape}, got {valid.dtype} {valid.shape}")
        present &= valid
    out = {}
    for name, instances in bones.items():
        pairs = topology.indices([j for pair in instances for j in pair]).reshape(-1, 2)
        length = np.linalg.norm(p[:, pairs[:, 0]] - p[:, pairs[:, 1]], axis=-1)  # (T, K)
        seen = present[:, pairs[:, 0]] & present[:, pairs[:, 1]]
        n = seen.sum(axis=0)
        mean = np.where(seen, length, 0.0).sum(axis=0) / np.maximum(n, 1)
        squares = np.where(seen, (length - mean) ** 2, 0.0).sum()
        out[name] = float(np.sqrt(squares / n.sum())) if n.sum() else np.nan
    return out


def held_out_support(
    merged_positions: np.ndarray,
    held_out_positions: np.ndarray,
    held_out_states: np.ndarray,
    *,
    thresholds: Sequence[float] = (0.05, 0.07),
    min_state: TrackingState = TrackingState.TRACKED,
    exclude_frames: np.ndarray | None = None,
) -> dict[float, float]:
    """Percentage of the joints seen by held-out cameras that lie near the merged joint.

    A held-out measurement counts when its state is at least ``min_state`` (the paper's "reliable
    measured joints") and its frame is not excluded. It supports the merged skeleton when it lies
    within ``d`` of the merged joint; a counted measurement of a joint the merge lacks (NaN) never
    supports it.

    Parameters
    ----------
    merged_positions : np.ndarray
        (T, J, 3) merged joints [m], world frame.
    held_out_positions : np.ndarray
        (C, T, J, 3) or (T, J, 3) the held-out cameras' joints [m], mapped to the world frame and
        resampled on the merged times.
    held_out_states : np.ndarray
        (C, T, J) or (T, J) their :class:`TrackingState` values.
    thresholds : sequence of float
        Distances d [m].
    min_state : TrackingState
        Least confidence of a held-out measurement that counts.
    exclude_frames : np.ndarray or None
        (C, T) or (T,) bool, frames to leave out, e.g. the held-out cameras' back-facing flags
        (labels swapped).

    Returns
    -------
    dict
        d -> percentage in [0, 100]; NaN when no held-out measurement counts.
    """
    merged = np.asarray(merged_positions, dtype=float)
    held = np.asarray(held_out_positions, dtype=float)
    states = np.asarray(held_out_states)
    if merged.ndim != 3 or merged.shape[2] != 3:
        raise BadInputError(f"merged_positions must have shape (T, J, 3), got {merged.shape}")
    if held.ndim == 3:
        held, states = held[None], states[None]
        exclude_frames = None if exclude_frames is None else np.asarray(exclude_frames)[None]
    if held.ndim != 4 or held.shape[1:] != merged.shape:
        raise BadInputError(f"held_out_positions must have shape (C, {', '.join(map(str, merged.shape))}), "
                            f"got {np.shape(held_out_positions)}")
    if states.shape != held.shape[:3]:
        raise BadInputError(f"held_out_states must have shape {held.shape[:3]}, got {np.shape(held_out_states)}")
    counted = (states >= min_state) & ~np.isnan(held).any(axis=-1)
    if exclude_frames is not None:
        exclude_frames = np.asarray(exclude_frames)
        if exclude_frames.shape != held.shape[:2] or exclude_frames.dtype != bool:
            raise BadInputError(f"exclude_frames must be bool of shape {held.shape[:2]}")
        counted &= ~exclude_frames[..., None]
    d = np.linalg.norm(held - merged[None], axis=-1)[counted]
    n = d.size
    out = {}
    for threshold in thresholds:
        if not (np.isfinite(threshold) and threshold > 0):
            raise BadInputError(f"thresholds must be positive distances [m], got {threshold}")
        out[float(threshold)] = 100.0 * np.count_nonzero(d <= threshold) / n if n else np.nan
    return out
