"""Commands that fit sensor profiles to real recordings and compare simulations with them:
sensor-fit, sensor-validate, sim-to-real, device-swap, angle-validate."""

from __future__ import annotations

import argparse
from pathlib import Path

from scenarios.cli.choices import add_choice


def _recording(spec: str, layout: str | None):
    """A recording directory, or with a CSV layout one file per camera joined by '+'."""
    from fusion.io.recording_files import load_recording
    from scenarios.cli.formats_commands import layout_recording
    from scenarios.runner import recording_dir

    if layout is None:
        return load_recording(recording_dir(spec))
    files = [Path(p) for p in spec.split("+")]
    return layout_recording(files, layout, names=[f"cam{i + 1}" for i in range(len(files))])


def _base_profile(base: str | None, recordings: dict):
    """``--base``, or the built-in profile of the tracker the recordings come from (the full joint set of
    a reduced one: UI-PRMD's files are a Kinect v2's)."""
    from fusion.errors import BadInputError
    from scenarios.runner import default_profile
    from sim.sensor_profile import load_profile

    sets = sorted({r.topology.full_set.name for r in recordings.values()})
    if len(sets) > 1:
        raise BadInputError(f"the recordings come from different trackers ({', '.join(sets)}); give one tracker's")
    return load_profile(base or default_profile(sets[0]))


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


def _persons(labels: list[str] | None, names: list[str]) -> dict[str, str] | None:
    from fusion.errors import BadInputError

    if labels is None:
        return None
    if len(labels) != len(names):
        raise BadInputError(f"give one --persons label per recording ({len(names)}), got {len(labels)}")
    return dict(zip(names, labels))


def _with_labs(recordings: dict, labels: list[str] | None) -> dict:
    """``recordings`` as ``--labs`` says: no lab (the default), their own (``recorded``), or one given per
    recording."""
    from fusion.errors import BadInputError

    if labels is None:
        return {n: r.with_lab(None) for n, r in recordings.items()}
    if labels != ["recorded"]:
        if len(labels) != len(recordings):
            raise BadInputError(f"give one --labs label per recording ({len(recordings)}), or 'recorded'; got {len(labels)}")
        recordings = {n: r.with_lab(lab) for (n, r), lab in zip(recordings.items(), labels)}
    named = sorted({r.lab for r in recordings.values() if r.lab is not None})
    if len(named) < 2:
        print(f"--labs: the recordings name {len(named)} lab(s){' (' + named[0] + ')' if named else ''}; a lab level "
              "needs two or more, so none is fitted")
    return recordings


def _add_labs(p: argparse.ArgumentParser) -> None:
    p.add_argument("--labs", nargs="+", default=None, metavar="LAB",
                   help="fit a population per lab: the lab each recording comes from, one label per recording, or "
                        "'recorded' for the recordings' own (import --lab); each lab of two or more gets its own "
                        "(default: no lab level)")


def _refinement(args: argparse.Namespace) -> dict:
    """Keywords of the refinement: ``speeds`` when ``--speeds`` was given (else its default grid) and
    ``structure``."""
    return ({} if args.speeds is None else {"speeds": tuple(args.speeds)}) | {"structure": tuple(args.structure)}


def _add_refinement(p: argparse.ArgumentParser) -> None:
    """The refinement's ``--speeds`` (its default grid: ``scenarios.sensors.fit_replica.SPEED_GRID_M_S``) and
    ``--structure`` options."""
    p.add_argument("--speeds", type=float, nargs="+", default=None, metavar="M_S",
                   help="reference speeds [m/s] of the tracker's speed dependence tried by the refinement, 0 for "
                        "none (default: 0 0.2 0.1 0.05 0.025); the one with the smallest loss is kept")
    add_choice(p, "--structure", path="scenarios.sensors.fit_structure.STRUCTURE_PARTS", nargs="+", default=[],
               metavar="PART",
               help="optional parts of the tracker model the refinement fits as well (from two-camera recordings: "
                    "limb-sharing: the view bias shared along a limb, from the cosine of neighbouring limb joints' "
                    "steady residuals; hidden-offsets: occluded joints reported confident with a guessed offset, "
                    "from the elbows' and wrists' residuals beyond 8 cm; bone-view: the view bias of the limb joints "
                    "leaning along their bones, from the share of the elbows' and wrists' steady residuals along them; "
                    "bone-noise: the jitter, slow error and outliers of the "
                    "limb joints leaning along their bones, from the share of the elbows' and wrists' frame-to-frame "
                    "steps along them; outlier-size: each joint group's outlier sizes, from the length of the "
                    "second differences over 5 cm; camera-scale: each camera scaling the whole skeleton, from how "
                    "much larger the second camera sees the limb bones; shared-bones: every camera holding the "
                    "person's own bone lengths, from how far the cameras disagree on the bones' proportions; "
                    "group-activity: each joint group's jitter growing "
                    "with the session's activity beyond the common factor, from three recordings or more); default "
                    "none: the base profile's values")


def _cmd_sensor_fit(args: argparse.Namespace) -> None:
    from fusion.io.atomic import check_output_file, write_text_atomic
    from scenarios.cli.outputs import check_output_dir
    from scenarios.config import load_scenario
    from scenarios.sensors.fit_and_compare import check_refinement, fit_sensor
    from scenarios.sensors.fit_report import (
        body_scale_words,
        error_growth,
        write_fit_report,
    )
    from sim.sensor_profile import profile_to_toml

    check_output_file(args.out, overwrite=args.overwrite)
    if args.report is not None:
        check_output_dir(args.report, overwrite=args.overwrite)
    check_refinement(replicas=args.replicas or args.population, scenario=args.scenario, structure=args.structure)
    calibs = _calibrations(args.calib, len(args.recordings))
    recordings = _with_labs({_name(spec): _recording(spec, args.layout) for spec in args.recordings}, args.labs)
    fit = fit_sensor(recordings, _base_profile(args.base, recordings),
                     calibrations=dict(zip(recordings, calibs)), name=args.name,
                     scenario=None if args.scenario is None else load_scenario(args.scenario),
                     replicas=args.replicas, iterations=args.iterations, jobs=args.jobs,
                     n_boot=args.bootstrap, seed=args.seed, population=args.population,
                     persons=_persons(args.persons, list(recordings)), **_refinement(args))
    if fit.bone_spread_m is not None:
        print(f"bone spread matched by simulating {args.scenario}: {1e3 * fit.bone_spread_m:.1f} mm")
    write_text_atomic(args.out, profile_to_toml(fit.profile))
    print(f"wrote {args.out}")
    if args.report is not None:
        for path in write_fit_report(fit.analytic, args.report, fit.replica, fit.cases, fit.population):
            print(f"wrote {path}")
    tr = fit.profile.tracker
    print(f"wobble time constant {tr.wobble_tau_s:.2f} s, {error_growth(tr)}, {body_scale_words(tr)}")
    for g, noise in tr.groups.items():
        print(f"  {g.value:6s} white {1e3 * noise.jitter_m:.2f} mm, wobble {1e3 * noise.wobble_m:.2f} mm, "
              f"outliers {100 * noise.outlier_rate:.2f} %, bone rigidity {noise.bone_rigidity:.2f}")
    if fit.population is not None:
        print("population (log units; confidence: arcsine square root, rad): family, mean, between people, between sessions, "
              "elasticity")
        for f, ff in fit.population.families.items():
            print(f"  {f.value:10s} {ff.spread.mean:+.3f}  {ff.spread.person_sd:.3f}  {ff.spread.session_sd:.3f}  "
                  f"{ff.elasticity:.2f}" + (f"  ({ff.note})" if ff.note else ""))
        for lab, pop in fit.profile.population.labs.items():
            print(f"  lab {lab}: " + ", ".join(f"{f.value} {s.mean:+.3f} / {s.person_sd:.3f}" for f, s in pop.spreads.items()))


def _cmd_sensor_validate(args: argparse.Namespace) -> None:
    import shlex

    from tqdm import tqdm

    from scenarios.sensors.fit_and_compare import measure_recordings
    from scenarios.sensors.fit_population import person_of
    from scenarios.sensors.replica_case import prepare_cases
    from scenarios.sensors.validate_population import (
        calibration_counts,
        check_validation,
        leave_one_person_out,
        pass_counts,
    )
    from scenarios.sensors.validate_report import write_validation

    recordings = _with_labs({_name(spec): _recording(spec, args.layout) for spec in args.recordings}, args.labs)
    persons = _persons(args.persons, list(recordings)) or {n: person_of(n) for n in recordings}
    check_validation(persons, args.draws)
    base = _base_profile(args.base, recordings)
    calibs, stats = measure_recordings(recordings, None, calibrate=True, n_boot=0, seed=args.seed, jobs=args.jobs)
    with tqdm(total=len(recordings), desc="replicas", unit="recording", leave=False) as bar:
        cases = prepare_cases(recordings, calibs, stats, jobs=args.jobs, progress=bar.update)
    folds = leave_one_person_out(recordings, stats, cases, persons, base, draws=args.draws,
                                 iterations=args.iterations, seed=args.seed, jobs=args.jobs, progress=print,
                                 **_refinement(args))
    shown = [a for a in args.argv if a not in args.recordings]  # the recordings named by count, not one by one
    command = "mocap-bench " + shlex.join(shown[:1]) + f" <{len(args.recordings)} recordings: {_name(args.recordings[0])}"\
        f" ... {_name(args.recordings[-1])}> " + shlex.join(shown[1:])
    for path in write_validation(folds, args.out, args.draws, command):
        print(f"wrote {path}")
    for which in ("population", "typical"):
        counts = pass_counts(folds, which)
        table = calibration_counts(folds, which).values()
        outside = sum(c.below_all + c.above_all for c in table)
        print(f"{which}: " + ", ".join(f"{p} {k}/{n}" for p, (k, n) in counts.items())
              + f"; as wide as its draws it would pass {sum(c.expected_passing for c in table):.0f}; "
              f"outside every draw {outside} (calibrated: {sum(2 * c.expected_tail for c in table):.0f})")


def _cmd_sim_to_real(args: argparse.Namespace) -> None:
    import shlex

    from fusion.io.calibration_file import save_calibration
    from scenarios.cli.outputs import check_output_dir
    from scenarios.config import load_scenario
    from scenarios.sensors.fit_and_compare import compare_session
    from scenarios.sensors.fit_report import (
        band_summary,
        band_table,
        comparison_table,
        write_sim_to_real,
        write_sim_to_real_band,
    )

    check_output_dir(args.out, overwrite=args.overwrite)
    real = _recording(args.recording, args.layout)
    (calibration,) = _calibrations([args.calib] if args.calib else None, 1)
    scenario = None if args.scenario is None else load_scenario(args.scenario)
    name = _name(args.recording)
    result, used, replica_path = compare_session(real, args.out, calibration=calibration, scenario=scenario,
                                                 profile=args.profile, name=name, n_boot=args.bootstrap,
                                                 seed=args.seed, draws=args.draws)
    if calibration is None and used is not None:
        save_calibration(used, args.out / "calibration.toml")
        notes = used.info.get("notes") or ["calibrated from the body (skeletons only)"]
        print(f"{notes[0]}; wrote {args.out / 'calibration.toml'}")
    if replica_path is not None:
        print(f"wrote {replica_path} (the replica simulated)")
    if args.draws == 1:
        for path in write_sim_to_real(result, name, args.out):
            print(f"wrote {path}")
        print(comparison_table({name: result.rows}))
        return
    for path in write_sim_to_real_band(result, name, args.out, "mocap-bench " + shlex.join(args.argv)):
        print(f"wrote {path}")
    print(f"sensor profile {result.profile}; {result.population}")
    print(band_table(result.rows) + band_summary(result))


def _cmd_device_swap(args: argparse.Namespace) -> None:
    import shlex

    from scenarios.cli.outputs import check_output_dir
    from scenarios.sensors.device_swap import swap_session
    from scenarios.sensors.device_swap_report import swap_table, write_device_swap

    check_output_dir(args.out, overwrite=args.overwrite)
    real = _recording(args.recording, args.layout)
    (calibration,) = _calibrations([args.calib] if args.calib else None, 1)
    name = _name(args.recording)
    result = swap_session(real, args.out, from_profile=args.from_profile, to_profile=args.to_profile, draws=args.draws,
                          calibration=calibration, seed=args.seed, name=name)
    for path in write_device_swap(result, name, args.out, "mocap-bench " + shlex.join(args.argv)):
        print(f"wrote {path}")
    print(swap_table(result), end="")


def _cmd_angle_validate(args: argparse.Namespace) -> None:
    import shlex

    import numpy as np

    from scenarios.cli.outputs import check_output_dir
    from scenarios.sensors.angle_validate import summarise
    from scenarios.sensors.angle_validate_report import agreement, expected_agreement
    from scenarios.sensors.angle_validate_run import validate_dataset

    out = check_output_dir(args.out, overwrite=args.overwrite)
    done = validate_dataset(args.dataset, out, command="mocap-bench " + shlex.join(args.argv), subjects=args.subjects,
                            movements=args.movements, profile=args.profile,
                            seeds=range(args.seed, args.seed + args.seeds), limit=args.limit, incorrect=args.incorrect,
                            fit=True if args.fit == [] else args.fit or False, leave_one_out=args.leave_one_out,
                            jobs=args.jobs, say=print)
    for path in done.written:
        print(f"wrote {path}")
    summary = summarise(done.results)
    k, n = agreement(summary)
    expected = expected_agreement(summary)
    print(f"{len(done.results)} episodes" + (f" ({len(done.left_out)} left out, unreadable)" if done.left_out else "")
          + f"; simulated mean error agrees with the real one in {k}/{n} rows ("
          + (f"a simulation with exactly the right mean errors: {expected:.1f} of {n} on as many new people, on average)"
             if np.isfinite(expected) else "under three subjects: too few to judge a correct simulation by)"))


def register(sub: argparse._SubParsersAction) -> None:
    """Add the sensor-fit, sensor-validate, sim-to-real, device-swap and angle-validate sub-commands."""
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
                        "simulation-based fit of every tracker parameter the statistics see, see docs/studies/sensor_profiles.md)")
    p.add_argument("--population", action="store_true",
                   help="also fit how the tracker varies between people and sessions (implies --replicas; "
                        "sessions of two people or more for the between-person part)")
    p.add_argument("--persons", nargs="+", default=None, metavar="LABEL",
                   help="whose recording each is, one label per recording (default: each file name up to its "
                        "first underscore)")
    _add_labs(p)
    p.add_argument("--iterations", type=int, default=5, help="refinement iterations per reference speed (default 5)")
    _add_refinement(p)
    p.add_argument("--jobs", type=int, default=-1,
                   help="processes measuring recordings, building replicas and refining at once (default -1: one per core)")
    p.add_argument("--bootstrap", type=int, default=100, help="bootstrap resamples per statistic (default 100)")
    p.add_argument("--seed", type=int, default=0, help="seed of the calibration and bootstrap draws")
    p.add_argument("--overwrite", action="store_true",
                   help="replace an existing profile TOML and write into a non-empty --report directory")
    p.set_defaults(func=_cmd_sensor_fit)

    p = sub.add_parser("sensor-validate", help="leave-one-person-out check of a sensor population fit")
    p.add_argument("recordings", nargs="+", metavar="RECORDING",
                   help="sessions of two people or more (recording directories, or CSVs through --layout joined by '+')")
    p.add_argument("--out", required=True, type=Path, help="directory for report.md, results.json and validate.png")
    p.add_argument("--layout", default=None, metavar="NAME|TOML", help="read CSVs through a layout (azure_2cam, kimore)")
    p.add_argument("--persons", nargs="+", default=None, metavar="LABEL",
                   help="whose recording each is, one label per recording (default: each name up to its first underscore)")
    _add_labs(p)
    p.add_argument("--base", default=None, help="profile whose unfitted values are kept (default: built-in of the topology)")
    p.add_argument("--draws", type=int, default=6, help="simulated people per left-out session (default 6)")
    p.add_argument("--iterations", type=int, default=5, help="refinement iterations per reference speed (default 5)")
    _add_refinement(p)
    p.add_argument("--jobs", type=int, default=-1, help="processes at once (default -1: one per core)")
    p.add_argument("--seed", type=int, default=0, help="seed of the calibrations, re-trackings and draws")
    p.set_defaults(func=_cmd_sensor_validate)

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
    p.add_argument("--out", required=True, type=Path,
                   help="directory for sim_to_real.md/.json/.png (with --draws N > 1: report.md, results.json, band.png)")
    p.add_argument("--draws", type=int, default=1, metavar="N",
                   help="simulate the stand-in N times (scenario seeds seed .. seed+N-1, each a person and session of "
                        "the profile's population) and judge the session against the draws' 5-95 %% band (default 1)")
    p.add_argument("--bootstrap", type=int, default=100, help="bootstrap resamples per statistic (default 100)")
    p.add_argument("--seed", type=int, default=0, help="seed of the calibration and bootstrap draws")
    p.add_argument("--overwrite", action="store_true", help="write into an existing non-empty --out directory")
    p.set_defaults(func=_cmd_sim_to_real)

    p = sub.add_parser("device-swap", help="simulate a real session's replica with two sensor profiles and table "
                                           "what changes (truth-free statistics, calibration, joint and angle errors)")
    p.add_argument("recording", metavar="RUN_OR_RECORDING",
                   help="recording directory, or with --layout the CSV files of the session joined by '+'")
    p.add_argument("--calib", type=Path, default=None,
                   help="calibration of the real cameras (default: from the body, skeletons only)")
    p.add_argument("--from", dest="from_profile", default=None, metavar="PROFILE",
                   help="sensor profile the session was recorded with (built-in name or TOML; default: the "
                        "built-in of the session's topology)")
    p.add_argument("--to", dest="to_profile", required=True, metavar="PROFILE",
                   help="sensor profile to swap to (built-in name or TOML), e.g. orbbec_femto_bolt")
    p.add_argument("--draws", type=int, default=3, metavar="N",
                   help="scenario seeds per profile, seed .. seed+N-1, the same for both (default 3)")
    p.add_argument("--layout", default=None, metavar="NAME|TOML", help="read CSVs through a layout (azure_2cam, kimore)")
    p.add_argument("--out", required=True, type=Path,
                   help="directory for report.md, results.json, swap.png and the replica (replica.toml, its motion)")
    p.add_argument("--seed", type=int, default=0, help="first scenario seed and seed of the body calibrations")
    p.add_argument("--overwrite", action="store_true", help="write into an existing non-empty --out directory")
    p.set_defaults(func=_cmd_device_swap)

    p = sub.add_parser("angle-validate", help="clinical angle errors of the real Kinect and of its simulation against "
                                              "an optical reference (UI-PRMD)")
    p.add_argument("dataset", type=Path, metavar="DATASET", help="the UI-PRMD folder (holding 'Segmented Movements')")
    p.add_argument("--subjects", nargs="+", default=None, metavar="SUBJECT", help="e.g. s01 s02 (default: all present)")
    p.add_argument("--movements", nargs="+", default=None, metavar="MOVEMENT",
                   help="e.g. m07 m10 (default: the shoulder movements m07-m10)")
    p.add_argument("--out", required=True, type=Path, help="directory for report.md, results.json and traces.png")
    p.add_argument("--profile", default="kinect_v2", help="Kinect v2 sensor profile of the simulation (default kinect_v2)")
    p.add_argument("--seeds", type=int, default=2,
                   help="simulations per episode (default 2): per seed, each subject is a simulated person of its "
                        "own, the same in all its episodes, and each episode a session of its own")
    p.add_argument("--seed", type=int, default=0, help="first simulation seed (default 0)")
    p.add_argument("--limit", type=int, default=None, metavar="N", help="at most N episodes per subject and movement")
    p.add_argument("--incorrect", action="store_true", help="the incorrectly performed movements instead")
    add_choice(p, "--fit", path="scenarios.sensors.fit_arm_bias.FIT_PARTS", nargs="*", default=None, metavar="PART",
               help="fit the tracker's arm and trunk biases (or the PARTs named) to these subjects' real errors, write "
                    "OUT/profile_fitted.toml and simulate with it")
    p.add_argument("--leave-one-out", action="store_true",
                   help="with --fit: simulate each subject with the biases fitted without it (one profile per subject)")
    p.add_argument("--jobs", type=int, default=-1, help="processes at once (default -1: one per core)")
    p.add_argument("--overwrite", action="store_true", help="write into an existing non-empty --out directory")
    p.set_defaults(func=_cmd_angle_validate)
