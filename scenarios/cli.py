"""The ``mocap-bench`` command line. The only module that parses arguments."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from fusion.errors import BenchError


def _cmd_simulate(args: argparse.Namespace) -> None:
    from scenarios.config import load_scenario
    from scenarios.runner import simulate_to_disk

    scenario = load_scenario(args.scenario)
    run = simulate_to_disk(scenario, args.out, seed=args.seed, duration_s=args.duration, overwrite=args.overwrite)
    print(f"wrote {run}  (recording/, truth/, scenario.json)")


def _cmd_show(args: argparse.Namespace) -> None:
    from scenarios.runner import load_run
    from scenarios.show import show_run

    recording, truth = load_run(args.run)
    for p in show_run(recording, truth, args.out):
        print(f"wrote {p}")


def _cmd_demo(args: argparse.Namespace) -> None:
    from scenarios.demo import run_demo

    run_demo(args.out, scenario=args.scenario, seed=args.seed, duration_s=args.duration)


def _cmd_bench(args: argparse.Namespace) -> None:
    from scenarios.bench.runner import run_benchmarks

    run_benchmarks(args.out, only=args.only)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every sub-command."""
    parser = argparse.ArgumentParser(
        prog="mocap-bench",
        description="Simulation-backed test bench for marker-less multi-camera motion capture.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("simulate", help="simulate a scenario into a recording plus ground truth")
    p.add_argument("scenario", help="scenario TOML path or built-in name (fma_2cam, ring6, single, ...)")
    p.add_argument("--out", required=True, type=Path, help="output directory of the run")
    p.add_argument("--seed", type=int, default=None, help="override the scenario's seed")
    p.add_argument("--duration", type=float, default=None, metavar="SECONDS", help="truncate the session")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_simulate)

    p = sub.add_parser("show", help="draw a run: top view of the rig and per-camera depth with skeleton")
    p.add_argument("run", type=Path, help="directory written by `simulate`")
    p.add_argument("--out", required=True, type=Path, help="directory for the PNG files")
    p.set_defaults(func=_cmd_show)

    p = sub.add_parser("demo", help="run every stage on the default scenario and write a report")
    p.add_argument("--out", type=Path, default=Path("out/demo"), help="output directory (default out/demo)")
    p.add_argument("--scenario", default="fma_2cam", help="scenario (default fma_2cam)")
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--duration", type=float, default=None, metavar="SECONDS")
    p.set_defaults(func=_cmd_demo)

    p = sub.add_parser("bench", help="run the benchmark scenarios and write BENCHMARKS.md")
    p.add_argument("--out", type=Path, default=Path("BENCHMARKS.md"), help="results table (Markdown)")
    p.add_argument("--only", nargs="*", default=None, help="names of benchmarks to run (default all)")
    p.set_defaults(func=_cmd_bench)
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
