"""Commands that bring recorded motion onto the humanoid: retarget, retarget-report, replica."""

from __future__ import annotations

import argparse
from pathlib import Path

from scenarios.cli.choices import add_choice


def _cmd_retarget(args: argparse.Namespace) -> None:
    from tqdm import tqdm

    from fusion.io.atomic import check_output_file
    from scenarios.replay_source import (
        SourceFormat,
        SourceOptions,
        guess_format,
        load_trajectory,
    )
    from scenarios.sensors.replica import residual_table
    from sim.replay import fit_motion, save_motion
    from sim.retarget import RetargetOptions

    check_output_file(args.out, overwrite=args.overwrite)
    fmt = guess_format(args.source) if args.format is None else SourceFormat(args.format)
    options = SourceOptions(camera=args.camera, calibration=args.calib, marker_map=args.marker_map,
                            units=args.units, up_axis=args.up_axis)
    trajectory = load_trajectory(args.source, fmt, options)
    if args.start is not None or args.end is not None:
        trajectory = trajectory.window(args.start, args.end)
    with tqdm(total=trajectory.n_frames, desc="retarget", unit="frame", leave=False) as bar:
        motion, result, scale = fit_motion(trajectory, RetargetOptions(max_rms_m=args.max_rms), progress=bar.update,
                                           units_option="--units")
    save_motion(motion, args.out)
    a = scale.anthropometry
    print(f"subject: stature {scale.stature_m:.3f} m (scale {a.height_m:.3f} m); multipliers trunk {a.trunk:.3f}, upper arm {a.upper_arm:.3f}, "
          f"forearm {a.forearm:.3f}, thigh {a.thigh:.3f}, shank {a.shank:.3f}"
          + (f" (clipped: {', '.join(scale.clipped)})" if scale.clipped else ""))
    print(residual_table(result))
    print(f"wrote {args.out}")


def _cmd_retarget_report(args: argparse.Namespace) -> None:
    from tqdm import tqdm

    from fusion.io.atomic import check_output_file, write_text_atomic
    from scenarios.interop.retarget_report import fit_sources, report_markdown

    check_output_file(args.out, overwrite=args.overwrite)
    with tqdm(desc="retarget", unit="frame", leave=False) as bar:
        fits = fit_sources(args.sources, progress=bar.update)
    text = report_markdown(fits)
    write_text_atomic(args.out, text)
    print(text, end="")
    print(f"wrote {args.out}")


def _cmd_replica(args: argparse.Namespace) -> None:
    from fusion.io.atomic import check_output_file
    from fusion.io.calibration_file import load_calibration
    from fusion.io.recording_files import load_recording
    from scenarios.config import NoiseLevel
    from scenarios.runner import recording_dir
    from scenarios.sensors.fit_and_compare import replica_with_progress
    from scenarios.sensors.replica import residual_table, write_replica

    check_output_file(args.out, overwrite=args.overwrite)
    check_output_file(args.out.with_suffix(".motion.npz"), overwrite=args.overwrite)
    recording = load_recording(recording_dir(args.recording))
    replica = replica_with_progress(recording, load_calibration(args.calib), name=args.name or args.out.stem,
                                    motion_path=args.out.with_suffix(".motion.npz"), noise=NoiseLevel(args.noise),
                                    profile=args.profile, seed=args.seed)
    scenario_path, motion_path = write_replica(replica, args.out)
    print(residual_table(replica.result))
    print(f"wrote {scenario_path} and {motion_path}")


def register(sub: argparse._SubParsersAction) -> None:
    """Add the retarget, retarget-report and replica sub-commands."""
    p = sub.add_parser("retarget", help="fit the humanoid's joint angles to recorded motion (recording, C3D, TRC, BVH, "
                                        "UI-PRMD Vicon)")
    p.add_argument("source", type=Path,
                   help="recording / run / fused directory, or a .c3d, .trc, .bvh or UI-PRMD Vicon positions file")
    p.add_argument("--out", required=True, type=Path, help="motion file to write (.npz)")
    add_choice(p, "--format", default=None,
                   path="scenarios.replay_source.SourceFormat", members=("RECORDING", "C3D", "TRC", "BVH", "UI_PRMD_VICON"),
                   help="source format (default: from the name; a ..._positions.txt.gz file under a Vicon folder is "
                        "ui-prmd-vicon)")
    p.add_argument("--camera", default=None, help="camera of a recording (default: fused, else the reference)")
    p.add_argument("--calib", default=None, type=Path, help="calibration TOML placing the recording's cameras")
    p.add_argument("--marker-map", default=None,
                   help="built-in map (body25, cmu, kinect_v2, plug_in_gait) or a TOML map (C3D/TRC default "
                        "kinect_v2, BVH cmu, UI-PRMD Vicon plug_in_gait)")
    add_choice(p, "--units", default=None, path="fusion.frames.LengthUnit", help="length unit of a C3D/TRC/BVH file")
    add_choice(p, "--up-axis", default=None, path="fusion.frames.UpAxis", help="vertical axis of a C3D/TRC/BVH file")
    p.add_argument("--start", type=float, default=None, metavar="SECONDS", help="first time to fit")
    p.add_argument("--end", type=float, default=None, metavar="SECONDS", help="last time to fit")
    p.add_argument("--max-rms", type=float, default=0.15, metavar="METRES",
                   help="frames with a larger weighted RMS residual count as not converged (default 0.15)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing motion file")
    p.set_defaults(func=_cmd_retarget)

    p = sub.add_parser("retarget-report", help="retarget several sources and tabulate the residuals per joint group")
    p.add_argument("sources", nargs="+", type=Path, metavar="SOURCE",
                   help="fused directory, one-camera recording, or .c3d / .trc / .bvh file (default options)")
    p.add_argument("--out", required=True, type=Path, help="Markdown report to write")
    p.add_argument("--overwrite", action="store_true", help="replace an existing report")
    p.set_defaults(func=_cmd_retarget_report)

    p = sub.add_parser("replica", help="write a scenario replaying a real session from its calibrated camera places")
    p.add_argument("recording", type=Path, help="recording (or run) directory")
    p.add_argument("--calib", required=True, type=Path, help="its calibration TOML from `calibrate`")
    p.add_argument("--out", required=True, type=Path,
                   help="scenario TOML to write; the motion file goes next to it (<out>.motion.npz)")
    p.add_argument("--name", default=None, help="scenario name (default: the file's stem)")
    add_choice(p, "--noise", default="default", path="scenarios.config.NoiseLevel", help="sensor noise preset")
    p.add_argument("--seed", type=int, default=0, help="seed written into the replica scenario (default 0)")
    p.add_argument("--profile", default=None,
                   help="sensor profile of the replica (built-in name or TOML; default: that of the recording's topology)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing scenario TOML and motion file")
    p.set_defaults(func=_cmd_replica)
