"""Sim-to-real: simulate a scenario standing in for a real session and compare truth-free statistics.

The scenario is a value: the replica of the real session (its calibrated camera poses and its motion
retargeted onto the humanoid) when one is available, otherwise a scenario with the session's
geometry and scripted movements. Both recordings go through the same statistics
(:func:`scenarios.sensors.fit.measure`: calibrated from the body when they have two cameras), and each
statistic is reported with the ratio simulated / real and a verdict against a tolerance.

With several draws (:func:`sim_to_real_band`) the scenario is simulated with consecutive seeds, each
(with a profile that has a population) a different person and session, and the real session is
judged against the band of the draws (:func:`band_rows`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from fusion.errors import BadInputError, CalibrationError
from fusion.merge.sensor_stats import SensorStats
from fusion.recording import Recording
from scenarios.config import NoiseLevel, PopulationDraw, Scenario
from scenarios.runner import default_profile, simulate
from scenarios.sensors.fit import measure
from sim.sensor_profile import SensorProfile, load_profile

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


BAND = (5.0, 95.0)
"""Percentiles [%] of the simulated draws that bound a statistic's band."""


@dataclass(frozen=True)
class BandRow:
    """One statistic of a real session against several simulated draws of its stand-in.

    Attributes
    ----------
    statistic : str
        What is compared, with its unit.
    real : float
        Its value on the real recording.
    median, low, high : float
        Median and :data:`BAND` percentiles over the draws.
    by_points : bool
        A share compared in points (within :data:`POINTS_TOLERANCE` of the median) instead of a ratio.
    verdict : str
        ``inside band``, ``near median`` (outside the band but within the tolerance of the median),
        ``outside`` or ``missing``.
    below : float
        Draws below the real value (a tie counts half): its rank, 0 to ``n_draws``. Were the real session
        one more draw of the simulation, every rank would be equally likely.
    n_draws : int
        Draws with a value.
    draws_passing : float
        Share of the draws that pass when each in turn is judged as the real value against the other
        draws: the pass rate a simulation whose spread is exactly the real one would reach (judged on one
        draw fewer, which costs it 1-3 points).
    """

    statistic: str
    real: float
    median: float
    low: float
    high: float
    by_points: bool
    verdict: str
    below: float = np.nan
    n_draws: int = 0
    draws_passing: float = np.nan

    @property
    def passed(self) -> bool | None:
        """Inside the band or near the median; None when missing."""
        return None if self.verdict == "missing" else self.verdict != "outside"


def _band_verdict(statistic: str, value: float, sims: np.ndarray, by_points: bool, tolerance: float,
                  points: float) -> tuple[str, float, float, float]:
    """Verdict of ``value`` against the draws ``sims`` (finite, at least one), with their median and band."""
    median = float(np.median(sims))
    low, high = (float(v) for v in np.percentile(sims, BAND))
    if low <= value <= high:
        verdict = "inside band"
    elif _row(statistic, value, median, by_points=by_points, tolerance=tolerance, points=points).passed:
        verdict = "near median"
    else:
        verdict = "outside"
    return verdict, median, low, high


def band_rows(real: SensorStats, draws: list[SensorStats], *, tolerance: float = RATIO_TOLERANCE,
              points: float = POINTS_TOLERANCE) -> tuple[BandRow, ...]:
    """The statistics of :func:`compare_stats` on a real session against ``draws`` (simulated sessions of
    its stand-in, each a different person and session of the population): per statistic the median and
    the :data:`BAND` of the draws, a verdict (inside the band, or within ``tolerance`` of the median,
    shares within ``points``), the real value's rank among the draws and the draws' own pass rate
    (:class:`BandRow`)."""
    if not draws:
        raise BadInputError("band_rows needs at least one simulated draw")
    per_draw = [compare_stats(real, d, tolerance=tolerance, points=points) for d in draws]
    rows = []
    for k, first in enumerate(per_draw[0]):
        sims = np.array([rows_of[k].sim for rows_of in per_draw], dtype=np.float64)
        sims = sims[np.isfinite(sims)]
        if not (sims.size and np.isfinite(first.real)):
            rows.append(BandRow(first.statistic, first.real, np.nan, np.nan, np.nan, first.by_points, "missing"))
            continue
        judge = dict(by_points=first.by_points, tolerance=tolerance, points=points)
        verdict, median, low, high = _band_verdict(first.statistic, first.real, sims, **judge)
        below = float(np.sum(sims < first.real) + 0.5 * np.sum(sims == first.real))
        own = [_band_verdict(first.statistic, v, np.delete(sims, i), **judge)[0] != "outside"
               for i, v in enumerate(sims)] if sims.size > 1 else []
        rows.append(BandRow(first.statistic, first.real, median, low, high, first.by_points, verdict, below,
                            int(sims.size), float(np.mean(own)) if own else np.nan))
    return tuple(rows)


def with_profile(scenario: Scenario, profile: str | None) -> Scenario:
    """``scenario`` with its sensor profile replaced by ``profile`` (built-in name or TOML path; None
    keeps the scenario's)."""
    if profile is None:
        return scenario
    return scenario.replace(sensors=dataclasses.replace(scenario.sensors, profile=str(profile)))


def simulate_stand_in(real: Recording, scenario: Scenario) -> Recording:
    """Simulate ``scenario`` (with its own seed) as the stand-in of ``real``, checking that it simulates
    the same skeleton topology (or the full set of a reduced one, then reduced to it:
    :meth:`~fusion.recording.Recording.as_joint_set`) and camera count; the joints ``real`` never
    reports are left out of it (:meth:`~fusion.recording.Recording.without_joints`)."""
    sim_rec, _ = simulate(scenario, progress=False)
    if sim_rec.topology != real.topology.full_set:
        raise BadInputError(f"the scenario simulates {sim_rec.topology.name} skeletons, the recording holds "
                            f"{real.topology.name}; set subject.topology to match")
    sim_rec = sim_rec.as_joint_set(real.topology).without_joints(real.never_reported())
    n_real = sum(c.skeleton is not None for c in real.cameras)
    if len(sim_rec.cameras) != n_real:
        raise BadInputError(f"the scenario has {len(sim_rec.cameras)} cameras, the recording {n_real}")
    return sim_rec


def measure_draws(real: Recording, scenario: Scenario, seeds: Sequence[int], *,
                  T_world_cam: Mapping[str, np.ndarray] | None = None, n_boot: int = 100,
                  rng: np.random.Generator,
                  progress: Callable[[int], object] | None = None) -> tuple[SensorStats, list[SensorStats | None]]:
    """The statistics of a real session (measured once) and of its stand-in simulated with each seed.

    The first draw is simulated (and checked, :func:`simulate_stand_in`) before the real session is
    measured, so that a mismatch fails early; ``rng`` serves the real session's statistics first, then
    each draw's in turn. ``progress`` is called with 1 after each draw. With several seeds a draw whose
    cameras cannot be calibrated from the body (a simulated person the rig cannot calibrate) is None;
    with one seed that is an error.
    """
    if not seeds:
        raise BadInputError("at least one simulation seed is needed")
    real_stats, draws = None, []
    for seed in seeds:
        sim_rec = simulate_stand_in(real, scenario if seed == scenario.seed else scenario.replace(seed=int(seed)))
        if real_stats is None:
            real_stats = measure(real, T_world_cam, n_boot=n_boot, rng=rng)
        try:
            draws.append(measure(sim_rec, None, n_boot=n_boot, rng=rng))
        except CalibrationError:
            if len(seeds) == 1:
                raise
            draws.append(None)
        if progress is not None:
            progress(1)
    return real_stats, draws


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
    scenario = with_profile(scenario, profile)
    real_stats, (sim_stats,) = measure_draws(real, scenario, [scenario.seed], T_world_cam=T_world_cam,
                                             n_boot=n_boot, rng=rng)
    return SimToReal(compare_stats(real_stats, sim_stats), real_stats, sim_stats, scenario)


@dataclass(frozen=True)
class SimToRealBand:
    """A real session against several simulated draws of its stand-in (:func:`sim_to_real_band`).

    Attributes
    ----------
    rows : tuple of BandRow
        Per compared statistic the real value, the draws' median and band, and the verdict.
    real : SensorStats
        The real session's statistics.
    draws : tuple of SensorStats
        Each draw's statistics, in the order of ``seeds``.
    seeds : tuple of int
        The scenario seed of each draw.
    scenario : Scenario
        The simulated scenario (with its sensor profile; its seed is the first draw's).
    profile : str
        Name of the sensor profile simulated.
    population : str
        What varies between the draws, in words (:func:`population_note`).
    has_population : bool
        The profile has a population and the draws are people drawn from it.
    """

    rows: tuple[BandRow, ...]
    real: SensorStats
    draws: tuple[SensorStats, ...]
    seeds: tuple[int, ...]
    scenario: Scenario
    profile: str
    population: str
    has_population: bool

    @property
    def counts(self) -> tuple[int, int]:
        """Statistics passing (inside the band or near the median) and statistics compared."""
        compared = [r for r in self.rows if r.passed is not None]
        return sum(bool(r.passed) for r in compared), len(compared)

    @property
    def passed(self) -> bool:
        """Every statistic that could be compared passes."""
        return all(r.passed for r in self.rows if r.passed is not None)

    def values(self) -> list[list[float]]:
        """Per statistic of ``rows`` its value in each draw (NaN where missing)."""
        per_draw = [compare_stats(self.real, d) for d in self.draws]
        return [[rows[k].sim for rows in per_draw] for k in range(len(self.rows))]


def population_note(scenario: Scenario, sensor: SensorProfile) -> tuple[str, bool]:
    """What differs between draws of ``scenario`` simulated with several seeds, in words, and whether
    the draws are people of ``sensor``'s population."""
    seed_only = "the band holds only the simulation's seed noise"
    if sensor.population is None:
        return f"the profile has no population: every draw is its typical person, so {seed_only}", False
    if scenario.sensors.tracker_noise is not NoiseLevel.DEFAULT:
        return f"the scenario turns the tracker noise off, so {seed_only}", False
    if scenario.sensors.population is PopulationDraw.TYPICAL:
        return ('the scenario simulates the profile\'s typical person (sensors.population = "typical"), so '
                f"{seed_only}"), False
    whose = "the profile's population" + sensor.population.lab_words(scenario.sensors.lab)
    if scenario.sensors.person_seed is not None:
        return ("the scenario fixes the person (sensors.person_seed): the draws are sessions of one person of "
                f"{whose}"), True
    return f"each draw is a person and a session drawn from {whose}", True


def check_draws(draws: int) -> None:
    """Refuse a number of simulated draws below one."""
    if isinstance(draws, bool) or not isinstance(draws, (int, np.integer)) or draws < 1:
        raise BadInputError(f"--draws must be a whole number >= 1 (simulated people of the profile's population), got {draws!r}")


def sim_to_real_band(real: Recording, scenario: Scenario, draws: int, *, profile: str | None = None,
                     T_world_cam: Mapping[str, np.ndarray] | None = None, n_boot: int = 100,
                     rng: np.random.Generator, progress: Callable[[int], object] | None = None) -> SimToRealBand:
    """Simulate ``scenario`` ``draws`` times (seeds ``seed, seed + 1, ...``: with the default
    ``sensors.population = "draw"`` each a person and session of the profile's population) and judge
    the real recording against the band of the draws (:func:`band_rows`).

    Parameters as :func:`sim_to_real`; ``progress`` is called with 1 after each draw.
    """
    check_draws(draws)
    scenario = with_profile(scenario, profile)
    seeds = tuple(scenario.seed + d for d in range(int(draws)))
    real_stats, sims = measure_draws(real, scenario, seeds, T_world_cam=T_world_cam, n_boot=n_boot, rng=rng,
                                     progress=progress)
    sensor = load_profile(scenario.sensors.profile if scenario.sensors.profile is not None
                          else default_profile(real.topology.full_set.name))  # the stand-in's, checked above
    note, has_population = population_note(scenario, sensor)
    failed = [s for s, d in zip(seeds, sims) if d is None]
    if len(failed) == len(seeds):
        raise CalibrationError("no simulated draw could be calibrated from the body; see sim-to-real with one draw")
    if failed:
        note += (f"; the draws of seed(s) {', '.join(map(str, failed))} could not be calibrated from the body "
                 "(a simulated person the rig cannot calibrate) and are left out of the band")
        seeds = tuple(s for s, d in zip(seeds, sims) if d is not None)
        sims = [d for d in sims if d is not None]
    return SimToRealBand(band_rows(real_stats, sims), real_stats, tuple(sims), seeds, scenario, sensor.name, note,
                         has_population)
