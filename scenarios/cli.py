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


def _cmd_calibrate(args: argparse.Namespace) -> None:
    import numpy as np
    from tqdm import tqdm

    from fusion.calibration import CalibrationOptions, Refinement, RigMethod, calibrate_rig
    from fusion.calibration_file import calibration_from_rig, save_calibration
    from fusion.recording import load_recording
    from scenarios.runner import recording_dir

    recording = load_recording(recording_dir(args.run))
    options = CalibrationOptions(refine=Refinement(args.refine), rig=RigMethod(args.rig), reference=args.reference)
    n = len(recording.cameras)
    with tqdm(total=n * (n - 1) // 2 + 2, desc="calibrate", unit="step", leave=False) as bar:
        def step(message: str) -> None:
            bar.set_postfix_str(message)
            bar.update(1)

        rig = calibrate_rig(recording, options, rng=np.random.default_rng(args.seed), progress=step)
    save_calibration(calibration_from_rig(rig), args.out)
    for p in rig.pairs:
        icp = "" if p.icp is None else f", ICP {'accepted' if p.icp.accepted else 'rejected'} (rmse {p.icp.inlier_rmse_m * 1e3:.1f} mm)"
        print(f"{p.a}-{p.b}: support {p.ransac.support:.0%}, residual {p.ransac.rmse * 1e3:.0f} mm{icp}")
    if rig.loop is not None:
        print(f"ring loop closure: {rig.loop.mean_mm:.1f} mm")
    for note in rig.notes:
        print(f"note: {note}")
    print(f"wrote {args.out}")


def _cmd_evaluate(args: argparse.Namespace) -> None:
    from fusion.calibration_file import load_calibration
    from fusion.recording import load_recording
    from scenarios.evaluate import evaluate_to_disk
    from scenarios.runner import load_truth_if_any, recording_dir

    calibration = load_calibration(args.calib)
    truth = load_truth_if_any(args.run)
    recording = load_recording(recording_dir(args.run))
    other = None if args.compare is None else load_calibration(args.compare)
    config = {"run": str(args.run), "calibration": str(args.calib), "compare": None if other is None else str(args.compare)}
    result = evaluate_to_disk(calibration, truth, args.out, config=config, recording=recording, other=other,
                              overwrite=args.overwrite)
    if "summary" in result:
        s = result["summary"]
        print(f"rotation error: median {s['rotation_error_deg']['median']:.3f} deg, max {s['rotation_error_deg']['max']:.3f}"
              f"; translation error: median {s['translation_error_mm']['median']:.1f} mm, "
              f"max {s['translation_error_mm']['max']:.1f}")
    else:
        free = result["truth_free"]
        print("no ground truth: truth-free measures only; bone-length std [mm]: "
              + ", ".join(f"{k} {v:.1f}" for k, v in free.get("bone_length_std_mm", {}).items()))
        if "session_to_session_rmse_mm" in free:
            print(f"session-to-session RMSE: {free['session_to_session_rmse_mm']:.1f} mm")
    print(f"wrote {args.out}/result.json and report.md")


def _cmd_calib_study(args: argparse.Namespace) -> None:
    from tqdm import tqdm

    from scenarios.calib_study import run_study, write_study

    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    with tqdm(total=len(seeds), desc=f"study {args.scenario}", unit="seed") as bar:
        runs = run_study(args.scenario, seeds, duration_s=args.duration, jobs=args.jobs, progress=bar.update)
    write_study(args.out, args.scenario, runs, overwrite=args.overwrite)
    print((args.out / "table1.md").read_text())


def _cmd_fuse(args: argparse.Namespace) -> None:
    from fusion.calibration_file import load_calibration
    from fusion.filters import TemporalFilter
    from fusion.fuse import FuseOptions
    from fusion.merge import MergeMethod
    from fusion.recording import load_recording
    from scenarios.fusing import fuse_to_disk
    from scenarios.runner import recording_dir

    options = FuseOptions(method=MergeMethod(args.method), relabel_back_facing=not args.no_relabel,
                          temporal=TemporalFilter(args.filter), bone_lengths=args.bone_lengths)
    summary = fuse_to_disk(load_recording(recording_dir(args.run)), load_calibration(args.calib), args.out, options,
                           cloud_time_s=args.cloud_time, mesh=args.mesh, overwrite=args.overwrite)
    rel = summary["reliability"]
    print(f"{summary['frames']} frames from {', '.join(summary['cameras'])}: high confidence {rel['high']:.1%}, "
          f"back pose {rel['back_pose']:.1%}")
    print("bone-length std [mm]: " + ", ".join(f"{k} {v:.1f}" for k, v in summary["bone_length_std_mm"].items()))
    print(f"wrote {args.out} ({', '.join(sorted(p.name for p in args.out.iterdir()))})")


def _cmd_export(args: argparse.Namespace) -> None:
    from fusion import export
    from fusion.calibration_file import load_calibration
    from fusion.errors import BadInputError
    from fusion.recording import load_recording
    from scenarios.runner import recording_dir

    if args.format == "camera-toml":
        if args.camera is not None:
            raise BadInputError("--camera applies to skeleton formats, not camera-toml")
        if not args.input.is_file():
            raise BadInputError(f"{args.input} is not a file: camera-toml exports a calibration TOML from `calibrate`")
        export.export_camera_toml(load_calibration(args.input), args.out)
    else:
        recording = load_recording(recording_dir(args.input))
        if args.camera is None and len(recording.cameras) > 1:
            raise BadInputError(f"{args.input} has several cameras; choose one with --camera "
                                f"({', '.join(recording.camera_names)})")
        camera = recording.cameras[0] if args.camera is None else recording.camera(args.camera)
        if camera.skeleton is None:
            raise BadInputError(f"camera {camera.name} of {args.input} has no skeleton stream")
        write = {"c3d": export.export_c3d, "trc": export.export_trc, "csv": export.export_csv}[args.format]
        write(camera.skeleton, args.out)
    print(f"wrote {args.out}")


def _cmd_layout(args: argparse.Namespace) -> None:
    from tqdm import tqdm

    from scenarios.config import load_scenario
    from scenarios.layout import layout_study, tables_markdown, write_layout_report

    scenario = load_scenario(args.scenario)
    if args.seed is not None:
        scenario = scenario.replace(seed=args.seed)
    if args.duration is not None:
        scenario = scenario.replace(duration_s=args.duration)
    with tqdm(total=13, desc=f"layout {scenario.name}", unit="step", leave=False) as bar:
        def step(message: str) -> None:
            bar.set_postfix_str(message)
            bar.update(1)

        result = layout_study(scenario, poses=args.poses, progress=step)
    write_layout_report(result, args.out, overwrite=args.overwrite)
    print(tables_markdown(result))
    print(f"wrote {args.out} (tables.md, tables.png, layouts.png, layout.json)")


def _cmd_import(args: argparse.Namespace) -> None:
    from fusion.camera import AxisConvention
    from fusion.formats.csv_skeleton import ConfidenceScale, CsvOptions, LengthUnit
    from fusion.recording import save_recording
    from fusion.topology import topology_by_name
    from scenarios.interchange import FileFormat, import_files

    csv_options = CsvOptions(topology=topology_by_name(args.csv_topology), unit=LengthUnit[args.csv_unit.upper()],
                             axes=AxisConvention(args.csv_axes), confidence=ConfidenceScale(args.csv_confidence))
    recording = import_files(FileFormat(args.format), args.files, csv_options=csv_options)
    save_recording(recording, args.out, overwrite=args.overwrite)
    for cam in recording.cameras:
        sk = cam.skeleton
        print(f"{cam.name}: {sk.n_frames} frames, {sk.topology.name}, tracked {(sk.states >= 2).mean():.0%}")
    print(f"wrote {args.out}")


def _cmd_write(args: argparse.Namespace) -> None:
    from fusion.recording import load_recording
    from scenarios.interchange import FileFormat, write_files
    from scenarios.runner import recording_dir

    for path in write_files(FileFormat(args.format), load_recording(recording_dir(args.run)), args.out):
        print(f"wrote {path}")


def _cmd_roundtrip(args: argparse.Namespace) -> None:
    from tqdm import tqdm

    from fusion.atomic import atomic_directory
    from scenarios.config import load_scenario
    from scenarios.interchange import FileFormat, round_trip_study, round_trip_table

    scenario = load_scenario(args.scenario)
    if args.duration is not None:
        scenario = scenario.replace(duration_s=args.duration)
    formats = [FileFormat(f) for f in args.formats]
    with tqdm(total=len(formats) * len(args.cameras), desc="round trip", unit="session", leave=False) as bar:
        rows = round_trip_study(scenario, formats, args.cameras, progress=lambda m: bar.update(1))
    table = round_trip_table(rows)
    with atomic_directory(args.out, overwrite=args.overwrite) as tmp:
        import json

        (tmp / "roundtrip.json").write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")
        (tmp / "roundtrip.md").write_text("# Write, import, calibrate (skeleton only)\n\n" + table, encoding="utf-8")
    print(table)


def _cmd_fma(args: argparse.Namespace) -> None:
    from tqdm import tqdm

    from scenarios.fma_study import analyse, report_markdown, write_report

    with tqdm(desc="fma", unit="step", leave=False) as bar:
        result = analyse(args.dataset, seed=args.seed, progress=lambda m: (bar.set_postfix_str(m), bar.update(1)))
    write_report(result, args.out, overwrite=args.overwrite)
    print(report_markdown(result))
    print(f"wrote {args.out} (report.md, results.json, features.csv, PNGs)")


def _cmd_demo(args: argparse.Namespace) -> None:
    from scenarios.demo import run_demo

    run_demo(args.out, scenario=args.scenario, seed=args.seed, duration_s=args.duration)


def _cmd_cohort(args: argparse.Namespace) -> None:
    from scenarios.cohort import generate_cohort, load_cohort

    cohort = load_cohort(args.cohort)
    result = generate_cohort(cohort, args.out, jobs=args.jobs, overwrite=args.overwrite)
    subjects = result.manifest["subjects"]
    print(f"wrote {result.out_dir}: {len(subjects)} subjects (manifest.json, manifest.csv, subjects/)")
    for subject_id in result.failed:
        error = next(s["error"] for s in subjects if s["id"] == subject_id)
        print(f"{subject_id}: {error}")


def _cmd_bench(args: argparse.Namespace) -> None:
    from scenarios.bench.runner import run_benchmarks

    run_benchmarks(args.out, only=args.only)


def _cmd_sensor_check(args: argparse.Namespace) -> None:
    from scenarios.sensor_check import REPORT_NAME, format_summary, sensor_check_to_disk

    result, written = sensor_check_to_disk(
        args.out, seed=args.seed, overwrite=args.overwrite,
        progress=lambda i, n, title: print(f"[{i}/{n}] {title}", flush=True),
    )
    print(format_summary(result))
    print(f"wrote {', '.join(p.name for p in written)} into {args.out}")
    print(f"report: {args.out / REPORT_NAME}")
    if not result.passed:
        raise SystemExit(1)


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

    p = sub.add_parser("calibrate", help="calibrate the cameras of a recording from the person's body")
    p.add_argument("run", type=Path, help="run directory or recording directory")
    p.add_argument("--out", required=True, type=Path, help="calibration TOML to write")
    p.add_argument("--refine", choices=["icp", "none"], default="icp", help="ICP refinement on depth (default icp)")
    p.add_argument("--rig", choices=["chain", "graph"], default="graph",
                   help="chaining to the reference (the paper) or global pose graph (default graph)")
    p.add_argument("--reference", default=None, help="reference camera (default: the first)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random sampling (default 0)")
    p.set_defaults(func=_cmd_calibrate)

    p = sub.add_parser("evaluate", help="score a calibration against the run's ground truth")
    p.add_argument("run", type=Path, help="run directory (with truth/) or a recording")
    p.add_argument("--calib", required=True, type=Path, help="calibration TOML from `calibrate`")
    p.add_argument("--out", required=True, type=Path, help="result directory (result.json, arrays.npz, report.md)")
    p.add_argument("--compare", type=Path, default=None,
                   help="another calibration of the same rig (e.g. another session) for the session-to-session RMSE")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty result directory")
    p.set_defaults(func=_cmd_evaluate)

    p = sub.add_parser("calib-study", help="calibration over many seeds: Table 1, session-to-session, loop closure")
    p.add_argument("scenario", help="scenario TOML path or built-in name")
    p.add_argument("--out", required=True, type=Path, help="directory for study.json, table1.md, study.png")
    p.add_argument("--seeds", type=int, default=20, help="number of seeds (default 20)")
    p.add_argument("--first-seed", type=int, default=1, help="first seed (default 1)")
    p.add_argument("--duration", type=float, default=None, metavar="SECONDS", help="session length override")
    p.add_argument("--jobs", type=int, default=None, help="parallel processes (default: all cores)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_calib_study)

    p = sub.add_parser("cohort", help="synthetic patient / healthy cohort: simulate, calibrate, fuse, manifest")
    p.add_argument("cohort", help="cohort TOML path or built-in name (cohort_paper)")
    p.add_argument("--out", required=True, type=Path, help="output directory (manifest.json, manifest.csv, subjects/)")
    p.add_argument("--jobs", type=int, default=None, help="parallel processes (default: the cohort's, else all cores)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_cohort)

    p = sub.add_parser("fuse", help="merge the calibrated cameras into one skeleton stream and one point cloud")
    p.add_argument("run", type=Path, help="run directory or recording directory")
    p.add_argument("--calib", required=True, type=Path, help="calibration TOML from `calibrate`")
    p.add_argument("--method", default="avg_frontal",
                   choices=["average", "frontality", "distance", "avg_distance", "avg_frontal", "avg_dist_frontal"],
                   help="merging method of the paper (default avg_frontal)")
    p.add_argument("--filter", default="none", choices=["none", "kalman", "one_euro"], help="temporal filter")
    p.add_argument("--bone-lengths", action="store_true", help="make bone lengths constant over time")
    p.add_argument("--no-relabel", action="store_true",
                   help="keep back-facing skeletons' labels as reported (the paper only down-weights them)")
    p.add_argument("--cloud-time", type=float, default=None, metavar="SECONDS",
                   help="time of the merged point cloud (default: mid-session)")
    p.add_argument("--mesh", action="store_true", help="also write a surface mesh of the cloud (mesh.glb)")
    p.add_argument("--out", required=True, type=Path, help="output directory")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_fuse)

    p = sub.add_parser("export", help="export a fused skeleton (C3D, TRC, CSV) or a calibration (camera TOML)")
    p.add_argument("input", type=Path, help="fused directory or recording (c3d, trc, csv); calibration TOML (camera-toml)")
    p.add_argument("--format", required=True, choices=["c3d", "trc", "csv", "camera-toml"], help="output format")
    p.add_argument("--out", required=True, type=Path, help="file to write")
    p.add_argument("--camera", default=None, help="camera of the recording (default: its only camera)")
    p.set_defaults(func=_cmd_export)

    p = sub.add_parser("layout", help="compare camera layouts and merging methods (the paper's Tables 2 and 3)")
    p.add_argument("scenario", nargs="?", default="ring6", help="ring scenario (default ring6)")
    p.add_argument("--out", required=True, type=Path, help="report directory")
    p.add_argument("--poses", choices=["body", "truth"], default="body",
                   help="calibrate from the body (default) or use the true camera poses")
    p.add_argument("--seed", type=int, default=None)
    p.add_argument("--duration", type=float, default=None, metavar="SECONDS")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_layout)

    formats = ["ntu", "k4abt-json", "csv"]
    p = sub.add_parser("import", help="read real body-tracker files into a recording")
    p.add_argument("format", choices=formats, help="file format")
    p.add_argument("files", nargs="+", type=Path, help="one file per camera")
    p.add_argument("--out", required=True, type=Path, help="recording directory to write")
    p.add_argument("--csv-topology", default="kinect_v2", choices=["kinect_v2", "k4abt"], help="CSV joint set")
    p.add_argument("--csv-unit", default="m", choices=["m", "mm"], help="CSV length unit")
    p.add_argument("--csv-axes", default="kinect_v2", choices=["kinect_v2", "opencv"],
                   help="CSV camera axes: kinect_v2 (+x left, +y up) or opencv (+x right, +y down)")
    p.add_argument("--csv-confidence", default="state_0_2", choices=["state_0_2", "state_0_3", "probability"],
                   help="CSV confidence scale")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_import)

    p = sub.add_parser("write", help="write a recording's skeletons as real body-tracker files")
    p.add_argument("format", choices=formats, help="file format")
    p.add_argument("run", type=Path, help="run directory or recording directory")
    p.add_argument("--out", required=True, type=Path, help="directory for the files")
    p.set_defaults(func=_cmd_write)

    p = sub.add_parser("roundtrip", help="write a simulated session in each format, import it, compare calibrations")
    p.add_argument("scenario", nargs="?", default="fma_2cam", help="scenario (default fma_2cam)")
    p.add_argument("--out", required=True, type=Path, help="directory for roundtrip.md and roundtrip.json")
    p.add_argument("--formats", nargs="+", default=formats, choices=formats)
    p.add_argument("--cameras", nargs="+", type=int, default=[2, 3], help="camera counts (default 2 3)")
    p.add_argument("--duration", type=float, default=None, metavar="SECONDS")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_roundtrip)

    p = sub.add_parser("fma", help="Fugl-Meyer analysis of a cohort dataset (the paper's section 4)")
    p.add_argument("dataset", type=Path, help="directory written by `mocap-bench cohort`")
    p.add_argument("--out", required=True, type=Path, help="report directory")
    p.add_argument("--seed", type=int, default=0, help="seed of camera picks and classifiers (default 0)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_fma)

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

    p = sub.add_parser("sensor-check", help="measure the simulated sensors against the facts they model")
    p.add_argument("--out", required=True, type=Path, help="output directory for sensor_check.md, .json and PNGs")
    p.add_argument("--seed", type=int, default=0, help="seed of every random draw (default 0)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_sensor_check)
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
