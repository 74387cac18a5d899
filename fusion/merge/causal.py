"""Causal fusion: every decision about a frame uses only that frame and earlier ones.

The offline back-facing detector (:func:`fusion.facing.detect_back_facing`) decides a whole linked
group of runs from the medians of its foot cue over the group, future frames included. A live
server cannot wait for the future, so :class:`CausalBackFacing` takes the same decision frame by
frame from the group's frames so far (same swap events, same groups, same score, the medians over
the frames up to the current one). :func:`causal_camera_views` and :func:`fuse_causal` are the
offline, whole-recording form of what the live server computes instant by instant
(:mod:`fusion.live`): the same views, merging and causal temporal filter, so both give the same
fused skeleton.
"""

from __future__ import annotations

import bisect
from dataclasses import replace

import numpy as np

from fusion.calibration import Calibration
from fusion.errors import BadInputError
from fusion.facing import foot_cue, swap_events
from fusion.merge.backfacing import cross_check_back_facing
from fusion.merge.filters import TemporalFilter
from fusion.merge.fuse import FuseOptions, camera_views, fuse_views
from fusion.merge.methods import MergedSkeleton
from fusion.merge.views import CameraViews, views_from_streams
from fusion.recording import Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import Topology

CAUSAL_FILTERS = (TemporalFilter.NONE, TemporalFilter.ONE_EURO)
"""Temporal filters whose output at a frame depends on earlier frames only."""


class CausalBackFacing:
    """Back-facing flag of each frame of one camera's stream, decided from the frames so far.

    Feed the frames in time order with :meth:`step`. Swap events, gaps and linked groups are those
    of :func:`fusion.facing.swap_events` on consecutive skeletons with both sides' limbs; a group's
    state assignment is chosen by the difference of the median foot cues of its even and odd runs
    (one kind alone: the sign of its median), over the group's frames up to the current one.

    Parameters
    ----------
    topology : Topology
        Joint set of the stream.
    max_gap_s : float
        Consecutive limb skeletons further apart than this [s] start a new group.
    """

    def __init__(self, topology: Topology, *, max_gap_s: float = 0.2) -> None:
        if not (np.isfinite(max_gap_s) and max_gap_s > 0):
            raise BadInputError(f"max_gap_s must be positive and finite, got {max_gap_s}")
        self.topology = topology
        self.max_gap_s = float(max_gap_s)
        self._last: SkeletonStream | None = None  # the last frame with limbs on both sides
        self._parity = 0  # swap events so far
        self._cues: tuple[list[float], list[float]] = ([], [])  # sorted cues of even, odd runs of the group
        self._time = -np.inf

    def step(self, timestamp: float, positions: np.ndarray, states: np.ndarray) -> bool:
        """The flag of one frame (True: the skeleton is fitted to the person's back).

        Parameters
        ----------
        timestamp : float
            Frame time [s] on the camera's clock, later than the previous frame's.
        positions : np.ndarray
            (J, 3) joint positions [m] in the camera frame; NaN where absent.
        states : np.ndarray
            (J,) tracking states.
        """
        if not timestamp > self._time:
            raise BadInputError(f"frames must come in time order: {timestamp} after {self._time}")
        self._time = float(timestamp)
        frame = SkeletonStream(self.topology, np.array([timestamp]), positions[None], states[None])
        if swap_events(frame, max_gap_s=self.max_gap_s)[1].size:  # limbs on both sides
            if self._last is None or timestamp - self._last.timestamps[0] > self.max_gap_s:
                self._cues = ([], [])
            else:
                pair = SkeletonStream(self.topology, np.append(self._last.timestamps, timestamp),
                                      np.concatenate([self._last.positions, frame.positions]),
                                      np.concatenate([self._last.states, frame.states]))
                self._parity += swap_events(pair, max_gap_s=self.max_gap_s)[0].size
            self._last = frame
        if self._last is None or not np.isfinite(frame.positions).any():
            return False
        odd = self._parity % 2 == 1
        cue = float(foot_cue(frame)[0])
        if np.isfinite(cue):
            bisect.insort(self._cues[int(odd)], cue)
        even_cues, odd_cues = self._cues
        if even_cues and odd_cues:
            score = _median(even_cues) - _median(odd_cues)
        elif even_cues or odd_cues:
            score = _median(even_cues) if even_cues else -_median(odd_cues)
        else:
            score = 1.0
        return odd if score >= 0 else not odd


def _median(sorted_values: list[float]) -> float:
    n = len(sorted_values)
    return float(np.median(sorted_values[(n - 1) // 2:n // 2 + 1]))


def causal_back_facing(stream: SkeletonStream, *, max_gap_s: float = 0.2) -> np.ndarray:
    """(T,) bool flags of :class:`CausalBackFacing` over a whole stream."""
    detector = CausalBackFacing(stream.topology, max_gap_s=max_gap_s)
    return np.array([detector.step(t, p, s) for t, p, s in zip(stream.timestamps, stream.positions, stream.states)],
                    dtype=bool)


def causal_camera_views(recording: Recording, calibration: Calibration, *, cross_check: bool = True) -> CameraViews:
    """Every calibrated camera's skeletons on the reference camera's timestamps, in the world frame,
    with causal back-facing flags: :func:`fusion.merge.fuse.camera_views` (same cameras, order and
    times) with :func:`causal_back_facing` in place of the whole-stream detector.

    Raises
    ------
    BadInputError
        No camera of the recording is calibrated.
    """
    base = camera_views(recording, calibration, cross_check=False)
    ref = calibration.reference if calibration.reference in base.names else base.names[0]
    streams = {n: recording.camera(n).skeleton for n in base.names}
    offsets = {n: calibration.clock_offset_s[n] - calibration.clock_offset_s[ref] for n in base.names}
    flags = {n: causal_back_facing(s) for n, s in streams.items()}
    views = views_from_streams(streams, calibration.T_world_cam, base.times, offsets, flags)
    return replace(views, back_facing=cross_check_back_facing(views)) if cross_check else views


def check_causal(options: FuseOptions) -> None:
    """Raise :class:`BadInputError` unless ``options`` fuse causally (a causal filter, no bone-length fit)."""
    if options.temporal not in CAUSAL_FILTERS:
        raise BadInputError(f"temporal filter {options.temporal.value} uses future frames; a causal fusion takes "
                            f"{' or '.join(f.value for f in CAUSAL_FILTERS)}")
    if options.bone_lengths:
        raise BadInputError("bone-length consistency uses the whole recording's median lengths; switch it off "
                            "for a causal fusion")


def fuse_causal(recording: Recording, calibration: Calibration, options: FuseOptions = FuseOptions()) -> MergedSkeleton:
    """The whole recording fused causally: :func:`causal_camera_views`, then the offline merging and
    temporal filter (:func:`fusion.merge.fuse.fuse_views`, whose One-Euro filter is
    :class:`fusion.merge.filters.OneEuroFilter` stepped over the frames).

    Raises
    ------
    BadInputError
        ``options`` are not causal (:func:`check_causal`).
    """
    check_causal(options)
    return fuse_views(causal_camera_views(recording, calibration, cross_check=options.cross_check), options)
