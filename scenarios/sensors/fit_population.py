"""Fit a sensor's population (:mod:`sim.sensor_population`) from several people's sessions.

The typical tracker (the replica fit, :mod:`scenarios.sensors.fit_replica`) re-tracks each session's
replica; per session and family the log-ratio real / simulated of the family's statistics
(:func:`family_statistics`; for the confidence share the difference on its arcsine scale,
:func:`sim.sensor_population.confidence_scale`) is what that session's person and day add to the typical person, up to
two things the fit removes:

- **the statistic's response** to its family's factor (the *elasticity*, not 1: part of a jitter or a
  bone-length spread comes from the motion): the replicas are re-tracked once more with each family's
  factor raised by :data:`STEP`, and the median change over the sessions divided by the step is the
  elasticity; each log-ratio is divided by it;
- **the simulation's own seed noise**: the replicas are re-tracked with a second seed and calibrated
  again; half the variance of the difference of the two seeds' factors is the seed variance of one.

The factors of the two seeds are averaged and fitted by a linear mixed-effects model with a random
intercept per person (``statsmodels`` ``MixedLM``, REML): ``x = mean + u_person + e_session``. Its
residual variance, less the averaged seed variance (floored at 0), is the between-session part, and its
intercept is the population's mean person relative to the typical tracker (the replica fit, pooled
as medians over the sessions, need not be the people's mean). A new person is predicted as a random-effects model
predicts a new group from ``k`` observed ones: scale ``s * sqrt(1 + 1/k)``, ``s`` the standard
deviation of the people's mean factors (which, unlike the REML variance, does not collapse to 0 when a
few people happen to agree), drawn Student-t with ``k - 1`` degrees of freedom: ``s`` rests on ``k``
people, and the t carries that uncertainty into the draw (the draws are clipped at
:data:`sim.sensor_population.CLIP` scale units). Judged by leaving each person out, normal draws of that
scale left 42 % of the Azure rows outside all six draws where 29 % is expected; the t draws leave 27 %
(``docs/studies/population_validation.md``). With one person the between-person part cannot be seen
and is 0 (the provenance says so).

**Labs.** When the sessions come from two labs or more (each person from one), each lab is given a
population of its own (:attr:`sim.sensor_population.Population.labs`): the same mixed-effects model with a
fixed intercept per lab (the lab's mean person), the spread of the people's mean factors about their
lab's mean pooled over the labs (``k - L`` degrees of freedom for ``k`` people of ``L`` labs; a new
person of a lab of ``k_l`` people: scale ``s_w * sqrt(1 + 1/k_l)``, Student-t with ``k - L``), and the
between-session spread of the population (a lab is the same for all of one person's sessions). A
family whose statistic a lab's recordings lack keeps the population's spread for that lab. The
population itself, for a person of a lab not fitted, still holds the labs' differences in its person
spread.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from joblib import Parallel, delayed

from fusion.errors import BadInputError
from fusion.merge.sensor_stats import SensorStats
from scenarios.sensors.replica_case import Poses, ReplicaCase, retracked_stats
from scenarios.sensors.replica_ratios import excess_jitter
from sim.sensor_population import (
    MAX_LOG_SD,
    SPREAD_FIELDS,
    Family,
    Population,
    Spread,
    apply_factors,
    confidence_scale,
)
from sim.sensor_profile import SensorProfile

STEP = {Family.NOISE: 0.4, Family.BIAS: 0.4, Family.BONE: 0.4, Family.CONFIDENCE: 0.1}
"""Raise of each family's factor for its elasticity (log units; for confidence radians of
:func:`sim.sensor_population.confidence_scale`, 0.1: a share of 2 % becomes 5.7 %)."""

_STATISTIC = {
    Family.NOISE: "mean log of the head/spine/wrist/... jitter beyond the motion's own and of the median "
                  "fluctuating cross-camera residual",
    Family.BIAS: "log of the median steady cross-camera residual",
    Family.BONE: "mean log of the upper-arm and forearm length spreads",
    Family.CONFIDENCE: "arcsine square root of the share of joints below confidence 2",
}


def family_statistics(case: ReplicaCase, stats: SensorStats) -> dict[Family, float]:
    """Per family the statistic it moves (:data:`_STATISTIC`), measured on ``stats`` (the real session's
    or a re-tracking of its replica); NaN where the recording lacks it (one camera: no residuals)."""
    jitter = [np.log(excess_jitter(stats.jitter_mm[k].value, case.motion.jitter_mm[k].value))
              for k in stats.jitter_mm if k in case.motion.jitter_mm]
    noise = [np.nanmean(jitter)] if jitter else []
    if stats.residual_fluct_joint_mm.size:
        noise.append(np.log(np.nanmedian(stats.residual_fluct_joint_mm)))
    bias = np.log(np.nanmedian(stats.residual_static_joint_mm)) if stats.residual_static_joint_mm.size else np.nan
    bones = [np.log(stats.bone_std_mm[b].value) for b in ("upper_arm", "forearm")]
    low = float(confidence_scale(1 - stats.confidence2["all"].value))
    return {Family.NOISE: float(np.nanmean(noise)) if noise else np.nan, Family.BIAS: float(bias),
            Family.BONE: float(np.nanmean(bones)), Family.CONFIDENCE: low}


@dataclass(frozen=True)
class FamilyFit:
    """One family's fit: the :class:`Spread` and what it came from.

    Attributes
    ----------
    spread : Spread
        Mean, between-person and between-session standard deviations (log units).
    elasticity : float
        Change of the family's statistic per unit of its factor (median over the sessions).
    seed_sd : float
        Standard deviation of one seed's factor from the simulation's own noise.
    factors : mapping session name -> float
        Each session's factor (mean of the two seeds).
    note : str
        Why a part could not be fitted ('' when all could).
    """

    spread: Spread
    elasticity: float
    seed_sd: float
    factors: Mapping[str, float]
    note: str = ""


@dataclass(frozen=True)
class PopulationFit:
    """The profile with its population, the per-family fits, whose each session is and (when the
    population knows labs) from which lab."""

    profile: SensorProfile
    families: Mapping[Family, FamilyFit]
    persons: Mapping[str, str]
    labs: Mapping[str, str] = dataclasses.field(default_factory=dict)


def _case_sims(case: ReplicaCase, profile: SensorProfile, seed: int,
               first: tuple[SensorStats, Poses] | None = None) -> dict[str, dict[Family, float]]:
    """One session's family statistics: real, re-tracked with two seeds (each calibrated; the first one's
    statistics and poses ``first`` when already known), and with each family's factor raised by
    :data:`STEP` (first seed, its poses)."""
    first_stats, T = first or retracked_stats(case, profile, seed)
    second, _ = retracked_stats(case, profile, seed + 1)
    out = {"real": family_statistics(case, case.real), "seed0": family_statistics(case, first_stats),
           "seed1": family_statistics(case, second)}
    for fam, step in STEP.items():
        raised = dataclasses.replace(profile, tracker=apply_factors(profile.tracker, {fam: step}))
        out[fam.value] = family_statistics(case, retracked_stats(case, raised, seed, T)[0])
    return out


def _variance_components(x: np.ndarray, persons: Sequence[str]) -> tuple[float, float, float, float]:
    """Mean and within-person variance of ``x`` by REML, and the scale and degrees of freedom of a new
    person's draw (module docstring); one person: mean, variance, no person part."""
    people = sorted(set(persons))
    if len(people) < 2:
        return float(np.mean(x)), float(np.var(x, ddof=1)) if len(x) > 1 else 0.0, 0.0, np.inf
    import statsmodels.api as sm

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # boundary fits (no between-person variance) warn
        result = sm.MixedLM(x, np.ones((len(x), 1)), groups=np.asarray(persons)).fit(reml=True)
    means = np.array([np.mean(x[np.asarray(persons) == p]) for p in people])
    k = len(people)
    return float(result.fe_params[0]), float(result.scale), float(np.std(means, ddof=1) * np.sqrt(1 + 1 / k)), float(k - 1)


def _lab_spreads(x: np.ndarray, persons: Sequence[str], labs: Sequence[str], session_sd: float
                 ) -> dict[str, Spread] | None:
    """Per lab the :class:`Spread` of its people (module docstring, *Labs*) from the sessions' factors
    ``x``; None when the labs leave no person to measure the spread within a lab (``k - L < 1``)."""
    people = sorted(set(persons))
    lab_of = dict(zip(persons, labs))
    names = sorted(set(labs))
    k, n_labs = len(people), len(names)
    if k - n_labs < 1:
        return None
    import statsmodels.api as sm

    exog = np.array([[lab == n for n in names] for lab in labs], float)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # boundary fits warn, as in _variance_components
        result = sm.MixedLM(x, exog, groups=np.asarray(persons)).fit(reml=True)
    means = {p: float(np.mean(x[np.asarray(persons) == p])) for p in people}
    lab_means = {n: np.mean([m for p, m in means.items() if lab_of[p] == n]) for n in names}
    s_w = float(np.sqrt(sum((m - lab_means[lab_of[p]]) ** 2 for p, m in means.items()) / (k - n_labs)))
    size = {n: sum(lab_of[p] == n for p in people) for n in names}
    return {n: Spread(float(result.fe_params[i]), min(s_w * np.sqrt(1 + 1 / size[n]), MAX_LOG_SD), session_sd,
                      float(k - n_labs)) for i, n in enumerate(names)}


def check_labs(labs: Mapping[str, str | None], persons: Mapping[str, str]) -> dict[str, str]:
    """The sessions' labs when a lab level can be fitted (every session names its lab, each person is
    of one lab, two labs or more), else ``{}`` (one lab or none named)."""
    named = {n: lab for n, lab in labs.items() if lab is not None}
    if len(set(named.values())) < 2:
        return {}
    unnamed = sorted(n for n in persons if labs.get(n) is None)
    if unnamed:
        raise BadInputError(f"session(s) {', '.join(unnamed[:5])} name no lab while others do; give every "
                            "recording's lab (sensor-fit --labs, or import --lab)")
    for person in sorted(set(persons.values())):
        theirs = sorted({named[n] for n, p in persons.items() if p == person})
        if len(theirs) > 1:
            raise BadInputError(f"person {person!r} has sessions of labs {', '.join(theirs)}; a person is of one lab")
    return {n: named[n] for n in persons}


def fit_population(profile: SensorProfile, cases: Sequence[ReplicaCase], persons: Mapping[str, str], *,
                   seed: int = 0, jobs: int = 1, progress: Callable[[int], None] | None = None,
                   retracked: Sequence[tuple[SensorStats, Poses]] | None = None) -> PopulationFit:
    """The population of ``profile`` (its typical tracker) from the replicas of several people's sessions.

    Parameters
    ----------
    profile : SensorProfile
        The typical tracker (usually the replica fit of the same sessions).
    cases : sequence of ReplicaCase
        One per session (:func:`scenarios.sensors.replica_case.prepare_cases`); at least two. Where their
        recordings name two labs or more (:attr:`ReplicaCase.lab`) each lab gets a population of its own
        (module docstring, :func:`check_labs`).
    persons : mapping session name -> person label
        Whose session each case is.
    seed : int
        Seed of the re-trackings (``seed`` and ``seed + 1``).
    jobs : int
        Sessions re-tracked at once (joblib; -1: one per core).
    progress : callable, optional
        Called with 1 as each session is done.
    retracked : sequence of (SensorStats, Poses), optional
        Per case, its re-tracking with ``profile`` and ``seed`` calibrated from the body, when already
        made (:attr:`scenarios.sensors.fit_replica.ReplicaFit.retracked` of the refinement that gave
        ``profile``): not made again.

    Returns
    -------
    PopulationFit
    """
    if len(cases) < 2:
        raise BadInputError(f"a population needs at least two sessions, got {len(cases)}")
    missing = [c.name for c in cases if c.name not in persons]
    if missing:
        raise BadInputError(f"no person given for session(s) {', '.join(missing)}")
    tick = progress or (lambda n: None)
    sims = []
    if retracked is not None and len(retracked) != len(cases):
        raise BadInputError(f"{len(retracked)} re-trackings given for {len(cases)} sessions")
    firsts = retracked or [None] * len(cases)
    for s in Parallel(n_jobs=jobs, return_as="generator")(
            delayed(_case_sims)(c, profile, seed, f) for c, f in zip(cases, firsts)):
        sims.append(s)
        tick(1)
    labels = [persons[c.name] for c in cases]
    lab_of = check_labs({c.name: c.lab for c in cases}, {c.name: persons[c.name] for c in cases})
    lab_spreads: dict[str, dict[Family, Spread]] = {lab: {} for lab in sorted(set(lab_of.values()))}
    families, prov = {}, dict(profile.provenance)
    for fam in Family:
        real = np.array([s["real"][fam] for s in sims])
        ok = np.isfinite(real) & np.array([np.isfinite(s["seed0"][fam]) for s in sims])
        if ok.sum() < 2:
            families[fam] = FamilyFit(Spread(), np.nan, np.nan, {},
                                      "not fitted, does not vary: the recordings lack its statistic")
            continue
        base = np.array([s["seed0"][fam] for s in sims])[ok]
        raised = np.array([s[fam.value][fam] for s in sims])[ok]
        elasticity = float(np.median((raised - base) / STEP[fam]))
        if not elasticity > 0.05:
            raise BadInputError(f"the {fam.value} statistic hardly responds to its factor (elasticity "
                                f"{elasticity:.3f}); the replicas cannot separate it")
        x0 = (real[ok] - base) / elasticity
        x1 = (real[ok] - np.array([s["seed1"][fam] for s in sims])[ok]) / elasticity
        seed_var = float(np.var(x0 - x1, ddof=1) / 2)
        x = (x0 + x1) / 2
        group = [lab for lab, k in zip(labels, ok) if k]
        mean, within_var, person_scale, person_df = _variance_components(x, group)
        session_sd = float(np.sqrt(max(within_var - seed_var / 2, 0.0)))
        spread = Spread(mean, min(person_scale, MAX_LOG_SD), min(session_sd, MAX_LOG_SD), person_df)
        one_person = "" if len(set(group)) > 1 else "one person: between-person spread not seen"
        note = "; ".join(n for n in (
            one_person,
            "" if person_scale <= MAX_LOG_SD else f"between-person scale {person_scale:.2f} held at {MAX_LOG_SD:g}",
            "" if session_sd <= MAX_LOG_SD else f"between-session sd {session_sd:.2f} held at {MAX_LOG_SD:g} "
                                                "(the sessions differ in kind, e.g. two exercises)") if n)
        names = [c.name for c, k in zip(cases, ok) if k]
        families[fam] = FamilyFit(spread, elasticity, float(np.sqrt(seed_var)), dict(zip(names, x.tolist())), note)
        where = f"{len(group)} sessions of {len(set(group))} people ({', '.join(sorted(set(group)))})"
        contrast = "difference real - simulated" if fam is Family.CONFIDENCE else "log-ratio real / simulated"
        how = (f"mixed-effects fit (statsmodels MixedLM, REML, random intercept per person) over {where} of each "
               f"session's {contrast} of the {_STATISTIC[fam]}, divided by its elasticity "
               f"{elasticity:.2f} (re-tracking with the factor raised by {STEP[fam]:g}); seed noise of the "
               f"simulation (sd {np.sqrt(seed_var):.3f}, two seeds) removed from the session part")
        prov[f"population.{fam.value}_mean"] = f"{how}: fixed intercept"
        new_person = (f"{how}: a new person's scale, sd of the {len(set(group))} people's mean factors times "
                      "sqrt(1 + 1/people)") if not one_person else f"{how}: {one_person}"
        prov[f"population.{fam.value}_person_sd"] = new_person
        prov[f"population.{fam.value}_person_df"] = (
            f"people - 1 = {person_df:g}: a new person drawn Student-t, the between-person scale resting on "
            f"{len(set(group))} people (scenarios.sensors.fit_population; clipped at sim.sensor_population.CLIP)"
            if np.isfinite(person_df) else f"{how}: {one_person}")
        prov[f"population.{fam.value}_session_sd"] = (f"{how}: residual variance less the seed variance"
                                                      + (f" ({note})" if "session" in note else ""))
        if lab_of:
            _fit_labs(fam, spread, x, group, [lab_of[n] for n in names], lab_spreads, prov, how)
    population = Population({f: ff.spread for f, ff in families.items() if np.isfinite(ff.elasticity)},
                            {lab: Population({f: sp[f] for f in Family if f in sp}) for lab, sp in lab_spreads.items()})
    return PopulationFit(dataclasses.replace(profile, population=population, provenance=prov), families,
                         {c.name: persons[c.name] for c in cases}, lab_of)


def _fit_labs(fam: Family, spread: Spread, x: np.ndarray, persons: list[str], labs: list[str],
              out: dict[str, dict[Family, Spread]], prov: dict[str, str], how: str) -> None:
    """Each lab's spread of family ``fam`` into ``out`` and its provenance into ``prov``: fitted by
    :func:`_lab_spreads` from the lab's sessions, the population's ``spread`` for a lab whose sessions
    lack the statistic."""
    fitted = _lab_spreads(x, persons, labs, spread.session_sd) if len(set(labs)) > 1 else None
    for lab in out:
        key = f"population.labs.{lab}.{fam.value}"
        if fitted is None or lab not in fitted:
            out[lab][fam] = spread
            why = ("its recordings lack the statistic" if lab not in labs else
                   "one lab's sessions measure it, or no lab has two people")
            for k in SPREAD_FIELDS:
                prov[f"{key}_{k}"] = f"the population's {fam.value}_{k}: {why}"
            continue
        out[lab][fam] = fitted[lab]
        n_people = len(set(persons))
        prov[f"{key}_mean"] = f"{how}; a fixed intercept per lab ({', '.join(sorted(set(labs)))}): this lab's"
        prov[f"{key}_person_sd"] = (f"{how}: sd of the {n_people} people's mean factors about their lab's mean, "
                                    f"pooled over {len(set(labs))} labs, times sqrt(1 + 1/people of this lab)")
        prov[f"{key}_person_df"] = (f"people - labs = {fitted[lab].person_df:g}: a new person of this lab drawn "
                                    "Student-t (scenarios.sensors.fit_population)")
        prov[f"{key}_session_sd"] = f"the population's {fam.value}_session_sd (a lab is the same for a person's sessions)"


def person_of(name: str) -> str:
    """The default person label of a recording name: the part before its first underscore."""
    return name.split("_", 1)[0]
