"""Commands that fit sensor profiles to real recordings and compare simulations with them:
sensor-fit, sim-to-real."""

from __future__ import annotations

import argparse
from pathlib import Path


def _recording(spec: str, layout: str | None):
    """A recording directory, or with a CSV layout one file per camera joined by '+'."""
    from fusion.io.formats.csv_layout import read_csv_layout
    from fusion.io.recording import load_recording
    from scenarios.cli.formats import csv_layout
    from scenarios.runner import recording_dir

    if layout is None:
        return load_recording(recording_dir(spec))
    files = [Path(p) for p in spec.split("+")]
    return read_csv_layout(files, csv_layout(layout), names=[f"cam{i + 1}" for i in range(len(files))])


def _name(spec: str) -> str:
    return Path(spec.split("+")[0]).stem


def _calibrations(paths: list[Path] | None, n: int) -> list:
    from fusion.errors import BadInputError
    from fusion.io.calibration_file import load_calibration

    if not paths:
        return [None] * n
    if len(paths) != n:
        raise BadInputError(f"give one --calib per recording ({n}), got {len(paths)}")
    return [load_calibration(p) for p in paths]


def _cmd_sensor_fit(args: argparse.Namespace) -> None:
    import dataclasses

    import numpy as np
    from tqdm import tqdm

    from fusion.errors import BadInputError
    from fusion.io.atomic import write_text_atomic
    from scenarios.runner import DEFAULT_PROFILE
    from scenarios.sensor_fit import fit_profile, measure, session_calibration
    from scenarios.sensor_report import error_growth, write_fit_report
    from sim.sensor_profile import load_profile, profile_to_toml
    from sim.tracker_noise import JointGroup

    if args.replicas and args.scenario is not None:
        raise BadInputError("--replicas and --scenario both refine the fit: choose one")
    rng = np.random.default_rng(args.seed)
    calibs = _calibrations(args.calib, len(args.recordings))
    recordings, stats = {}, {}
    for i, spec in enumerate(tqdm(args.recordings, desc="sensor-fit", unit="recording", leave=False)):
        name = _name(spec)
        recordings[name] = _recording(spec, args.layout)
        if args.replicas and calibs[i] is None:
            calibs[i] = session_calibration(recordings[name], rng=rng)
        stats[name] = measure(recordings[name], None if calibs[i] is None else calibs[i].T_world_cam,
                              n_boot=args.bootstrap, rng=rng)
    topology = next(iter(recordings.values())).topology.name
    base = load_profile(args.base or DEFAULT_PROFILE[topology])
    result = fit_profile(recordings, stats, base, name=args.name or base.name)
    replica, cases = None, []
    if args.scenario is not None:
        from scenarios.config import load_scenario
        from scenarios.sensor_fit_sim import refine_bones

        profile, spread = refine_bones(result, load_scenario(args.scenario))
        result = dataclasses.replace(result, profile=profile, tau_s=profile.tracker.wobble_tau_s,
                                     rigidity=profile.tracker.groups[JointGroup.LIMB].bone_rigidity,
                                     wobble_m={g: n.wobble_m for g, n in profile.tracker.groups.items()})
        print(f"bone spread matched by simulating {args.scenario}: {1e3 * spread:.1f} mm")
    if args.replicas:
        from scenarios.replica_case import prepare_cases
        from scenarios.sensor_fit_replica import SPEED_GRID_M_S, refine_on_replicas

        with tqdm(total=len(recordings), desc="replicas", unit="recording", leave=False) as bar:
            cases = prepare_cases(recordings, dict(zip(recordings, calibs)), stats, jobs=args.jobs, progress=bar.update)
        with tqdm(total=len(SPEED_GRID_M_S) * (args.iterations + 1), desc="refine", unit="trial", leave=False) as bar:
            replica = refine_on_replicas(result.profile, cases, iterations=args.iterations, seed=args.seed,
                                         jobs=args.jobs, progress=bar.update)
    profile = replica.profile if replica is not None else result.profile
    write_text_atomic(args.out, profile_to_toml(profile))
    print(f"wrote {args.out}")
    if args.report is not None:
        for path in write_fit_report(result, args.report, replica, cases):
            print(f"wrote {path}")
    tr = profile.tracker
    print(f"wobble time constant {tr.wobble_tau_s:.2f} s, {error_growth(tr)}")
    for g, noise in tr.groups.items():
        print(f"  {g.value:6s} white {1e3 * noise.jitter_m:.2f} mm, wobble {1e3 * noise.wobble_m:.2f} mm, "
              f"outliers {100 * noise.outlier_rate:.2f} %, bone rigidity {noise.bone_rigidity:.2f}")


def _replica_scenario(real, calibration, args: argparse.Namespace):
    """The replica of ``real`` (``mocap-bench replica``) from ``calibration``, its motion file written into ``args.out``."""
    from scenarios.cli.replay import replica_with_progress
    from scenarios.replica import write_replica

    args.out.mkdir(parents=True, exist_ok=True)
    replica = replica_with_progress(real, calibration, name=f"replica_{_name(args.recording)}",
                                    motion_path=args.out / "replica.motion.npz")
    scenario_path, _ = write_replica(replica, args.out / "replica.toml")
    print(f"wrote {scenario_path} (the replica simulated below)")
    return replica.scenario


def _session_calibration(real, out: Path, rng):
    """The real cameras calibrated from the body (one camera: level, feet on the floor), written to
    ``out/calibration.toml`` for reuse with ``--calib``."""
    from fusion.io.calibration_file import save_calibration
    from scenarios.sensor_fit import session_calibration

    calibration = session_calibration(real, rng=rng)
    out.mkdir(parents=True, exist_ok=True)
    save_calibration(calibration, out / "calibration.toml")
    notes = calibration.info.get("notes") or ["calibrated from the body (skeletons only)"]
    print(f"{notes[0]}; wrote {out / 'calibration.toml'}")
    return calibration


def _cmd_sim_to_real(args: argparse.Namespace) -> None:
    import numpy as np

    from scenarios.config import load_scenario
    from scenarios.sensor_report import comparison_table, write_sim_to_real
    from scenarios.sim_to_real import sim_to_real

    rng = np.random.default_rng(args.seed)
    real = _recording(args.recording, args.layout)
    (calibration,) = _calibrations([args.calib] if args.calib else None, 1)
    if args.scenario is not None:
        scenario = load_scenario(args.scenario)
    else:
        if calibration is None:
            calibration = _session_calibration(real, args.out, rng)
        scenario = _replica_scenario(real, calibration, args)
    T = None if calibration is None else calibration.T_world_cam
    result = sim_to_real(real, scenario, profile=args.profile, T_world_cam=T, n_boot=args.bootstrap, rng=rng)
    name = _name(args.recording)
    for path in write_sim_to_real(result, name, args.out):
        print(f"wrote {path}")
    print(comparison_table({name: result.rows}))


def register(sub: argparse._SubParsersAction) -> None:
    """Add the sensor-fit and sim-to-real sub-commands."""
    p = sub.add_parser("sensor-fit", help="fit a sensor profile to real recordings (no ground truth needed)")
    p.add_argument("recordings", nargs="+", metavar="RECORDING",
                   help="recording directory, or with --layout the CSV files of one session joined by '+'")
    p.add_argument("--out", required=True, type=Path, help="profile TOML to write")
    p.add_argument("--layout", default=None, metavar="NAME|TOML", help="read CSVs through a layout (azure_2cam, kimore)")
    p.add_argument("--calib", nargs="+", type=Path, default=None,
                   help="one calibration file per recording (default: calibrate multi-camera recordings from the body)")
    p.add_argument("--base", default=None, help="profile whose unfitted values are kept (default: built-in of the topology)")
    p.add_argument("--name", default=None, help="name of the fitted profile (default: the base's)")
    p.add_argument("--report", type=Path, default=None, help="directory for fit.md and fit.png")
    p.add_argument("--scenario", default=None,
                   help="scenario with the recordings' geometry: match the bone-length spread by simulating it")
    p.add_argument("--replicas", action="store_true",
                   help="refine the fit on each recording's replica (a one-camera recording as a level camera; a "
                        "simulation-based fit of every tracker parameter the statistics see, see docs/sensor_profiles.md)")
    p.add_argument("--iterations", type=int, default=5, help="refinement iterations per reference speed (default 5)")
    p.add_argument("--jobs", type=int, default=-1,
                   help="processes building replicas and refining reference speeds at once (default -1: one per core)")
    p.add_argument("--bootstrap", type=int, default=100, help="bootstrap resamples per statistic (default 100)")
    p.add_argument("--seed", type=int, default=0, help="seed of the calibration and bootstrap draws")
    p.set_defaults(func=_cmd_sensor_fit)

    p = sub.add_parser("sim-to-real", help="simulate a stand-in of a real session and compare statistics")
    p.add_argument("recording", metavar="RECORDING",
                   help="recording directory, or with --layout the CSV files of the session joined by '+'")
    p.add_argument("--scenario", default=None,
                   help="a scenario with the session's geometry (e.g. azure_2cam_45, kimore_frontal); default: the "
                        "session's replica, built from --calib (replica.toml and its motion file go into --out)")
    p.add_argument("--profile", default=None, help="sensor profile (built-in name or TOML) for the simulation")
    p.add_argument("--calib", type=Path, default=None, help="calibration of the real cameras (default: from the body, skeletons only, written to "
                        "OUT/calibration.toml; one camera: level, at the height that puts the feet on the floor)")
    p.add_argument("--layout", default=None, metavar="NAME|TOML", help="read CSVs through a layout (azure_2cam, kimore)")
    p.add_argument("--out", required=True, type=Path, help="directory for sim_to_real.md/.json/.png")
    p.add_argument("--bootstrap", type=int, default=100, help="bootstrap resamples per statistic (default 100)")
    p.add_argument("--seed", type=int, default=0, help="seed of the calibration and bootstrap draws")
    p.set_defaults(func=_cmd_sim_to_real)
