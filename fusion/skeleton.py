"""Per-camera skeleton streams."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fusion.errors import BadInputError
from fusion.topology import Topology, TrackingState


@dataclass(frozen=True, eq=False)
class SkeletonStream:
    """Skeletons of one person seen by one camera, in that camera's frame.

    Attributes
    ----------
    topology : Topology
        Joint set (J joints).
    timestamps : np.ndarray
        (T,) float64 seconds on the camera's clock, strictly increasing.
    positions : np.ndarray
        (T, J, 3) float64 metres in the camera frame; NaN where a joint is absent.
    states : np.ndarray
        (T, J) int8 :class:`TrackingState` values; 0 (NOT_TRACKED) wherever positions are NaN.
    """

    topology: Topology
    timestamps: np.ndarray
    positions: np.ndarray
    states: np.ndarray

    def __post_init__(self) -> None:
        ts = np.array(self.timestamps, dtype=np.float64)
        pos = np.array(self.positions, dtype=np.float64)  # a copy: NaN normalisation writes to it
        st = np.asarray(self.states)
        T, J = ts.shape[0] if ts.ndim == 1 else -1, self.topology.n_joints
        if ts.ndim != 1:
            raise BadInputError(f"timestamps must be 1-D, got shape {ts.shape}")
        if pos.shape != (T, J, 3):
            raise BadInputError(f"positions must have shape ({T}, {J}, 3), got {pos.shape}")
        if st.shape != (T, J):
            raise BadInputError(f"states must have shape ({T}, {J}), got {st.shape}")
        if not np.all(np.isfinite(ts)):
            raise BadInputError("timestamps contain NaN or infinite values")
        if T > 1 and np.any(np.diff(ts) <= 0):
            raise BadInputError("timestamps must be strictly increasing")
        if st.size and (st.min() < 0 or st.max() > max(TrackingState)):
            raise BadInputError(f"tracking states must lie in 0..{int(max(TrackingState))}")
        if np.any(np.isinf(pos)):
            raise BadInputError("positions contain infinite values")
        st = st.astype(np.int8)
        absent = np.isnan(pos).any(axis=-1)
        if np.any(st[absent] != TrackingState.NOT_TRACKED):
            raise BadInputError("a joint with NaN position must have state NOT_TRACKED (0)")
        pos[absent] = np.nan
        for name, arr in (("timestamps", ts), ("positions", pos), ("states", st)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def n_frames(self) -> int:
        """Number of frames T."""
        return self.timestamps.shape[0]

    def subset(self, frames: np.ndarray | slice) -> "SkeletonStream":
        """A stream of the selected frames (index array, boolean mask or slice)."""
        return SkeletonStream(self.topology, self.timestamps[frames], self.positions[frames], self.states[frames])

    def as_joint_set(self, topology: Topology) -> "SkeletonStream":
        """The joints of this stream that stand for those of ``topology``, a joint set this one covers
        (:meth:`~fusion.topology.Topology.columns_in`): a simulated Kinect v2 seen as UI-PRMD's files."""
        cols = topology.columns_in(self.topology)
        return SkeletonStream(topology, self.timestamps, self.positions[:, cols], self.states[:, cols])

    def equals(self, other: "SkeletonStream") -> bool:
        """Exact equality of topology and all arrays (NaN equal to NaN)."""
        return (
            self.topology == other.topology
            and np.array_equal(self.timestamps, other.timestamps)
            and np.array_equal(self.positions, other.positions, equal_nan=True)
            and np.array_equal(self.states, other.states)
        )
