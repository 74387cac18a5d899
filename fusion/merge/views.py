"""Every camera's skeletons on one time base in the world frame: the input of merging."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from fusion.arrays import check_times, frozen
from fusion.calibrate.sync import interpolate_stream
from fusion.errors import BadInputError, UnknownNameError
from fusion.skeleton import SkeletonStream
from fusion.topology import Topology, TrackingState
from fusion.transforms import apply, validate_transform


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
        times = check_times(self.times)
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
            object.__setattr__(self, name, frozen(arr))

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
        Camera name -> that camera's clock minus the reference clock [s] (:mod:`fusion.calibrate.sync`
        convention); camera c is resampled at ``times + clock_offset_s[c]``.
    back_facing : mapping or None
        Camera name -> (T_c,) bool per-frame back-facing flags of that camera's stream (e.g.
        :attr:`fusion.facing.BackFacing.flipped`), or None; missing cameras are front-facing.
        Flags are taken from the frame nearest in time.
    max_gap_s : float
        Longest interval [s] between two frames that is interpolated across
        (:func:`fusion.calibrate.sync.interpolate_stream`).

    Returns
    -------
    CameraViews
        Cameras in the order of ``streams``.
    """
    if not streams:
        raise BadInputError("views_from_streams needs at least one stream")
    times = check_times(times)
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
        _check_overlap(name, stream.timestamps, local, offset)
        resampled = interpolate_stream(stream, local, max_gap_s=max_gap_s)
        positions.append(apply(T, resampled.positions))
        states.append(resampled.states)
        centres.append(T[:3, 3])
        backs.append(_nearest_flags(name, stream.timestamps, back_facing.get(name), local))
    return CameraViews(names, topology, times, np.stack(positions), np.stack(states), np.stack(centres),
                       np.stack(backs))


MIN_TIME_OVERLAP = 0.25
"""Least share of the reference frames' span a camera's frames must cover after its clock offset."""


def _check_overlap(name: str, timestamps: np.ndarray, local: np.ndarray, offset: float) -> None:
    """Refuse a camera whose frames, moved by its clock offset, hardly overlap the reference frames."""
    if timestamps.size < 2 or local.size < 2:
        return
    span = local[-1] - local[0]
    shared = min(local[-1], timestamps[-1]) - max(local[0], timestamps[0])
    if span > 0 and shared < MIN_TIME_OVERLAP * span:
        raise BadInputError(
            f"camera {name}'s frames ({timestamps[0]:.6g}-{timestamps[-1]:.6g} s on its clock) overlap the reference "
            f"camera's ({local[0]:.6g}-{local[-1]:.6g} s on that clock, with the clock offset {offset:.6g} s) for "
            f"{max(shared, 0.0) / span:.0%} of the session; the calibration's clock offsets do not fit this recording: "
            "calibrate it, or check the offsets in the calibration file")


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
    positions, states = gather(views, np.arange(views.n_cameras), unflip=True)
    return CameraViews(views.names, views.topology, views.times, positions, states, views.centres,
                       views.back_facing)


def gather(views: CameraViews, cameras: np.ndarray, *, unflip: bool) -> tuple[np.ndarray, np.ndarray]:
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
