"""Sim-to-real: simulate a scenario standing in for a real session and compare truth-free statistics.

The scenario is a value: the replica of the real session (its calibrated camera poses and its motion
retargeted onto the humanoid) when one is available, otherwise a scenario with the session's
geometry and scripted movements. Both recordings go through the same statistics
(:func:`scenarios.sensors.fit.measure`: calibrated from the body when they have two cameras), and each
statistic is reported with the ratio simulated / real and a verdict against a tolerance.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from fusion.errors import BadInputError
from fusion.merge.sensor_stats import SensorStats
from fusion.recording import Recording
from scenarios.config import Scenario
from scenarios.runner import simulate
from scenarios.sensors.fit import measure

RATIO_TOLERANCE = 0.25
"""Allowed relative difference of a statistic (simulated within +-25 % of real)."""

POINTS_TOLERANCE = 0.10
"""Allowed difference of a share compared in points (10 percentage points)."""


@dataclass(frozen=True)
class Row:
    """One statistic on both recordings.

    Attributes
    ----------
    statistic : str
        What is compared, with its unit.
    real, sim : float
        Its values on the real and the simulated recording.
    ratio : float
        sim / real (NaN when real is 0 or missing).
    by_points : bool
        Compared as a difference of shares (within :data:`POINTS_TOLERANCE`) instead of a ratio.
    passed : bool or None
        Within the tolerance; None when either value is missing.
    """

    statistic: str
    real: float
    sim: float
    ratio: float
    by_points: bool
    passed: bool | None


@dataclass(frozen=True)
class SimToReal:
    """The comparison of a real recording and its simulated stand-in.

    Attributes
    ----------
    rows : tuple of Row
        The compared statistics.
    real, sim : SensorStats
        All statistics of both recordings (for the plots).
    scenario : Scenario
        The simulated scenario (with its sensor profile).
    """

    rows: tuple[Row, ...]
    real: SensorStats
    sim: SensorStats
    scenario: Scenario

    @property
    def passed(self) -> bool:
        """Every statistic that could be compared is within its tolerance."""
        return all(r.passed for r in self.rows if r.passed is not None)


def _row(statistic: str, real: float, sim: float, *, by_points: bool = False, tolerance: float = RATIO_TOLERANCE,
         points: float = POINTS_TOLERANCE) -> Row:
    ratio = sim / real if np.isfinite(real) and real != 0 and np.isfinite(sim) else np.nan
    if not (np.isfinite(real) and np.isfinite(sim)):
        passed = None
    elif by_points:
        passed = bool(abs(sim - real) <= points + 1e-12)
    else:
        passed = bool(np.isfinite(ratio) and abs(ratio - 1) <= tolerance + 1e-12)
    return Row(statistic, float(real), float(sim), float(ratio), by_points, passed)


def compare_stats(real: SensorStats, sim: SensorStats, *, tolerance: float = RATIO_TOLERANCE,
                  points: float = POINTS_TOLERANCE) -> tuple[Row, ...]:
    """The statistics of the acceptance table, real against simulated.

    Median cross-camera residual [mm] and share beyond 5 cm (when both have residuals); head, spine
    and wrist jitter [mm]; upper-arm and forearm length std [mm] (each within ``tolerance`` as a
    ratio); the share of samples at confidence 2 (within ``points``).
    """
    if tolerance <= 0 or points <= 0:
        raise BadInputError(f"tolerances must be positive, got {tolerance} and {points}")
    kw = {"tolerance": tolerance, "points": points}
    rows = []
    if "all" in real.residual_mm and "all" in sim.residual_mm:
        rows.append(_row("median cross-camera residual [mm]", real.residual_mm["all"].value,
                         sim.residual_mm["all"].value, **kw))
        rows.append(_row("share of joints beyond 5 cm", real.beyond_5cm.value, sim.beyond_5cm.value, **kw))
    for g in ("head", "spine", "wrist"):
        rows.append(_row(f"{g} jitter [mm]", real.jitter_mm[g].value, sim.jitter_mm[g].value, **kw))
    for b in ("upper_arm", "forearm"):
        rows.append(_row(f"{b.replace('_', '-')} length std [mm]", real.bone_std_mm[b].value,
                         sim.bone_std_mm[b].value, **kw))
    rows.append(_row("share of joints at confidence 2", real.confidence2["all"].value,
                     sim.confidence2["all"].value, by_points=True, **kw))
    return tuple(rows)


def sim_to_real(real: Recording, scenario: Scenario, *, profile: str | None = None,
                T_world_cam: Mapping[str, np.ndarray] | None = None, n_boot: int = 100,
                rng: np.random.Generator) -> SimToReal:
    """Simulate ``scenario`` with a sensor profile and compare it with a real recording.

    Parameters
    ----------
    real : Recording
        The real session.
    scenario : Scenario
        Its replica or stand-in (same topology and camera count as ``real``).
    profile : str, optional
        Sensor profile (built-in name or TOML path) replacing the scenario's.
    T_world_cam : mapping, optional
        Calibration of the real cameras; None calibrates them from the body.
    n_boot : int
        Bootstrap resamples per statistic.
    rng : np.random.Generator
        Source of the calibrations' and bootstraps' randomness (the simulation uses the scenario's seed).

    Returns
    -------
    SimToReal
    """
    if profile is not None:
        scenario = scenario.replace(sensors=dataclasses.replace(scenario.sensors, profile=str(profile)))
    sim_rec, _ = simulate(scenario, progress=False)
    if sim_rec.topology != real.topology:
        raise BadInputError(f"the scenario simulates {sim_rec.topology.name} skeletons, the recording holds "
                            f"{real.topology.name}; set subject.topology to match")
    n_real = sum(c.skeleton is not None for c in real.cameras)
    if len(sim_rec.cameras) != n_real:
        raise BadInputError(f"the scenario has {len(sim_rec.cameras)} cameras, the recording {n_real}")
    real_stats = measure(real, T_world_cam, n_boot=n_boot, rng=rng)
    sim_stats = measure(sim_rec, None, n_boot=n_boot, rng=rng)
    return SimToReal(compare_stats(real_stats, sim_stats), real_stats, sim_stats, scenario)
