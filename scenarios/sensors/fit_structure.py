"""Optional parts of the tracker model, fitted on replicas of real recordings when asked.

Each part is fixed by truth-free statistics, by the same damped fixed-point steps as the rest of the
replica fit (:mod:`scenarios.sensors.fit_replica`). All but ``outlier-size`` and ``group-activity`` move
their parameter by the median over the recordings of a statistic, real less simulated, over that
statistic's measured slope; the first three use the cross-camera residual, which one-camera recordings lack (they keep the profile's value).

- ``limb-sharing``: how far the view bias is shared along a limb (``view_limb_correlation``), from the
  limb cosine (:func:`fusion.merge.limb_sharing.limb_cosine`: how far neighbouring limb joints' steady
  residuals point the same way), over :data:`COSINE_SLOPE`;
- ``hidden-offsets``: the share of the frames in which a hidden joint reported at full confidence
  still carries a guessed offset (``hidden_offset_share``), from the far tail of the elbows' and wrists'
  residuals (:func:`fusion.merge.residual_parts.tracked_tail`), over :data:`TAIL_SLOPE`;
- ``bone-view``: how far a limb joint's view bias lies along its bone (``view_bone_alignment``), from
  the share of the elbows' and wrists' steady residual along their bones
  (:func:`fusion.merge.limb_sharing.residual_bone_share`), over :data:`VIEW_SHARE_SLOPE`;
- ``bone-noise``: how far a limb joint's jitter, slow error and outliers lie along its bone
  (``noise_bone_alignment``, :func:`sim.tracker_axes.bone_aligned`), from the mean squared cosine between
  the elbows' and wrists' second differences and their bones (:func:`fusion.merge.limb_sharing.bone_step_parts`),
  over :data:`BONE_STEP_SLOPE`; one camera is enough;
- ``outlier-size``: per joint group, the size range of its outliers (``outlier_m``), scaled by the ratio
  real / simulated of the median length of the second differences over 5 cm (the spikes whose share
  fixes the outlier rate), pooled as the median over the recordings, within :data:`OUTLIER_BOUNDS_M`;
  one camera is enough;
- ``camera-scale``: how far each camera scales the whole skeleton (``camera_scale_sd``), from how much
  larger the other cameras see the person than the reference (:func:`fusion.merge.camera_sizes.size_agreement`),
  over :data:`CAMERA_SCALE_SLOPE`; two cameras are needed;
- ``shared-bones``: how far the bone rigidity holds the person's own bone lengths in every camera
  (``shared_bone_lengths``), from how far the cameras disagree on the proportions (the same function),
  over :data:`SHARED_BONES_SLOPE`; two cameras are needed;
- ``trunk-turn``: how far each camera session turns the trunk against the limbs (``trunk_turn_sd_deg``,
  :mod:`sim.tracker_trunk_turn`), from how much the trunk's turn under the session's calibration
  (:func:`fusion.merge.residual_parts.trunk_turn`, the first camera pair) changes between one person's
  sessions (:func:`turn_spread`): its variance moves by the gap of the squared spreads, real less
  simulated, over :data:`TURN_SLOPE`; it needs two cameras and people with two sessions or more
  (:attr:`~scenarios.sensors.replica_case.ReplicaCase.person`);
- ``group-activity``: per joint group, how its jitter and slow error grow with the session's activity
  beyond the common factor (the group's ``activity_exponent``), moved by the Theil-Sen slope of the
  recordings' log-ratio real / simulated of the group's jitter (beyond the motion's own) against their log
  activity (three recordings or more, of different activity). The common factor is then fitted from the
  residuals alone (:func:`scenarios.sensors.fit_replica.activity_slope`). Unlike the two above it needs no
  second camera.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import numpy as np

from fusion.errors import BadInputError
from fusion.merge.sensor_stats import SensorStats
from fusion.topology import Topology
from scenarios.sensors.fit import STATS_OF_GROUP
from scenarios.sensors.replica_case import ReplicaCase
from scenarios.sensors.replica_ratios import (
    activity_trend,
    jitter_ratio,
    measured_on_own_joints,
)
from sim.tracker_noise import JointGroup, TrackerNoise

STRUCTURE_PARTS = ("limb-sharing", "hidden-offsets", "bone-view", "bone-noise", "outlier-size", "camera-scale",
                   "shared-bones", "trunk-turn", "group-activity")
"""The optional parts a refinement can fit."""

PERSON_PARTS = ("trunk-turn",)
"""The parts fixed by a statistic over one person's sessions: with one of them the refinement re-tracks each
person's replicas as one simulated person (:func:`shares_people`)."""

COSINE_SLOPE = 0.65
"""Growth of the simulated limb cosine with the view bias's limb correlation: on nine replicas of the
azure_2cam sessions (every third) its median went from -0.04 at 0 to 0.55 at 0.9."""

TAIL_SLOPE = 0.15
"""Growth of the simulated far-tail share with ``hidden_offset_share``: on the same nine replicas its median
went from 0.084 at 0 to 0.172 at 0.5 and 0.231 at 1."""

VIEW_SHARE_SLOPE = 0.24
"""Growth of the simulated residual share along the bones with ``view_bone_alignment``: on the replicas of the
27 azure_2cam sessions its median went from 0.29 at 0 to 0.43 at 0.5 and 0.53 at 1."""

BONE_STEP_SLOPE = 0.12
"""Growth of the simulated bone-step share with ``noise_bone_alignment``: on the replicas of the 24 Kinect v2
recordings of the built-in profile's fit its median went from 0.235 at 0 to 0.294 at 0.5 and 0.360 at 1."""

CAMERA_SCALE_SLOPE = 0.54
"""Growth of the simulated camera scale (:attr:`~fusion.merge.sensor_stats.SensorStats.camera_scale`) with
``camera_scale_sd``: on the replicas of the 27 azure_2cam sessions (``shared_bone_lengths`` 1) its median went
from 0.0029 at 0 to 0.0113 at 0.015 and 0.0189 at 0.03."""

SHARED_BONES_SLOPE = -0.045
"""Change of the simulated bone-ratio spread (:attr:`~fusion.merge.sensor_stats.SensorStats.bone_ratio_spread`)
with ``shared_bone_lengths``: on the same replicas its median went from 0.045 at 0 to 0.022 at 0.5 and 0.0007
at 1."""

TURN_SLOPE = 1.7
"""Growth of the simulated trunk-turn spread's square (:func:`turn_spread`, deg^2) with ``trunk_turn_sd_deg``'s
square: on the replicas of the 27 azure_2cam sessions (one simulated person per person, two draws) its median
over the people went from 0.08 at 0 to 0.24 at 0.3 deg."""

TURN_BOUNDS_DEG = (0.0, 5.0)
"""Bounds [deg] of a fitted ``trunk_turn_sd_deg``."""

OUTLIER_BOUNDS_M = (0.02, 0.5)
"""Bounds [m] of a fitted outlier size: a group whose simulated spikes are not its outliers' (a foot's guessed
offsets while hidden) would otherwise grow its outliers without end."""

DAMPING = 0.8
"""Share of each step's gap taken (as :data:`scenarios.sensors.fit_replica.DAMPING`)."""

_PARTS = {  # part: (statistic of SensorStats, tracker parameter, slope, bounds, provenance)
    "limb-sharing": ("residual_limb_cosine", "view_limb_correlation", COSINE_SLOPE, (0.0, 0.95),
                     "median limb cosine of the steady cross-camera residuals (neighbouring limb joints), real "
                     "against simulated"),
    "hidden-offsets": ("residual_tail", "hidden_offset_share", TAIL_SLOPE, (0.0, 1.0),
                       "median share of the elbows' and wrists' cross-camera residual samples, Tracked in both "
                       "cameras, beyond 8 cm, real against simulated"),
    "bone-view": ("residual_bone_share", "view_bone_alignment", VIEW_SHARE_SLOPE, (-2.0, 2.0),
                  "median share of the elbows' and wrists' steady cross-camera residual along their bones, real "
                  "against simulated"),
    "bone-noise": ("bone_step_share", "noise_bone_alignment", BONE_STEP_SLOPE, (-2.0, 2.0),
                   "median mean squared cosine between the elbows' and wrists' second differences and their bones, "
                   "real against simulated"),
    "camera-scale": ("camera_scale", "camera_scale_sd", CAMERA_SCALE_SLOPE, (0.0, 0.2),
                     "median absolute log ratio of the second camera's limb bone lengths to the first's, real against "
                     "simulated"),
    "shared-bones": ("bone_ratio_spread", "shared_bone_lengths", SHARED_BONES_SLOPE, (0.0, 1.0),
                     "median spread over the limb bones of the log ratio of the second camera's bone lengths to the "
                     "first's, real against simulated"),
}


def check_parts(parts: Sequence[str]) -> tuple[str, ...]:
    """``parts`` as a tuple, each one of :data:`STRUCTURE_PARTS`."""
    unknown = [p for p in parts if p not in STRUCTURE_PARTS]
    if unknown:
        raise BadInputError(f"unknown model part(s) {unknown}; choose from {', '.join(STRUCTURE_PARTS)}")
    return tuple(parts)


def shares_people(parts: Sequence[str]) -> bool:
    """Whether fitting ``parts`` needs one person's replicas re-tracked as one simulated person
    (:data:`PERSON_PARTS`)."""
    return any(p in PERSON_PARTS for p in check_parts(parts))


def structure_keys(parts: Sequence[str]) -> tuple[str, ...]:
    """The profile keys (``"table.key"``) that fitting ``parts`` may set."""
    keys = [f"tracker.{_PARTS[p][1]}" for p in check_parts(parts) if p in _PARTS]
    if "trunk-turn" in parts:
        keys.append("tracker.trunk_turn_sd_deg")
    for part, key in (("group-activity", "activity_exponent"), ("outlier-size", "outlier_m")):
        if part in parts:
            keys += [f"tracker.groups.{g.value}.{key}" for g in JointGroup]
    return tuple(keys)


def statistic_gap(cases: Sequence[ReplicaCase], sims: Sequence[SensorStats], statistic: str) -> float | None:
    """Median of the real recordings' ``statistic`` less that of their simulations (over the recordings
    that have it in both); None where none has (the cross-camera statistics of one-camera recordings)."""
    pairs = np.array([(getattr(c.real, statistic), getattr(s, statistic)) for c, s in zip(cases, sims)])
    ok = np.isfinite(pairs).all(axis=1) if pairs.size else np.zeros(0, dtype=bool)
    return float(np.median(pairs[ok, 0]) - np.median(pairs[ok, 1])) if ok.any() else None


def turn_spread(cases: Sequence[ReplicaCase], stats: Sequence[SensorStats]) -> float | None:
    """Median over the people with two sessions or more of the RMS [deg] of their sessions' trunk turn
    (``stats[k].trunk_turn_deg`` of the first camera pair, one per case) about the person's mean; None
    without such a person."""
    turns: dict[str, list[np.ndarray]] = {}
    for c, s in zip(cases, stats):
        if c.person is not None and len(s.trunk_turn_deg) and np.isfinite(s.trunk_turn_deg[0]).all():
            turns.setdefault(c.person, []).append(s.trunk_turn_deg[0])
    spreads = [np.sqrt(np.mean(np.sum((v - np.mean(v, axis=0)) ** 2, axis=1)))
               for v in map(np.array, turns.values()) if len(v) >= 2]
    return float(np.median(spreads)) if spreads else None


def _per_recording(cases: Sequence[ReplicaCase], sims: Sequence[SensorStats], topology: Topology,
                   value: Callable[[ReplicaCase, SensorStats, JointGroup], float]) -> dict[JointGroup, list[float]]:
    """Per joint group whose statistics are measured on its own joints (not the hips:
    :func:`~scenarios.sensors.replica_ratios.measured_on_own_joints`), ``value`` of every recording and its
    simulation (NaN where it has none)."""
    own = measured_on_own_joints(topology)
    return {g: [value(c, s, g) for c, s in zip(cases, sims)] for g in JointGroup if own[g]}


def _log_jitter_ratio(c: ReplicaCase, s: SensorStats, g: JointGroup) -> float:
    logs = [np.log(jitter_ratio(c, s, k)) for k in STATS_OF_GROUP[g] if k in c.real.jitter_mm]
    return float(np.mean(logs)) if logs and np.all(np.isfinite(logs)) else np.nan


def group_activity_slopes(cases: Sequence[ReplicaCase], sims: Sequence[SensorStats], topology: Topology
                          ) -> dict[JointGroup, float]:
    """Per joint group measured on its own joints (:func:`_per_recording`), the Theil-Sen slope of the
    recordings' mean log-ratio real / simulated of the group's jitter beyond the motion's own against their
    log activity (groups without one left out); ``topology`` the tracker's joint set."""
    slopes = {g: activity_trend(cases, v) for g, v in _per_recording(cases, sims, topology, _log_jitter_ratio).items()}
    return {g: slope for g, slope in slopes.items() if slope is not None}


def _spike_ratio(c: ReplicaCase, s: SensorStats, g: JointGroup) -> float:
    r = [c.real.spike_mm[k].value / s.spike_mm[k].value for k in STATS_OF_GROUP[g]
         if k in c.real.spike_mm and k in s.spike_mm and s.spikes[k].value >= 2 * c.motion.spikes[k].value]
    r = [x for x in r if np.isfinite(x) and x > 0]
    return float(np.mean(r)) if r else np.nan


def spike_size_ratios(cases: Sequence[ReplicaCase], sims: Sequence[SensorStats], topology: Topology
                      ) -> dict[JointGroup, float]:
    """Per joint group measured on its own joints (:func:`_per_recording`), the median over the recordings
    of the mean ratio real / simulated of its statistic groups' median spike length. A statistic group
    counts in a recording only where its simulation spikes at least twice as often as the replica's own
    motion does (:attr:`ReplicaCase.motion`): elsewhere the spikes are the motion's, which no outlier size
    moves."""
    ratios = {g: [x for x in v if np.isfinite(x)] for g, v in _per_recording(cases, sims, topology, _spike_ratio).items()}
    return {g: float(np.median(v)) for g, v in ratios.items() if v}


def with_structure(tracker: TrackerNoise, cases: Sequence[ReplicaCase], sims: Sequence[SensorStats],
                   parts: Sequence[str], topology: Topology) -> tuple[TrackerNoise, dict[str, str]]:
    """One damped step of each of ``parts`` toward what ``cases`` show against their simulations ``sims``
    (``topology`` the tracker's joint set), and the provenance (``"table.key"`` -> how) of every value that
    moved."""
    prov = {}
    for part in check_parts(parts):
        if part not in _PARTS:
            continue
        statistic, key, slope, (low, high), how = _PARTS[part]
        gap = statistic_gap(cases, sims, statistic)
        if gap is not None:
            tracker = dataclasses.replace(tracker, **{key: float(np.clip(
                getattr(tracker, key) + DAMPING * gap / slope, low, high))})
            prov[f"tracker.{key}"] = how
    if "trunk-turn" in parts:
        real, simulated = turn_spread(cases, [c.real for c in cases]), turn_spread(cases, sims)
        if real is not None and simulated is not None:
            variance = tracker.trunk_turn_sd_deg ** 2 + DAMPING * (real ** 2 - simulated ** 2) / TURN_SLOPE
            tracker = dataclasses.replace(tracker, trunk_turn_sd_deg=float(np.clip(
                np.sqrt(max(variance, 0.0)), *TURN_BOUNDS_DEG)))
            prov["tracker.trunk_turn_sd_deg"] = (
                "median over the people of the RMS of their sessions' trunk turn about its mean (the rotation left "
                "between the cameras' trunk joints under the session's calibration), real against simulated")
    if "group-activity" in parts:
        groups = dict(tracker.groups)
        for g, slope in group_activity_slopes(cases, sims, topology).items():
            groups[g] = dataclasses.replace(groups[g], activity_exponent=float(np.clip(
                groups[g].activity_exponent + DAMPING * slope, -3.0, 3.0)))
            prov[f"tracker.groups.{g.value}.activity_exponent"] = (
                "Theil-Sen slope of the recordings' log-ratio real / simulated of the jitter beyond the motion's own "
                f"({'/'.join(STATS_OF_GROUP[g])}) against their log activity, driven to zero")
        tracker = dataclasses.replace(tracker, groups=groups)
    if "outlier-size" in parts:
        groups = dict(tracker.groups)
        for g, ratio in spike_size_ratios(cases, sims, topology).items():
            groups[g] = dataclasses.replace(groups[g], outlier_m=tuple(
                float(np.clip(v * ratio ** DAMPING, *OUTLIER_BOUNDS_M)) for v in groups[g].outlier_m))
            prov[f"tracker.groups.{g.value}.outlier_m"] = (
                "scaled by the recordings' median ratio real / simulated of the median length of the second differences "
                f"over 5 cm ({'/'.join(STATS_OF_GROUP[g])})")
        tracker = dataclasses.replace(tracker, groups=groups)
    return tracker, prov
