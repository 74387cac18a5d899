"""The hostile suite command: hostile."""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path


def _cmd_hostile(args: argparse.Namespace) -> None:
    import numpy as np
    from tqdm import tqdm

    from fusion.io.atomic import check_output_file, write_text_atomic
    from scenarios.cli import main
    from scenarios.hostile.command_cases import all_cases
    from scenarios.hostile.reader_cases import build_base
    from scenarios.hostile.suite import GOOD, counts, report_markdown, run_suite

    check_output_file(args.out, overwrite=args.overwrite)
    with tempfile.TemporaryDirectory(prefix="hostile-") as work:
        base = build_base(Path(work) / "base", seed=args.seed)
        cases = all_cases(base, mutants=args.mutants, rng=np.random.default_rng(args.seed))
        if args.quick:
            cases = [c for c in cases if c.quick]
        with tqdm(total=len(cases), desc="hostile", unit="case") as bar:
            results = run_suite(cases, Path(work) / "cases", main, timeout_s=args.timeout,
                                progress=lambda r: (bar.set_postfix_str(r.outcome.value), bar.update(1)))
    write_text_atomic(args.out, report_markdown(results))
    print(", ".join(f"{k}: {v}" for k, v in counts(results).items()))
    for r in results:
        if r.outcome not in GOOD:
            print(f"{r.outcome.value}: {r.case.group}: {r.case.name}: {r.message}")
    print(f"wrote {args.out}")
    if any(r.outcome not in GOOD for r in results):
        raise SystemExit(1)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the hostile sub-command."""
    p = sub.add_parser("hostile", help="run bad inputs through every reader and command and count the outcomes")
    p.add_argument("--out", required=True, type=Path, help="report (Markdown)")
    p.add_argument("--quick", action="store_true", help="leave out the cases that fuse a whole session")
    p.add_argument("--mutants", type=int, default=100, help="randomly damaged reader files (default 100)")
    p.add_argument("--seed", type=int, default=1, help="seed of the base session and the mutants (default 1)")
    p.add_argument("--timeout", type=float, default=120.0, metavar="SECONDS",
                   help="a case running longer counts as a hang (default 120)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing report")
    p.set_defaults(func=_cmd_hostile)
