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
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from fusion.errors import BadInputError, UnknownNameError
from fusion.skeleton import SkeletonStream
from fusion.sync import interpolate_stream
from fusion.topology import Landmark, Topology, TrackingState
from fusion.transforms import apply, validate_transform


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


def _frozen(arr: np.ndarray) -> np.ndarray:
    arr.setflags(write=False)
    return arr


def _times(times: np.ndarray) -> np.ndarray:
    times = np.array(times, dtype=np.float64)
    if times.ndim != 1:
        raise BadInputError(f"times must be 1-D, got shape {times.shape}")
    if not np.all(np.isfinite(times)):
        raise BadInputError("times contain NaN or infinite values")
    if np.any(np.diff(times) <= 0):
        raise BadInputError("times must be strictly increasing")
    return times


@dataclass(frozen=True, eq=False)
class CameraViews:
    """Every camera's skeletons on one time base, in the world frame: the input of :func:`merge`.

    Attributes
    ----------
    names : tuple of str
        C unique camera names.
    topology : Topology
        Joint set (J joints) shared by all cameras.
    times : np.ndarray
        (T,) float64 strictly increasing times [s] on the reference camera's clock.
    positions : np.ndarray
        (C, T, J, 3) float64 world positions [m]; NaN where a camera lacks a joint.
    states : np.ndarray
        (C, T, J) int8 :class:`TrackingState`; NOT_TRACKED exactly where positions are NaN
        (a NOT_TRACKED joint's position is discarded).
    centres : np.ndarray
        (C, 3) float64 camera centres [m] in the world frame.
    back_facing : np.ndarray
        (C, T) bool, the camera's skeleton is fitted to the person's back (labels swapped).
    """

    names: tuple[str, ...]
    topology: Topology
    times: np.ndarray
    positions: np.ndarray
    states: np.ndarray
    centres: np.ndarray
    back_facing: np.ndarray

    def __post_init__(self) -> None:
        names = tuple(self.names)
        if not names or len(set(names)) != len(names) or not all(isinstance(n, str) for n in names):
            raise BadInputError(f"names must be at least one unique camera name, got {names}")
        times = _times(self.times)
        C, T, J = len(names), times.size, self.topology.n_joints
        pos = np.array(self.positions, dtype=np.float64)
        st = np.asarray(self.states)
        centres = np.array(self.centres, dtype=np.float64)
        back = np.asarray(self.back_facing)
        if pos.shape != (C, T, J, 3):
            raise BadInputError(f"positions must have shape ({C}, {T}, {J}, 3), got {pos.shape}")
        if st.shape != (C, T, J) or not np.issubdtype(st.dtype, np.integer):
            raise BadInputError(f"states must be integers of shape ({C}, {T}, {J}), got {st.dtype} {st.shape}")
        if centres.shape != (C, 3) or not np.all(np.isfinite(centres)):
            raise BadInputError(f"centres must be finite with shape ({C}, 3), got {centres.shape}")
        if back.shape != (C, T) or back.dtype != bool:
            raise BadInputError(f"back_facing must be bool of shape ({C}, {T}), got {back.dtype} {back.shape}")
        if np.any(np.isinf(pos)):
            raise BadInputError("positions contain infinite values")
        if st.size and (st.min() < 0 or st.max() > max(TrackingState)):
            raise BadInputError(f"tracking states must lie in 0..{int(max(TrackingState))}")
        st = st.astype(np.int8)
        absent = np.isnan(pos).any(axis=-1)
        if np.any(st[absent] != TrackingState.NOT_TRACKED):
            raise BadInputError("a joint with NaN position must have state NOT_TRACKED (0)")
        pos[st == TrackingState.NOT_TRACKED] = np.nan
        object.__setattr__(self, "names", names)
        for name, arr in (("times", times), ("positions", pos), ("states", st), ("centres", centres),
                          ("back_facing", back.copy())):
            object.__setattr__(self, name, _frozen(arr))

    @property
    def n_cameras(self) -> int:
        """Number of cameras C."""
        return len(self.names)

    def subset(self, names: list[str] | tuple[str, ...]) -> "CameraViews":
        """The views of the named cameras only, in the given order."""
        index = {n: i for i, n in enumerate(self.names)}
        missing = [n for n in names if n not in index]
        if missing:
            raise UnknownNameError("camera", missing[0], self.names)
        k = np.array([index[n] for n in names], dtype=int)
        return CameraViews(tuple(names), self.topology, self.times, self.positions[k], self.states[k],
                           self.centres[k], self.back_facing[k])


def views_from_streams(
    streams: Mapping[str, SkeletonStream],
    T_world_cam: Mapping[str, np.ndarray],
    times: np.ndarray,
    clock_offset_s: Mapping[str, float],
    back_facing: Mapping[str, np.ndarray | None] | None = None,
    *,
    max_gap_s: float = 0.05,
) -> CameraViews:
    """Resample every camera's skeletons at common times and map them into the world frame.

    Parameters
    ----------
    streams : mapping
        Camera name -> skeleton stream in that camera's frame, on that camera's clock.
    T_world_cam : mapping
        Camera name -> (4, 4) camera pose [m]; must cover every stream.
    times : np.ndarray
        (T,) strictly increasing times [s] on the reference clock.
    clock_offset_s : mapping
        Camera name -> that camera's clock minus the reference clock [s] (:mod:`fusion.sync`
        convention); camera c is resampled at ``times + clock_offset_s[c]``.
    back_facing : mapping or None
        Camera name -> (T_c,) bool per-frame back-facing flags of that camera's stream (e.g.
        :attr:`fusion.backfacing.BackFacing.flipped`), or None; missing cameras are front-facing.
        Flags are taken from the frame nearest in time.
    max_gap_s : float
        Longest interval [s] between two frames that is interpolated across
        (:func:`fusion.sync.interpolate_stream`).

    Returns
    -------
    CameraViews
        Cameras in the order of ``streams``.
    """
    if not streams:
        raise BadInputError("views_from_streams needs at least one stream")
    times = _times(times)
    back_facing = back_facing or {}
    names = tuple(streams)
    topology = streams[names[0]].topology
    positions, states, centres, backs = [], [], [], []
    for name in names:
        stream = streams[name]
        if stream.topology != topology:
            raise BadInputError(f"camera {name} uses topology {stream.topology.name}, expected {topology.name}")
        for what, mapping in (("pose", T_world_cam), ("clock offset", clock_offset_s)):
            if name not in mapping:
                raise BadInputError(f"camera {name} has no {what}; given for: {', '.join(mapping) or 'none'}")
        T = validate_transform(T_world_cam[name], f"T_world_cam of {name}")
        offset = float(clock_offset_s[name])
        if not np.isfinite(offset):
            raise BadInputError(f"clock offset of {name} must be finite, got {offset}")
        local = times + offset
        resampled = interpolate_stream(stream, local, max_gap_s=max_gap_s)
        positions.append(apply(T, resampled.positions))
        states.append(resampled.states)
        centres.append(T[:3, 3])
        backs.append(_nearest_flags(name, stream.timestamps, back_facing.get(name), local))
    return CameraViews(names, topology, times, np.stack(positions), np.stack(states), np.stack(centres),
                       np.stack(backs))


def _nearest_flags(name: str, timestamps: np.ndarray, flags: np.ndarray | None, times: np.ndarray) -> np.ndarray:
    """(N,) flags of the frames nearest to ``times`` (False without flags or frames)."""
    if flags is None:
        return np.zeros(times.size, dtype=bool)
    flags = np.asarray(flags)
    if flags.shape != timestamps.shape or flags.dtype != bool:
        raise BadInputError(f"back-facing flags of {name} must be bool of shape {timestamps.shape}, "
                            f"got {flags.dtype} {flags.shape}")
    if timestamps.size == 0:
        return np.zeros(times.size, dtype=bool)
    k = np.searchsorted(timestamps, times).clip(0, timestamps.size - 1)
    prev = np.maximum(k - 1, 0)
    k = np.where(np.abs(times - timestamps[prev]) <= np.abs(timestamps[k] - times), prev, k)
    return flags[k]


def unflip_back_facing(views: CameraViews) -> CameraViews:
    """The views with the left/right labels of back-facing skeletons swapped back.

    The back-facing flags are kept: the measurements still rank lowest in :func:`merge`.
    """
    if not views.back_facing.any():
        return views
    positions, states = _gather(views, np.arange(views.n_cameras), unflip=True)
    return CameraViews(views.names, views.topology, views.times, positions, states, views.centres,
                       views.back_facing)


def _gather(views: CameraViews, cameras: np.ndarray, *, unflip: bool) -> tuple[np.ndarray, np.ndarray]:
    """(C', T, J, 3) positions and (C', T, J) states of the given cameras, in one gather.

    With ``unflip`` the joints of back-facing skeletons are read from their mirror joints.
    """
    T, J = views.times.size, views.topology.n_joints
    c = cameras[:, None, None]
    t = np.arange(T)[None, :, None]
    j = np.arange(J)[None, None, :]
    if unflip:
        j = np.where(views.back_facing[cameras][..., None], views.topology.mirror, j)
    return views.positions[c, t, j], views.states[c, t, j]


def _unit(v: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore", divide="ignore"):
        return v / np.linalg.norm(v, axis=-1, keepdims=True)


def frontality(views: CameraViews, *, min_state: TrackingState = TrackingState.INFERRED) -> np.ndarray:
    """Frontality angle of each camera's skeleton, per frame.

    The torso normal is ``(shoulder_left - shoulder_right) x up`` with ``up`` from the spine-mid
    (else the pelvis) to the spine-shoulder (else the shoulders' midpoint); it points out of the
    chest. The angle is taken to the direction from the shoulders' midpoint to the camera: 0 when
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

    def joint(lm: Landmark) -> np.ndarray:
        return usable[:, :, topo.index(lm)]

    left, right = joint(Landmark.SHOULDER_LEFT), joint(Landmark.SHOULDER_RIGHT)
    middle = 0.5 * (left + right)
    upper = joint(Landmark.SPINE_SHOULDER)
    upper = np.where(np.isnan(upper), middle, upper)
    lower = joint(Landmark.SPINE_MID)
    lower = np.where(np.isnan(lower), joint(Landmark.PELVIS), lower)
    to_camera = _unit(centres[:, None, :] - middle)
    shoulder_line = _unit(left - right)
    normal = _unit(np.cross(left - right, upper - lower))
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
        times = _times(self.times)
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
        object.__setattr__(self, "times", _frozen(times))
        object.__setattr__(self, "positions", _frozen(pos))
        for name, arr in arrays.items():
            object.__setattr__(self, name, _frozen(arr))

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
    P, states = _gather(views, order, unflip=relabel_back_facing)
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
