"""Benchmarks on the shared real samples: sensor fit, sensor fit on replicas and of populations (Azure Kinect,
Kinect v2), sim-to-real, angle-validate."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path

from fusion.errors import ScenarioError

SAMPLES_DIR = Path(__file__).resolve().parents[2] / ".." / "shared" / "samples" / "azure_2cam"
"""The shared real two-camera sessions (outside the repository)."""


def azure_sessions(count: int | None) -> dict:
    """The first ``count`` shared azure_2cam sessions by name (None: all of them)."""
    from fusion.io.formats.csv_layout import AZURE_2CAM, read_csv_layout

    files = sorted(SAMPLES_DIR.glob("*_master_positions_3d.csv"))[:count]
    if not files:
        raise ScenarioError(f"this benchmark reads the shared real samples, not found in {SAMPLES_DIR.resolve()}")
    return {f.name[:9]: read_csv_layout([f, Path(str(f).replace("_master_", "_sub_"))], AZURE_2CAM,
                                        names=["master", "sub"]) for f in files}


def _timed(repeats: int, run: Callable[[int], None]) -> list[float]:
    """Wall time [s] of ``run(k)`` for each repeat ``k``."""
    samples = []
    for k in range(repeats):
        t0 = time.perf_counter()
        run(k)
        samples.append(time.perf_counter() - t0)
    return samples


def sensor_fit(repeats: int) -> list[float]:
    """Statistics of the nine sessions (no calibration, bootstrap intervals) and the analytic fit."""
    from scenarios.sensors.fit_and_compare import fit_sensor
    from sim.sensor_profile import load_profile

    return _timed(repeats, lambda k: fit_sensor(azure_sessions(9), load_profile("azure_kinect"), name="bench", seed=k))


def sim_to_real_bench(repeats: int, draws: int = 1) -> list[float]:
    """Import, body calibration, replica (fuse and retarget), ``draws`` simulations and statistics of one session."""
    import tempfile

    from scenarios.sensors.fit_and_compare import compare_session

    def run(k: int) -> None:
        (real,) = azure_sessions(1).values()
        with tempfile.TemporaryDirectory() as tmp:
            compare_session(real, Path(tmp), name="bench", seed=k, draws=draws)

    return _timed(repeats, run)


def sensor_fit_replicas(repeats: int) -> list[float]:
    """``sensor-fit --replicas`` over the nine sessions: statistics, analytic fit, replicas, refinement."""
    from scenarios.sensors.fit_and_compare import fit_sensor
    from sim.sensor_profile import load_profile

    return _timed(repeats, lambda k: fit_sensor(azure_sessions(9), load_profile("azure_kinect"), name="bench",
                                            replicas=True, jobs=-1, seed=k))


def sensor_fit_population(repeats: int) -> list[float]:
    """``sensor-fit --population --speeds 0.4 --structure trunk-turn`` over every shared session (the built-in
    Azure profile's command): statistics, fit, replicas, refinement, population."""
    from scenarios.sensors.fit_and_compare import fit_sensor
    from sim.sensor_profile import load_profile

    return _timed(repeats, lambda k: fit_sensor(azure_sessions(None), load_profile("azure_kinect"), name="bench",
                                            population=True, jobs=-1, seed=k, speeds=(0.4,),
                                            structure=("trunk-turn",)))


def kinect_v2_recordings() -> tuple[dict, dict]:
    """The built-in ``kinect_v2`` profile's recordings, by name, and whose each is: UI-PRMD s01-s05, each
    movement m07-m10's ten correct repetitions as one recording, and KIMORE's four exercises of two people."""
    from fusion.io.formats.csv_layout import KIMORE, read_csv_layout
    from fusion.io.formats.ui_prmd import join_episodes, read_ui_prmd_kinect

    root = SAMPLES_DIR.parent
    positions = root / "ui_prmd" / "Segmented Movements" / "Kinect" / "Positions"
    if not positions.is_dir() or not (root / "kimore").is_dir():
        raise ScenarioError(f"this benchmark reads the shared UI-PRMD and KIMORE samples, not found in {root.resolve()}")
    recordings, persons = {}, {}
    for subject in ("s01", "s02", "s03", "s04", "s05"):
        for movement in ("m07", "m08", "m09", "m10"):
            files = sorted(positions.glob(f"{movement}_{subject}_e??_positions.txt.gz"))
            recordings[f"{subject}_{movement}"] = join_episodes([read_ui_prmd_kinect(f) for f in files])
            persons[f"{subject}_{movement}"] = subject
    for name, person in (("JointPositionExercise1", "P1"), ("JointPositionExercise2", "P1"),
                         ("JointPositionExercise1_2", "P2"), ("JointPositionExercise2_2", "P2")):
        recordings[name] = read_csv_layout([root / "kimore" / f"{name}.csv"], KIMORE, names=["cam1"])
        persons[name] = person
    return recordings, persons


def sensor_fit_population_kinect_v2(repeats: int) -> list[float]:
    """``sensor-fit --population --speeds 0.4`` of the built-in Kinect v2's 24 recordings of seven people
    (:func:`kinect_v2_recordings`, read untimed): statistics, fit, replicas, refinement, population."""
    from scenarios.sensors.fit_and_compare import fit_sensor
    from sim.sensor_profile import load_profile

    recordings, persons = kinect_v2_recordings()
    return _timed(repeats, lambda k: fit_sensor(recordings, load_profile("kinect_v2"), name="bench", population=True,
                                            persons=persons, jobs=-1, seed=k, speeds=(0.4,)))


def angle_validate_bench(repeats: int) -> list[float]:
    """``angle-validate --fit --leave-one-out`` of UI-PRMD's s01-s05 (the four shoulder movements, two seeds):
    clock ratios, arm offsets and six fits, then 200 real comparisons and 400 simulations, and the report."""
    import tempfile

    from scenarios.sensors.angle_validate_run import validate_dataset

    dataset = SAMPLES_DIR.parent / "ui_prmd"
    if not dataset.is_dir():
        raise ScenarioError(f"this benchmark reads the shared UI-PRMD samples, not found in {dataset.resolve()}")

    def run(k: int) -> None:
        with tempfile.TemporaryDirectory() as tmp:
            validate_dataset(dataset, Path(tmp), command="benchmark", subjects=["s01", "s02", "s03", "s04", "s05"],
                             seeds=(2 * k, 2 * k + 1), fit=True, leave_one_out=True)

    return _timed(repeats, run)
