"""Commands of the merging stage and its outputs: fuse, export, layout, angle-figure, angle-study."""

from __future__ import annotations

import argparse
from pathlib import Path

from scenarios.cli.choices import add_choice
from scenarios.cli.sweep_args import add_sweep_arguments, sweep_options


def _limb_axis_options(args: argparse.Namespace):
    """The limb-axis options of ``fuse --limb-axes [--limb-axes-without PART...]``, None without --limb-axes."""
    from fusion.errors import BadInputError
    from fusion.merge.limb_axis_options import LimbAxisOptions

    if not args.limb_axes:
        if args.limb_axes_without:
            raise BadInputError("--limb-axes-without leaves parts out of --limb-axes; add --limb-axes")
        return None
    return LimbAxisOptions().without(args.limb_axes_without)


def _cmd_fuse(args: argparse.Namespace) -> None:
    from fusion.errors import BadInputError
    from fusion.io.camera_toml import load_calibration_for
    from fusion.io.recording_files import load_recording
    from fusion.merge.filters import TemporalFilter
    from fusion.merge.fuse import Fit, FuseOptions
    from fusion.merge.methods import MergeMethod
    from scenarios.fusing import fuse_to_disk
    from scenarios.runner import recording_dir

    fit = Fit(args.fit)
    if args.method is not None and fit is not Fit.MERGE:
        raise BadInputError(f"--method chooses the merging method of --fit merge; --fit {fit.value} fits one "
                            "skeleton to every camera (add --fit merge to merge per joint and frame)")
    options = FuseOptions(method=MergeMethod.AVG_FRONTAL if args.method is None else MergeMethod(args.method), fit=fit,
                          relabel_back_facing=not args.no_relabel,
                          temporal=TemporalFilter(args.filter), bone_lengths=args.bone_lengths,
                          neutral_s=None if args.neutral is None else tuple(args.neutral),
                          limb_axes=_limb_axis_options(args))
    recording = load_recording(recording_dir(args.run))
    summary = fuse_to_disk(recording, load_calibration_for(recording, args.calib), args.out, options,
                           cloud_time_s=args.cloud_time, mesh=args.mesh, overwrite=args.overwrite,
                           check_moves=not args.no_move_check, check_clocks=not args.no_clock_check)
    rel = summary["reliability"]
    print(f"{summary['frames']} frames from {', '.join(summary['cameras'])}: high confidence {rel['high']:.1%}, "
          f"back pose {rel['back_pose']:.1%}")
    print("bone-length std [mm]: " + ", ".join(f"{k} {v:.1f}" for k, v in summary["bone_length_std_mm"].items()))
    if "limb_axes" in summary:
        axes = summary["limb_axes"]
        print("limb axes counted at: " + ", ".join(f"{k} {v:.0%}" for k, v in axes["counted_share"].items()))
        centres = {k: "twin's" if p["twin"] else "found" if p["point_mm"] else "none"
                   for k, p in axes["pivots"].items()}
        print("functional centres: " + (", ".join(f"{k} {v}" for k, v in centres.items()) or "none tried")
              + "; placed from the clouds at: " + (", ".join(f"{k} {v:.0%}" for k, v in axes["anchored_share"].items())
                                                   or "no instant"))
    print(f"wrote {args.out} ({', '.join(sorted(p.name for p in args.out.iterdir()))})")


def _cmd_export(args: argparse.Namespace) -> None:
    from fusion.errors import BadInputError
    from fusion.io import export
    from fusion.io.atomic import check_output_file
    from fusion.io.calibration_file import load_calibration
    from fusion.io.recording_files import load_recording
    from scenarios.runner import recording_dir

    fmt = export.ExportFormat(args.format)
    skeleton_only = {"--camera": args.camera, "--rate": args.rate, "--units": args.units, "--up-axis": args.up_axis}
    if args.cohort is not None:
        _export_cohort(args, skeleton_only)
        return
    if args.input is None:
        raise BadInputError("give the fused directory, recording or calibration TOML to export, or --cohort DIR")
    if fmt is export.ExportFormat.BIDS or args.truth:
        raise BadInputError("bids and --truth export a whole cohort folder: add --cohort DIR (from `mocap-bench cohort`)")
    check_output_file(args.out, overwrite=args.overwrite)
    if fmt is export.ExportFormat.CAMERA_TOML:
        given = [k for k, v in skeleton_only.items() if v is not None]
        if given:
            raise BadInputError(f"{', '.join(given)} apply to skeleton formats, not camera-toml")
        if not args.input.is_file():
            raise BadInputError(f"{args.input} is not a file: camera-toml exports a calibration TOML from `calibrate`")
        export.export_camera_toml(load_calibration(args.input), args.out, kinect_image=args.kinect_image)
    else:
        if export.KinectImage(args.kinect_image) is not export.KinectImage.UNMIRRORED:
            raise BadInputError("--kinect-image applies to camera-toml only")
        if fmt is export.ExportFormat.CSV and (args.rate, args.units, args.up_axis) != (None, None, None):
            raise BadInputError("csv writes the frames as they are, in metres and the stream's axes: "
                                "--rate, --units and --up-axis apply to c3d and trc")
        if fmt is export.ExportFormat.C3D and args.up_axis is not None:
            raise BadInputError("c3d is always z up; --up-axis applies to trc")
        recording = load_recording(recording_dir(args.input))
        if args.camera is None and len(recording.cameras) > 1:
            raise BadInputError(f"{args.input} has several cameras; choose one with --camera "
                                f"({', '.join(recording.camera_names)})")
        camera = recording.cameras[0] if args.camera is None else recording.camera(args.camera)
        if camera.skeleton is None:
            raise BadInputError(f"camera {camera.name} of {args.input} has no skeleton stream")
        axes = None if recording.metadata.get("frame") == "world" else camera.intrinsics.axes
        options = {k: v for k, v in (("rate_hz", args.rate), ("units", args.units), ("up_axis", args.up_axis))
                   if v is not None}
        if fmt is export.ExportFormat.CSV:
            export.export_csv(camera.skeleton, args.out)
        elif fmt is export.ExportFormat.C3D:
            export.export_c3d(camera.skeleton, args.out, camera_axes=axes, **options)
        else:
            export.export_trc(camera.skeleton, args.out, camera_axes=axes, **options)
    print(f"wrote {args.out}")


def _export_cohort(args: argparse.Namespace, skeleton_only: dict[str, object]) -> None:
    from fusion.errors import BadInputError
    from scenarios.clinical.cohort_export import export_cohort

    given = [k for k, v in {"INPUT": args.input, **skeleton_only}.items() if v is not None]
    if given:
        raise BadInputError(f"--cohort exports every subject's skeletons as recorded (csv) or at their own rate in "
                            f"the default units (c3d mm, trc m y up); drop {', '.join(given)}")
    result = export_cohort(args.cohort, args.format, args.out, truth=args.truth, overwrite=args.overwrite)
    print(f"wrote {result.out_dir}: {len(result.files)} files ({result.format.value})")
    if result.skipped:
        print(f"no fused skeleton (calibration or fusion failed): {', '.join(result.skipped)}")


def _cmd_layout(args: argparse.Namespace) -> None:
    from tqdm import tqdm

    from scenarios.config import load_scenario
    from scenarios.studies.layout import (
        layout_study,
        tables_markdown,
        write_layout_report,
    )

    scenario = load_scenario(args.scenario)
    if args.seed is not None:
        scenario = scenario.replace(seed=args.seed)
    if args.duration is not None:
        scenario = scenario.replace(duration_s=args.duration)
    with tqdm(total=2, desc=f"layout {scenario.name}", unit="step", leave=False) as bar:
        def step(message: str) -> None:
            bar.set_postfix_str(message)
            bar.update(1)

        result = layout_study(scenario, poses=args.poses, sweep=sweep_options(args), progress=step,
                              algorithm=args.algorithm)
    write_layout_report(result, args.out, overwrite=args.overwrite)
    print(tables_markdown(result))
    print(f"wrote {args.out} (tables.md, tables.png, layouts.png, layout.json)")


def _cmd_angle_figure(args: argparse.Namespace) -> None:
    from scenarios.studies.angle_figure import plot_angle_frames, salute_top_pose

    plot_angle_frames(salute_top_pose(), args.out)
    print(f"wrote {args.out}")


def _cmd_angle_study(args: argparse.Namespace) -> None:
    import json

    from tqdm import tqdm

    from fusion.io.atomic import atomic_directory
    from scenarios.config import load_scenario
    from scenarios.studies.angle_study import angle_study, angle_study_markdown
    from sim.tracker_bias import TrackerBias

    scenario = load_scenario(args.scenario)
    if args.duration is not None:
        scenario = scenario.replace(duration_s=args.duration)
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    subsets = [None if s == "all" else s.split("+") for s in args.cameras]
    with tqdm(total=len(seeds), desc=f"angle study {scenario.name}", unit="seed", leave=False) as bar:
        result = angle_study(scenario, seeds, subsets=subsets, bias=TrackerBias(args.tracker_bias), progress=bar.update,
                             algorithm=args.algorithm, limb_axes=args.limb_axes)
    text = angle_study_markdown(result)
    with atomic_directory(args.out, overwrite=args.overwrite) as tmp:
        (tmp / "angle_study.md").write_text(text, encoding="utf-8")
        (tmp / "angle_study.json").write_text(json.dumps(result, indent=1) + "\n", encoding="utf-8")
    print(text)
    print(f"wrote {args.out} (angle_study.md, angle_study.json)")


def register(sub: argparse._SubParsersAction) -> None:
    """Add the fuse, export, layout, angle-figure, angle-study sub-commands."""
    p = sub.add_parser("fuse", help="merge the calibrated cameras into one skeleton stream and one point cloud")
    p.add_argument("run", type=Path, help="run directory or recording directory")
    p.add_argument("--calib", required=True, type=Path, help="calibration TOML from `calibrate`")
    add_choice(p, "--fit", default="kinematic", path="fusion.merge.fuse.Fit",
                   help="kinematic: fit one articulated skeleton to all cameras (default); merge: merge per joint "
                        "and frame with a method of the paper (--method)")
    add_choice(p, "--method", default=None, path="fusion.merge.methods.MergeMethod",
                   help="merging method of --fit merge (default avg_frontal)")
    p.add_argument("--neutral", type=float, nargs=2, default=None, metavar=("START", "END"),
                   help="neutral-pose trial [s]: remove the angles' constant offsets over it")
    add_choice(p, "--filter", default="none", path="fusion.merge.filters.TemporalFilter", help="temporal filter")
    p.add_argument("--bone-lengths", action="store_true", help="make bone lengths constant over time")
    p.add_argument("--limb-axes", action="store_true",
                   help="move the limb joints onto the upper arms', forearms', thighs' and shanks' axes fitted to the "
                        "depth clouds, the shoulders and hips to where those axes meet in the trunk, and the hands to "
                        "the cloud's hand (needs depth frames; fusion.merge.limb_axes)")
    add_choice(p, "--limb-axes-without", path="fusion.merge.limb_axis_options.OPTIONAL_PARTS", nargs="+", default=[],
               metavar="PART", help="with --limb-axes, leave out the shoulders' and hips' centres (or one pair of them) "
                                    "or the hands from the clouds, e.g. hands for depth without body labels where a "
                                    "hand rests on a table, shoulder-centres for a single arm's movement")
    p.add_argument("--no-relabel", action="store_true",
                   help="keep back-facing skeletons' labels as reported (the paper only down-weights them)")
    p.add_argument("--cloud-time", type=float, default=None, metavar="SECONDS",
                   help="time of the merged point cloud (default: mid-session)")
    p.add_argument("--mesh", action="store_true", help="also write a surface mesh of the cloud (mesh.glb)")
    p.add_argument("--no-move-check", action="store_true",
                   help="fuse even when a camera disagrees with the others for a stretch of the session (it moved)")
    p.add_argument("--no-clock-check", action="store_true",
                   help="fuse even when the body's motion says the calibration's clock offsets are off by > 0.25 s")
    p.add_argument("--out", required=True, type=Path, help="output directory")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_fuse)

    p = sub.add_parser("export", help="export a fused skeleton (C3D, TRC, CSV), a calibration (camera TOML) or a "
                                      "whole cohort with its labels (--cohort: CSV, C3D, TRC, Motion-BIDS)")
    p.add_argument("input", type=Path, nargs="?", default=None,
                   help="fused directory or recording (c3d, trc, csv); calibration TOML (camera-toml)")
    p.add_argument("--cohort", type=Path, default=None, metavar="DIR",
                   help="cohort folder from `mocap-bench cohort`: one file per subject, labels inside; --out is a folder")
    p.add_argument("--truth", action="store_true", help="--cohort: also export the ground-truth skeletons")
    add_choice(p, "--format", required=True, path="fusion.io.export.ExportFormat", help="output format")
    p.add_argument("--out", required=True, type=Path, help="file to write (a folder with --cohort)")
    p.add_argument("--camera", default=None,
                   help="camera of the recording (default: its only camera); its frame is turned z up (C3D) or y up (TRC)")
    p.add_argument("--rate", type=float, default=None, metavar="HZ",
                   help="c3d, trc: frame rate of the uniform grid (default: the median frame rate)")
    add_choice(p, "--units", path="fusion.frames.LengthUnit", members=("M", "MM"), default=None, help="c3d (default mm), trc (default m): length unit")
    add_choice(p, "--up-axis", path="fusion.frames.UpAxis", default=None,
                   help="trc: vertical axis (default y, OpenSim: x forward, y up, z right)")
    add_choice(p, "--kinect-image", path="fusion.io.export.KinectImage", default="unmirrored",
                   help="camera-toml: describe the left-right flipped Kinect v2 images with fx > 0 (default) "
                        "or the mirrored images as recorded with fx < 0")
    p.add_argument("--overwrite", action="store_true", help="replace an existing output file (or folder)")
    p.set_defaults(func=_cmd_export)

    p = sub.add_parser("layout", help="compare camera layouts and merging methods (the paper's Tables 2 and 3)")
    p.add_argument("scenario", nargs="?", default="ring6", help="ring scenario (default ring6)")
    p.add_argument("--out", required=True, type=Path, help="report directory")
    add_choice(p, "--poses", path="scenarios.config.PoseSource", default="body",
                   help="calibrate from the body (default) or use the true camera poses")
    p.add_argument("--seed", type=int, default=None, help="override the scenario's seed")
    p.add_argument("--duration", type=float, default=None, metavar="SECONDS", help="truncate the session")
    p.add_argument("--algorithm", default=None, metavar="MODULE:FUNCTION",
                   help="also compare your fusion, fn(recording, calibration) -> (T, J, 3) positions [m] on the "
                        "reference camera's frames, in Table 3 (package.module:function or path/to/file.py:function; "
                        "see scenarios.api)")
    add_sweep_arguments(p)
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_layout)

    p = sub.add_parser("angle-figure", help="draw the segment frames of the joint angles on the humanoid (PNG)")
    p.add_argument("--out", required=True, type=Path, help="PNG file to write")
    p.set_defaults(func=_cmd_angle_figure)

    p = sub.add_parser("angle-study", help="joint and clinical-angle errors: kinematic fusion against Avg(Frontal)")
    p.add_argument("scenario", nargs="?", default="fma_2cam", help="scenario (default fma_2cam)")
    p.add_argument("--out", required=True, type=Path, help="report directory")
    p.add_argument("--seeds", type=int, default=10, help="number of seeds (default 10)")
    p.add_argument("--first-seed", type=int, default=1, help="first seed (default 1)")
    p.add_argument("--duration", type=float, default=None, metavar="SECONDS", help="truncate each session")
    p.add_argument("--cameras", nargs="+", default=["all"], metavar="SUBSET",
                   help="camera subsets, 'all' or names joined by '+', e.g. all cam1+cam3+cam5")
    add_choice(p, "--tracker-bias", path="sim.tracker_bias.TrackerBias", default="on",
                   help="off: the simulated tracker's static biases switched off (jitter, outliers, flips kept); "
                        "model-off / view-off: their body-model / view-dependent part; arms-off: both parts on "
                        "the limb and hand joints")
    p.add_argument("--limb-axes", action="store_true",
                   help="simulate depth frames too (at least 10 Hz) and score both fusions once more with the joints "
                        "corrected from the depth clouds as fuse --limb-axes does (rows +axes)")
    p.add_argument("--algorithm", default=None, metavar="MODULE:FUNCTION",
                   help="also score your fusion, fn(recording, calibration) -> (T, J, 3) positions [m] on the "
                        "reference camera's frames, with the true camera poses (package.module:function or "
                        "path/to/file.py:function; see scenarios.api)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_angle_study)
