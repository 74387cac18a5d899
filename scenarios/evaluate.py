"""Calibration scored against ground truth (the only place where estimate and truth meet).

Errors are reported two ways:

- **relative to the reference camera** (gauge-free): ``T_ref_cam`` estimated against true; the
  reference itself is exact by definition;
- **in the world frame** after removing the remaining gauge freedom: the estimated world has its
  floor at z = 0 like the truth, but its origin and heading come from the subject's estimated start
  pose, so the best rotation about z plus floor translation (:func:`fusion.calibrate.floor.align_gauge`,
  ``GaugeMode.FLOOR``) is removed first; the size of that gauge transform is reported too.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fusion.calibrate.floor import GaugeMode, align_gauge
from fusion.calibrate.results import relative_poses
from fusion.calibration import Calibration
from fusion.errors import BadInputError
from fusion.io.atomic import atomic_directory
from fusion.merge.fuse import FuseOptions, camera_views, fuse_views
from fusion.merge.metrics import Stats, bone_length_std
from fusion.merge.residual_parts import cross_camera_residuals
from fusion.merge.sensor_stats import BEYOND_M
from fusion.recording import Recording
from fusion.topology import TrackingState
from fusion.transforms import apply, invert, rotation_angle, transform_difference
from sim.truth import GroundTruth


@dataclass(frozen=True)
class CameraScore:
    """Errors of one camera's estimated pose.

    Attributes
    ----------
    name : camera.
    rotation_error_deg, translation_error_mm : ``T_ref_cam`` against truth.
    world_rotation_error_deg, world_translation_error_mm : ``T_world_cam`` against truth after the
        floor gauge alignment.
    rmse_points_mm : RMS distance [mm] between the true joints this camera saw, mapped to the
        reference frame by the estimated and by the true ``T_ref_cam``.
    """

    name: str
    rotation_error_deg: float
    translation_error_mm: float
    world_rotation_error_deg: float
    world_translation_error_mm: float
    rmse_points_mm: float


@dataclass(frozen=True)
class CalibrationScores:
    """Every camera's errors, the gauge removed, and summary statistics."""

    reference: str
    cameras: tuple[CameraScore, ...]
    gauge_yaw_deg: float
    gauge_shift_mm: float

    def summary(self) -> dict[str, dict[str, float]]:
        """rmse, mean, median, std, max and n over the non-reference cameras, per error kind."""
        others = [c for c in self.cameras if c.name != self.reference] or list(self.cameras)
        keys = ("rotation_error_deg", "translation_error_mm", "world_rotation_error_deg", "world_translation_error_mm",
                "rmse_points_mm")
        return {key: Stats.of(np.array([getattr(c, key) for c in others])).as_dict() for key in keys}


def _points_rmse(T_ref_cam_est: np.ndarray, T_ref_cam_true: np.ndarray, p_cam: np.ndarray) -> float:
    d = np.linalg.norm(apply(T_ref_cam_est, p_cam) - apply(T_ref_cam_true, p_cam), axis=-1)
    return float(np.sqrt(np.nanmean(d**2)) * 1e3)


def score_calibration(T_world_cam: dict[str, np.ndarray], truth: GroundTruth, reference: str) -> CalibrationScores:
    """Score estimated camera poses against the truth (see the module docstring).

    Parameters
    ----------
    T_world_cam : camera name -> (4, 4) estimated pose; cameras missing here are not scored.
    truth : the simulation's ground truth (true poses, true joints per camera frame).
    reference : reference camera of the relative errors.
    """
    true_world = truth.T_world_cam()
    est_rel = relative_poses(T_world_cam, reference)
    true_rel = relative_poses({n: true_world[n] for n in T_world_cam}, reference)
    T_true_est, aligned = align_gauge(T_world_cam, true_world, mode=GaugeMode.FLOOR)
    scores = []
    for name in T_world_cam:
        rot, trans = transform_difference(est_rel[name], true_rel[name])
        wrot, wtrans = transform_difference(aligned[name], true_world[name])
        cam_truth = truth.camera(name)
        p_cam = apply(invert(cam_truth.T_world_cam), cam_truth.joints_world[:: max(1, len(cam_truth.true_times) // 300)])
        scores.append(CameraScore(name, float(rot), float(trans) * 1e3, float(wrot), float(wtrans) * 1e3,
                                  _points_rmse(est_rel[name], true_rel[name], p_cam)))
    yaw = float(np.degrees(rotation_angle(T_true_est[:3, :3])))
    return CalibrationScores(reference, tuple(scores), yaw, float(np.linalg.norm(T_true_est[:3, 3]) * 1e3))


def session_to_session_rmse_mm(T_ref_cam_a: dict[str, np.ndarray], T_ref_cam_b: dict[str, np.ndarray],
                               p_ref: np.ndarray) -> float:
    """RMS distance [mm] between points of the reference frame sent into each other camera by one
    calibration and back by another (the paper's session-to-session measure, gauge-free).

    Parameters
    ----------
    T_ref_cam_a, T_ref_cam_b : two calibrations of the same rig, relative to the same reference.
    p_ref : (N, 3) points [m] in the reference frame, e.g. a body near the rig's centre.
    """
    d = []
    for name in T_ref_cam_a:
        if name in T_ref_cam_b:
            p_back = apply(T_ref_cam_b[name], apply(invert(T_ref_cam_a[name]), p_ref))
            d.append(np.linalg.norm(p_back - p_ref, axis=-1))
    return float(np.sqrt(np.mean(np.concatenate(d) ** 2)) * 1e3)


@dataclass(frozen=True, eq=False)
class SessionSpread:
    """Agreement of several calibrations of one fixed rig (sessions), gauge-free.

    Every calibration sends the same reference-frame points into each other camera's frame; a
    fixed rig should send them to the same place every time.

    Attributes
    ----------
    cameras : the non-reference cameras compared (present in every calibration).
    pairwise_rmse_mm : (N, N) RMS distance [mm] between two sessions' points, like
        :func:`session_to_session_rmse_mm` but over the non-reference cameras only.
    per_session_mm : (N,) RMS distance [mm] of each session's points from their mean over sessions.
    spread_mm : RMS of ``per_session_mm`` (the points' scatter about their mean, all sessions).
    interval_mm : 2.5 and 97.5 percentiles [mm] of ``spread_mm`` over the sessions resampled with
        replacement (:data:`SPREAD_BOOTSTRAP` resamples, a fixed seed); None with fewer than
        :data:`MIN_SESSIONS_FOR_INTERVAL` sessions. Nine real Azure Kinect sessions of one person
        give 3.6 mm [2.3, 4.3]: the intervals of two methods overlap even where a paired comparison
        on the same sessions tells them apart (docs/studies/calibration_real_azure.md).
    """

    cameras: tuple[str, ...]
    pairwise_rmse_mm: np.ndarray
    per_session_mm: np.ndarray
    spread_mm: float
    interval_mm: tuple[float, float] | None = None

    def pairwise(self) -> Stats:
        """Statistics of the N (N - 1) / 2 session-to-session RMSEs."""
        return Stats.of(self.pairwise_rmse_mm[np.triu_indices(self.pairwise_rmse_mm.shape[0], 1)])


def session_spread(T_ref_cams: list[dict[str, np.ndarray]], p_ref: np.ndarray) -> SessionSpread:
    """Session-to-session agreement of any number (>= 2) of calibrations of one rig.

    Parameters
    ----------
    T_ref_cams : per session, camera -> (4, 4) ``T_ref_cam`` relative to one common reference camera.
    p_ref : (N, 3) points [m] in the reference frame, e.g. the reference camera's tracked joints.

    Returns
    -------
    SessionSpread

    Raises
    ------
    BadInputError
        Fewer than two sessions, no camera besides the reference in all of them, or bad points.
    """
    p_ref = np.asarray(p_ref, dtype=float)
    if len(T_ref_cams) < 2:
        raise BadInputError(f"the session spread needs at least two calibrations, got {len(T_ref_cams)}")
    if p_ref.ndim != 2 or p_ref.shape[1] != 3 or p_ref.shape[0] == 0 or not np.all(np.isfinite(p_ref)):
        raise BadInputError(f"p_ref must be a finite non-empty (N, 3) array, got shape {p_ref.shape}")
    shared = set.intersection(*(set(T) for T in T_ref_cams))
    cameras = tuple(sorted(n for n in shared if not all(np.allclose(T[n], np.eye(4)) for T in T_ref_cams)))
    if not cameras:
        raise BadInputError("the calibrations share no camera besides the reference; nothing to compare")
    # (S, C, N, 3): the reference points in each camera's frame according to each session
    q = np.stack([np.stack([apply(invert(T[c]), p_ref) for c in cameras]) for T in T_ref_cams])
    q = q - q.mean(axis=0)  # the spread is blind to a shift common to all sessions
    per_session = np.sqrt(np.mean(np.sum(q**2, axis=-1), axis=(1, 2))) * 1e3
    n = len(T_ref_cams)
    pairwise = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1, n):
            pairwise[i, j] = pairwise[j, i] = np.sqrt(np.mean(np.sum((q[i] - q[j]) ** 2, axis=-1))) * 1e3
    spread = float(np.sqrt(np.mean(per_session**2)))
    interval = _spread_interval(q) if n >= MIN_SESSIONS_FOR_INTERVAL else None
    return SessionSpread(cameras, pairwise, per_session, spread, interval)


SPREAD_BOOTSTRAP = 2000
"""Resamples of the sessions behind :attr:`SessionSpread.interval_mm`."""

MIN_SESSIONS_FOR_INTERVAL = 5
"""Fewest sessions with which :func:`session_spread` gives an interval: of three, one resample in nine
repeats a single session (spread 0), so the lower percentile says nothing."""


def _spread_interval(q: np.ndarray) -> tuple[float, float]:
    """Bootstrap percentiles [mm] of the spread of (S, C, N, 3) per-session points over resampled sessions.

    A resample that takes session s ``w_s`` times has spread^2 = sum_s w_s G_ss / S - w^T G w / S^2,
    ``G_st`` the mean over cameras and points of ``q_s . q_t``: one (S, S) matrix serves every resample."""
    S = q.shape[0]
    flat = q.reshape(S, -1)
    G = flat @ flat.T / (flat.shape[1] / 3)
    w = np.random.default_rng(0).multinomial(S, np.full(S, 1.0 / S), size=SPREAD_BOOTSTRAP).astype(float)
    sq = w @ np.diag(G) / S - np.einsum("bs,st,bt->b", w, G, w) / S**2
    sq *= S / (S - 1)  # a resample's mean square about its own mean is (S - 1) / S of the sample's, on average
    low, high = np.percentile(np.sqrt(np.maximum(sq, 0.0)) * 1e3, [2.5, 97.5])
    return float(low), float(high)


def scores_table(scores: CalibrationScores) -> str:
    """Markdown table of per-camera errors."""
    lines = ["| camera | rotation [deg] | translation [mm] | world rotation [deg] | world translation [mm] | "
             "points RMSE [mm] |", "| --- | --- | --- | --- | --- | --- |"]
    for c in scores.cameras:
        lines.append(f"| {c.name}{' (reference)' if c.name == scores.reference else ''} | {c.rotation_error_deg:.3f} | "
                     f"{c.translation_error_mm:.1f} | {c.world_rotation_error_deg:.3f} | "
                     f"{c.world_translation_error_mm:.1f} | {c.rmse_points_mm:.1f} |")
    return "\n".join(lines)


def truth_free_table(calibration: Calibration) -> str:
    """Markdown table of the quality figures stored with a calibration (no truth needed)."""
    lines = ["| pair | support | residual RMSE [mm] | rotation std [deg] | translation std [mm] | ICP | ICP RMSE [mm] |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for p in calibration.info.get("pair", []):
        lines.append(f"| {'-'.join(p['cameras'])} | {p['support']:.1%} | {p['residual_rmse_mm']:.1f} | "
                     f"{p['rotation_std_deg']:.3f} | {p['translation_std_mm']:.1f} | {p['icp']} | "
                     f"{p.get('icp_rmse_mm', float('nan')):.1f} |")
    return "\n".join(lines)


def _reference_points(calibration: Calibration, recording: Recording | None) -> np.ndarray:
    """The reference camera's tracked joints [m], or one point 2 m in front of it without a recording."""
    ref = calibration.reference
    if recording is not None and ref in recording.camera_names:
        sk = recording.camera(ref).skeleton
        return sk.positions[sk.states >= 2]
    return np.array([[0.0, 0.0, 2.0]])


def cross_camera_within(calibration: Calibration, recording: Recording, *,
                        threshold_m: float = BEYOND_M) -> dict[str, float]:
    """Share [%] of the reference camera's joints that another camera puts within ``threshold_m``.

    Frames are paired by timestamp (within half the reference camera's frame period) and both
    cameras' joints mapped to the world frame by the calibration. ``"all"`` counts every joint both
    cameras report, ``"confidence2"`` only joints at confidence >= 2 (Tracked) in both; NaN when
    none count.
    """
    ref = calibration.reference
    period = float(np.median(np.diff(recording.camera(ref).skeleton.timestamps)))
    out = {}
    for key, state in (("all", TrackingState.NOT_TRACKED), ("confidence2", TrackingState.TRACKED)):
        parts = cross_camera_residuals(recording, calibration.T_world_cam, ref, period, min_state=state)
        d = np.linalg.norm(np.concatenate(parts), axis=-1) if parts else np.zeros(0)
        d = d[np.isfinite(d)]
        out[key] = 100.0 * float(np.mean(d <= threshold_m)) if d.size else float("nan")
    return out


def truth_free_measures(calibration: Calibration, recording: Recording | None,
                        others: Sequence[Calibration] = ()) -> dict[str, Any]:
    """Measures that need no ground truth: bone-length spread of the fused skeleton (Avg(Frontal)), the
    share of joints two cameras put within 5 cm of each other (:func:`cross_camera_within`) and,
    against other calibrations of the same rig (other sessions), the session-to-session RMSE [mm]
    against the first of them and the spread of all of them together (:func:`session_spread`), over
    the reference camera's tracked joints."""
    out: dict[str, Any] = {}
    if recording is not None:
        views = camera_views(recording, calibration)
        merged = fuse_views(views, FuseOptions())
        out["bone_length_std_mm"] = {k: v * 1e3 for k, v in bone_length_std(merged.positions, views.topology).items()}
        out["within_5cm_pct"] = cross_camera_within(calibration, recording)
    if others:
        ref = calibration.reference
        p_ref = _reference_points(calibration, recording)
        poses = [relative_poses(c.T_world_cam, ref) for c in (calibration, *others)]
        out["session_to_session_rmse_mm"] = session_to_session_rmse_mm(poses[0], poses[1], p_ref)
        spread = session_spread(poses, p_ref)
        out["session_spread"] = {"sessions": len(poses), "cameras": list(spread.cameras),
                                 "spread_mm": spread.spread_mm, "spread_interval_mm": spread.interval_mm,
                                 "per_session_mm": spread.per_session_mm.tolist(),
                                 "pairwise_rmse_mm": spread.pairwise().as_dict()}
    return out


def spread_interval_text(spread: dict[str, Any]) -> str:
    """``"; 95 % interval over the sessions a-b mm"`` of a ``session_spread`` result, or ``""`` without one."""
    interval = spread.get("spread_interval_mm")
    return "" if interval is None else f"; 95 % interval over the sessions {interval[0]:.1f}-{interval[1]:.1f} mm"


def evaluate_to_disk(calibration: Calibration, truth: GroundTruth | None, out_dir: Path, *,
                     config: dict[str, Any], recording: Recording | None = None,
                     others: Sequence[Calibration] = (), overwrite: bool = False) -> dict[str, Any]:
    """Write ``result.json``, ``arrays.npz`` and ``report.md`` for one calibration.

    Without truth (a real recording) the calibration's own quality figures are reported, plus the
    truth-free measures of :func:`truth_free_measures` when a recording (and another calibration of
    the same rig, ``others``: other sessions) are given.
    """
    result: dict[str, Any] = {"config": config, "reference": calibration.reference,
                              "refine": calibration.info.get("refine"), "rig": calibration.info.get("rig"),
                              "loop_closure_mm": calibration.info.get("loop_closure_mm"),
                              "pairs": calibration.info.get("pair", []), "notes": calibration.info.get("notes", [])}
    report = [f"# Calibration evaluation ({result['refine']}, {result['rig']})", ""]
    arrays: dict[str, np.ndarray] = {}
    if truth is not None:
        scores = score_calibration(calibration.T_world_cam, truth, calibration.reference)
        result["cameras"] = {c.name: {k: v for k, v in asdict(c).items() if k != "name"} for c in scores.cameras}
        result["summary"] = scores.summary()
        result["gauge"] = {"yaw_deg": scores.gauge_yaw_deg, "shift_mm": scores.gauge_shift_mm}
        for key in ("rotation_error_deg", "translation_error_mm", "rmse_points_mm"):
            arrays[key] = np.array([getattr(c, key) for c in scores.cameras])
        report += ["Errors against the simulation's truth. Relative errors compare `T_ref_cam` with the truth "
                   "(the reference is exact by definition); world errors are taken after removing the floor "
                   f"gauge (here {scores.gauge_yaw_deg:.2f} deg about z and {scores.gauge_shift_mm:.0f} mm).", "",
                   scores_table(scores), ""]
    else:
        report += ["No ground truth (a real recording): truth-free quality figures only.", ""]
    free = truth_free_measures(calibration, recording, others)
    result["truth_free"] = free
    if "bone_length_std_mm" in free:
        report += ["Bone-length standard deviation of the fused skeleton (Avg(Frontal)): " + ", ".join(
            f"{k} {v:.1f} mm" for k, v in free["bone_length_std_mm"].items()) + ".", ""]
    if "within_5cm_pct" in free:
        share = free["within_5cm_pct"]
        report += [(f"Cross-camera agreement: {share['all']:.1f} % of the joints both cameras report lie within 5 cm "
                    f"of each other ({share['confidence2']:.1f} % of those at confidence 2 in both)."), ""]
    if "session_to_session_rmse_mm" in free:
        spread = free["session_spread"]
        report += [f"Session-to-session RMSE against the first other calibration: "
                   f"{free['session_to_session_rmse_mm']:.1f} mm. Over all {spread['sessions']} calibrations: spread "
                   f"{spread['spread_mm']:.1f} mm (RMS about the mean{spread_interval_text(spread)}), pairwise RMSE median "
                   f"{spread['pairwise_rmse_mm']['median']:.1f} mm, max {spread['pairwise_rmse_mm']['max']:.1f} mm.", ""]
    if result["loop_closure_mm"] is not None:
        report += [f"Ring loop closure of the pairwise transforms: {result['loop_closure_mm']:.1f} mm.", ""]
    report += ["## Camera pairs", "", truth_free_table(calibration), ""]
    if result["notes"]:
        report += ["## Notes", ""] + [f"- {n}" for n in result["notes"]]
    arrays["camera_names"] = np.array(calibration.camera_names)
    with atomic_directory(out_dir, overwrite=overwrite) as tmp:
        (tmp / "result.json").write_text(json.dumps(result, indent=2, sort_keys=True) + "\n", encoding="utf-8")
        np.savez(tmp / "arrays.npz", **arrays)
        (tmp / "report.md").write_text("\n".join(report) + "\n", encoding="utf-8")
    return result
