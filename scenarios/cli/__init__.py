"""The ``mocap-bench`` command line: the only package that parses arguments.

Each module registers one group of sub-commands (``register(sub)``) whose handlers import the library
lazily, turn the parsed arguments into values and print what was written.
"""

from __future__ import annotations

import argparse
import sys

from fusion.errors import BenchError
from scenarios.cli import calibration, clinical, formats, fusing, replay, simulation

GROUPS = (simulation, calibration, fusing, formats, clinical, replay)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every sub-command."""
    parser = argparse.ArgumentParser(
        prog="mocap-bench",
        description="Simulation-backed test bench for marker-less multi-camera motion capture.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for group in GROUPS:
        group.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``mocap-bench`` console command; returns the exit status."""
    args = build_parser().parse_args(argv)
    try:
        args.func(args)
    except BenchError as exc:
        print(f"mocap-bench {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
