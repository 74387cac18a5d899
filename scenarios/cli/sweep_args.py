"""The ``--workers`` / ``--scheduler`` options shared by the commands that run Dask sweeps."""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from scenarios.sweep import SweepOptions


def add_sweep_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--workers N`` and ``--scheduler ADDRESS`` to a sub-command."""
    parser.add_argument("--workers", type=int, default=None,
                        help="worker processes of the local Dask cluster (default: one per core; 0 = in this process)")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="run on an existing Dask cluster (e.g. tcp://host:8786 from `dask scheduler`)")


def sweep_options(args: argparse.Namespace) -> SweepOptions:
    """The sweep options given on the command line."""
    from scenarios.sweep import SweepOptions

    return SweepOptions(workers=args.workers, scheduler=args.scheduler)
