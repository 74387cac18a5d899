"""Optional parts of the tracker model, fitted on replicas of real recordings when asked.

Each part is fixed by truth-free statistics, by the same damped fixed-point steps as the rest of the
replica fit (:mod:`scenarios.sensors.fit_replica`). The first two move their parameter by the median over
the recordings of a statistic of the cross-camera residual, real less simulated, over that statistic's
measured slope; one-camera recordings have no cross-camera residual, and keep the profile's value.

- ``limb-sharing``: how far the view bias is shared along a limb (``view_limb_correlation``), from the
  limb cosine (:func:`fusion.merge.limb_sharing.limb_cosine`: how far neighbouring limb joints' steady
  residuals point the same way), over :data:`COSINE_SLOPE`;
- ``hidden-offsets``: the share of the frames in which a hidden joint reported at full confidence
  still carries a guessed offset (``hidden_offset_share``), from the far tail of the elbows' and wrists'
  residuals (:func:`fusion.merge.residual_parts.tracked_tail`), over :data:`TAIL_SLOPE`;
- ``group-activity``: per joint group, how its jitter and slow error grow with the session's activity
  beyond the common factor (the group's ``activity_exponent``), moved by the Theil-Sen slope of the
  recordings' log-ratio real / simulated of the group's jitter (beyond the motion's own) against their log
  activity (three recordings or more, of different activity). The common factor is then fitted from the
  residuals alone (:func:`scenarios.sensors.fit_replica.activity_slope`). Unlike the two above it needs no
  second camera.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

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

STRUCTURE_PARTS = ("limb-sharing", "hidden-offsets", "group-activity")
"""The optional parts a refinement can fit."""

COSINE_SLOPE = 0.65
"""Growth of the simulated limb cosine with the view bias's limb correlation: on nine replicas of the
azure_2cam sessions (every third) its median went from -0.04 at 0 to 0.55 at 0.9."""

TAIL_SLOPE = 0.15
"""Growth of the simulated far-tail share with ``hidden_offset_share``: on the same nine replicas its median
went from 0.084 at 0 to 0.172 at 0.5 and 0.231 at 1."""

DAMPING = 0.8
"""Share of each step's gap taken (as :data:`scenarios.sensors.fit_replica.DAMPING`)."""

_PARTS = {  # part: (statistic of SensorStats, tracker parameter, slope, bounds, provenance)
    "limb-sharing": ("residual_limb_cosine", "view_limb_correlation", COSINE_SLOPE, (0.0, 0.95),
                     "median limb cosine of the steady cross-camera residuals (neighbouring limb joints), real "
                     "against simulated"),
    "hidden-offsets": ("residual_tail", "hidden_offset_share", TAIL_SLOPE, (0.0, 1.0),
                       "median share of the elbows' and wrists' cross-camera residual samples, Tracked in both "
                       "cameras, beyond 8 cm, real against simulated"),
}


def check_parts(parts: Sequence[str]) -> tuple[str, ...]:
    """``parts`` as a tuple, each one of :data:`STRUCTURE_PARTS`."""
    unknown = [p for p in parts if p not in STRUCTURE_PARTS]
    if unknown:
        raise BadInputError(f"unknown model part(s) {unknown}; choose from {', '.join(STRUCTURE_PARTS)}")
    return tuple(parts)


def structure_keys(parts: Sequence[str]) -> tuple[str, ...]:
    """The profile keys (``"table.key"``) that fitting ``parts`` may set."""
    keys = [f"tracker.{_PARTS[p][1]}" for p in check_parts(parts) if p in _PARTS]
    if "group-activity" in parts:
        keys += [f"tracker.groups.{g.value}.activity_exponent" for g in JointGroup]
    return tuple(keys)


def statistic_gap(cases: Sequence[ReplicaCase], sims: Sequence[SensorStats], statistic: str) -> float | None:
    """Median of the real recordings' ``statistic`` less that of their simulations (over the recordings
    that have it in both); None without cross-camera residuals."""
    pairs = np.array([(getattr(c.real, statistic), getattr(s, statistic)) for c, s in zip(cases, sims)])
    ok = np.isfinite(pairs).all(axis=1) if pairs.size else np.zeros(0, dtype=bool)
    return float(np.median(pairs[ok, 0]) - np.median(pairs[ok, 1])) if ok.any() else None


def group_activity_slopes(cases: Sequence[ReplicaCase], sims: Sequence[SensorStats], topology: Topology
                          ) -> dict[JointGroup, float]:
    """Per joint group whose statistics are measured on its own joints (not the hips:
    :func:`~scenarios.sensors.replica_ratios.measured_on_own_joints`), the Theil-Sen slope of the recordings' mean log-ratio real / simulated of the group's
    jitter beyond the motion's own against their log activity (groups without one left out); ``topology``
    the tracker's joint set."""
    out = {}
    own = measured_on_own_joints(topology)
    for g in JointGroup:
        if not own[g]:
            continue
        values = []
        for c, s in zip(cases, sims):
            logs = [np.log(jitter_ratio(c, s, k)) for k in STATS_OF_GROUP[g] if k in c.real.jitter_mm]
            values.append(float(np.mean(logs)) if logs and np.all(np.isfinite(logs)) else np.nan)
        slope = activity_trend(cases, values)
        if slope is not None:
            out[g] = slope
    return out


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
    if "group-activity" in parts:
        groups = dict(tracker.groups)
        for g, slope in group_activity_slopes(cases, sims, topology).items():
            groups[g] = dataclasses.replace(groups[g], activity_exponent=float(np.clip(
                groups[g].activity_exponent + DAMPING * slope, -3.0, 3.0)))
            prov[f"tracker.groups.{g.value}.activity_exponent"] = (
                "Theil-Sen slope of the recordings' log-ratio real / simulated of the jitter beyond the motion's own "
                f"({'/'.join(STATS_OF_GROUP[g])}) against their log activity, driven to zero")
        tracker = dataclasses.replace(tracker, groups=groups)
    return tracker, prov
