"""Commands of the Fugl-Meyer layer: cohort, fma."""

from __future__ import annotations

import argparse
from pathlib import Path

from scenarios.cli.sweep_args import add_sweep_arguments


def _cmd_cohort(args: argparse.Namespace) -> None:
    from scenarios.clinical.cohort import generate_cohort
    from scenarios.clinical.cohort_file import load_cohort
    from scenarios.runner import SOURCE_ROOT, commit_id
    from scenarios.sweep import SweepOptions

    cohort = load_cohort(args.cohort)
    workers = cohort.study.workers if args.workers is None else args.workers
    result = generate_cohort(cohort, args.out, sweep=SweepOptions(workers=workers, scheduler=args.scheduler),
                             overwrite=args.overwrite, commit=commit_id(SOURCE_ROOT))
    subjects = result.manifest["subjects"]
    print(f"wrote {result.out_dir}: {len(subjects)} subjects (manifest.json, manifest.csv, participants.tsv/.json, "
          "datasheet.md, subjects/)")
    for subject_id in result.failed:
        error = next(s["error"] for s in subjects if s["id"] == subject_id)
        print(f"{subject_id}: {error}")


def _cmd_fma(args: argparse.Namespace) -> None:
    from tqdm import tqdm

    from scenarios.clinical.fma_study import analyse, report_markdown, write_report

    with tqdm(desc="fma", unit="step", leave=False) as bar:
        result = analyse(args.dataset, seed=args.seed, progress=lambda m: (bar.set_postfix_str(m), bar.update(1)))
    write_report(result, args.out, overwrite=args.overwrite)
    print(report_markdown(result))
    print(f"wrote {args.out} (report.md, results.json, features.csv, PNGs)")


def register(sub: argparse._SubParsersAction) -> None:
    """Add the cohort, fma sub-commands."""
    p = sub.add_parser("cohort", help="synthetic patient / healthy cohort: simulate, calibrate, fuse, manifest")
    p.add_argument("cohort", help="cohort TOML path or built-in name (cohort_paper)")
    p.add_argument("--out", required=True, type=Path,
                   help="output directory (manifest.json, manifest.csv, participants.tsv/.json, datasheet.md, subjects/)")
    add_sweep_arguments(p)
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_cohort)

    p = sub.add_parser("fma", help="Fugl-Meyer analysis of a cohort dataset (the paper's section 4)")
    p.add_argument("dataset", type=Path, help="directory written by `mocap-bench cohort`")
    p.add_argument("--out", required=True, type=Path, help="report directory")
    p.add_argument("--seed", type=int, default=0, help="seed of camera picks and classifiers (default 0)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_fma)
