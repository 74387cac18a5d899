"""Pairwise camera calibration from the person's body: Kabsch inside RANSAC over all frames.

Following section 3.3-3.4 of the reference paper. A *candidate* is a correspondence (frame pair,
joint) whose joint is tracked well enough in both cameras. Each hypothesis takes three candidates,
one per body region (upper, mid, lower), and fits ``T_a_b`` to them by Kabsch. Because the cameras
do not move, every correspondence of every frame obeys the same ``T_a_b``; so the three candidates
are drawn independently over all frame pairs rather than from one frame. Spreading them over time
gives better-conditioned triangles than one posture (whose upper, mid and lower joints lie nearly on
a vertical line) and lets a region tracked in other frames still contribute. A hypothesis is scored
by the number of candidates of all frames it maps to within ``inlier_threshold_m``; the best one is
refitted on its inliers by weighted Kabsch.

For speed, every hypothesis is first scored on a random subset of 4096 candidates, and only the 32
best are scored on all of them (consecutive frames are nearly redundant, so the subset ranks the
hypotheses almost as the full set does; the winner is still chosen by its count over all frames).

The result type :class:`PairCalibration` lives in :mod:`fusion.calibrate.ransac_result`.
"""

from __future__ import annotations

import numpy as np

from fusion.calibrate.kabsch import kabsch_batch
from fusion.calibrate.ransac_result import PairCalibration
from fusion.calibrate.sync import FramePairs
from fusion.errors import BadInputError, CalibrationError
from fusion.skeleton import SkeletonStream
from fusion.topology import Region, TrackingState
from fusion.transforms import apply

_SCORE_BLOCK = 1_000_000
"""Hypothesis x candidate distances evaluated per block while scoring (bounds memory)."""

_PRESCORE_SIZE = 4096
"""Candidates, drawn at random, on which every hypothesis is scored first."""

_SHORTLIST = 32
"""Best pre-scored hypotheses that are then scored on all candidates."""


def ransac_skeleton_pair(
    stream_a: SkeletonStream,
    stream_b: SkeletonStream,
    pairs: FramePairs,
    *,
    rng: np.random.Generator,
    n_trials: int = 2000,
    inlier_threshold_m: float = 0.08,
    min_state: TrackingState = TrackingState.TRACKED,
    exclude_frames_a: np.ndarray | None = None,
    exclude_frames_b: np.ndarray | None = None,
    joint_weights: np.ndarray | None = None,
    refine_iterations: int = 20,
    reweight_joints: bool = True,
    min_correspondences: int = 10,
    min_spread_m: float = 0.05,
) -> PairCalibration:
    """Calibrate camera b against camera a from one person's skeletons.

    Parameters
    ----------
    stream_a, stream_b : SkeletonStream
        The person seen by cameras a and b (same topology, J joints), each in its camera's frame.
    pairs : FramePairs
        Simultaneous frames, from :func:`fusion.calibrate.sync.associate`.
    rng : np.random.Generator
        The only source of randomness: the same generator state gives the same result.
    n_trials : int
        Number of hypotheses.
    inlier_threshold_m : float
        A candidate supports a hypothesis when its joints land within this distance [m].
    min_state : TrackingState
        A joint is a candidate in a frame pair only when its state is at least this in both cameras.
    exclude_frames_a, exclude_frames_b : np.ndarray or None
        (Ta,) and (Tb,) bool, frames to leave out, typically skeletons detected as back-facing
        (left/right swapped).
    joint_weights : np.ndarray or None
        (J,) non-negative trust per joint type. It sets the probability of drawing a joint within its
        region and its weight in the refit; zero drops the joint. None weighs all joints equally.
    refine_iterations : int
        Maximum number of refits on the inliers (each refit re-selects the inliers; they stop when
        neither the inliers nor the transform change, or the inliers would shrink by more than 5 %). 0 keeps the three-point
        hypothesis.
    reweight_joints : bool
        In each refit, weight every joint by the inverse square of its systematic disagreement
        between the cameras (the mean residual vector of its inliers), so joints whose tracker
        bias differs between the views pull less.
    min_correspondences : int
        Fewest candidates accepted (at least 3).
    min_spread_m : float
        The candidates of each camera pooled over all frames, and again the final inliers, must
        spread at least this much [m] (rms) along their second and third principal axes. A static
        person fails this: one standing posture is only a few centimetres thick. (Coplanar points
        still determine a rigid transform in principle; the check stands in for "the person did not
        move", whose per-joint, view-dependent tracker bias then never averages out.)

    Returns
    -------
    PairCalibration
        ``T_a_b`` with its inliers and diagnostics.

    Raises
    ------
    CalibrationError
        No frame pairs, every pair excluded, too few candidates, a body region without candidates,
        candidates nearly collinear or coplanar-thin (a static person), or no usable hypothesis.
    BadInputError
        Bad arguments.
    """
    J = _check_inputs(stream_a, stream_b, pairs, rng, n_trials, inlier_threshold_m, refine_iterations,
                      min_correspondences, min_spread_m)
    excl_a = _frame_mask("exclude_frames_a", exclude_frames_a, stream_a.n_frames)
    excl_b = _frame_mask("exclude_frames_b", exclude_frames_b, stream_b.n_frames)
    weights = _joint_weights(joint_weights, J)
    min_state = TrackingState(min_state)

    if pairs.n_pairs == 0:
        raise CalibrationError(
            f"no frame pairs in time: camera a spans {_span(stream_a)}, camera b {_span(stream_b)} with an "
            f"assumed clock offset of {pairs.offset_s:.3f} s and a tolerance of {pairs.tolerance_s * 1e3:.1f} ms; "
            "record both cameras at the same time, or estimate the clock offset (fusion.calibrate.sync.estimate_clock_offset) "
            "and associate the frames again"
        )
    ia, ib = pairs.index_a, pairs.index_b
    kept = ~excl_a[ia] & ~excl_b[ib]
    if not kept.any():
        raise CalibrationError(
            f"all {pairs.n_pairs} frame pairs are excluded (back-facing in camera a or b); record the person "
            "facing between the two cameras for part of the session"
        )
    ia, ib = ia[kept], ib[kept]
    usable = (stream_a.states[ia] >= min_state) & (stream_b.states[ib] >= min_state) & (weights > 0)
    p_idx, joint = np.nonzero(usable)
    candidates = np.column_stack([ia[p_idx], ib[p_idx], joint])
    K = candidates.shape[0]
    region = stream_a.topology.region_array[joint]
    region_counts = np.bincount(region, minlength=len(Region))
    if K < min_correspondences:
        raise CalibrationError(
            f"too few shared joints: found {K} (frame, joint) correspondences {min_state.name} in both cameras "
            f"over {ia.size} frame pairs ({np.unique(joint).size} distinct joints), need at least "
            f"{min_correspondences}; record longer with the whole body in view of both cameras, placed so that "
            "both see the person's front (neighbouring viewpoints)"
        )
    empty = [Region(r).name for r in range(len(Region)) if region_counts[r] == 0]
    if len(empty) > 1:
        raise CalibrationError(
            f"no candidates in body region(s) {', '.join(empty)}: no such joint is {min_state.name} in both "
            f"cameras in any of {ia.size} frame pairs (region counts {region_counts.tolist()}); record with the "
            "whole body, head to feet, in view of both cameras"
        )
    p_a = stream_a.positions[candidates[:, 0], joint]
    p_b = stream_b.positions[candidates[:, 1], joint]
    _check_spread(p_a, p_b, min_spread_m, "candidate")

    picks = _draw_hypotheses(region, weights[joint], n_trials, rng)
    T_hyp, ok = kabsch_batch(p_b[picks], p_a[picks])
    ok &= _rigidly_consistent(p_a[picks], p_b[picks], 2 * inlier_threshold_m)
    if not ok.any():
        raise CalibrationError(
            f"none of {n_trials} hypotheses was usable (degenerate or inconsistent triangles); the candidates "
            f"are too noisy for an inlier threshold of {inlier_threshold_m} m or the cameras disagree: check the "
            "threshold and record clearer, more varied poses"
        )
    shortlist = np.flatnonzero(ok)
    if K > _PRESCORE_SIZE:
        subset = np.sort(rng.choice(K, size=_PRESCORE_SIZE, replace=False))
        prescores = _count_inliers(T_hyp[shortlist], p_b[subset], p_a[subset], inlier_threshold_m)
        shortlist = np.sort(shortlist[np.argsort(-prescores, kind="stable")[:_SHORTLIST]])
    scores = _count_inliers(T_hyp[shortlist], p_b, p_a, inlier_threshold_m)
    T_a_b = T_hyp[shortlist[int(np.argmax(scores))]]

    inliers = _residuals(T_a_b, p_b, p_a) < inlier_threshold_m
    n_refits = 0
    fit_weights = np.where(inliers, weights[joint], 0.0)
    for _ in range(refine_iterations):
        w = weights[joint] * (_joint_reliability(T_a_b, p_b, p_a, joint, inliers, J)[joint] if reweight_joints else 1.0)
        T_new, fit_ok = kabsch_batch(p_b, p_a, np.where(inliers, w, 0.0))
        if not fit_ok:
            break
        new_inliers = _residuals(T_new, p_b, p_a) < inlier_threshold_m
        if new_inliers.sum() < 0.95 * inliers.sum():
            break
        settled = np.array_equal(new_inliers, inliers) and np.abs(T_new - T_a_b).max() < _SETTLED
        fit_weights = np.where(inliers, w, 0.0)
        T_a_b, n_refits, inliers = T_new, n_refits + 1, new_inliers
        if settled:
            break

    _check_spread(p_a[inliers], p_b[inliers], min_spread_m, "inlier")
    residuals = _residuals(T_a_b, p_b, p_a)
    per_joint = np.full(J, np.nan)
    for j in np.unique(joint):
        per_joint[j] = np.median(residuals[joint == j])
    n_inliers = int(inliers.sum())
    return PairCalibration(
        T_a_b=T_a_b,
        candidates=candidates,
        inlier_mask=inliers,
        n_trials=n_trials,
        n_valid_trials=int(ok.sum()),
        n_inliers=n_inliers,
        support=n_inliers / K,
        residuals_per_joint=per_joint,
        rmse=float(np.sqrt(np.mean(residuals[inliers] ** 2))) if n_inliers else float("nan"),
        region_counts=region_counts,
        inlier_threshold_m=float(inlier_threshold_m),
        n_refits=n_refits,
        fit_weights=fit_weights,
    )


_SETTLED = 1e-9
"""Largest change of any transform entry between refits that counts as converged."""

_RELIABILITY_FLOOR_M = 0.01
"""Systematic disagreement [m] below which joints count as equally reliable."""


def _joint_reliability(
    T_a_b: np.ndarray, p_b: np.ndarray, p_a: np.ndarray, joint: np.ndarray, inliers: np.ndarray, J: int
) -> np.ndarray:
    """(J,) weights 1 / (|mean residual vector|^2 + floor^2) per joint over its inliers.

    A joint whose two cameras disagree systematically (a view-dependent bias of the tracker) keeps a
    constant residual under the right transform; down-weighting it reduces the bias it pulls into
    the fit. The mean (not a component-wise median) keeps the weights independent of which camera
    is a and which b. Joints without inliers get weight 0.
    """
    res = p_a - (p_b @ T_a_b[:3, :3].T + T_a_b[:3, 3])
    out = np.zeros(J)
    for j in np.unique(joint[inliers]):
        off = res[inliers & (joint == j)].mean(axis=0)
        out[j] = 1.0 / (off @ off + _RELIABILITY_FLOOR_M**2)
    return out


def _draw_hypotheses(region: np.ndarray, weight: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 3) candidate indices, column r drawn from region r with probability proportional to weight; a
    region without candidates (e.g. legs hidden behind furniture) draws from the other regions instead."""
    u = rng.random((n, len(Region)))
    picks = np.empty((n, len(Region)), dtype=np.int64)
    for r in range(len(Region)):
        members = np.flatnonzero(region == r)
        if members.size == 0:
            members = np.arange(region.size)
        cum = np.cumsum(weight[members])
        k = np.searchsorted(cum, u[:, r] * cum[-1], side="right")
        picks[:, r] = members[np.minimum(k, members.size - 1)]
    return picks


def _rigidly_consistent(tri_a: np.ndarray, tri_b: np.ndarray, tol: float) -> np.ndarray:
    """(n,) True where the three mutual distances of each (n, 3, 3) triangle agree within ``tol`` [m]."""
    def sides(tri: np.ndarray) -> np.ndarray:
        return np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=-1)

    return np.all(np.abs(sides(tri_a) - sides(tri_b)) <= tol, axis=1)


def _count_inliers(T_a_b: np.ndarray, p_b: np.ndarray, p_a: np.ndarray, threshold: float) -> np.ndarray:
    """(n,) number of candidates within ``threshold`` [m] under each of (n, 4, 4) transforms.

    Squared distances come from one matrix product: with centred points ``A = p_a - c_a``,
    ``B = p_b - c_b`` and ``u = R c_b + t - c_a``, ``|R B + u - A|^2 = |A|^2 + |B|^2 + |u|^2
    - 2 A.(R B) + 2 (R^T u).B - 2 u.A``, linear in per-candidate features.
    """
    c_a, c_b = p_a.mean(axis=0), p_b.mean(axis=0)
    A, B = p_a - c_a, p_b - c_b
    R, t = T_a_b[:, :3, :3], T_a_b[:, :3, 3]
    u = R @ c_b + t - c_a
    features = np.column_stack([(A[:, :, None] * B[:, None, :]).reshape(-1, 9), B, A, np.ones(len(A))])
    coeffs = np.column_stack([-2 * R.reshape(-1, 9), 2 * np.einsum("nji,nj->ni", R, u), -2 * u, (u * u).sum(axis=1)])
    features = np.ascontiguousarray(features.T)
    bound = threshold**2 - (A * A).sum(axis=1) - (B * B).sum(axis=1)
    counts = np.empty(len(T_a_b), dtype=np.int64)
    step = max(1, _SCORE_BLOCK // max(len(A), 1))
    for s in range(0, len(T_a_b), step):
        counts[s : s + step] = np.count_nonzero(coeffs[s : s + step] @ features < bound, axis=1)
    return counts


def _residuals(T_a_b: np.ndarray, p_b: np.ndarray, p_a: np.ndarray) -> np.ndarray:
    return np.linalg.norm(apply(T_a_b, p_b) - p_a, axis=-1)


def _check_spread(p_a: np.ndarray, p_b: np.ndarray, min_spread_m: float, kind: str) -> None:
    """Raise CalibrationError unless both (K, 3) point sets spread in 3-D by ``min_spread_m`` rms."""
    for camera, p in (("a", p_a), ("b", p_b)):
        s = np.zeros(3)
        if len(p) >= 3:
            s = np.linalg.svd(p - p.mean(axis=0), compute_uv=False) / np.sqrt(len(p))
        if s[1] < min_spread_m or s[2] < min_spread_m:
            shape = "nearly collinear" if s[1] < min_spread_m else "coplanar-thin"
            raise CalibrationError(
                f"degenerate body geometry: the {len(p)} {kind} joint positions of camera {camera}, pooled "
                f"over all frames, are {shape} (rms spread along principal axes {s[0]:.3f}, {s[1]:.3f}, "
                f"{s[2]:.3f} m; at least {min_spread_m} m needed on each). The person hardly moved or too few "
                "joints are tracked; record the person moving in depth too (walking a few steps, turning, "
                "raising the arms forward) with the whole body tracked in both cameras"
            )


def _check_inputs(
    stream_a: SkeletonStream, stream_b: SkeletonStream, pairs: FramePairs, rng: np.random.Generator,
    n_trials: int, inlier_threshold_m: float, refine_iterations: int, min_correspondences: int,
    min_spread_m: float,
) -> int:
    if stream_a.topology != stream_b.topology:
        raise BadInputError(f"streams have different topologies: {stream_a.topology.name} and {stream_b.topology.name}")
    if not isinstance(pairs, FramePairs):
        raise BadInputError(f"pairs must be a FramePairs (fusion.calibrate.sync.associate), got {type(pairs).__name__}")
    if pairs.n_pairs and (pairs.index_a.max() >= stream_a.n_frames or pairs.index_b.max() >= stream_b.n_frames):
        raise BadInputError(
            f"frame pairs index past the streams ({stream_a.n_frames} and {stream_b.n_frames} frames); "
            "associate the timestamps of these very streams"
        )
    if not isinstance(rng, np.random.Generator):
        raise BadInputError(f"rng must be a numpy Generator, got {type(rng).__name__}")
    for name, value, least in (("n_trials", n_trials, 1), ("refine_iterations", refine_iterations, 0),
                               ("min_correspondences", min_correspondences, 3)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
            raise BadInputError(f"{name} must be an integer >= {least}, got {value!r}")
    if not (np.isfinite(inlier_threshold_m) and inlier_threshold_m > 0):
        raise BadInputError(f"inlier_threshold_m must be positive and finite, got {inlier_threshold_m}")
    if not (np.isfinite(min_spread_m) and min_spread_m >= 0):
        raise BadInputError(f"min_spread_m must be finite and >= 0, got {min_spread_m}")
    return stream_a.topology.n_joints


def _frame_mask(name: str, mask: np.ndarray | None, n_frames: int) -> np.ndarray:
    if mask is None:
        return np.zeros(n_frames, dtype=bool)
    mask = np.asarray(mask)
    if mask.dtype != bool or mask.shape != (n_frames,):
        raise BadInputError(f"{name} must be a boolean array of shape ({n_frames},), got {mask.dtype} {mask.shape}")
    return mask


def _joint_weights(weights: np.ndarray | None, J: int) -> np.ndarray:
    if weights is None:
        return np.ones(J)
    weights = np.asarray(weights, dtype=float)
    if weights.shape != (J,) or not np.all(np.isfinite(weights)) or np.any(weights < 0):
        raise BadInputError(f"joint_weights must be {J} finite non-negative values, got shape {weights.shape}")
    return weights


def _span(stream: SkeletonStream) -> str:
    ts = stream.timestamps
    return f"[{ts[0]:.3f}, {ts[-1]:.3f}] s" if ts.size else "no frames"
