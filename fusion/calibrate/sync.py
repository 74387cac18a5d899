"""Time association of skeleton streams from different cameras.

Clock convention, used by every function here: ``offset_s`` is camera b's clock minus camera a's
clock. A frame that camera b stamped ``ts_b`` was captured at ``ts_b - offset_s`` on camera a's
clock. A camera whose clock runs 30 ms ahead of camera a's therefore has ``offset_s = +0.030``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fusion.errors import BadInputError
from fusion.skeleton import SkeletonStream
from fusion.topology import TrackingState


@dataclass(frozen=True, eq=False)
class FramePairs:
    """Frames of two cameras captured at (nearly) the same time.

    Attributes
    ----------
    indices : np.ndarray
        (P, 2) int64 (frame index in camera a, frame index in camera b), increasing in both columns.
    dt_s : np.ndarray
        (P,) float64 absolute capture-time difference [s] of each pair after the offset correction,
        ``|ts_a[i] - (ts_b[j] - offset_s)|``.
    offset_s : float
        Clock offset [s] (camera b's clock minus camera a's) the association assumed.
    tolerance_s : float
        Largest accepted ``dt_s`` [s].
    """

    indices: np.ndarray
    dt_s: np.ndarray
    offset_s: float
    tolerance_s: float

    def __post_init__(self) -> None:
        idx = np.asarray(self.indices)
        dt = np.asarray(self.dt_s, dtype=np.float64)
        if idx.ndim != 2 or idx.shape[1] != 2 or not np.issubdtype(idx.dtype, np.integer):
            raise BadInputError(f"indices must be an integer array of shape (P, 2), got {idx.dtype} {idx.shape}")
        if dt.shape != (idx.shape[0],):
            raise BadInputError(f"dt_s must have shape ({idx.shape[0]},), got {dt.shape}")
        if idx.size and idx.min() < 0:
            raise BadInputError("frame indices must be non-negative")
        if idx.shape[0] > 1 and np.any(np.diff(idx, axis=0) <= 0):
            raise BadInputError("frame pairs must be one-to-one and increasing in both cameras")
        if not np.all(np.isfinite(dt)) or np.any(dt < 0):
            raise BadInputError("dt_s must be finite and non-negative")
        check_positive("tolerance_s", self.tolerance_s)
        if not np.isfinite(self.offset_s):
            raise BadInputError(f"offset_s must be finite, got {self.offset_s}")
        idx = idx.astype(np.int64)
        for name, arr in (("indices", idx), ("dt_s", dt)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def n_pairs(self) -> int:
        """Number of pairs P."""
        return self.indices.shape[0]

    @property
    def index_a(self) -> np.ndarray:
        """(P,) frame indices in camera a."""
        return self.indices[:, 0]

    @property
    def index_b(self) -> np.ndarray:
        """(P,) frame indices in camera b."""
        return self.indices[:, 1]


def associate(
    ts_a: np.ndarray, ts_b: np.ndarray, *, tolerance_s: float = 1 / 60, offset_s: float = 0.0
) -> FramePairs:
    """Pair the frames of two cameras that were captured at the same time.

    Frames are matched as mutual nearest neighbours in time (after moving camera b's timestamps onto
    camera a's clock), which is one-to-one; ties go to the earlier frame. A pair is kept when its
    time difference is at most ``tolerance_s``.

    Parameters
    ----------
    ts_a : np.ndarray
        (Ta,) strictly increasing timestamps [s] of camera a.
    ts_b : np.ndarray
        (Tb,) strictly increasing timestamps [s] of camera b.
    tolerance_s : float
        Largest accepted time difference [s]; the default is half a frame at 30 Hz.
    offset_s : float
        Camera b's clock minus camera a's [s] (see the module docstring), e.g. from
        :func:`estimate_clock_offset`.

    Returns
    -------
    FramePairs
        The pairs, possibly none (then the recordings do not overlap in time).
    """
    ts_a = _timestamps("ts_a", ts_a)
    ts_b = _timestamps("ts_b", ts_b)
    check_positive("tolerance_s", tolerance_s)
    if not np.isfinite(offset_s):
        raise BadInputError(f"offset_s must be finite, got {offset_s}")
    tb = ts_b - offset_s
    if ts_a.size == 0 or tb.size == 0:
        return FramePairs(np.zeros((0, 2), dtype=np.int64), np.zeros(0), float(offset_s), float(tolerance_s))
    j_of_a = nearest_index(tb, ts_a)
    i_of_b = nearest_index(ts_a, tb)
    i = np.flatnonzero(i_of_b[j_of_a] == np.arange(ts_a.size))
    j = j_of_a[i]
    dt = np.abs(ts_a[i] - tb[j])
    keep = dt <= tolerance_s
    return FramePairs(np.stack([i[keep], j[keep]], axis=1), dt[keep], float(offset_s), float(tolerance_s))


def interpolate_stream(stream: SkeletonStream, times: np.ndarray, *, max_gap_s: float = 0.1) -> SkeletonStream:
    """Resample a skeleton stream at other times of the same clock.

    A time equal to a frame's timestamp takes that frame. Any other time inside the recording is
    interpolated linearly between the two frames around it, with state the lower of their two
    states. A joint comes out absent (NaN, NOT_TRACKED) where either neighbour lacks it, where the
    neighbours are more than ``max_gap_s`` apart (dropped frames), and outside the recording.

    Parameters
    ----------
    stream : SkeletonStream
        The stream to resample (T frames).
    times : np.ndarray
        (N,) strictly increasing times [s] on the stream's clock. To resample camera b at camera a's
        frames, pass ``ts_a + offset_s``.
    max_gap_s : float
        Longest interval [s] between two frames that is interpolated across.

    Returns
    -------
    SkeletonStream
        (N frames) with ``timestamps = times``.
    """
    times = _timestamps("times", times)
    check_positive("max_gap_s", max_gap_s)
    ts, T = stream.timestamps, stream.n_frames
    positions = np.full((times.size, stream.topology.n_joints, 3), np.nan)
    states = np.zeros(positions.shape[:2], dtype=np.int8)
    if T:
        k = np.searchsorted(ts, times, side="right") - 1
        k0 = np.clip(k, 0, T - 1)
        k1 = np.minimum(k0 + 1, T - 1)
        exact = (k >= 0) & (ts[k0] == times)
        gap = ts[k1] - ts[k0]
        between = (k >= 0) & (k < T - 1) & ~exact & (gap <= max_gap_s)
        alpha = ((times[between] - ts[k0[between]]) / gap[between])[:, None, None]
        p0, p1 = stream.positions[k0[between]], stream.positions[k1[between]]
        positions[between] = (1 - alpha) * p0 + alpha * p1
        states[between] = np.minimum(stream.states[k0[between]], stream.states[k1[between]])
        positions[exact] = stream.positions[k0[exact]]
        states[exact] = stream.states[k0[exact]]
    states[np.isnan(positions).any(axis=-1)] = TrackingState.NOT_TRACKED
    positions[states == TrackingState.NOT_TRACKED] = np.nan
    return SkeletonStream(stream.topology, times, positions, states)


def resample_joints(timestamps: np.ndarray, positions: np.ndarray, times: np.ndarray, max_gap_s: float) -> np.ndarray:
    """(N, J, 3) positions [m] at ``times``, each joint interpolated between its own nearest frames.

    Unlike :func:`interpolate_stream`, a joint missing in a few frames is bridged from the frames
    that have it, as long as those are at most ``max_gap_s`` apart. NaN elsewhere.
    """
    out = np.full((times.size,) + positions.shape[1:], np.nan)
    for j in range(positions.shape[1]):
        present = np.flatnonzero(np.isfinite(positions[:, j, 0]))
        if present.size < 2:
            continue
        ts = timestamps[present]
        k = np.clip(np.searchsorted(ts, times), 1, ts.size - 1)
        inside = (times >= ts[0]) & (times <= ts[-1]) & (ts[k] - ts[k - 1] <= max_gap_s)
        for c in range(3):
            out[inside, j, c] = np.interp(times[inside], ts, positions[present, j, c])
    return out


def nearest_index(ref: np.ndarray, query: np.ndarray) -> np.ndarray:
    """Index of the element of sorted ``ref`` nearest to each query; ties go to the earlier one."""
    j = np.clip(np.searchsorted(ref, query), 1, max(ref.size - 1, 1))
    if ref.size == 1:
        return np.zeros(query.shape, dtype=np.int64)
    left_closer = query - ref[j - 1] <= ref[j] - query
    return np.where(left_closer, j - 1, j).astype(np.int64)


def _timestamps(name: str, ts: np.ndarray) -> np.ndarray:
    ts = np.asarray(ts, dtype=np.float64)
    if ts.ndim != 1:
        raise BadInputError(f"{name} must be 1-D, got shape {ts.shape}")
    if not np.all(np.isfinite(ts)):
        raise BadInputError(f"{name} contains NaN or infinite values")
    if np.any(np.diff(ts) <= 0):
        raise BadInputError(f"{name} must be strictly increasing")
    return ts


def check_positive(name: str, value: float) -> None:
    """Raise :class:`BadInputError` unless ``value`` is finite and positive."""
    if not (np.isfinite(value) and value > 0):
        raise BadInputError(f"{name} must be positive and finite, got {value}")


def span_text(ts: np.ndarray) -> str:
    """``[first, last] s`` of (T,) timestamps [s], for error messages."""
    return f"[{ts[0]:.3f}, {ts[-1]:.3f}] s" if ts.size else "no frames"
