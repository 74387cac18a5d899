"""The low-confidence shares of a tracker's joint groups, fitted on replicas of real recordings.

A joint is reported at low confidence more often while hidden from the camera than while seen. Each
replica (:mod:`scenarios.sensors.replica_case`) knows how often each statistic group's joints were
hidden; the real recording gives the share reported low. Per joint group the two probabilities follow
by bounded least squares over the recordings.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np
from scipy.optimize import lsq_linear

from scenarios.sensors.fit import STATS_OF_GROUP
from scenarios.sensors.replica_case import ReplicaCase
from sim.sensor_profile import SensorProfile


def fit_confidence(profile: SensorProfile, cases: Sequence[ReplicaCase]) -> SensorProfile:
    """Per group, the low-confidence shares of hidden and visible joints by bounded least squares over
    the recordings (each recording one equation per statistic group of the joint group)."""
    groups = {}
    for g, gn in profile.tracker.groups.items():
        rows, rhs = [], []
        for c in cases:
            for k in STATS_OF_GROUP[g]:
                low, h = 1 - c.real.confidence2[k].value if k in c.real.confidence2 else np.nan, c.hidden_share.get(k, np.nan)
                if np.isfinite(low) and np.isfinite(h):
                    rows.append([h, 1 - h])
                    rhs.append(low)
        if not rows:
            groups[g] = gn
            continue
        p_hidden, p_visible = lsq_linear(np.array(rows), np.array(rhs), bounds=(0.0, 1.0)).x
        if not np.any(np.array(rows)[:, 0] > 0.01):
            p_hidden = gn.hidden_low_confidence  # never hidden: nothing to fit
        groups[g] = dataclasses.replace(gn, low_confidence=(float(p_visible), float(p_visible)),
                                        hidden_low_confidence=float(p_hidden))
    return dataclasses.replace(profile, tracker=dataclasses.replace(profile.tracker, groups=groups))
