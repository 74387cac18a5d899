"""Leave-one-person-out validation of a sensor population (``mocap-bench sensor-validate``).

For each person: the profile is fitted on everybody else's sessions (analytic fit, refinement on the
replicas, population: :mod:`scenarios.sensors.fit_population`), and each of the left-out person's
sessions is judged against ``draws`` re-trackings of its replica, each by a new person and session
drawn from that population (:func:`scenarios.sensors.sim_to_real.band_rows`: inside the 5-95 % band
of the draws, or within the tolerance of their median). The same draws with the typical tracker only
(no population: the band holds the simulation's seed noise) are judged alongside, to show what the
population adds.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from fusion.errors import BadInputError, CalibrationError
from fusion.merge.sensor_stats import SensorStats, sensor_stats
from fusion.recording import Recording
from scenarios.sensors.fit import fit_profile
from scenarios.sensors.fit_population import fit_population
from scenarios.sensors.fit_replica import SPEED_GRID_M_S, refine_on_replicas
from scenarios.sensors.replica_case import (
    ReplicaCase,
    body_poses,
    retrack,
    with_persons,
)
from scenarios.sensors.sim_to_real import BandRow, band_rows, compare_stats
from sim.sensor_population import session_tracker
from sim.sensor_profile import SensorProfile


@dataclass(frozen=True)
class HeldOut:
    """One left-out session judged by the population fitted without its person, and by the typical
    tracker alone.

    Attributes
    ----------
    session, person : str
        The session and whose it is.
    population, typical : tuple of BandRow
        The verdicts against draws of people from the population, and against draws of the typical
        tracker (seeds only).
    """

    session: str
    person: str
    population: tuple[BandRow, ...]
    typical: tuple[BandRow, ...]


@dataclass(frozen=True)
class Fold:
    """One person left out: the profile fitted on the others and the verdicts on that person's sessions."""

    person: str
    profile: SensorProfile
    sessions: tuple[HeldOut, ...]


def _draw_stats(case: ReplicaCase, profile: SensorProfile, draws: int, seed: int, population: bool) -> list[SensorStats]:
    """Statistics of ``draws`` re-trackings of ``case``: draw ``d`` with seed ``seed + d``, a new person each
    (person seed ``(seed, d)``: its systematic errors and, with ``population``, its factors, of the
    case's lab when the population knows it, and a session of it), calibrated from the body as the real session was; a draw that cannot be calibrated (a
    simulated person the rig cannot calibrate) is left out."""
    out = []
    for d in range(draws):
        person_seed = int(np.random.SeedSequence([seed, d]).generate_state(1)[0])
        tracker = profile.tracker
        if population and profile.population is not None:
            tracker = session_tracker(tracker, profile.population.for_lab(case.lab), person_seed, len(case.placements),
                                      np.random.default_rng(seed + d))
        recording = retrack(case, dataclasses.replace(profile, tracker=tracker), seed=seed + d,
                            person_seed=person_seed)
        try:
            poses = body_poses(recording, seed + d)
        except CalibrationError:
            continue
        out.append(sensor_stats(recording, poses, n_boot=0, rng=np.random.default_rng(seed + d)))
    return out


def check_validation(persons: Mapping[str, str], draws: int) -> None:
    """Refuse a validation that cannot run: fewer than two people, or fewer than two draws."""
    people = sorted(set(persons.values()))
    if len(people) < 2:
        raise BadInputError(f"leave-one-person-out needs sessions of two people or more, got {people}; "
                            "give --persons labels (one per recording)")
    if isinstance(draws, bool) or not isinstance(draws, int) or draws < 2:
        raise BadInputError(f"draws must be a whole number >= 2 for a band, got {draws!r}")


def _judge(real: SensorStats, draws: list[SensorStats]) -> tuple[BandRow, ...]:
    """:func:`band_rows`; with no draw left (none could be calibrated) every statistic is outside."""
    if draws:
        return band_rows(real, draws)
    return tuple(BandRow(r.statistic, r.real, np.nan, np.nan, np.nan, r.by_points, "outside")
                 for r in compare_stats(real, real))


def leave_one_person_out(recordings: Mapping[str, Recording], stats: Mapping[str, SensorStats],
                         cases: Sequence[ReplicaCase], persons: Mapping[str, str], base: SensorProfile, *,
                         draws: int = 6, iterations: int = 5, speeds: Sequence[float] = SPEED_GRID_M_S,
                         seed: int = 0, jobs: int = 1, structure: Sequence[str] = (),
                         progress: Callable[[str], None] | None = None) -> list[Fold]:
    """Fit without each person in turn and judge that person's sessions (module docstring).

    Parameters
    ----------
    recordings, stats : mapping session name -> Recording / its SensorStats
        Every person's sessions and their statistics (:func:`scenarios.sensors.fit.measure`).
    cases : sequence of ReplicaCase
        The sessions' replicas (:func:`scenarios.sensors.replica_case.prepare_cases`).
    persons : mapping session name -> person label
        Two people or more.
    base : SensorProfile
        Profile whose unfitted values are kept.
    draws : int
        Simulated sessions per left-out session.
    iterations : int
        Refinement iterations per reference speed.
    speeds : sequence of float
        Reference speeds [m/s] the refinement tries (:func:`scenarios.sensors.fit_replica.refine_on_replicas`).
    structure : sequence of str
        Optional parts of the model the refinement fits as well (:mod:`scenarios.sensors.fit_structure`).
    seed, jobs : int
        Seed, processes at once (-1: one per core).
    progress : callable, optional
        Called with a line as each step finishes.

    Returns
    -------
    list of Fold
        One per person, in sorted order.
    """
    check_validation(persons, draws)
    people = sorted(set(persons[c.name] for c in cases))
    say = progress or (lambda line: None)
    folds = []
    cases = with_persons(cases, persons)
    for person in people:
        train = [c for c in cases if persons[c.name] != person]
        names = [c.name for c in train]
        analytic = fit_profile({n: recordings[n] for n in names}, {n: stats[n] for n in names}, base, name=base.name)
        typical = refine_on_replicas(analytic.profile, train, iterations=iterations, speeds=speeds, seed=seed,
                                     jobs=jobs, structure=structure)
        profile = fit_population(typical.profile, train, {n: persons[n] for n in names}, seed=seed, jobs=jobs,
                                 retracked=typical.retracked_per_session).profile
        say(f"fitted without {person} on {len(train)} sessions")
        held = []
        for c in cases:
            if persons[c.name] != person:
                continue
            held.append(HeldOut(c.name, person, _judge(c.real, _draw_stats(c, profile, draws, seed, True)),
                                _judge(c.real, _draw_stats(c, profile, draws, seed, False))))
        say(f"judged {len(held)} sessions of {person}")
        folds.append(Fold(person, profile, tuple(held)))
    return folds


def pass_counts(folds: Sequence[Fold], which: str) -> dict[str, tuple[int, int]]:
    """Per person (and ``all``) the statistics passing and compared, for ``which`` = ``population`` or
    ``typical``."""
    counts = {}
    for fold in folds:
        rows = [r for s in fold.sessions for r in getattr(s, which) if r.passed is not None]
        counts[fold.person] = (sum(r.passed for r in rows), len(rows))
    counts["all"] = tuple(int(sum(v[i] for v in counts.values())) for i in (0, 1))
    return counts


@dataclass(frozen=True)
class Calibration:
    """How one statistic's real values sit among the draws, over every left-out session.

    Attributes
    ----------
    rows : int
        Sessions where the statistic was compared.
    passing : int
        Of them, passing.
    expected_passing : float
        Sum of the rows' :attr:`~scenarios.sensors.sim_to_real.BandRow.draws_passing`: how many rows a real
        session would pass were it one more draw of the population.
    below_all, above_all : int
        Rows whose real value lies below every draw, above every draw.
    expected_tail : float
        What a calibrated population gives for each of the two: the rows over (draws + 1).
    """

    rows: int
    passing: int
    expected_passing: float
    below_all: int
    above_all: int
    expected_tail: float


def calibration_counts(folds: Sequence[Fold], which: str) -> dict[str, Calibration]:
    """Per statistic, the :class:`Calibration` of ``which`` (``population`` or ``typical``) over all folds."""
    out = {}
    for k, name in enumerate(r.statistic for r in getattr(folds[0].sessions[0], which)):
        rows = [getattr(s, which)[k] for f in folds for s in f.sessions]
        rows = [r for r in rows if r.passed is not None and r.n_draws]
        out[name] = Calibration(len(rows), sum(r.passed for r in rows),
                                float(np.nansum([r.draws_passing for r in rows])),
                                sum(r.below == 0 for r in rows), sum(r.below == r.n_draws for r in rows),
                                float(sum(1 / (r.n_draws + 1) for r in rows)))
    return out
