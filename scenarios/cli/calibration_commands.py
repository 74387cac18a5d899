"""Commands of the calibration stage: calibrate, evaluate, calib-study."""

from __future__ import annotations

import argparse
from pathlib import Path

from scenarios.cli.choices import add_choice
from scenarios.cli.sweep_args import add_sweep_arguments, sweep_options


def _cmd_calibrate(args: argparse.Namespace) -> None:
    from tqdm import tqdm

    from fusion.calibrate.options import (
        CalibrationOptions,
        JointWeighting,
        Refinement,
        RigMethod,
        SkeletonFit,
    )
    from fusion.io.atomic import check_output_file
    from fusion.io.calibration_file import save_calibration
    from fusion.io.plausibility import check_usable_streams
    from fusion.io.recording_files import load_recording
    from scenarios import api
    from scenarios.runner import recording_dir

    check_output_file(args.out, overwrite=args.overwrite)
    recordings = [load_recording(recording_dir(run)) for run in args.run]
    for run, recording in zip(args.run, recordings):
        check_usable_streams({c.name: c.skeleton for c in recording.cameras}, str(run))
    plain = SkeletonFit(args.skeleton_fit) is SkeletonFit.PLAIN
    options = CalibrationOptions(refine=Refinement(args.refine), rig=RigMethod(args.rig), reference=args.reference,
                                 skeleton_fit=SkeletonFit(args.skeleton_fit), estimate_clock=not plain,
                                 estimate_confidence=not plain, joint_weighting=JointWeighting(args.joint_weighting))
    n = len(recordings[0].cameras)
    with tqdm(total=n * (n - 1) // 2 + 2, desc="calibrate", unit="step", leave=False) as bar:
        def step(message: str) -> None:
            bar.set_postfix_str(message)
            bar.update(1)

        result = api.calibrate(recordings, options, seed=args.seed, progress=step)
    save_calibration(result.calibration, args.out)
    rig = result.rig
    for p in rig.pairs:
        icp = "" if p.icp is None else f", ICP {'accepted' if p.icp.accepted else 'rejected'} (rmse {p.icp.inlier_rmse_m * 1e3:.1f} mm)"
        print(f"{p.a}-{p.b}: support {p.ransac.support:.0%}, residual {p.ransac.rmse * 1e3:.0f} mm{icp}")
    if rig.loop is not None:
        print(f"ring loop closure: {rig.loop.mean_mm:.1f} mm")
    for a, b in rig.distrusted:
        print(f"distrusted edge: {a}-{b}")
    for note in rig.notes:
        print(f"note: {note}")
    print(f"wrote {args.out}")


def _cmd_evaluate(args: argparse.Namespace) -> None:
    from fusion.io.camera_toml import load_calibration_for
    from fusion.io.recording_files import load_recording
    from scenarios.evaluate import evaluate_to_disk, spread_interval_text
    from scenarios.runner import load_truth_if_any, recording_dir

    recording = load_recording(recording_dir(args.run))
    calibration = load_calibration_for(recording, args.calib)
    truth = load_truth_if_any(args.run)
    others = [load_calibration_for(recording, path) for path in args.compare]
    config = {"run": str(args.run), "calibration": str(args.calib), "compare": [str(p) for p in args.compare]}
    result = evaluate_to_disk(calibration, truth, args.out, config=config, recording=recording, others=others,
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
        if "within_5cm_pct" in free:
            share = free["within_5cm_pct"]
            print(f"joints within 5 cm across cameras: {share['all']:.1f} % (confidence 2: {share['confidence2']:.1f} %)")
        if "session_to_session_rmse_mm" in free:
            spread = free["session_spread"]
            print(f"session-to-session RMSE: {free['session_to_session_rmse_mm']:.1f} mm; spread of all "
                  f"{spread['sessions']} calibrations: {spread['spread_mm']:.1f} mm{spread_interval_text(spread)}, "
                  f"pairwise RMSE median "
                  f"{spread['pairwise_rmse_mm']['median']:.1f} mm, max {spread['pairwise_rmse_mm']['max']:.1f} mm")
    print(f"wrote {args.out}/result.json and report.md")


def _cmd_calib_study(args: argparse.Namespace) -> None:
    from scenarios.studies.calib_study import run_study, write_study

    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    runs = run_study(args.scenario, seeds, duration_s=args.duration, sweep=sweep_options(args), algorithm=args.algorithm)
    write_study(args.out, args.scenario, runs, overwrite=args.overwrite)
    print((args.out / "table1.md").read_text())


def register(sub: argparse._SubParsersAction) -> None:
    """Add the calibrate, evaluate, calib-study sub-commands."""
    p = sub.add_parser("calibrate", help="calibrate the cameras of a recording from the person's body")
    p.add_argument("run", type=Path, nargs="+",
                   help="run or recording directory; several: sessions of one fixed rig, calibrated together")
    p.add_argument("--out", required=True, type=Path, help="calibration TOML to write")
    add_choice(p, "--refine", path="fusion.calibrate.options.Refinement", default="icp", help="ICP refinement on depth (default icp)")
    add_choice(p, "--rig", path="fusion.calibrate.options.RigMethod", default="graph",
                   help="chaining to the reference (the paper) or global pose graph (default graph)")
    p.add_argument("--reference", default=None, help="reference camera (default: the first)")
    add_choice(p, "--skeleton-fit", path="fusion.calibrate.options.SkeletonFit", default="robust",
                   help="robust (default): RANSAC, refits with joints reweighted by their cross-camera bias, "
                        "back-facing skeletons excluded, clock offsets and missing confidences estimated; plain: "
                        "the textbook baseline, RANSAC and one Kabsch refit on the Tracked joints as recorded")
    add_choice(p, "--joint-weighting", path="fusion.calibrate.options.JointWeighting", default="uniform",
                   help="robust fit's refits: joints weighted equally (default) or by their cross-camera residual")
    p.add_argument("--seed", type=int, default=0, help="seed of the random sampling (default 0)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing calibration file")
    p.set_defaults(func=_cmd_calibrate)

    p = sub.add_parser("evaluate", help="score a calibration against the run's ground truth")
    p.add_argument("run", type=Path, help="run directory (with truth/) or a recording")
    p.add_argument("--calib", required=True, type=Path, help="calibration TOML from `calibrate`")
    p.add_argument("--out", required=True, type=Path, help="result directory (result.json, arrays.npz, report.md)")
    p.add_argument("--compare", type=Path, nargs="+", default=[], metavar="OTHER",
                   help="other calibrations of the same rig (other sessions): session-to-session RMSE and spread")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty result directory")
    p.set_defaults(func=_cmd_evaluate)

    p = sub.add_parser("calib-study", help="calibration over many seeds: Table 1, session-to-session, loop closure")
    p.add_argument("scenario", help="scenario TOML path or built-in name")
    p.add_argument("--out", required=True, type=Path, help="directory for study.json, table1.md, study.png")
    p.add_argument("--seeds", type=int, default=20, help="number of seeds (default 20)")
    p.add_argument("--first-seed", type=int, default=1, help="first seed (default 1)")
    p.add_argument("--duration", type=float, default=None, metavar="SECONDS", help="session length override")
    p.add_argument("--algorithm", default=None, metavar="MODULE:FUNCTION",
                   help="also score your calibration, fn(recording, *, rng) -> Calibration or {camera: (4, 4) "
                        "T_world_cam}, on the same sessions (package.module:function or path/to/file.py:function; "
                        "see scenarios.api)")
    add_sweep_arguments(p)
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_calib_study)
