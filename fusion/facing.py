"""Back-facing skeletons from one camera's stream alone.

A body tracker seen from behind still fits a front-facing skeleton: left and right labels swap.
Two observation-only cues find those frames:

1. **Swap events.** When the tracker starts or stops reporting a person from behind, the left and
   right labels of the limbs jump onto each other's previous positions between consecutive frames.
   Frames between events therefore alternate between front- and back-facing.
2. **Feet against the chest.** Feet point forward from the ankles. A skeleton fitted to a person's
   back believes the chest faces the camera while the real feet point away, so the foot direction
   opposes the skeleton's chest normal. This cue decides which of the two alternating states a group
   of linked runs is in: the state whose runs have the larger median cue faces the camera (comparing
   the two states' medians cancels a static per-camera bias of the feet).

The result is a per-frame flag and score. Once the cameras are calibrated,
:func:`cross_check_back_facing` corrects the flags by comparing each skeleton with the other cameras'.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from fusion.arrays import nanmean, unit
from fusion.errors import BadInputError
from fusion.skeleton import SkeletonStream
from fusion.topology import Landmark, Topology

if TYPE_CHECKING:
    pass


LIMB_PAIRS = (
    (Landmark.SHOULDER_LEFT, Landmark.SHOULDER_RIGHT),
    (Landmark.ELBOW_LEFT, Landmark.ELBOW_RIGHT),
    (Landmark.HIP_LEFT, Landmark.HIP_RIGHT),
    (Landmark.KNEE_LEFT, Landmark.KNEE_RIGHT),
)


@dataclass(frozen=True, eq=False)
class BackFacing:
    """Per-frame back-facing detection of one skeleton stream.

    Attributes
    ----------
    flipped : (T,) bool, the skeleton is judged to be fitted to the person's back (labels swapped).
    foot_cue : (T,) float [m], foot direction along the skeleton's chest normal (NaN if unknown);
        positive for a front-facing fit.
    events : (E,) int, frames at which a left/right swap was detected (relative to the frame before).
    segment : (T,) int, id of the run of frames between events and gaps (-1 without a skeleton).
    """

    flipped: np.ndarray
    foot_cue: np.ndarray
    events: np.ndarray
    segment: np.ndarray


def trunk_axes(positions: np.ndarray, topology: Topology) -> tuple[np.ndarray, np.ndarray]:
    """The trunk's two measured directions, not normalised: (..., 3) ``left`` (right shoulder to left
    shoulder) and (..., 3) ``up`` (pelvis, else spine-mid, to spine-shoulder, else the shoulders'
    midpoint). ``positions`` is (..., J, 3); NaN where the joints are absent. The one trunk frame of the
    project: :func:`chest_normal`, :func:`trunk_frame`, frontality and the clinical angles build on it."""
    def j(lm: Landmark) -> np.ndarray:
        return positions[..., topology.index(lm), :]

    left_sh, right_sh = j(Landmark.SHOULDER_LEFT), j(Landmark.SHOULDER_RIGHT)
    upper = j(Landmark.SPINE_SHOULDER)
    upper = np.where(np.isnan(upper), 0.5 * (left_sh + right_sh), upper)
    lower = j(Landmark.PELVIS)
    lower = np.where(np.isnan(lower), j(Landmark.SPINE_MID), lower)
    return left_sh - right_sh, upper - lower


def chest_normal(positions: np.ndarray, topology: Topology) -> np.ndarray:
    """(..., 3) forward direction of the skeleton's chest, not normalised: ``left x up`` of
    :func:`trunk_axes`; NaN where the trunk is absent. ``positions`` is (..., J, 3)."""
    return np.cross(*trunk_axes(positions, topology))


def trunk_frame(positions: np.ndarray, topology: Topology) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit (..., 3) ``left``, ``up`` and ``forward = unit(left x up)`` of :func:`trunk_axes`
    (``left`` and ``up`` are not forced orthogonal); NaN where the trunk is absent."""
    left, up = trunk_axes(positions, topology)
    return unit(left), unit(up), unit(np.cross(left, up))


def thorax_frame(positions: np.ndarray, topology: Topology) -> np.ndarray:
    """(..., 3, 3) orthonormal thorax frame after the ISB (Wu et al. 2005), columns ``X`` forward,
    ``Y`` up and ``Z`` to the subject's right, built on :func:`trunk_axes`: ``Y`` is the trunk's up
    direction, ``Z`` the right-pointing shoulder line made orthogonal to ``Y``, ``X = Y x Z``.

    The skeleton has no thorax-fixed point off the spine besides the shoulders, so the shoulder line
    stands for the thorax's lateral axis: a protracted or retracted shoulder girdle on one side turns
    this frame about ``Y``. ``positions`` is (..., J, 3); NaN where the trunk is absent."""
    left, up = trunk_axes(positions, topology)
    y = unit(up)
    z = unit(np.einsum("...k,...k->...", left, y)[..., None] * y - left)
    return np.stack([np.cross(y, z), y, z], axis=-1)


def foot_cue(stream: SkeletonStream) -> np.ndarray:
    """(T,) [m] mean foot-minus-ankle vector projected on the skeleton's chest normal; NaN if unknown."""
    topo, P = stream.topology, stream.positions
    normal = chest_normal(P, topo)
    with np.errstate(invalid="ignore", divide="ignore"):
        normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    feet = np.stack(
        [P[:, topo.index(Landmark.FOOT_LEFT)] - P[:, topo.index(Landmark.ANKLE_LEFT)],
         P[:, topo.index(Landmark.FOOT_RIGHT)] - P[:, topo.index(Landmark.ANKLE_RIGHT)]], axis=1
    )
    return nanmean(np.einsum("tsk,tk->ts", feet, normal), axis=1)


def swap_events(
    stream: SkeletonStream, *, max_gap_s: float = 0.2, swap_ratio: float = 0.75, min_jump_m: float = 0.1
) -> tuple[np.ndarray, np.ndarray]:
    """Frames where the limb labels swap sides, and frames that start after a gap in tracking.

    Parameters
    ----------
    stream : one camera's skeletons.
    max_gap_s : consecutive skeletons further apart than this [s] are not compared (a gap).
    swap_ratio : a swap needs the swapped match to cost less than this fraction of the direct one.
    min_jump_m : and the direct match to move the limbs by at least this much on average [m].

    Returns
    -------
    events : (E,) int frame indices t where labels at t are swapped relative to the previous skeleton.
    gaps : (G,) int frame indices t that begin a new run (no usable previous skeleton).
    """
    topo, P = stream.topology, stream.positions
    li = topo.indices([a for a, _ in LIMB_PAIRS])
    ri = topo.indices([b for _, b in LIMB_PAIRS])
    present = np.isfinite(P[:, li]).all(-1).any(-1) & np.isfinite(P[:, ri]).all(-1).any(-1)
    idx = np.flatnonzero(present)
    if idx.size == 0:
        return np.empty(0, dtype=int), np.empty(0, dtype=int)
    prev, cur = idx[:-1], idx[1:]
    linked = (stream.timestamps[cur] - stream.timestamps[prev]) <= max_gap_s
    L0, R0, L1, R1 = P[prev][:, li], P[prev][:, ri], P[cur][:, li], P[cur][:, ri]
    direct = nanmean(np.concatenate([np.linalg.norm(L1 - L0, axis=-1), np.linalg.norm(R1 - R0, axis=-1)], 1), axis=1)
    swapped = nanmean(np.concatenate([np.linalg.norm(L1 - R0, axis=-1), np.linalg.norm(R1 - L0, axis=-1)], 1), axis=1)
    with np.errstate(invalid="ignore"):
        event = linked & (swapped < swap_ratio * direct) & (direct > min_jump_m)
    gaps = np.concatenate([idx[:1], cur[~linked]])
    return cur[event], gaps


def _front_score(cue: np.ndarray, odd: np.ndarray) -> float:
    """Evidence that the even runs face the camera: median cue on even runs minus on odd runs.

    The difference of medians cancels a constant per-camera bias of the cue; with only one kind of
    run present the sign of its median decides.
    """
    even_cue, odd_cue = cue[~odd], cue[odd]
    even_cue, odd_cue = even_cue[np.isfinite(even_cue)], odd_cue[np.isfinite(odd_cue)]
    if even_cue.size and odd_cue.size:
        return float(np.median(even_cue) - np.median(odd_cue))
    if even_cue.size:
        return float(np.median(even_cue))
    return float(-np.median(odd_cue)) if odd_cue.size else 1.0


def detect_back_facing(stream: SkeletonStream, *, max_gap_s: float = 0.2) -> BackFacing:
    """Flag the frames of ``stream`` whose skeleton is fitted to the person's back.

    Runs of frames between swap events alternate between front and back; runs separated by a gap
    in tracking are decided independently. Each linked group of runs takes the state assignment
    that best agrees with the per-frame foot cue (see the module docstring).
    """
    if not isinstance(stream, SkeletonStream):
        raise BadInputError("detect_back_facing needs a SkeletonStream")
    T = stream.n_frames
    cue = foot_cue(stream)
    events, gaps = swap_events(stream, max_gap_s=max_gap_s)
    present = np.zeros(T, dtype=bool)
    if gaps.size:
        present[gaps[0]:] = np.isfinite(stream.positions).any(axis=(1, 2))[gaps[0]:]
    boundary = np.zeros(T, dtype=int)
    boundary[events] = 1
    boundary[gaps] = 1
    segment = np.where(present, np.cumsum(boundary) - 1, -1)
    parity = np.cumsum(np.isin(np.arange(T), events))  # swaps so far
    group = np.cumsum(np.isin(np.arange(T), gaps)) - 1  # linked groups start at gaps
    flipped = np.zeros(T, dtype=bool)
    for g in np.unique(group[present]):
        sel = present & (group == g)
        odd = (parity[sel] % 2).astype(bool)
        flipped[sel] = odd if _front_score(cue[sel], odd) >= 0 else ~odd
    return BackFacing(flipped=flipped, foot_cue=cue, events=events, segment=segment)
