"""The command of the documentation's study pages: studies."""

from __future__ import annotations

import argparse
from pathlib import Path


def _cmd_studies(args: argparse.Namespace) -> None:
    from fusion.errors import BadInputError
    from scenarios.cli import main
    from scenarios.studies.pages import (
        Status,
        check_pages,
        load_registry,
        mark_pages,
        record,
        regenerate,
        select,
        status_table,
    )

    folder, root = args.folder, args.root
    if not (folder / "studies.toml").is_file():
        raise BadInputError(f"no study registry {folder / 'studies.toml'}: run from the repository root or give "
                            "--folder and --root")
    studies = load_registry(folder)
    if args.only or args.all:
        chosen = [s for s in select(studies, args.only) if args.only or s.generated]
        for study in chosen:
            print(f"regenerating {study.name} ...")
            for path in regenerate(study, folder, root, main):
                print(f"wrote {path}")
    elif args.record:
        for study in select(studies, args.record):
            print(f"stamped {record(study, folder, root)}")
    statuses = mark_pages(folder, root) if args.mark else check_pages(folder, root)
    print(status_table(statuses), end="")
    bad = [s for s in statuses if not s.honest]
    stale = [s for s in statuses if s.status is Status.STALE]
    print(f"{len(statuses)} pages: {len(statuses) - len(stale)} fresh, {len(stale)} older than their inputs")
    if args.check and bad:
        for s in bad:
            why = ("records no provenance" if s.status is Status.UNRECORDED else
                   "is older than its inputs without saying so" if s.status is Status.STALE else
                   "says it is stale but is not")
            print(f"{s.study.page} {why}: `mocap-bench studies --mark` updates the notices")
        raise SystemExit(1)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the studies sub-command."""
    p = sub.add_parser("studies", help="the documentation's study pages: list, check, regenerate, stamp")
    action = p.add_mutually_exclusive_group()
    action.add_argument("--only", nargs="+", metavar="NAME", help="regenerate these studies (their commands)")
    action.add_argument("--all", action="store_true",
                        help="regenerate every study made by commands alone (hours on two cores)")
    action.add_argument("--record", nargs="+", metavar="NAME",
                        help="stamp hand-written pages, just updated from their runs, with this commit and inputs")
    action.add_argument("--mark", action="store_true", help="show or remove each page's notice that it is "
                                                             "older than its inputs")
    action.add_argument("--check", action="store_true",
                        help="exit 1 if a page records no provenance or its notice disagrees with its inputs")
    p.add_argument("--folder", type=Path, default=Path("docs/studies"),
                   help="the study pages and their studies.toml (default docs/studies)")
    p.add_argument("--root", type=Path, default=Path("."),
                   help="repository root the inputs are relative to (default: the working directory)")
    p.set_defaults(func=_cmd_studies)
