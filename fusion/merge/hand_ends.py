"""The hands from the depth clouds: the far end of the body beyond each wrist.

A body tracker's hand, hand-tip and thumb joints err by several centimetres (its hand model is coarse,
and the hand is small in a depth image), yet the cameras see the hand's surface. Per depth instant and
side, after the limb axes and pivots have corrected the arm (:mod:`fusion.merge.limb_axes`):

- **Points.** The body points within ``reach_m`` of the segment that continues the forearm past the
  corrected wrist for ``length_m``, beyond the wrist along it, and nearer to that segment than to any
  bone of the skeleton but the forearm and the hand's own (the tracker's hand joints are what is
  corrected, so their bones do not claim points). A hand near the face or the trunk keeps only the
  points nearer to it than to the head's and the trunk's bones.
- **Axis.** The points' principal direction, pointing away from the elbow; a hand whose points turn
  more than ``max_turn_deg`` from the forearm, or that has fewer than ``min_points`` points, is left out.
- **Tip.** The hand tip is the points' centroid moved along the axis to their ``quantile`` extent (the
  far end of the hand, robust to a few stray points); the hand joint lies ``hand_fraction`` of the way
  from the corrected wrist to the tip (the project's landmark: 0.3 hand lengths from the wrist,
  :mod:`sim.humanoid_model`). Both are anchors (:func:`fusion.merge.limb_corrections.joint_offsets`).

What it cannot see: the thumb (left to the tracker), a fist's fingers (its tip is the knuckles), a hand
pressed against the body, whose surface the points cannot tell from the body's, and, in depth frames
without body labels, a hand resting on a table, whose surface comes with it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fusion.arrays import segment_distances, unit
from fusion.errors import BadInputError
from fusion.topology import Landmark, Topology

SIDES = (("ELBOW_LEFT", "WRIST_LEFT", "HAND_LEFT", "HANDTIP_LEFT", "THUMB_LEFT"),
         ("ELBOW_RIGHT", "WRIST_RIGHT", "HAND_RIGHT", "HANDTIP_RIGHT", "THUMB_RIGHT"))
"""Per side the :class:`~fusion.topology.Landmark` names: elbow, wrist, hand, hand tip, thumb."""


@dataclass(frozen=True)
class HandOptions:
    """Constants of the hand-end fit (module docstring).

    Attributes
    ----------
    reach_m : [m] a hand point lies within this of the forearm's continuation past the wrist.
    length_m : [m] the continuation's length (longer than a hand).
    min_points : the fewest points a hand is found from.
    max_turn_deg : [deg] the most the hand's direction may turn from the forearm's.
    quantile : the quantile of the points' extent along the hand taken as its far end.
    hand_fraction : where the hand joint lies from the wrist to the tip (0-1).
    """

    reach_m: float = 0.06
    length_m: float = 0.22
    min_points: int = 30
    max_turn_deg: float = 45.0
    quantile: float = 0.98
    hand_fraction: float = 0.3

    def __post_init__(self) -> None:
        for name in ("reach_m", "length_m", "max_turn_deg"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise BadInputError(f"hands: {name} must be positive and finite, got {getattr(self, name)}")
        for name in ("quantile", "hand_fraction"):
            if not 0.0 < getattr(self, name) <= 1.0:
                raise BadInputError(f"hands: {name} must lie in (0, 1], got {getattr(self, name)}")
        if self.min_points < 3:
            raise BadInputError(f"hands: min_points must be at least 3 (a direction needs them), got {self.min_points}")


def hand_points(points: np.ndarray, skeleton: np.ndarray, topology: Topology, elbow: int, wrist: int,
                hand: set[int], options: HandOptions) -> np.ndarray:
    """(M, 3) [m] the hand's ``points`` (N, 3) beyond the ``wrist`` of the corrected ``skeleton`` (J, 3),
    whose ``hand`` joints' bones claim none (module docstring)."""
    d = unit(skeleton[wrist] - skeleton[elbow])
    if not (np.isfinite(d).all() and len(points)):
        return np.zeros((0, 3))
    near = points[np.linalg.norm(points - skeleton[wrist], axis=1) < options.length_m + options.reach_m]
    near = near[(near - skeleton[wrist]) @ d > 0.0]
    own = hand | {wrist}
    bones = np.array([(a, b) for a, b in topology.bones if not ({int(a), int(b)} & own)
                      and np.isfinite(skeleton[[a, b]]).all()])
    mine = segment_distances(near, skeleton[wrist][None], (skeleton[wrist] + options.length_m * d)[None])[0][:, 0]
    keep = mine < options.reach_m
    if len(bones) and keep.any():
        others = segment_distances(near[keep], skeleton[bones[:, 0]], skeleton[bones[:, 1]])[0].min(axis=1)
        keep[np.flatnonzero(keep)[others <= mine[keep]]] = False
    return near[keep]


def hand_end(points: np.ndarray, wrist: np.ndarray, forearm: np.ndarray,
             options: HandOptions) -> tuple[np.ndarray, np.ndarray]:
    """The hand's tip and hand joint (3,) [m] from its ``points`` (M, 3), the corrected ``wrist`` (3,) and
    the unit ``forearm`` direction (3,) (module docstring); NaN when the checks fail."""
    none = (np.full(3, np.nan), np.full(3, np.nan))
    if len(points) < options.min_points:
        return none
    centre = points.mean(axis=0)
    axis = np.linalg.svd(points - centre, full_matrices=False)[2][0]
    axis = axis if axis @ forearm >= 0 else -axis
    if np.degrees(np.arccos(np.clip(axis @ forearm, -1.0, 1.0))) > options.max_turn_deg:
        return none
    tip = centre + np.quantile((points - centre) @ axis, options.quantile) * axis
    return tip, wrist + options.hand_fraction * (tip - wrist)


def hand_anchors(points: np.ndarray, skeleton: np.ndarray, topology: Topology, options: HandOptions) -> np.ndarray:
    """(J, 3) [m] the hand and hand-tip anchors of one instant: its body ``points`` (N, 3) and corrected
    ``skeleton`` (J, 3); NaN elsewhere and where a side fails its checks."""
    out = np.full(skeleton.shape, np.nan)
    for side in SIDES:
        if not all(Landmark[n] in topology.landmarks for n in side[:4]):
            continue
        elbow, wrist, hand, tip = (topology.index(Landmark[n]) for n in side[:4])
        own = {topology.index(Landmark[n]) for n in side[2:] if Landmark[n] in topology.landmarks}
        forearm = unit(skeleton[wrist] - skeleton[elbow])
        end, middle = hand_end(hand_points(points, skeleton, topology, elbow, wrist, own, options), skeleton[wrist],
                               forearm, options)
        out[tip], out[hand] = end, middle
    return out
