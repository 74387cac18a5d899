"""Joint confidences estimated from consistency, for trackers that give none (e.g. K4ABT JSON).

Without confidences every present joint counts as Tracked, and the calibration would trust an
occluded hand as much as the pelvis. What a tracker's low-confidence joints share is that they
are inconsistent: they jump between frames more than the body can move, and their bones stretch
and shrink. :func:`estimate_states` marks a joint Inferred in a frame where either happens,
measured against the joint's own robust statistics over the session, so that the calibration's
candidate selection (Tracked joints only) and its per-joint reweighting see them as the tracker
would have flagged them.
"""

from __future__ import annotations

import warnings

import numpy as np

from fusion.errors import BadInputError
from fusion.skeleton import SkeletonStream
from fusion.topology import TrackingState


def has_confidences(stream: SkeletonStream) -> bool:
    """Whether the stream carries confidences: some present joint is below Tracked."""
    present = stream.states > TrackingState.NOT_TRACKED
    return bool(np.any(stream.states[present] < TrackingState.TRACKED))


def _robust_scale(x: np.ndarray) -> np.ndarray:
    """Per column: 1.4826 x median absolute deviation from the median (NaN ignored)."""
    med = np.nanmedian(x, axis=0)
    return 1.4826 * np.nanmedian(np.abs(x - med), axis=0)


def estimate_states(stream: SkeletonStream, *, k_sigma: float = 4.0, half_window: int = 2) -> SkeletonStream:
    """The stream with joints that behave inconsistently marked Inferred.

    Two tests per joint and frame, each against the joint's own robust spread over the session
    (median and 1.4826 MAD), flagging values beyond the median plus ``k_sigma`` spreads:

    - temporal: distance [m] from the joint's median position over the ``2 * half_window + 1``
      frames around it (a jump away from its own trajectory);
    - bones: relative deviation of each bone through the joint from that bone's median length.

    Parameters
    ----------
    stream : (T, J) skeleton stream, positions [m].
    k_sigma : threshold in robust standard deviations.
    half_window : frames on each side of the temporal median.

    Returns
    -------
    SkeletonStream
        Same positions; Tracked joints that fail a test become Inferred.

    Raises
    ------
    BadInputError
        ``k_sigma`` not positive or ``half_window`` below 1.
    """
    if not (np.isfinite(k_sigma) and k_sigma > 0) or half_window < 1:
        raise BadInputError(f"need k_sigma > 0 and half_window >= 1, got {k_sigma}, {half_window}")
    P = stream.positions
    T = P.shape[0]
    flag = np.zeros(stream.states.shape, dtype=bool)
    if T > 2 * half_window:
        padded = np.concatenate([np.full((half_window,) + P.shape[1:], np.nan), P,
                                 np.full((half_window,) + P.shape[1:], np.nan)])
        windows = np.stack([padded[i:i + T] for i in range(2 * half_window + 1)])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN windows: absent joints
            centre = np.nanmedian(windows, axis=0)
        jump = np.linalg.norm(P - centre, axis=-1)
        flag |= _beyond(jump, k_sigma)
    bones = np.asarray(stream.topology.bones, dtype=int).reshape(-1, 2)
    if bones.size:
        length = np.linalg.norm(P[:, bones[:, 0]] - P[:, bones[:, 1]], axis=-1)
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore", RuntimeWarning)
            rel = length / np.nanmedian(length, axis=0) - 1.0
        bad = _beyond(np.abs(rel), k_sigma)
        for col, (i, j) in enumerate(bones):
            flag[:, i] |= bad[:, col]
            flag[:, j] |= bad[:, col]
    states = np.array(stream.states)
    states[flag & (states >= TrackingState.TRACKED)] = TrackingState.INFERRED
    return SkeletonStream(stream.topology, stream.timestamps, P, states)


def _beyond(x: np.ndarray, k_sigma: float) -> np.ndarray:
    """(T, K) bool: finite values beyond their column's median + k_sigma robust spreads."""
    with warnings.catch_warnings(), np.errstate(all="ignore"):
        warnings.simplefilter("ignore", RuntimeWarning)  # columns without any finite value
        limit = np.nanmedian(x, axis=0) + k_sigma * _robust_scale(x)
        return np.isfinite(x) & (x > limit)
