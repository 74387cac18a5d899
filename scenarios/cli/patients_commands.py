"""Commands of the synthetic-patient studies: patient-study."""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from scenarios.cli.choices import add_choice
from scenarios.cli.sweep_args import add_sweep_arguments


def _cmd_patient_study(args: argparse.Namespace) -> None:
    from tqdm import tqdm

    from fusion.errors import BadInputError
    from scenarios.clinical.cohort_file import load_cohort
    from scenarios.clinical.patient_study import (
        compare_with_baseline,
        report_markdown,
        run_seed_study,
        write_report,
    )
    from scenarios.sweep import SweepOptions
    from sim.patients import ModelPart, PatientModel

    cohort = load_cohort(args.cohort)
    counts = {k: v for k, v in (("healthy", args.healthy), ("mild", args.mild),
                                ("moderate_severe", args.moderate_severe)) if v is not None}
    if counts:
        cohort = dataclasses.replace(cohort, groups=dataclasses.replace(cohort.groups, **counts))
        if min(dataclasses.astuple(cohort.groups)) < 0 or cohort.groups.total < 3:
            raise BadInputError("group counts must be >= 0 with at least three subjects in all")
    if args.ablate:
        if cohort.patients.model is not PatientModel.LITERATURE:
            raise BadInputError(f"--ablate needs a cohort with [patients] model = \"literature\"; {args.cohort} "
                                f"uses {cohort.patients.model.value!r} (try cohort_literature)")
        parts = list(dict.fromkeys(ModelPart(p) for p in args.ablate))
        cohort = dataclasses.replace(cohort, patients=dataclasses.replace(cohort.patients, ablate=parts))
    datasets = args.datasets or args.out.with_name(args.out.name + "-datasets")
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    with tqdm(total=2 * len(seeds), desc="patient-study", unit="step") as bar:
        result = run_seed_study(cohort, seeds, datasets,
                                sweep=SweepOptions(workers=args.workers, scheduler=args.scheduler, progress=False), analysis_seed=args.analysis_seed,
                                progress=lambda m: (bar.set_postfix_str(m), bar.update(1)))
    if args.baseline is not None:
        result = compare_with_baseline(result, args.baseline)
    write_report(result, args.out, overwrite=args.overwrite)
    print(report_markdown(result) + f"\nwrote {args.out} (report.md, results.json, PNGs); cohorts in {datasets}")


def register(sub: argparse._SubParsersAction) -> None:
    """Add the patient-study sub-command."""
    p = sub.add_parser("patient-study", help="generate and analyse a cohort over several seeds, with intervals")
    p.add_argument("cohort", help="cohort TOML path or built-in name (e.g. cohort_literature)")
    p.add_argument("--out", required=True, type=Path, help="report directory")
    p.add_argument("--seeds", type=int, default=5, help="number of cohort seeds (default 5)")
    p.add_argument("--first-seed", type=int, default=1, help="first cohort seed (default 1)")
    p.add_argument("--datasets", type=Path, default=None,
                   help="where the cohorts go (default: <out>-datasets); existing ones are reused")
    for group in ("healthy", "mild", "moderate-severe"):
        p.add_argument(f"--{group}", type=int, default=None, help=f"override the cohort's {group} subject count")
    add_choice(p, "--ablate", nargs="+", default=[], metavar="PART",
                   path="sim.patients.ModelPart",
                   help="switch parts of the literature patient model off (same subjects otherwise)")
    p.add_argument("--baseline", type=Path, default=None, metavar="REPORTDIR",
                   help="report of the same seeds without --ablate: adds the paired changes to the report")
    add_sweep_arguments(p)
    p.add_argument("--analysis-seed", type=int, default=0, help="seed of camera picks and classifiers (default 0)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty report directory")
    p.set_defaults(func=_cmd_patient_study)
