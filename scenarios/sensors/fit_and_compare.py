"""The sensor-fit and sim-to-real pipelines, assembled once: ``mocap-bench sensor-fit`` /
``sim-to-real`` and the benchmarks on the real samples call these functions.

A sensor fit: per recording its statistics (after a body calibration where one is needed), the
analytic fit (:func:`scenarios.sensors.fit.fit_profile`), then optionally a refinement of the bone
behaviour by simulating a scenario (:func:`scenarios.sensors.fit_sim.refine_bones`) or of every
tracker parameter on the recordings' replicas (:func:`scenarios.sensors.fit_replica.refine_on_replicas`),
and on those replicas the population of people and sessions
(:func:`scenarios.sensors.fit_population.fit_population`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from joblib import Parallel, delayed
from tqdm import tqdm

from fusion.calibration import Calibration
from fusion.errors import BadInputError
from fusion.merge.sensor_stats import SensorStats
from fusion.recording import Recording
from scenarios.config import Scenario
from scenarios.sensors.fit import (
    FitResult,
    check_span,
    fit_profile,
    measure,
    session_calibration,
)
from scenarios.sensors.fit_population import PopulationFit, fit_population, person_of
from scenarios.sensors.fit_replica import SPEED_GRID_M_S, ReplicaFit, refine_on_replicas
from scenarios.sensors.fit_sim import refine_bones
from scenarios.sensors.replica import Replica, build_replica, write_replica
from scenarios.sensors.replica_case import ReplicaCase, prepare_cases, with_persons
from scenarios.sensors.sim_to_real import (
    SimToReal,
    SimToRealBand,
    check_draws,
    sim_to_real,
    sim_to_real_band,
)
from sim.sensor_profile import SensorProfile
from sim.tracker_noise import JointGroup


@dataclass(frozen=True)
class SensorFit:
    """What a sensor fit produced.

    Attributes
    ----------
    profile : SensorProfile
        The final profile (refined where a refinement ran).
    analytic : FitResult
        The analytic fit (after the scenario refinement of the bones, if any).
    replica : ReplicaFit or None
        The refinement on replicas (``replicas=True``).
    cases : list of ReplicaCase
        The replicas the refinement ran on (empty without it).
    bone_spread_m : float or None
        The bone-length spread matched by simulating the scenario (``scenario`` given) [m].
    population : PopulationFit or None
        The population fit (``population=True``).
    """

    profile: SensorProfile
    analytic: FitResult
    replica: ReplicaFit | None = None
    cases: list[ReplicaCase] = dataclasses.field(default_factory=list)
    bone_spread_m: float | None = None
    population: PopulationFit | None = None


def check_refinement(*, replicas: bool, scenario: object | None, structure: Sequence[str] = ()) -> None:
    """Refuse two refinements of one fit (on replicas and by simulating a scenario), and optional model
    parts without the refinement on replicas that fits them."""
    if replicas and scenario is not None:
        raise BadInputError("--replicas (or --population) and --scenario both refine the fit: choose one")
    if structure and not replicas:
        raise BadInputError(f"--structure {' '.join(structure)} is fitted by the refinement on replicas: add "
                            "--replicas or --population")


def _measured(recording: Recording, calibration: Calibration | None, calibrate: bool, n_boot: int,
              stream: np.random.SeedSequence) -> tuple[Calibration | None, SensorStats]:
    """A recording's calibration (made from the body when ``calibrate`` and none is given) and statistics,
    its random draws from ``stream``."""
    rng = np.random.default_rng(stream)
    if calibrate and calibration is None:
        calibration = session_calibration(recording, rng=rng)
    return calibration, measure(recording, None if calibration is None else calibration.T_world_cam,
                                n_boot=n_boot, rng=rng)


def measure_recordings(recordings: Mapping[str, Recording], calibrations: Mapping[str, Calibration | None] | None,
                       *, calibrate: bool, n_boot: int, seed: int, jobs: int = 1,
                       ) -> tuple[dict[str, Calibration | None], dict[str, SensorStats]]:
    """Calibrations and statistics of every recording (by name), ``jobs`` at once (joblib; -1: one per core).

    A recording without a calibration in ``calibrations`` is calibrated from its body
    (:func:`scenarios.sensors.fit.session_calibration`) when ``calibrate``; otherwise its calibration stays
    None and :func:`scenarios.sensors.fit.measure` measures its residuals through a body calibration of its
    own. Each recording draws from its own stream of ``seed``, so the result does not depend on ``jobs``.
    """
    names = list(recordings)
    given = calibrations or {}
    measured = Parallel(n_jobs=jobs, return_as="generator")(
        delayed(_measured)(recordings[n], given.get(n), calibrate, n_boot, stream)
        for n, stream in zip(names, np.random.SeedSequence(seed).spawn(len(names))))
    calibs, stats = {}, {}
    for n, (calib, stat) in tqdm(zip(names, measured), total=len(names), desc="measure", unit="recording",
                                 leave=False):
        calibs[n], stats[n] = calib, stat
    return calibs, stats


def fit_sensor(recordings: Mapping[str, Recording], base: SensorProfile, *,
               calibrations: Mapping[str, Calibration | None] | None = None, name: str | None = None,
               scenario: Scenario | None = None, replicas: bool = False, iterations: int = 5, jobs: int = 1,
               n_boot: int = 100, seed: int = 0, population: bool = False,
               persons: Mapping[str, str] | None = None, speeds: Sequence[float] = SPEED_GRID_M_S,
               structure: Sequence[str] = ()) -> SensorFit:
    """Fit a sensor profile to real recordings (no ground truth needed).

    Parameters
    ----------
    recordings : mapping name -> Recording
        The fitting recordings, one person's or several people's sessions of one sensor.
    base : SensorProfile
        The profile whose unfitted values are kept.
    calibrations : mapping name -> Calibration or None, optional
        The recordings' calibrations; a missing one is made from the body when the replicas need it,
        and the statistics of a recording without one are measured without cross-camera residuals.
    name : str, optional
        Name of the fitted profile (default: the base's).
    scenario : Scenario, optional
        A scenario with the recordings' geometry: match the bone-length spread by simulating it.
    replicas : bool
        Refine every tracker parameter the statistics see on the recordings' replicas.
    iterations, jobs : int
        Refinement iterations per reference speed; processes at once for the statistics, replicas,
        refinement and population (-1: one per core; the result does not depend on it).
    n_boot : int
        Bootstrap resamples per statistic.
    seed : int
        Seed of the calibration and bootstrap draws (one stream per recording) and of the refinement.
    population : bool
        Also fit how people and sessions vary (implies ``replicas``; two sessions or more).
    persons : mapping name -> person label, optional
        Whose recording each is (default :func:`scenarios.sensors.fit_population.person_of` of its name).
    speeds : sequence of float
        Reference speeds [m/s] of the speed dependence tried by the refinement (0: none); the one with
        the smallest loss is kept.
    structure : sequence of str
        Optional parts of the model the refinement fits as well
        (:data:`scenarios.sensors.fit_structure.STRUCTURE_PARTS`; two-camera recordings).
    """
    replicas = replicas or population
    check_refinement(replicas=replicas, scenario=scenario, structure=structure)
    if not recordings:
        raise BadInputError("sensor-fit needs at least one recording")
    calibs, stats = measure_recordings(recordings, calibrations, calibrate=replicas, n_boot=n_boot, seed=seed,
                                       jobs=jobs)
    analytic = fit_profile(recordings, stats, base, name=name or base.name)
    if scenario is not None:
        profile, spread = refine_bones(analytic, scenario)
        analytic = dataclasses.replace(analytic, profile=profile, tau_s=profile.tracker.wobble_tau_s,
                                       rigidity=profile.tracker.groups[JointGroup.LIMB].bone_rigidity,
                                       wobble_m={g: n.wobble_m for g, n in profile.tracker.groups.items()})
        return SensorFit(profile, analytic, bone_spread_m=spread)
    if not replicas:
        return SensorFit(analytic.profile, analytic)
    labels = {n: (persons or {}).get(n, person_of(n)) for n in recordings}
    with tqdm(total=len(recordings), desc="replicas", unit="recording", leave=False) as bar:
        cases = with_persons(prepare_cases(recordings, calibs, stats, jobs=jobs, progress=bar.update), labels)
    with tqdm(total=len(speeds) * (iterations + 1), desc="refine", unit="trial", leave=False) as bar:
        replica = refine_on_replicas(analytic.profile, cases, iterations=iterations, speeds=speeds, seed=seed,
                                     jobs=jobs, progress=bar.update, structure=structure)
    if not population:
        return SensorFit(replica.profile, analytic, replica, cases)
    with tqdm(total=len(cases), desc="population", unit="recording", leave=False) as bar:
        pop = fit_population(replica.profile, cases, labels, seed=seed, jobs=jobs, progress=bar.update,
                             retracked=replica.retracked_per_session)
    return SensorFit(pop.profile, analytic, replica, cases, population=pop)


def replica_with_progress(recording: Recording, calibration: Calibration, **options) -> Replica:
    """:func:`scenarios.sensors.replica.build_replica` with a progress bar over the fitted frames."""
    n = max((c.skeleton.n_frames for c in recording.cameras if c.skeleton is not None), default=0)
    with tqdm(total=n, desc="replica", unit="frame", leave=False) as bar:
        return build_replica(recording, calibration, progress=bar.update, **options)


def session_replica(real: Recording, calibration: Calibration, out: Path, *, name: str) -> tuple[Replica, Path]:
    """The replica of a real session (``mocap-bench replica``), its scenario and motion file written
    into the directory ``out``; returns the replica and its scenario file."""
    out.mkdir(parents=True, exist_ok=True)
    replica = replica_with_progress(real, calibration, name=name, motion_path=out / "replica.motion.npz")
    scenario_path, _ = write_replica(replica, out / "replica.toml")
    return replica, scenario_path


def compare_session(real: Recording, out: Path, *, calibration: Calibration | None = None,
                    scenario: Scenario | None = None, profile: str | None = None, name: str = "session",
                    n_boot: int = 100, seed: int = 0,
                    draws: int = 1) -> tuple[SimToReal | SimToRealBand, Calibration | None, Path | None]:
    """Sim-to-real of one real session: simulate a stand-in and compare truth-free statistics.

    Without ``scenario`` the stand-in is the session's replica, built from ``calibration`` (made from
    the body when None) and written into ``out``. With ``draws`` > 1 the stand-in is simulated with
    the seeds ``seed, seed + 1, ...`` of its scenario (each a person and session of the profile's
    population) and the session judged against their band (:class:`SimToRealBand`); with one draw the
    comparison is a :class:`SimToReal`. Returns the comparison, the calibration used (None with a
    scenario and no calibration) and the replica's scenario file (None with a scenario).
    """
    check_draws(draws)  # before any replica is built
    check_span(real)  # before anything is written
    rng = np.random.default_rng(seed)
    replica_path = None
    if scenario is None:
        if calibration is None:
            calibration = session_calibration(real, rng=rng)
        replica, replica_path = session_replica(real, calibration, out, name=f"replica_{name}")
        scenario = replica.scenario
    T = None if calibration is None else calibration.T_world_cam
    if draws == 1:
        result = sim_to_real(real, scenario, profile=profile, T_world_cam=T, n_boot=n_boot, rng=rng)
    else:
        with tqdm(total=draws, desc="sim-to-real draws", unit="draw", leave=False) as bar:
            result = sim_to_real_band(real, scenario, draws, profile=profile, T_world_cam=T, n_boot=n_boot,
                                      rng=rng, progress=bar.update)
    return result, calibration, replica_path
