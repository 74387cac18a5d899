"""How a real recording's statistics compare with its replica's, shared by the replica fit
(:mod:`scenarios.sensors.fit_replica`), its optional parts (:mod:`scenarios.sensors.fit_structure`) and the
population fit (:mod:`scenarios.sensors.fit_population`)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy.stats import theilslopes

from fusion.merge.sensor_stats import STAT_GROUPS, SensorStats
from fusion.topology import Topology
from scenarios.sensors.fit import STATS_OF_GROUP
from scenarios.sensors.replica_case import ReplicaCase
from sim.tracker_noise import JointGroup, joint_groups


def excess_jitter(total: float, motion: float) -> float:
    """The part of a median second-difference norm beyond the motion's own, in quadrature (at least 30 %)."""
    return float(np.sqrt(max(total ** 2 - motion ** 2, (0.3 * total) ** 2)))


def jitter_ratio(case: ReplicaCase, sim: SensorStats, k: str) -> float:
    """Ratio real / simulated of stat group ``k``'s jitter beyond the motion's own (:func:`excess_jitter`)."""
    motion = case.motion.jitter_mm[k].value
    return excess_jitter(case.real.jitter_mm[k].value, motion) / excess_jitter(sim.jitter_mm[k].value, motion)


def activity_trend(cases: Sequence[ReplicaCase], values: Sequence[float]) -> float | None:
    """Theil-Sen slope of ``values`` (one per case, NaN where missing) against the cases' log activity. None
    with fewer than three values (through two points any difference between them, such as two different
    exercises, would pass for activity) or activities within 5 % of each other."""
    x = np.log([max(c.activity, 1e-6) for c in cases])
    y = np.asarray(values, dtype=np.float64)
    ok = np.isfinite(y)
    if ok.sum() < 3 or np.ptp(x[ok]) < 0.05:
        return None
    return float(theilslopes(y[ok], x[ok]).slope)


def measured_on_own_joints(topology: Topology) -> dict[JointGroup, bool]:
    """Per joint group, whether the statistics that inform it (``STATS_OF_GROUP``) are measured on any of
    its own joints. The hips' are the pelvis's, a torso joint the hips' own errors do not move: updating
    a hip parameter from it (their outlier rate, how their jitter grows) would move it without end."""
    groups = np.array(joint_groups(topology))
    return {g: any(groups[topology.index(lm)] == g for k in STATS_OF_GROUP[g] for lm in STAT_GROUPS[k]
                   if lm in topology.landmarks) for g in JointGroup}
