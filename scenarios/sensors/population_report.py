"""The population part of a sensor fit's report (``fit.md`` of ``sensor-fit --population --report``)."""

from __future__ import annotations

import numpy as np

from scenarios.sensors.fit_population import PopulationFit


def population_lines(population: PopulationFit) -> list[str]:
    """Markdown section: per family the fitted mean, between-person and between-session spread, the
    elasticity and seed noise, and each person's mean factor."""
    people = sorted(set(population.persons.values()))
    lines = ["## Population: how people and sessions vary", "",
             "Per family, on its log scale (confidence: arcsine square root, rad), the mean person relative to the typical "
             "parameters, the scale (and degrees of freedom) of a new person, the spread between one "
             "person's sessions, the statistic's response to the factor (elasticity), the simulation's seed "
             "noise, and each person's mean factor:", "",
             "| family | mean | new person: scale (df) | between sessions | elasticity | seed noise | "
             + " | ".join(people) + " |", "|---|---|---|---|---|---|" + "---|" * len(people)]
    for fam, ff in population.families.items():
        if not np.isfinite(ff.elasticity):
            lines.append(f"| {fam.value} | {ff.note} | | | | |" + " |" * len(people))
            continue
        s = ff.spread
        means = [np.mean([x for n, x in ff.factors.items() if population.persons[n] == p] or [np.nan]) for p in people]
        lines.append(f"| {fam.value} | {s.mean:+.3f} | {s.person_sd:.3f} ({s.person_df:g}) | {s.session_sd:.3f} | "
                     f"{ff.elasticity:.2f} | {ff.seed_sd:.3f} | " + " | ".join(f"{m:+.2f}" for m in means) + " |")
    return lines + [""] + lab_lines(population)


def lab_lines(population: PopulationFit) -> list[str]:
    """Markdown: each lab's people and, per family, its mean person and a new person's scale (df); none
    without labs."""
    labs = population.profile.population.labs if population.profile.population is not None else {}
    if not labs:
        return []
    lines = ["Labs (a person of a lab the population knows is drawn from that lab's people; the table above "
             "is a person of another lab):", "", "| lab | people | " + " | ".join(
                 f"{f.value}: mean, new person (df)" for f in population.families) + " |",
             "|---|---|" + "---|" * len(population.families)]
    for lab, pop in labs.items():
        people = sorted({population.persons[n] for n, v in population.labs.items() if v == lab})
        cells = [pop.spread(f).text() if f in pop.spreads else "-" for f in population.families]
        lines.append(f"| {lab} | {', '.join(people)} | " + " | ".join(cells) + " |")
    return lines + [""]
