"""How far the view bias is shared along a limb, fitted on replicas of real two-camera recordings.

The limb cosine of a recording (:func:`fusion.merge.limb_sharing.limb_cosine`: how far neighbouring limb
joints' steady cross-camera residuals point the same way) fixes the view bias's limb correlation
(``view_limb_correlation`` of :class:`sim.tracker_noise.TrackerNoise`), by the same damped fixed-point
steps as the rest of the replica fit (:mod:`scenarios.sensors.fit_replica`): each step moves it by the
median limb cosine of the recordings, real less simulated, over :data:`COSINE_SLOPE`. One-camera
recordings have no cross-camera residual and cannot show it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from fusion.merge.sensor_stats import SensorStats
from scenarios.sensors.replica_case import ReplicaCase
from sim.tracker_noise import TrackerNoise

COSINE_SLOPE = 0.65
"""Growth of the simulated limb cosine with the view bias's limb correlation: on nine replicas of the
azure_2cam sessions (every third) its median went from -0.04 at 0 to 0.55 at 0.9."""

DAMPING = 0.8
"""Share of each step's gap taken (as :data:`scenarios.sensors.fit_replica.DAMPING`)."""

PROVENANCE = ("median limb cosine of the steady cross-camera residuals (neighbouring limb joints), "
              "real against simulated")


def cosine_gap(cases: Sequence[ReplicaCase], sims: Sequence[SensorStats]) -> float | None:
    """Median limb cosine of the real recordings less that of their simulations (over the recordings that
    have it in both); None without cross-camera residuals."""
    pairs = np.array([(c.real.residual_limb_cosine, s.residual_limb_cosine) for c, s in zip(cases, sims)])
    ok = np.isfinite(pairs).all(axis=1) if pairs.size else np.zeros(0, dtype=bool)
    return float(np.median(pairs[ok, 0]) - np.median(pairs[ok, 1])) if ok.any() else None


def with_limb_sharing(tracker: TrackerNoise, cases: Sequence[ReplicaCase],
                      sims: Sequence[SensorStats]) -> tuple[TrackerNoise, dict[str, str]]:
    """One damped step of the view bias's limb correlation toward what ``cases`` show against their
    simulations ``sims`` (clipped to [0, 0.95]), and the provenance (``"table.key"`` -> how) of the value
    when it moved (none without cross-camera residuals)."""
    gap = cosine_gap(cases, sims)
    if gap is None:
        return tracker, {}
    return dataclasses.replace(tracker, view_limb_correlation=float(np.clip(
        tracker.view_limb_correlation + DAMPING * gap / COSINE_SLOPE, 0.0, 0.95))), \
        {"tracker.view_limb_correlation": PROVENANCE}
