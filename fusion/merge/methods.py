"""Merging the skeletons of several calibrated cameras into one skeleton stream (paper section 3.6).

Per joint and frame, over the measurements of that joint from all cameras:

1. back-facing skeletons (the tracker fits a front-facing skeleton to a person seen from behind)
   get the lowest confidence, below every sensor confidence, so they are used only when nothing
   else measured the joint; with ``relabel_back_facing=True`` (beyond the paper) their left/right
   labels are first swapped back, so a left joint is merged with left joints;
2. only the measurements at the highest confidence present are kept;
3. they are merged by a :class:`MergeMethod`, using each measurement's frontality angle (the angle
   between its skeleton's torso normal and the direction to its camera) and its distance from its
   camera.

The result is invariant to the order of the cameras: they are processed sorted by name, and ties
of the selection methods go to the first camera name.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from fusion.arrays import check_times, frozen, unit
from fusion.errors import BadInputError
from fusion.facing import trunk_axes
from fusion.merge.views import CameraViews, gather
from fusion.skeleton import SkeletonStream
from fusion.topology import Landmark, Topology, TrackingState


class MergeMethod(enum.Enum):
    """How the retained measurements of a joint become one position (paper equations 5-8)."""

    AVERAGE = "average"
    """Plain mean."""
    FRONTALITY = "frontality"
    """The measurement with the smallest frontality angle."""
    DISTANCE = "distance"
    """The measurement closest to its camera."""
    AVG_DISTANCE = "avg_distance"
    """Mean weighted by ``w_d = exp(-(dist - d0)^2 / gamma_d)``."""
    AVG_FRONTAL = "avg_frontal"
    """Mean weighted by ``w_f = exp(-alpha^2 / gamma_a)``."""
    AVG_DIST_FRONTAL = "avg_dist_frontal"
    """Mean weighted by ``w_f * w_d``."""


_SELECTIONS = (MergeMethod.FRONTALITY, MergeMethod.DISTANCE)


class Reliability(enum.IntEnum):
    """Reliability of a merged joint (paper section 3.8.2), ordered from worst to best."""

    NONE = 0
    """No camera measured the joint."""
    BACK_POSE = 1
    """All its measurements come from back-facing skeletons."""
    LOW = 2
    """Its best measurements are Inferred (or a temporal filter predicted it across a gap)."""
    HIGH = 3
    """At least one measurement is Tracked (or better) on a front-facing skeleton."""


_BACK_LEVEL = 1
"""Confidence level of a back-facing measurement; sensor state s ranks as 2 s, so 1 is below all."""


_RELIABILITY_OF_LEVEL = np.array(
    [Reliability.NONE, Reliability.BACK_POSE, Reliability.LOW, Reliability.LOW,
     Reliability.HIGH, Reliability.HIGH, Reliability.HIGH], dtype=np.int8
)


_STATE_OF_RELIABILITY = np.array(
    [TrackingState.NOT_TRACKED, TrackingState.INFERRED, TrackingState.INFERRED, TrackingState.TRACKED],
    dtype=np.int8,
)


@dataclass(frozen=True)
class MergeParams:
    """Constants of the merging methods.

    Attributes
    ----------
    gamma_a : float
        Frontality weight scale [rad^2] of ``w_f = exp(-alpha^2 / gamma_a)``; ``inf`` gives equal
        weights.
    gamma_d : float
        Distance weight scale [m^2] of ``w_d = exp(-(dist - d0)^2 / gamma_d)``; ``inf`` gives equal
        weights.
    d0 : float
        Distance [m] of full distance weight (the Kinect v2's minimal sensing distance).
    unknown_frontality_rad : float
        Frontality angle [rad] assumed for a measurement whose skeleton lacks a shoulder, in
        [0, pi]; the default, pi/2, ranks it as a side view.
    frontality_min_state : TrackingState
        Shoulders and spine joints below this confidence are not used for the frontality angle.
    """

    gamma_a: float = 1.1
    gamma_d: float = 2.0
    d0: float = 0.5
    unknown_frontality_rad: float = np.pi / 2
    frontality_min_state: TrackingState = TrackingState.INFERRED

    def __post_init__(self) -> None:
        for name in ("gamma_a", "gamma_d"):
            value = getattr(self, name)
            if not value > 0:
                raise BadInputError(f"{name} must be positive (inf allowed), got {value}")
        if not (np.isfinite(self.d0) and self.d0 >= 0):
            raise BadInputError(f"d0 must be a finite distance >= 0 [m], got {self.d0}")
        if not 0 <= self.unknown_frontality_rad <= np.pi:
            raise BadInputError(f"unknown_frontality_rad must lie in [0, pi], got {self.unknown_frontality_rad}")
        if not isinstance(self.frontality_min_state, TrackingState) or self.frontality_min_state < 1:
            raise BadInputError("frontality_min_state must be a TrackingState of at least INFERRED")


def frontality(views: CameraViews, *, min_state: TrackingState = TrackingState.INFERRED) -> np.ndarray:
    """Frontality angle of each camera's skeleton, per frame.

    The torso normal is :func:`fusion.facing.chest_normal` (the shoulder line crossed with the trunk's
    up direction of :func:`fusion.facing.trunk_axes`); it points out of the chest. The angle is taken to the direction from the shoulders' midpoint to the camera: 0 when
    the skeleton faces its camera, pi when it turns its back. Without a usable spine the torso is
    assumed upright relative to the camera and the angle is the one the shoulder depths give:
    ``arcsin(|s . d|)`` for the unit shoulder line ``s`` and camera direction ``d``, in [0, pi/2]
    (front and back cannot be told apart then). A back-facing skeleton whose labels are still
    swapped looks frontal: call :func:`unflip_back_facing` first.

    Parameters
    ----------
    views : CameraViews
        C cameras, T frames.
    min_state : TrackingState
        Torso joints below this confidence are not used.

    Returns
    -------
    np.ndarray
        (C, T) float64 angle [rad] in [0, pi]; NaN where a shoulder is missing or below
        ``min_state``.
    """
    return _frontality(views.topology, views.positions, views.states, views.centres, min_state)


def _frontality(topo: Topology, positions: np.ndarray, states: np.ndarray, centres: np.ndarray,
                min_state: TrackingState) -> np.ndarray:
    """:func:`frontality` on (C, T, J, 3) positions, (C, T, J) states and (C, 3) centres."""
    usable = np.where((states >= min_state)[..., None], positions, np.nan)
    shoulders, up = trunk_axes(usable, topo)
    middle = 0.5 * (usable[:, :, topo.index(Landmark.SHOULDER_LEFT)] + usable[:, :, topo.index(Landmark.SHOULDER_RIGHT)])
    to_camera = unit(centres[:, None, :] - middle)
    shoulder_line = unit(shoulders)
    normal = unit(np.cross(shoulders, up))
    with np.errstate(invalid="ignore"):
        angle = np.arccos(np.clip(np.einsum("ctk,ctk->ct", normal, to_camera), -1.0, 1.0))
        upright = np.arcsin(np.clip(np.abs(np.einsum("ctk,ctk->ct", shoulder_line, to_camera)), 0.0, 1.0))
    return np.where(np.isnan(angle), upright, angle)


def distance(views: CameraViews) -> np.ndarray:
    """(C, T, J) float64 distance [m] of each joint measurement from its camera; NaN where absent."""
    return _distance(views.positions, views.centres)


def _distance(positions: np.ndarray, centres: np.ndarray) -> np.ndarray:
    d = positions - centres[:, None, None, :]
    return np.sqrt(np.einsum("ctjk,ctjk->ctj", d, d))


def _log_weights(alpha: np.ndarray, dist: np.ndarray, method: MergeMethod, params: MergeParams) -> np.ndarray:
    if method in _SELECTIONS:
        raise BadInputError(f"{method.name} selects one measurement; it has no weights")
    out = np.zeros(np.broadcast_shapes(np.shape(alpha), np.shape(dist)))
    if method in (MergeMethod.AVG_FRONTAL, MergeMethod.AVG_DIST_FRONTAL):
        out = out - np.square(alpha) / params.gamma_a
    if method in (MergeMethod.AVG_DISTANCE, MergeMethod.AVG_DIST_FRONTAL):
        out = out - np.square(dist - params.d0) / params.gamma_d
    return out


def weights(
    alpha: np.ndarray, dist: np.ndarray, method: MergeMethod, params: MergeParams = MergeParams()
) -> np.ndarray:
    """Unnormalised weights of the averaging methods: 1, ``w_f``, ``w_d`` or ``w_f * w_d``.

    Parameters
    ----------
    alpha : np.ndarray
        Frontality angles [rad], broadcastable with ``dist``.
    dist : np.ndarray
        Distances [m] of the measurements from their cameras.
    method : MergeMethod
        An averaging method (AVERAGE or AVG_*).
    params : MergeParams
        Weight constants.

    Returns
    -------
    np.ndarray
        Weights in [0, 1], of the broadcast shape; 1 at ``alpha = 0`` and ``dist = d0``.
    """
    return np.exp(_log_weights(np.asarray(alpha, dtype=float), np.asarray(dist, dtype=float), method, params))


@dataclass(frozen=True, eq=False)
class MergedSkeleton:
    """One fused skeleton stream in the world frame.

    Attributes
    ----------
    times : np.ndarray
        (T,) float64 strictly increasing times [s] on the reference clock.
    positions : np.ndarray
        (T, J, 3) float64 world positions [m]; NaN exactly where ``reliability`` is NONE.
    reliability : np.ndarray
        (T, J) int8 :class:`Reliability`.
    n_cameras : np.ndarray
        (T, J) int16 number of measurements at the highest confidence present: those averaged, or
        those a selection method chose from.
    source_camera : np.ndarray
        (T, J) int16 index (in the views' camera order) of the selected measurement for the
        selection methods; -1 for the averaging methods and where nothing was measured.
    """

    times: np.ndarray
    positions: np.ndarray
    reliability: np.ndarray
    n_cameras: np.ndarray
    source_camera: np.ndarray

    def __post_init__(self) -> None:
        times = check_times(self.times)
        pos = np.array(self.positions, dtype=np.float64)
        T = times.size
        if pos.ndim != 3 or pos.shape[0] != T or pos.shape[2] != 3:
            raise BadInputError(f"positions must have shape ({T}, J, 3), got {pos.shape}")
        shape = pos.shape[:2]
        arrays = {}
        for name, lo, hi in (("reliability", 0, max(Reliability)), ("n_cameras", 0, np.iinfo(np.int16).max),
                             ("source_camera", -1, np.iinfo(np.int16).max)):
            arr = np.asarray(getattr(self, name))
            if arr.shape != shape or not np.issubdtype(arr.dtype, np.integer):
                raise BadInputError(f"{name} must be integers of shape {shape}, got {arr.dtype} {arr.shape}")
            if arr.size and (arr.min() < lo or arr.max() > hi):
                raise BadInputError(f"{name} must lie in {lo}..{int(hi)}")
            arrays[name] = arr.astype(np.int8 if name == "reliability" else np.int16)
        if np.any(np.isinf(pos)):
            raise BadInputError("positions contain infinite values")
        if np.any(np.isnan(pos).any(axis=-1) != (arrays["reliability"] == Reliability.NONE)):
            raise BadInputError("positions must be NaN exactly where reliability is NONE")
        object.__setattr__(self, "times", frozen(times))
        object.__setattr__(self, "positions", frozen(pos))
        for name, arr in arrays.items():
            object.__setattr__(self, name, frozen(arr))

    @property
    def n_joints(self) -> int:
        """Number of joints J."""
        return self.positions.shape[1]

    def to_stream(self, topology: Topology) -> SkeletonStream:
        """The fused skeleton as a recording stream whose "camera" frame is the world frame.

        States: HIGH -> TRACKED, LOW -> INFERRED, BACK_POSE -> INFERRED, NONE -> NOT_TRACKED.
        """
        if topology.n_joints != self.n_joints:
            raise BadInputError(
                f"topology {topology.name} has {topology.n_joints} joints, the skeleton {self.n_joints}"
            )
        return SkeletonStream(topology, self.times, self.positions, _STATE_OF_RELIABILITY[self.reliability])


def merge(
    views: CameraViews,
    method: MergeMethod,
    params: MergeParams = MergeParams(),
    *,
    relabel_back_facing: bool = True,
) -> MergedSkeleton:
    """Fuse every camera's measurements of each joint and frame into one skeleton (paper 3.6).

    Parameters
    ----------
    views : CameraViews
        C cameras, T frames, J joints, in the world frame.
    method : MergeMethod
        How the retained measurements are combined.
    params : MergeParams
        Weight constants and the frontality settings.
    relabel_back_facing : bool
        Swap the left/right labels of back-facing skeletons back before merging (beyond the
        paper, which uses them as reported). Either way their measurements rank lowest.

    Returns
    -------
    MergedSkeleton
        NaN and Reliability.NONE where no camera measured a joint.
    """
    if not isinstance(views, CameraViews):
        raise BadInputError(f"merge needs CameraViews, got {type(views).__name__}")
    if not isinstance(method, MergeMethod):
        raise BadInputError(f"method must be a MergeMethod ({', '.join(m.name for m in MergeMethod)}), got {method!r}")
    order = np.argsort(np.array(views.names, dtype=object), kind="stable")  # camera-order invariance
    P, states = gather(views, order, unflip=relabel_back_facing)
    back, centres = views.back_facing[order], views.centres[order]
    present = states > TrackingState.NOT_TRACKED
    level = np.where(present, np.where(back[..., None], np.int8(_BACK_LEVEL), 2 * states), 0)
    best = level.max(axis=0, initial=0)
    candidate = present & (level == best)
    n = candidate.sum(axis=0, dtype=np.int16)
    measured = n > 0

    needs_alpha = method in (MergeMethod.FRONTALITY, MergeMethod.AVG_FRONTAL, MergeMethod.AVG_DIST_FRONTAL)
    needs_dist = method in (MergeMethod.DISTANCE, MergeMethod.AVG_DISTANCE, MergeMethod.AVG_DIST_FRONTAL)
    alpha = (_frontality(views.topology, P, states, centres, params.frontality_min_state) if needs_alpha
             else np.zeros(P.shape[:2]))
    alpha = np.where(np.isnan(alpha), params.unknown_frontality_rad, alpha)[..., None]
    dist = _distance(P, centres) if needs_dist else np.zeros(P.shape[:3])

    if method in _SELECTIONS:
        criterion = np.broadcast_to(alpha, P.shape[:3]) if method is MergeMethod.FRONTALITY else dist
        criterion = np.where(candidate, criterion, np.inf)
        chosen = candidate & (criterion == criterion.min(axis=0, initial=np.inf))
        k = chosen.argmax(axis=0)  # first in name order among exact ties
        positions = np.take_along_axis(P, k[None, ..., None], axis=0)[0]
        source = np.where(measured, order[k], -1)
    else:
        log_w = np.where(candidate, _log_weights(alpha, dist, method, params), -np.inf)
        shift = log_w.max(axis=0, initial=-np.inf)
        w = np.exp(log_w - np.where(measured, shift, 0.0))  # largest weight 1: no underflow
        num = np.einsum("ctj,ctjk->tjk", w, np.where(candidate[..., None], P, 0.0))
        with np.errstate(invalid="ignore", divide="ignore"):
            positions = num / w.sum(axis=0)[..., None]
        source = np.full(n.shape, -1)
    positions[~measured] = np.nan
    return MergedSkeleton(views.times, positions, _RELIABILITY_OF_LEVEL[best], n, source)
