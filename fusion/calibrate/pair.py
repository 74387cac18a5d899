"""Calibrating one pair of cameras from the body: skeleton RANSAC, bootstrap uncertainty, optional ICP."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from fusion.calibrate.icp import refine_pair_icp
from fusion.calibrate.icp_points import select_calibration_points
from fusion.calibrate.icp_result import IcpResult
from fusion.calibrate.kabsch import kabsch_batch
from fusion.calibrate.options import (
    CalibrationOptions,
    JointWeighting,
    Refinement,
    SkeletonFit,
)
from fusion.calibrate.ransac import ransac_skeleton_pair
from fusion.calibrate.ransac_result import PairCalibration
from fusion.calibrate.results import PairResult
from fusion.calibrate.sync import associate
from fusion.errors import CalibrationError
from fusion.facing import detect_back_facing
from fusion.recording import CameraRecording
from fusion.skeleton import SkeletonStream
from fusion.topology import TrackingState
from fusion.transforms import transform_difference


def motion_extent_m(stream: SkeletonStream, *, min_frames: int = 30) -> float:
    """How far the person moves [m]: the largest, over joints, 80th-percentile distance of a Tracked
    joint from its median position (robust to outlier bursts; 0 without enough frames)."""
    P = np.where((stream.states >= TrackingState.TRACKED)[..., None], stream.positions, np.nan)
    seen = np.isfinite(P[..., 0]).sum(axis=0) >= min_frames
    if not seen.any():
        return 0.0
    P = P[:, seen]
    dist = np.linalg.norm(P - np.nanmedian(P, axis=0), axis=-1)
    return float(np.nanmax(np.nanpercentile(dist, 80, axis=0)))


def _bootstrap_std(result: PairCalibration, stream_a: SkeletonStream, stream_b: SkeletonStream, n: int,
                   rng: np.random.Generator) -> tuple[float, float]:
    """Standard deviation of the rotation [deg] and translation [mm] over bootstrap refits of the inliers
    (resampled with replacement, each keeping its weight in the final fit)."""
    used = result.fit_weights > 0
    cand = result.candidates[used]
    p_a = stream_a.positions[cand[:, 0], cand[:, 2]]
    p_b = stream_b.positions[cand[:, 1], cand[:, 2]]
    counts = rng.multinomial(cand.shape[0], np.full(cand.shape[0], 1.0 / cand.shape[0]), size=n)
    weights = counts * result.fit_weights[used]
    T, ok = kabsch_batch(np.broadcast_to(p_b, (n,) + p_b.shape), np.broadcast_to(p_a, (n,) + p_a.shape), weights)
    angle, dist = transform_difference(T[ok], result.T_a_b)
    return float(np.sqrt(np.mean(angle**2))), float(np.sqrt(np.mean(dist**2)) * 1e3)


def nearest_skeleton(stream: SkeletonStream, t: float) -> np.ndarray:
    """(J, 3) joints of the skeleton frame nearest to camera time ``t``."""
    return stream.positions[int(np.argmin(np.abs(stream.timestamps - t)))]


def body_speed(stream: SkeletonStream, times: np.ndarray, *, half_window_s: float = 0.1) -> np.ndarray:
    """(N,) median speed [m/s] of the Tracked joints around each camera time; NaN where unknown.

    Used to pick the instants when the person is most still, so that two cameras' depth frames
    captured a few milliseconds apart show the same body.
    """
    ts, P = stream.timestamps, np.where((stream.states >= TrackingState.TRACKED)[..., None], stream.positions, np.nan)
    lo = np.clip(np.searchsorted(ts, times - half_window_s), 0, ts.size - 1)
    hi = np.clip(np.searchsorted(ts, times + half_window_s), 0, ts.size - 1)
    dt = ts[hi] - ts[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        v = np.linalg.norm(P[hi] - P[lo], axis=-1) / dt[:, None]
    v[dt <= 0] = np.nan
    out = np.full(times.shape, np.nan)
    have = np.isfinite(v).any(axis=1)
    out[have] = np.nanmedian(v[have], axis=1)
    return out


def icp_instants(cam_a: CameraRecording, cam_b: CameraRecording, offset_s: float,
                 options: CalibrationOptions, *, phase: float = 0.0) -> np.ndarray:
    """Depth frame pairs for ICP: nearly simultaneous frames in which the body is nearly still.

    Frames are paired within ``options.depth_tolerance_s`` (after the clock offset); a pair is kept
    when the body's median joint speed (camera a's skeleton) is at most ``options.icp_max_speed_mps``
    and moves the body by at most ``options.icp_max_shift_m`` over the pair's time difference, so
    that both frames show the same body even when the clock offset is a frame off. Of those,
    ``options.icp_instants`` spread evenly over the session are chosen: the k-th (of K) at the
    fraction ``(k + phase) / (K - 1 + 2 phase)`` of the qualifying pairs, so ``phase`` 0 takes the
    first and the last and a phase in (0, 1) picks a set interleaved with it.

    Returns
    -------
    (K, 2) int64 depth frame indices (camera a, camera b), K <= ``options.icp_instants``; empty when
    a camera has no depth or no pair qualifies.
    """
    if cam_a.depth is None or cam_b.depth is None:
        return np.zeros((0, 2), dtype=np.int64)
    pairs = associate(cam_a.depth.timestamps, cam_b.depth.timestamps, tolerance_s=options.depth_tolerance_s,
                      offset_s=offset_s)
    speed = body_speed(cam_a.skeleton, cam_a.depth.timestamps[pairs.index_a])
    with np.errstate(invalid="ignore"):
        calm = np.flatnonzero((speed <= options.icp_max_speed_mps) & (speed * pairs.dt_s <= options.icp_max_shift_m))
    if calm.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    K = options.icp_instants
    fractions = (np.arange(K) + phase) / (K - 1 + 2 * phase) if K > 1 else np.zeros(1)
    return pairs.indices[calm[np.unique((fractions * (calm.size - 1)).round().astype(int))]]


def _icp_pair(cam_a: CameraRecording, cam_b: CameraRecording, T_a_b: np.ndarray, offset_s: float,
              options: CalibrationOptions, rng: np.random.Generator,
              phase: float = 0.0) -> tuple[IcpResult | None, str | None]:
    """ICP of one pair on its simultaneous depth frames (see :func:`icp_instants` for ``phase``), or
    (None, why not)."""
    if cam_a.depth is None or cam_b.depth is None:
        return None, "no depth frames in one of the cameras"
    clouds_a, clouds_b = [], []
    for ia, ib in icp_instants(cam_a, cam_b, offset_s, options, phase=phase):
        pa = select_calibration_points(cam_a.depth.depth_mm[ia], None if cam_a.depth.labels is None else
                                       cam_a.depth.labels[ia], cam_a.intrinsics, rng=rng,
                                       joints_cam=nearest_skeleton(cam_a.skeleton, cam_a.depth.timestamps[ia]))
        pb = select_calibration_points(cam_b.depth.depth_mm[ib], None if cam_b.depth.labels is None else
                                       cam_b.depth.labels[ib], cam_b.intrinsics, rng=rng,
                                       joints_cam=nearest_skeleton(cam_b.skeleton, cam_b.depth.timestamps[ib]))
        if pa.shape[0] >= 50 and pb.shape[0] >= 50:
            clouds_a.append(pa)
            clouds_b.append(pb)
    if len(clouds_a) < options.icp_min_instants:
        return None, (f"{len(clouds_a)} depth frame pair(s) show the person in both cameras, nearly still and nearly "
                      f"simultaneous (moving less than {options.icp_max_shift_m * 1e3:.0f} mm between the frames); "
                      f"ICP needs {options.icp_min_instants}, as one pose leaves it free to slide")
    return refine_pair_icp(clouds_a, clouds_b, T_a_b, method=options.icp_method), None


def calibrate_pair(
    cam_a: CameraRecording,
    cam_b: CameraRecording,
    options: CalibrationOptions,
    *,
    rng: np.random.Generator,
    clock_offset_s: float = 0.0,
    back_facing: tuple[np.ndarray, np.ndarray] | None = None,
) -> PairResult:
    """Calibrate camera b against camera a from the person's body (and depth, if asked).

    Parameters
    ----------
    cam_a, cam_b : the two cameras' recordings (skeleton streams required).
    options : calibration settings.
    rng : source of the RANSAC hypotheses, bootstrap and floor fits.
    clock_offset_s : clock of b minus clock of a [s].
    back_facing : (T_a,) and (T_b,) bool masks of back-facing skeletons to exclude; detected if None.
        With ``options.skeleton_fit`` plain, nothing is excluded.

    Raises
    ------
    CalibrationError
        Too few simultaneous frames or shared Tracked joints, a static person, or only back views.
    """
    sa, sb = cam_a.skeleton, cam_b.skeleton
    if sa is None or sb is None:
        raise CalibrationError(f"pair {cam_a.name}-{cam_b.name}: both cameras need skeleton streams")
    plain = options.skeleton_fit is SkeletonFit.PLAIN
    if plain:
        back_facing = (np.zeros(sa.n_frames, dtype=bool), np.zeros(sb.n_frames, dtype=bool))
    elif back_facing is None:
        back_facing = (detect_back_facing(sa).flipped, detect_back_facing(sb).flipped)
    pairs = associate(sa.timestamps, sb.timestamps, tolerance_s=options.tolerance_s, offset_s=clock_offset_s)
    if pairs.n_pairs == 0:
        raise CalibrationError(
            f"pair {cam_a.name}-{cam_b.name}: no simultaneous frames (within {options.tolerance_s * 1e3:.0f} ms); "
            "the recordings do not overlap in time or their clocks differ by more than the searched offset"
        )
    ia, ib = pairs.index_a, pairs.index_b
    front = ~back_facing[0][ia] & ~back_facing[1][ib]
    shared = (sa.states[ia] >= TrackingState.TRACKED) & (sb.states[ib] >= TrackingState.TRACKED)
    n_shared = int(shared[front].sum())
    if n_shared < options.min_candidates:
        all_back = int(shared.sum()) >= options.min_candidates
        raise CalibrationError(
            f"pair {cam_a.name}-{cam_b.name}: only {n_shared} joint measurements are Tracked in both cameras "
            f"at the same time with the person facing them (need {options.min_candidates})"
            + ("; most shared views are from behind: record the person facing between the cameras"
               if all_back else "; record a session in which the person is seen well by both cameras at once")
        )
    extent = motion_extent_m(sa.subset(ia[front]))
    if extent < options.min_motion_m:
        raise CalibrationError(
            f"pair {cam_a.name}-{cam_b.name}: the person hardly moves while both cameras see them (no joint moves "
            f"more than {extent * 100:.0f} cm, need {options.min_motion_m * 100:.0f} cm), so the body's poses cannot "
            "pin down the cameras' relative pose; record the person turning in place and raising the arms"
        )
    result = ransac_skeleton_pair(sa, sb, pairs, rng=rng, n_trials=options.n_trials,
                                  inlier_threshold_m=options.inlier_threshold_m,
                                  exclude_frames_a=back_facing[0], exclude_frames_b=back_facing[1],
                                  reweight_joints=not plain and options.joint_weighting is JointWeighting.RESIDUAL,
                                  **({"refine_iterations": 1} if plain else {}))
    rot_std, trans_std = _bootstrap_std(result, sa, sb, options.bootstrap, rng)
    icp, icp_note = None, None
    T_final = result.T_a_b
    if options.refine is Refinement.ICP:
        axes_deg = np.degrees(np.arccos(np.clip(result.T_a_b[2, 2], -1.0, 1.0)))
        if axes_deg > options.icp_max_angle_deg:
            icp_note = (f"viewing directions {axes_deg:.0f} deg apart (ICP limit {options.icp_max_angle_deg:.0f} deg); "
                        "skeleton transform kept")
        else:
            icp, why_not = _icp_pair(cam_a, cam_b, result.T_a_b, clock_offset_s, options, rng)
            if icp is None:
                icp_note = f"ICP not run: {why_not}"
            elif icp.accepted:
                T_final = icp.T_a_b
            else:
                icp_note = f"ICP result not used ({icp.reason}); skeleton transform kept"
    return PairResult(cam_a.name, cam_b.name, result.T_a_b, T_final, result, icp, clock_offset_s,
                      pairs.n_pairs, rot_std, trans_std, icp_note,
                      (options.icp_rotation_std_deg, options.icp_translation_std_mm),
                      (options.skeleton_rotation_std_deg, options.skeleton_translation_std_mm))


def retry_icp(cam_a: CameraRecording, cam_b: CameraRecording, pair: PairResult, T_a_b_start: np.ndarray,
              options: CalibrationOptions, *, rng: np.random.Generator) -> PairResult:
    """Run ICP of a pair again from another start, typically the transform the rest of the rig implies.

    A rejected ICP often started too far from the truth (the skeleton transform carries the
    tracker's view-dependent bias) and slid into a wrong overlap; from a start within a few
    millimetres it converges where it should. The result is accepted under the same checks.

    Parameters
    ----------
    cam_a, cam_b : the pair's recordings.
    pair : the pair as first calibrated (its ICP rejected).
    T_a_b_start : (4, 4) the alternative start.
    options : calibration settings.
    rng : source of the floor fits of the point selection.

    Returns
    -------
    PairResult
        The pair refined from the new start if ICP is accepted there; else ``pair`` with a note.
    """
    icp, why_not = _icp_pair(cam_a, cam_b, T_a_b_start, pair.clock_offset_s, options, rng)
    first = pair.icp_note or "ICP rejected"
    if icp is None:
        return replace(pair, icp_note=f"{first}; retry from the rig's start not run: {why_not}")
    if not icp.accepted:
        return replace(pair, icp_note=f"{first}; retried from the rig's start, also rejected ({icp.reason})")
    skeleton_reason = pair.icp.reason if pair.icp is not None else first
    return replace(pair, T_a_b=icp.T_a_b, icp=icp,
                   icp_note=f"ICP from the skeleton start rejected ({skeleton_reason}); accepted from the start "
                            f"the other pairs imply ({icp.reason})")


CROSS_CHECK_PHASES = (1 / 3, 2 / 3)
"""Phases (:func:`icp_instants`) of the instant sets on which a lone pair's ICP is cross-checked."""


def _suspicious(pair: PairResult) -> bool:
    """ICP rejected, or accepted but moved beyond twice the skeleton transform's own uncertainty."""
    if pair.icp is None:
        return False
    if not pair.icp.accepted:
        return True
    angle, dist = transform_difference(pair.icp.T_a_b_icp, pair.T_a_b_skeleton)
    rotation_deg, translation_mm = pair.skeleton_uncertainty
    return bool(angle > 2 * rotation_deg or dist * 1e3 > 2 * translation_mm)


def _agree(a: IcpResult, b: IcpResult, options: CalibrationOptions) -> bool:
    """Two ICP solutions agree within three standard deviations of their difference."""
    angle, dist = transform_difference(a.T_a_b_icp, b.T_a_b_icp)
    k = 3 * np.sqrt(2)
    return bool(angle <= k * options.icp_rotation_std_deg and dist <= k * options.icp_translation_std_mm * 1e-3)


def cross_check_icp(cam_a: CameraRecording, cam_b: CameraRecording, pair: PairResult, options: CalibrationOptions,
                    *, rng: np.random.Generator) -> PairResult:
    """Check a pair's ICP on other depth instants when no other camera can (a two-camera rig).

    When the ICP was rejected, or accepted but moved further from the skeleton transform than twice
    that transform's uncertainty, ICP is run again from the skeleton transform on the instant sets
    interleaved with the first (:data:`CROSS_CHECK_PHASES`), one set after the other until one agrees
    with an accepted first ICP (within three standard deviations of the difference of two ICP
    results, ``options.icp_rotation_std_deg`` and ``options.icp_translation_std_mm``), which is then
    kept. A wrong minimum belongs to the instants it was found on; the true transform is found on
    every set. Otherwise, of the accepted solutions, the one the most others agree with is kept, the
    earliest on a tie; a solution no other agrees with replaces nothing (a rejected first ICP keeps
    the skeleton transform, an accepted one stays).

    Parameters
    ----------
    cam_a, cam_b : the pair's recordings.
    pair : the pair as calibrated by :func:`calibrate_pair`.
    options : calibration settings.
    rng : source of the floor fits of the point selection.

    Returns
    -------
    PairResult
        ``pair`` itself when its ICP is not suspicious; else the chosen solution, with a note.
    """
    if not _suspicious(pair):
        return pair
    solutions = [pair.icp]
    for phase in CROSS_CHECK_PHASES:
        icp, _ = _icp_pair(cam_a, cam_b, pair.T_a_b_skeleton, pair.clock_offset_s, options, rng, phase)
        if icp is not None:
            solutions.append(icp)
            if pair.icp.accepted and icp.accepted and _agree(pair.icp, icp, options):
                break
    accepted = [s for s in solutions if s.accepted]
    votes = [sum(_agree(s, o, options) for o in accepted if o is not s) for s in accepted]
    first = pair.icp_note or f"ICP {pair.icp.reason}"
    summary = (f"{len(accepted)} of {len(solutions)} ICP runs accepted, the first and {len(solutions) - 1} on "
               "interleaved instant sets")
    if not accepted or max(votes) == 0:
        return replace(pair, icp_note=f"{first}; cross-check: {summary}, none confirmed by another")
    best = accepted[int(np.argmax(votes))]
    if best is pair.icp:
        return replace(pair, icp_note=f"ICP confirmed on other instants ({summary}, {max(votes)} agree with it)")
    return replace(pair, T_a_b=best.T_a_b, icp=best,
                   icp_note=f"first ICP not confirmed ({pair.icp.reason}); replaced by the solution "
                            f"{max(votes)} other instant set(s) agree with ({summary})")
