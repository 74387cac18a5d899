"""Truth-free statistics of a body tracker, measurable on real and simulated recordings alike.

Nothing here needs ground truth: every number comes from the reported skeletons (and, for the
cross-camera residual, a calibration given as a value). The same function runs on a real recording
and on its simulated replica, so the two can be compared side by side.

- jitter: median norm [mm] of the frame-to-frame second difference ``p[t+1] - 2 p[t] + p[t-1]`` per
  joint group, over runs of three frames one period apart; and the normalised autocorrelation of
  that second difference at lags 0..:data:`N_LAGS` (its shape tells white noise, lag-1 correlation
  -2/3, from slow wobble, which pushes it toward -1/2); the share of second differences over
  5 cm (spikes: outliers and swaps), and the median length of those spikes;
- bone-length spread: standard deviation over time [mm] of the upper-arm and forearm lengths, per
  camera, pooled over sides and cameras (mean of the per-track standard deviations); and bone-length
  jitter, the median absolute second difference of those lengths [mm], which a rigid body's motion
  leaves at zero; and how far the elbows' and wrists' second differences point along their bones, the
  mean squared cosine (:func:`fusion.merge.limb_sharing.bone_step_parts`; 1/3 for isotropic steps);
- confidence: share of the joint samples of tracked frames at confidence >= 2, per group;
- cross-camera residual: distance [mm] between the same joint seen by the reference camera and
  another camera, in the world frame of a calibration, frames paired by timestamp within half a
  period; median, share beyond 5 cm, per group; and split into the part that stays put over the
  recording (the norm of each joint's median residual vector) and the part that fluctuates (per-axis
  robust spread about it), how far neighbouring limb joints' steady parts point the same way, how
  much of the elbows' and wrists' steady part lies along their bones, and the rotation left between
  the cameras' trunk joints (:func:`fusion.merge.residual_parts.trunk_turn`);
- dropouts: share of missing frames (gaps in the timestamps) and of frames without a body.

Intervals are moving-block bootstrap percentiles (blocks of one second) over frames
(:mod:`fusion.merge.block_bootstrap`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from fusion.arrays import nanmean, nanmedian
from fusion.errors import BadInputError
from fusion.merge.block_bootstrap import (
    Interval,
    bootstrap,
    mean_of_each,
    median_of_each,
)
from fusion.merge.camera_sizes import size_agreement
from fusion.merge.limb_sharing import bone_step_parts, limb_cosine, residual_bone_share
from fusion.merge.metrics import PAPER_BONES
from fusion.merge.residual_parts import (
    cross_camera_residuals,
    steady_vectors,
    tracked_tail,
    trunk_turn,
)
from fusion.recording import Recording
from fusion.topology import Landmark, Topology, TrackingState
from fusion.transforms import apply

_L = Landmark
STAT_GROUPS: Mapping[str, tuple[Landmark, ...]] = MappingProxyType({
    "pelvis": (_L.PELVIS,),
    "spine": (_L.SPINE_SHOULDER,),
    "head": (_L.HEAD,),
    "shoulder": (_L.SHOULDER_LEFT, _L.SHOULDER_RIGHT),
    "elbow": (_L.ELBOW_LEFT, _L.ELBOW_RIGHT),
    "wrist": (_L.WRIST_LEFT, _L.WRIST_RIGHT),
    "hand": (_L.HAND_LEFT, _L.HAND_RIGHT, _L.HANDTIP_LEFT, _L.HANDTIP_RIGHT, _L.THUMB_LEFT, _L.THUMB_RIGHT),
    "knee": (_L.KNEE_LEFT, _L.KNEE_RIGHT),
    "ankle": (_L.ANKLE_LEFT, _L.ANKLE_RIGHT, _L.FOOT_LEFT, _L.FOOT_RIGHT),
})
"""Joint groups the statistics are reported for, by landmark (so both topologies work)."""

BONES: Mapping[str, tuple[tuple[Landmark, Landmark], ...]] = MappingProxyType({
    "upper_arm": PAPER_BONES["shoulder-elbow"], "forearm": PAPER_BONES["elbow-wrist"],
})
"""Bones whose length spread is reported, each pooled over its left and right instance."""

N_LAGS = 6
"""Highest lag of the second-difference autocorrelation."""

SPIKE_M = 0.05
"""Second differences longer than this [m] count as spikes."""

BEYOND_M = 0.05
"""Threshold of the 'share of joints beyond' cross-camera residual statistic [m]."""


@dataclass(frozen=True)
class SensorStats:
    """Truth-free statistics of one recording (see the module docstring for each definition).

    Attributes
    ----------
    jitter_mm : mapping group -> Interval
        Median second-difference norm [mm] per :data:`STAT_GROUPS` group.
    jitter_acf : mapping group -> np.ndarray
        (N_LAGS + 1,) normalised autocorrelation of the second difference (lag 0 is 1).
    spikes : mapping group -> Interval
        Share (0..1) of second differences longer than :data:`SPIKE_M` (outliers, flips, swaps).
    spike_mm : mapping group -> Interval
        Median length [mm] of those second differences (empty when not measured; NaN without spikes).
    bone_std_mm : mapping bone -> Interval
        Length standard deviation over time [mm] per :data:`BONES` bone.
    bone_jitter_mm : mapping bone -> Interval
        Median absolute second difference of the length [mm] per :data:`BONES` bone (empty when not
        measured).
    bone_step_share : float
        Mean squared cosine (0..1) between the elbows' and wrists' second differences and their bones, all
        cameras pooled; NaN when not measured.
    confidence2 : mapping group -> Interval
        Share (0..1) of samples at confidence >= 2 per group, and ``"all"`` joints; NaN when the files
        carry no confidence (:attr:`fusion.recording.Recording.confidence_assumed`).
    residual_mm : mapping group -> Interval
        Median cross-camera residual [mm] per group and ``"all"``; empty without a calibration or
        with one camera.
    beyond_5cm : Interval or None
        Share (0..1) of paired joint samples whose residual exceeds 5 cm.
    residual_static_mm : mapping group -> float
        Median over the group's joints (and camera pairs) of the norm of the residual vector's
        median over time [mm]: what stays put (view-dependent bias and calibration error).
    residual_fluct_mm : mapping group -> float
        RMS of the robust per-axis spread (1.4826 MAD) of the residual vector about that median [mm]:
        what changes from frame to frame (the two cameras' jitter and slow error).
    residual_samples_mm : np.ndarray
        (N,) every paired residual [mm] (for CDF plots), with ``residual_groups`` (N,) its group names.
    trunk_turn_deg : np.ndarray
        (P, 3) per camera pair, the rotation vector [deg] left between the trunk joints of the other camera
        and the reference under the calibration (:func:`fusion.merge.residual_parts.trunk_turn`); (0, 3)
        without residuals.
    residual_static_joint_mm, residual_fluct_joint_mm : np.ndarray
        (J,) the steady and fluctuating residual [mm] of every joint (median over camera pairs); empty
        without residuals.
    residual_limb_cosine : float
        Median cosine between the steady residual vectors of neighbouring limb joints
        (:func:`fusion.merge.limb_sharing.limb_cosine`): how far a limb's joints err together; NaN
        without residuals.
    residual_tail : float
        Share of the elbows' and wrists' residual samples, Tracked in both cameras, beyond 8 cm
        (:func:`fusion.merge.residual_parts.tracked_tail`); NaN without residuals.
    residual_bone_share : float
        Median share of the elbows' and wrists' steady residual along their bones
        (:func:`fusion.merge.limb_sharing.residual_bone_share`; 1/3 when isotropic); NaN without residuals.
    camera_scale, bone_ratio_spread : float
        How far the other cameras see the person larger or smaller than the reference camera (absolute
        log ratio of the limb bones' median lengths), and how far they disagree on the proportions (the
        ratios' spread over the bones) (:func:`fusion.merge.camera_sizes.size_agreement`); NaN with one camera.
    dropped_frames : float
        Share of frames missing from the timestamp sequence (gaps over 1.5 periods), all cameras.
    no_body : float
        Share of delivered frames without a tracked body.
    frame_rate_hz : float
        Median frame rate.
    n_frames : int
        Frames over all cameras.
    """

    jitter_mm: Mapping[str, Interval]
    jitter_acf: Mapping[str, np.ndarray]
    spikes: Mapping[str, Interval]
    bone_std_mm: Mapping[str, Interval]
    confidence2: Mapping[str, Interval]
    residual_mm: Mapping[str, Interval]
    beyond_5cm: Interval | None
    residual_static_mm: Mapping[str, float]
    residual_fluct_mm: Mapping[str, float]
    residual_samples_mm: np.ndarray
    residual_groups: np.ndarray
    dropped_frames: float
    no_body: float
    frame_rate_hz: float
    n_frames: int
    residual_static_joint_mm: np.ndarray = field(default_factory=lambda: np.zeros(0))
    residual_fluct_joint_mm: np.ndarray = field(default_factory=lambda: np.zeros(0))
    residual_limb_cosine: float = float("nan")
    residual_tail: float = float("nan")
    bone_jitter_mm: Mapping[str, Interval] = field(default_factory=dict)
    bone_step_share: float = float("nan")
    spike_mm: Mapping[str, Interval] = field(default_factory=dict)
    residual_bone_share: float = float("nan")
    camera_scale: float = float("nan")
    bone_ratio_spread: float = float("nan")
    trunk_turn_deg: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    def __post_init__(self) -> None:
        for name in ("jitter_mm", "jitter_acf", "spikes", "bone_std_mm", "confidence2", "residual_mm", "residual_static_mm",
                     "residual_fluct_mm", "bone_jitter_mm", "spike_mm"):
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))
        if self.residual_samples_mm.shape != self.residual_groups.shape:
            raise BadInputError("residual_samples_mm and residual_groups must have the same shape")


def _mean_bone_spread(lengths: np.ndarray) -> np.ndarray:
    """(B,) mean over the tracks of each length track's standard deviation over the frames, of (B, T, K)."""
    return nanmean(np.nanstd(lengths, axis=1), axis=1)


def _columns(tracks: list[np.ndarray]) -> np.ndarray:
    """(T, K) the K tracks (each (T_k,)) side by side, NaN-padded to the longest."""
    out = np.full((max(len(t) for t in tracks), len(tracks)), np.nan)
    for k, t in enumerate(tracks):
        out[: len(t), k] = t
    return out


def _group_columns(topology: Topology) -> dict[str, np.ndarray]:
    """Joint columns per :data:`STAT_GROUPS` group; a landmark the topology lacks is left out, and a
    group of none (UI-PRMD's hands) with it."""
    has = {g: [lm for lm in lms if lm not in topology.lacks] for g, lms in STAT_GROUPS.items()}
    return {g: topology.indices(lms) for g, lms in has.items() if lms}


def second_differences(positions: np.ndarray, timestamps: np.ndarray) -> np.ndarray:
    """(T, J, 3) second differences [m] centred on each frame, NaN where the three frames are not one
    period apart (the period is the median frame spacing) or a joint is absent."""
    p = np.asarray(positions, dtype=float)
    ts = np.asarray(timestamps, dtype=float)
    out = np.full(p.shape, np.nan)
    if p.shape[0] < 3:
        return out
    dt = np.diff(ts)
    regular = np.abs(dt - np.median(dt)) < 0.25 * np.median(dt)
    ok = regular[:-1] & regular[1:]
    d2 = p[2:] - 2 * p[1:-1] + p[:-2]
    out[1:-1] = np.where(ok[:, None, None], d2, np.nan)
    return out


def autocorrelation(x: np.ndarray, n_lags: int) -> np.ndarray:
    """(n_lags + 1,) normalised autocorrelation of (T, ...) series pooled over the trailing axes (NaN-aware)."""
    x = np.asarray(x, dtype=float)
    x = x.reshape(x.shape[0], -1)
    out = np.full(n_lags + 1, np.nan)
    c0 = np.nanmean(x * x) if np.isfinite(x).any() else np.nan
    for k in range(n_lags + 1):
        prod = x[k:] * x[: x.shape[0] - k]
        if np.isfinite(prod).any() and c0 > 0:
            out[k] = np.nanmean(prod) / c0
    return out


def sensor_stats(recording: Recording, T_world_cam: Mapping[str, np.ndarray] | None = None,
                 reference: str | None = None, *, n_boot: int = 200, rng: np.random.Generator) -> SensorStats:
    """Truth-free statistics of a recording's skeleton streams.

    Parameters
    ----------
    recording : Recording
        One or more cameras with skeleton streams (real or simulated).
    T_world_cam : mapping camera name -> (4, 4), optional
        A calibration of the cameras; needed for the cross-camera residuals (else they are empty).
    reference : str, optional
        Camera the others are compared with; default the first camera with a skeleton.
    n_boot : int
        Bootstrap resamples per statistic (>= 0).
    rng : np.random.Generator
        Source of the bootstrap resamples.

    Returns
    -------
    SensorStats
    """
    if not isinstance(recording, Recording):
        raise BadInputError(f"expected a Recording, got {type(recording).__name__}")
    cams = [c for c in recording.cameras if c.skeleton is not None]
    if not cams:
        raise BadInputError("the recording has no skeleton streams; statistics need at least one")
    if n_boot < 0:
        raise BadInputError(f"n_boot must be >= 0, got {n_boot}")
    topology = recording.topology
    groups = _group_columns(topology)
    ts_all = [c.skeleton.timestamps for c in cams]
    period = float(np.median(np.concatenate([np.diff(t) for t in ts_all if t.size > 1]))) if any(
        t.size > 1 for t in ts_all) else 1 / 30
    block = max(1, round(1.0 / period))
    boot = {"block": block, "n_boot": n_boot, "rng": rng}

    d2_cams = [second_differences(c.skeleton.positions, c.skeleton.timestamps) for c in cams]
    d2 = np.concatenate(d2_cams)
    cos2, n_steps = np.sum([bone_step_parts(s, c.skeleton.positions, topology) for s, c in zip(d2_cams, cams)], axis=0)
    d2n = np.linalg.norm(d2, axis=-1) * 1e3
    jitter = {g: bootstrap(d2n[:, cols], median_of_each, **boot) for g, cols in groups.items()}
    spike = np.where(np.isfinite(d2n), d2n > SPIKE_M * 1e3, np.nan)
    spikes = {g: bootstrap(spike[:, cols], mean_of_each, **boot) for g, cols in groups.items()}
    spike_mm = {g: bootstrap(np.where(spike[:, cols] == 1, d2n[:, cols], np.nan), median_of_each, **boot)
                for g, cols in groups.items()}
    acf_parts = {g: [autocorrelation(s[:, cols], N_LAGS) for s in d2_cams] for g, cols in groups.items()}
    acf = {g: nanmean(np.stack(parts), axis=0) for g, parts in acf_parts.items()}

    bone_std, bone_jitter = {}, {}
    for bone, pairs in BONES.items():
        tracks, steps = [], []
        for c in cams:
            p = c.skeleton.positions
            for a, b in pairs:
                tracks.append(np.linalg.norm(p[:, topology.index(a)] - p[:, topology.index(b)], axis=-1) * 1e3)
                steps.append(np.abs(second_differences(tracks[-1][:, None, None], c.skeleton.timestamps)[:, 0, 0]))
        bone_std[bone] = bootstrap(_columns(tracks), _mean_bone_spread, **boot)
        bone_jitter[bone] = bootstrap(_columns(steps), median_of_each, **boot)

    states = np.concatenate([c.skeleton.states for c in cams]).astype(float)
    tracked_body = np.any(states > 0, axis=1)
    high = np.where(tracked_body[:, None], states >= TrackingState.TRACKED, np.nan)
    if recording.confidence_assumed:
        high = np.full_like(high, np.nan)
    conf = {g: bootstrap(high[:, cols], mean_of_each, **boot) for g, cols in groups.items()}
    conf["all"] = bootstrap(high, mean_of_each, **boot)

    residual, beyond, residual_static, residual_fluct = {}, None, {}, {}
    static_joint, fluct_joint, limb_cos, tail, bone_share = np.zeros(0), np.zeros(0), np.nan, np.nan, np.nan
    turn = np.zeros((0, 3))
    samples, sample_groups = np.zeros(0), np.zeros(0, dtype="<U8")
    if T_world_cam is not None and len(cams) > 1:
        missing = [c.name for c in cams if c.name not in T_world_cam]
        if missing:
            raise BadInputError(f"the calibration has no pose for camera(s) {missing}; it holds {sorted(T_world_cam)}")
        ref_name = cams[0].name if reference is None else reference
        if ref_name not in T_world_cam:
            raise BadInputError(f"reference {ref_name!r} is not a calibrated camera; choose one of {sorted(T_world_cam)}")
        parts = cross_camera_residuals(recording, T_world_cam, ref_name, period)
        vec = np.concatenate(parts) * 1e3 if parts else np.zeros((0, topology.n_joints, 3))
        res = np.linalg.norm(vec, axis=-1)
        steady, fluct = steady_vectors(parts)
        static = np.linalg.norm(steady, axis=-1)
        limb_cos = limb_cosine(steady, topology)
        ref_world = apply(T_world_cam[ref_name], recording.camera(ref_name).skeleton.positions)
        bone_share = residual_bone_share(parts, ref_world, np.asarray(T_world_cam[ref_name])[:3, 3], topology)
        tracked = cross_camera_residuals(recording, T_world_cam, ref_name, period, min_state=TrackingState.TRACKED)
        tail, turn = tracked_tail(tracked, topology), trunk_turn(tracked, ref_world, topology)
        static_joint, fluct_joint = nanmedian(static, axis=0), nanmedian(fluct, axis=0)
        residual_static = {g: float(median_of_each(static[None, :, cols])[0]) for g, cols in groups.items()}
        residual_fluct = {g: float(np.sqrt(np.nanmean(fluct[:, cols] ** 2))) if np.isfinite(fluct[:, cols]).any()
                          else np.nan for g, cols in groups.items()}
        residual = {g: bootstrap(res[:, cols], median_of_each, **boot) for g, cols in groups.items()}
        residual["all"] = bootstrap(res, median_of_each, **boot)
        over = np.where(np.isfinite(res), res > BEYOND_M * 1e3, np.nan)
        beyond = bootstrap(over, mean_of_each, **boot)
        names = np.full(topology.n_joints, "other", dtype="<U8")
        for g, cols in groups.items():
            names[cols] = g
        finite = np.isfinite(res)
        samples, sample_groups = res[finite], np.broadcast_to(names, res.shape)[finite]

    sizes = size_agreement(recording, cams[0].name if reference is None else reference) if len(cams) > 1 else (
        np.nan, np.nan)
    expected = sum(max(1, round((t[-1] - t[0]) / period) + 1) for t in ts_all if t.size)
    return SensorStats(
        jitter_mm=jitter, jitter_acf=acf, spikes=spikes, bone_std_mm=bone_std, confidence2=conf, residual_mm=residual,
        beyond_5cm=beyond, residual_static_mm=residual_static, residual_fluct_mm=residual_fluct,
        residual_samples_mm=samples, residual_groups=np.asarray(sample_groups),
        dropped_frames=float(max(0.0, 1 - sum(t.size for t in ts_all) / expected)),
        no_body=float(1 - tracked_body.mean()), frame_rate_hz=float(1 / period), n_frames=int(states.shape[0]),
        residual_static_joint_mm=static_joint, residual_fluct_joint_mm=fluct_joint, residual_limb_cosine=limb_cos,
        residual_tail=tail, bone_jitter_mm=bone_jitter, bone_step_share=float(cos2 / n_steps) if n_steps > 0 else np.nan,
        spike_mm=spike_mm, residual_bone_share=bone_share, camera_scale=sizes[0], bone_ratio_spread=sizes[1],
        trunk_turn_deg=turn,
    )
