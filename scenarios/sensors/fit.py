"""Fit a sensor profile to real recordings from truth-free statistics (:mod:`fusion.merge.sensor_stats`).

What each statistic fixes (per tracker joint group, the statistics pooled as the median over the
recordings; ``dt`` the frame period, ``a = exp(-dt / tau)``):

- white jitter and slow wobble: the second difference ``d2`` of white noise of per-axis std ``s_w``
  has variance ``6 s_w^2`` and lag-one autocorrelation -2/3; that of a slow AR(1) error of std
  ``s_c`` has variance ``2 s_c^2 (1 - a)(3 - a)`` and lag-one autocorrelation near -1/2. The measured
  lag-one value ``r1`` gives the white share ``w = 6 (-r1 - 1/2)`` (clipped to [0, 1]) of the d2
  variance, whose per-axis size comes from the median d2 norm (median norm of a 3-D Gaussian =
  1.538 per-axis std);
- the time constant ``tau`` (single-camera fits, bones assumed free): the bone-length spread is the
  spread of the two end joints' errors along the bone, ``std^2 = v_parent + v_child`` with
  ``v = s_w^2 + s_c^2``; ``tau`` is the value that matches the upper-arm and forearm spreads (least
  squares in log);
- the body scale (:mod:`fusion.merge.body_scale`): when a common factor explains at least
  :data:`fusion.merge.body_scale.SCALE_SHARE` of the limb bones' length variance (a template tracker), its standard deviation,
  time constant and share common to the cameras (medians over the recordings); the bones' own spread
  is then the part the scale leaves, ``sqrt(1 - share)`` of the measured one;
- bone rigidity (multi-camera fits, or with a body scale; the same for every group):
  ``r = 1 - measured / predicted`` bone spread;
- view-dependent bias: the cross-camera residual of a joint is the difference of two cameras'
  independent errors, per-axis variance ``2 (s_w^2 + s_c^2) + 2 b^2 / 3`` for a view bias of 3-D size
  ``b``; the bias range is then ``b / sqrt(1 - model_fraction) * (0.5, 1.5)``, the model share
  staying the published value (no truth-free statistic separates it);
- outliers: the share of second differences over 5 cm, times ``m / (m + 2)`` for bursts of mean
  length ``m`` frames;
- low confidence: the range over the recordings of the share of samples below confidence 2;
- clock: the timestamp jitter (robust spread of the frame intervals) and the share of dropped frames,
  only from recordings with real timestamps (not a fixed rate).

Every parameter not fitted keeps the base profile's value and provenance.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from fusion.calibrate.level import level_camera_calibration
from fusion.calibrate.options import CalibrationOptions, Refinement
from fusion.calibrate.pipeline import calibrate_rig
from fusion.calibrate.results import calibration_from_rig
from fusion.calibration import Calibration
from fusion.errors import BadInputError
from fusion.merge.body_scale import SCALE_SHARE, body_scale_stats
from fusion.merge.sensor_stats import SensorStats, sensor_stats
from fusion.recording import Recording
from sim.camera_clock import ClockModel
from sim.sensor_profile import SensorProfile
from sim.tracker_noise import JointGroup

MEDIAN_NORM_3D = 1.538
"""Median of the norm of a 3-D standard Gaussian vector (per-axis std 1)."""

STATS_OF_GROUP: Mapping[JointGroup, tuple[str, ...]] = MappingProxyType({
    JointGroup.TORSO: ("head", "spine"), JointGroup.HIP: ("pelvis",), JointGroup.LIMB: ("shoulder", "elbow"),
    JointGroup.HAND: ("wrist",), JointGroup.TIP: ("hand",), JointGroup.FOOT: ("ankle",),
})
"""Statistic groups (:data:`fusion.merge.sensor_stats.STAT_GROUPS`) that inform each tracker joint group."""

_BONE_GROUPS = {"upper_arm": (JointGroup.LIMB, JointGroup.LIMB), "forearm": (JointGroup.LIMB, JointGroup.HAND)}


@dataclass(frozen=True)
class FitResult:
    """A fitted profile with what it was fitted from.

    Attributes
    ----------
    profile : SensorProfile
        The base profile with the fitted values (and their provenance) replaced.
    stats : mapping recording name -> SensorStats
        The statistics of each recording.
    white_m, wobble_m : mapping JointGroup -> float
        Fitted per-axis white jitter and slow wobble std [m].
    tau_s : float
        Wobble time constant [s] (fitted or kept).
    rigidity : float
        Bone rigidity (fitted or kept).
    view_bias_m : mapping JointGroup -> float
        Fitted 3-D view-bias size [m] (empty without residuals).
    d2_slow_m2 : mapping JointGroup -> float
        Per-axis variance [m^2] of the second difference attributed to the slow wobble.
    bone_std_m : mapping bone -> float
        The measured bone-length spreads [m] (pooled over the recordings) the fit aims at.
    multi_camera : bool
        The recordings had cross-camera residuals (rigidity fitted) rather than one camera (tau fitted).
    notes : tuple of str
        What was fitted, kept or clipped.
    """

    profile: SensorProfile
    stats: Mapping[str, SensorStats]
    white_m: Mapping[JointGroup, float]
    wobble_m: Mapping[JointGroup, float]
    tau_s: float
    rigidity: float
    view_bias_m: Mapping[JointGroup, float]
    d2_slow_m2: Mapping[JointGroup, float]
    bone_std_m: Mapping[str, float]
    multi_camera: bool
    notes: tuple[str, ...]


def _pooled(stats: Sequence[SensorStats], pick) -> float:
    values = [pick(s) for s in stats]
    values = [v for v in values if v is not None and np.isfinite(v)]
    return float(np.median(values)) if values else np.nan


def _group_value(stats: Sequence[SensorStats], group: JointGroup, pick) -> float:
    """Mean over the group's statistic groups of ``pick`` pooled over the recordings that have that
    statistic group (a joint set without hands, UI-PRMD's, has none of theirs)."""
    values = np.array([_pooled([s for s in stats if g in s.jitter_mm], lambda s, g=g: pick(s, g))
                       for g in STATS_OF_GROUP[group]])
    values = values[np.isfinite(values)]
    return float(values.mean()) if values.size else np.nan


def wobble_variance_factor(a: float) -> float:
    """``var(d2) / var(x)`` of a stationary AR(1) series ``x`` with coefficient ``a``: ``2 (1 - a)(3 - a)``."""
    return 2 * (1 - a) * (3 - a)


def _bone_prediction(white: Mapping[JointGroup, float], d2_slow: Mapping[JointGroup, float], dt: float,
                     tau: float) -> dict[str, float]:
    a = np.exp(-dt / tau)
    v = {g: white[g] ** 2 + d2_slow[g] / wobble_variance_factor(a) for g in white}
    return {b: float(np.sqrt(v[p] + v[c])) for b, (p, c) in _BONE_GROUPS.items()}


def _body_scale(recordings: Mapping[str, Recording], files: str, prov: dict) -> tuple[dict, float]:
    """The body-scale parameters of the tracker (its changes, provenance written in ``prov``) and the share
    ``sqrt(1 - share)`` of the bone-length spread left to the joints (1 without a scale)."""
    measured = [body_scale_stats(r) for r in recordings.values()]

    def median(name: str) -> float:
        return _pooled(measured, lambda b: getattr(b, name))

    share = median("share")
    keys = ("body_scale_sd", "body_scale_tau_s", "body_scale_shared")
    if not share >= SCALE_SHARE:
        for k in keys:
            prov[f"tracker.{k}"] = (f"fitted from {files}: no body scale, the bones vary each on its own (a common "
                                    f"scale explains {share:.2f} of the limb bones' length variance, under {SCALE_SHARE})")
        return {"body_scale_sd": 0.0}, 1.0
    shared = median("shared")
    changes = {"body_scale_sd": min(median("sd"), 0.2), "body_scale_tau_s": median("tau_s"),
               "body_scale_shared": float(np.clip(shared, 0.0, 1.0)) if np.isfinite(shared) else 0.0}
    what = {"body_scale_sd": "its standard deviation", "body_scale_tau_s": "the lag at which its autocorrelation "
            "falls below 1/e", "body_scale_shared": "the correlation of the cameras' scales (0 with one camera)"}
    for k in keys:
        prov[f"tracker.{k}"] = (f"fitted from {files}: a common scale explains {share:.4f} of the limb bones' length "
                                f"variance; {what[k]}, median over the recordings")
    return changes, float(np.sqrt(max(0.0, 1 - share)))


def fit_profile(recordings: Mapping[str, Recording], stats: Mapping[str, SensorStats], base: SensorProfile, *,
                name: str, description: str = "") -> FitResult:
    """Fit a profile's tracker and clock parameters to the statistics of real recordings.

    Parameters
    ----------
    recordings : mapping name -> Recording
        The recordings (for the timestamp spread); of ``base``'s joint set or a reduction of it
        (:attr:`~fusion.topology.Topology.full_set`).
    stats : mapping name -> SensorStats
        Their statistics (with residuals when the recordings have two cameras and a calibration).
    base : SensorProfile
        Profile whose other values (and provenance) are kept.
    name, description : str
        Of the fitted profile.

    Returns
    -------
    FitResult
    """
    if not stats or set(stats) != set(recordings):
        raise BadInputError("give the statistics of every recording (and at least one)")
    for n, rec in recordings.items():
        if rec.topology.full_set != base.topology:
            raise BadInputError(f"recording {n} holds {rec.topology.name} skeletons; the base profile "
                                f"{base.name} is for {base.topology.name}")
    S = list(stats.values())
    files = ", ".join(stats)
    dt = 1.0 / _pooled(S, lambda s: s.frame_rate_hz)
    notes: list[str] = []
    prov = dict(base.provenance)
    white, d2_slow = {}, {}
    for g in JointGroup:
        m = _group_value(S, g, lambda s, k: s.jitter_mm[k].value) * 1e-3
        r1 = _group_value(S, g, lambda s, k: s.jitter_acf[k][1])
        base_g = base.tracker.groups[g]
        if not (np.isfinite(m) and np.isfinite(r1)):
            white[g], d2_slow[g] = base_g.jitter_m, 0.0
            notes.append(f"{g.value}: no jitter measured, white jitter kept, no wobble")
            continue
        var_d2 = (m / MEDIAN_NORM_3D) ** 2
        w = float(np.clip(6 * (-r1 - 0.5), 0.0, 1.0))
        white[g], d2_slow[g] = float(np.sqrt(w * var_d2 / 6)), (1 - w) * var_d2
        src = f"fitted from {files}: median second-difference norm {m * 1e3:.2f} mm and its lag-1 autocorrelation " \
              f"{r1:.3f} (white share {w:.2f}) of {'/'.join(STATS_OF_GROUP[g])}"
        prov[f"tracker.groups.{g.value}.jitter_m"] = src
        prov[f"tracker.groups.{g.value}.wobble_m"] = src + " with tracker.wobble_tau_s"

    scale, own = _body_scale(recordings, files, prov)
    bone_obs = {b: own * _pooled(S, lambda s, b=b: s.bone_std_mm[b].value) * 1e-3 for b in _BONE_GROUPS}
    bone_txt = ", ".join(f"{b} {v * 1e3:.1f} mm" for b, v in bone_obs.items()) + (
        " beyond the body scale" if scale["body_scale_sd"] > 0 else "")
    fluct = {g: _group_value(S, g, lambda s, k: s.residual_fluct_mm.get(k, np.nan)) * 1e-3 for g in JointGroup}
    static = {g: _group_value(S, g, lambda s, k: s.residual_static_mm.get(k, np.nan)) * 1e-3 for g in JointGroup}
    multi = any(np.isfinite(v) for v in fluct.values())
    if scale["body_scale_sd"] > 0 and not multi:
        tau, a = base.tracker.wobble_tau_s, np.exp(-dt / base.tracker.wobble_tau_s)
        wobble = {g: float(np.sqrt(d2_slow[g] / wobble_variance_factor(a))) for g in JointGroup}
        pred = _bone_prediction(white, d2_slow, dt, tau)
        rigidity = float(np.clip(1 - np.mean([bone_obs[b] / pred[b] for b in _BONE_GROUPS]), 0.0, 1.0))
        rigidity_source = f"fitted from {files}: 1 - measured / predicted bone-length spread ({bone_txt})"
        notes.append("one camera and a body scale: the bone spread is the scale's, wobble_tau_s kept")
    elif multi:
        slow_var = {g: max(0.0, fluct[g] ** 2 / 2 - white[g] ** 2) for g in JointGroup if np.isfinite(fluct[g])}
        ratios = [d2_slow[g] / v for g, v in slow_var.items() if v > 0 and d2_slow[g] > 0]
        # 2 (1 - a)(3 - a) = ratio  ->  a = 2 - sqrt(1 + ratio / 2)
        taus = [-dt / np.log(np.clip(2 - np.sqrt(1 + q / 2), 1e-6, 1 - 1e-9)) for q in ratios]
        tau = float(np.median(taus)) if taus else base.tracker.wobble_tau_s
        a = np.exp(-dt / tau)
        wobble = {g: float(np.sqrt(slow_var[g])) if g in slow_var else
                  float(np.sqrt(d2_slow[g] / wobble_variance_factor(a))) for g in JointGroup}
        pred = {b: float(np.sqrt(sum(white[g] ** 2 + wobble[g] ** 2 for g in pair))) for b, pair in _BONE_GROUPS.items()}
        rigidity = float(np.clip(1 - np.mean([bone_obs[b] / pred[b] for b in _BONE_GROUPS]), 0.0, 1.0))
        prov["tracker.wobble_tau_s"] = (f"fitted from {files}: median over groups of the time constant that makes "
                                        "the slow part of the second difference match the fluctuating part of the "
                                        "cross-camera residual")
        rigidity_source = f"fitted from {files}: 1 - measured / predicted bone-length spread ({bone_txt})"
        for g in slow_var:
            prov[f"tracker.groups.{g.value}.wobble_m"] = (
                f"fitted from {files}: fluctuating cross-camera residual {fluct[g] * 1e3:.1f} mm per axis of "
                f"{'/'.join(STATS_OF_GROUP[g])} / sqrt(2), less the white jitter")
    else:
        grid = np.geomspace(dt * 1.5, 60.0, 400)
        loss = [sum(np.log(p / bone_obs[b]) ** 2 for b, p in _bone_prediction(white, d2_slow, dt, t).items())
                for t in grid]
        tau, rigidity = float(grid[int(np.argmin(loss))]), 0.0
        if tau in (grid[0], grid[-1]):
            notes.append(f"wobble_tau_s hit the search bound ({tau:.2f} s)")
        a = np.exp(-dt / tau)
        wobble = {g: float(np.sqrt(d2_slow[g] / wobble_variance_factor(a))) for g in JointGroup}
        prov["tracker.wobble_tau_s"] = f"fitted from {files}: matches the bone-length spread ({bone_txt}) with bones free"
        rigidity_source = "assumed 0: a single camera cannot separate it from the time constant"

    f = base.tracker.model_fraction
    view_bias: dict[JointGroup, float] = {}
    groups = {}
    for g in JointGroup:
        changes: dict = {"jitter_m": white[g], "wobble_m": wobble[g], "bone_rigidity": rigidity}
        prov[f"tracker.groups.{g.value}.bone_rigidity"] = rigidity_source
        if np.isfinite(static[g]):
            b = static[g] / np.sqrt(2)
            view_bias[g] = b
            mid = b / np.sqrt(1 - f) if f < 1 else 0.0
            changes["bias_m"] = (0.5 * mid, 1.5 * mid)
            prov[f"tracker.groups.{g.value}.bias_m"] = (
                f"fitted from {files}: the steady part of the cross-camera residual ({static[g] * 1e3:.1f} mm, "
                f"{'/'.join(STATS_OF_GROUP[g])}) / sqrt(2) is the view part; model share tracker.model_fraction "
                "kept (published: no truth-free statistic separates it)")
        lows = [1 - s.confidence2[k].value for s in S for k in STATS_OF_GROUP[g]
                if k in s.confidence2 and np.isfinite(s.confidence2[k].value)]
        if lows:
            changes["low_confidence"] = (float(min(lows)), float(max(lows)))
            prov[f"tracker.groups.{g.value}.low_confidence"] = (
                f"fitted from {files}: range over recordings of the share of {'/'.join(STATS_OF_GROUP[g])} samples "
                "below confidence 2")
        spikes = _group_value(S, g, lambda s, k: s.spikes[k].value)
        if np.isfinite(spikes):
            changes["outlier_rate"] = float(min(spikes * base.tracker.outlier_mean_frames
                                                / (base.tracker.outlier_mean_frames + 2), 0.5))
            prov[f"tracker.groups.{g.value}.outlier_rate"] = (
                f"fitted from {files}: share {spikes:.4f} of second differences over 5 cm of "
                f"{'/'.join(STATS_OF_GROUP[g])}, times m / (m + 2) for bursts of mean length m frames "
                "(each burst spikes the m + 2 second differences around it)")
        groups[g] = dataclasses.replace(base.tracker.groups[g], **changes)
    tracker = dataclasses.replace(base.tracker, groups=groups, wobble_tau_s=tau, activity_exponent=0.0, **scale)
    prov["tracker.activity_exponent"] = ("none in the fit from the statistics (each recording read as it is); "
                                         "`sensor-fit --replicas` fits it from three recordings or more")

    clock = base.clock
    timed = [n for n, r in recordings.items() if not r.metadata.get("fixed_rate", False)]
    if timed:
        clock = _fit_clock([recordings[n] for n in timed], [stats[n] for n in timed], base, dt)
        for key, what in (("jitter_sigma_s", "robust spread of the frame intervals / sqrt(2)"),
                          ("drop_probability", "share of frames missing from the timestamp sequence"),
                          ("rate_hz", "median frame interval")):
            prov[f"clock.{key}"] = f"fitted from {', '.join(timed)}: {what}"
    else:
        notes.append("the recordings carry no timestamps (a fixed frame rate): the clock keeps the base values")
    profile = dataclasses.replace(base, name=name, tracker=tracker, clock=clock, provenance=prov,
                                  description=description or base.description)
    return FitResult(profile, MappingProxyType(dict(stats)), MappingProxyType(white), MappingProxyType(wobble),
                     tau, rigidity, MappingProxyType(view_bias), MappingProxyType(d2_slow),
                     MappingProxyType(bone_obs), multi, tuple(notes))


def _fit_clock(recordings: list[Recording], stats: list[SensorStats], base: SensorProfile, dt: float) -> ClockModel:
    """Clock jitter, drop rate and frame rate of recordings with real timestamps."""
    intervals = np.concatenate([np.diff(c.skeleton.timestamps) for r in recordings for c in r.cameras
                                if c.skeleton is not None and c.skeleton.n_frames > 1])
    regular = intervals[intervals < 1.5 * dt]
    mad = float(np.median(np.abs(regular - np.median(regular)))) * 1.4826
    drops = _pooled(stats, lambda s: s.dropped_frames)
    return dataclasses.replace(base.clock, jitter_sigma_s=min(mad / np.sqrt(2), 0.1 * dt),
                               drop_probability=min(drops, 0.5), rate_hz=float(1 / dt))


MIN_SPAN_S = 2.0
"""Shortest skeleton stream [s] whose statistics are measured."""


def check_span(recording: Recording) -> None:
    """Refuse a recording in which no camera holds :data:`MIN_SPAN_S` of skeletons."""
    spans = [float(c.skeleton.timestamps[-1] - c.skeleton.timestamps[0]) for c in recording.cameras
             if c.skeleton is not None and c.skeleton.n_frames > 1]
    if max(spans, default=0.0) < MIN_SPAN_S:
        raise BadInputError(f"the recording holds {max(spans, default=0.0):.2f} s of skeletons; its statistics (jitter, "
                            f"bone-length spread, residuals) need at least {MIN_SPAN_S:g} s: give a longer recording")


def measure(recording: Recording, T_world_cam: Mapping[str, np.ndarray] | None = None, *, n_boot: int = 100,
            rng: np.random.Generator) -> SensorStats:
    """:func:`~fusion.merge.sensor_stats.sensor_stats` of a recording; a recording with two or more
    cameras and no calibration is first calibrated from the body (skeletons only, no ICP, no
    uncertainty bootstrap: only the poses are needed).

    Raises
    ------
    BadInputError
        No camera holds :data:`MIN_SPAN_S` of skeletons (the statistics of less would mean nothing).
    """
    check_span(recording)
    if T_world_cam is None:
        calibration = body_calibration(recording, rng=rng)
        T_world_cam = None if calibration is None else calibration.T_world_cam
    return sensor_stats(recording, T_world_cam, n_boot=n_boot, rng=rng)


def body_calibration(recording: Recording, *, rng: np.random.Generator) -> Calibration | None:
    """The cameras calibrated from the body (skeletons only, no ICP, no uncertainty bootstrap); None for
    a recording with fewer than two skeleton cameras."""
    if sum(c.skeleton is not None for c in recording.cameras) < 2:
        return None
    options = CalibrationOptions(refine=Refinement.NONE, bootstrap=1)
    return calibration_from_rig(calibrate_rig(recording, options, rng=rng))


def session_calibration(recording: Recording, *, rng: np.random.Generator) -> Calibration:
    """The cameras calibrated from the body (:func:`body_calibration`), or a one-camera recording's
    level camera (:func:`fusion.calibrate.level.level_camera_calibration`): what a replica needs."""
    calibration = body_calibration(recording, rng=rng)
    return level_camera_calibration(recording) if calibration is None else calibration
