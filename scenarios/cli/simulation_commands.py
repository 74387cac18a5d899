"""Commands that simulate and inspect runs: simulate, show, sensor-check, demo, bench."""

from __future__ import annotations

import argparse
from pathlib import Path

from scenarios.cli.choices import add_choice


def _cmd_simulate(args: argparse.Namespace) -> None:
    import dataclasses

    from scenarios.config import load_scenario
    from scenarios.runner import simulate_to_disk
    from sim.depth_renderer import DepthRenderer

    scenario = load_scenario(args.scenario)
    if args.depth_renderer is not None:
        sensors = dataclasses.replace(scenario.sensors, depth_renderer=DepthRenderer(args.depth_renderer))
        scenario = dataclasses.replace(scenario, sensors=sensors)
    run = simulate_to_disk(scenario, args.out, seed=args.seed, duration_s=args.duration, overwrite=args.overwrite)
    print(f"wrote {run}  (recording/, truth/, scenario.json)")


def _cmd_show(args: argparse.Namespace) -> None:
    from fusion.io.calibration_file import load_calibration
    from fusion.io.recording_files import load_recording
    from scenarios.runner import load_run, load_truth_if_any, recording_dir
    from scenarios.show import show_recording, show_run

    if args.calib is not None:
        written = show_recording(load_recording(recording_dir(args.run)), load_calibration(args.calib), args.out)
    elif load_truth_if_any(args.run) is None:
        from fusion.errors import BadInputError

        raise BadInputError(f"{args.run} has no ground truth (a real recording): give --calib CALIB.toml to draw "
                            "the cameras where the calibration puts them")
    else:
        written = show_run(*load_run(args.run), args.out)
    for p in written:
        print(f"wrote {p}")


def _cmd_sensor_check(args: argparse.Namespace) -> None:
    from scenarios.sensors.check.check_report import (
        REPORT_NAME,
        format_summary,
        sensor_check_to_disk,
    )
    from sim.sensor_profile import load_profile

    profile = None if args.profile is None else load_profile(args.profile)
    result, written = sensor_check_to_disk(
        args.out, seed=args.seed, overwrite=args.overwrite, profile=profile,
        progress=lambda i, n, title: print(f"[{i}/{n}] {title}", flush=True),
    )
    print(format_summary(result))
    print(f"wrote {', '.join(p.name for p in written)} into {args.out}")
    print(f"report: {args.out / REPORT_NAME}")
    if not result.passed:
        raise SystemExit(1)


def _cmd_demo(args: argparse.Namespace) -> None:
    from scenarios.studies.demo import run_demo

    run_demo(args.out, scenario=args.scenario, seed=args.seed, duration_s=args.duration)


def _cmd_bench(args: argparse.Namespace) -> None:
    from scenarios.bench.benchmarks import run_benchmarks

    run_benchmarks(args.out, only=args.only)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the simulate, show, sensor-check, demo, bench sub-commands."""
    p = sub.add_parser("simulate", help="simulate a scenario into a recording plus ground truth")
    p.add_argument("scenario", help="scenario TOML path or built-in name (fma_2cam, ring6, single, ...)")
    p.add_argument("--out", required=True, type=Path, help="output directory of the run")
    p.add_argument("--seed", type=int, default=None, help="override the scenario's seed")
    p.add_argument("--duration", type=float, default=None, metavar="SECONDS", help="truncate the session")
    add_choice(p, "--depth-renderer", path="sim.depth_renderer.DepthRenderer", default=None,
                   help="what renders depth: MuJoCo's OpenGL renderer, the ray caster, or auto (MuJoCo's on a "
                        "hardware-accelerated OpenGL context, else the ray caster); default the scenario's sensors.depth_renderer (auto)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_simulate)

    p = sub.add_parser("show", help="draw a run: top view of the rig and per-camera depth with skeleton")
    p.add_argument("run", type=Path, help="directory written by `simulate`, or a real recording with --calib")
    p.add_argument("--calib", type=Path, default=None,
                   help="calibration TOML: draw the cameras where it puts them and the subject as the reference "
                        "camera reports it (for recordings without ground truth)")
    p.add_argument("--out", required=True, type=Path, help="directory for the PNG files")
    p.set_defaults(func=_cmd_show)

    p = sub.add_parser("sensor-check", help="measure the simulated sensors against the facts they model")
    p.add_argument("--out", required=True, type=Path, help="output directory for sensor_check.md, .json and PNGs")
    p.add_argument("--seed", type=int, default=0, help="seed of every random draw (default 0)")
    p.add_argument("--profile", default=None,
                   help="sensor profile to check (built-in name or TOML); default the published defaults")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_sensor_check)

    p = sub.add_parser("demo", help="run every stage on the default scenario and write a report")
    p.add_argument("--out", type=Path, default=Path("out/demo"), help="output directory (default out/demo)")
    p.add_argument("--scenario", default="fma_2cam", help="scenario (default fma_2cam)")
    p.add_argument("--seed", type=int, default=None, help="override the scenario's seed")
    p.add_argument("--duration", type=float, default=None, metavar="SECONDS", help="truncate the session")
    p.set_defaults(func=_cmd_demo)

    p = sub.add_parser("bench", help="run the benchmark scenarios and write BENCHMARKS.md")
    p.add_argument("--out", type=Path, default=Path("BENCHMARKS.md"), help="results table (Markdown)")
    p.add_argument("--only", nargs="*", default=None, help="names of benchmarks to run (default all)")
    p.set_defaults(func=_cmd_bench)
