"""Benchmarks on the shared real samples: sensor fit, sensor fit on replicas, sim-to-real."""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from fusion.errors import ScenarioError

if TYPE_CHECKING:
    from scenarios.bench.runner import BenchmarkConfig

SAMPLES_DIR = Path(__file__).resolve().parents[2] / ".." / "shared" / "samples" / "azure_2cam"
"""The shared real two-camera sessions (outside the repository)."""


def azure_sessions(count: int) -> dict:
    from fusion.io.formats.csv_layout import AZURE_2CAM, read_csv_layout

    files = sorted(SAMPLES_DIR.glob("*_master_positions_3d.csv"))[:count]
    if not files:
        raise ScenarioError(f"this benchmark reads the shared real samples, not found in {SAMPLES_DIR.resolve()}")
    return {f.name[:9]: read_csv_layout([f, Path(str(f).replace("_master_", "_sub_"))], AZURE_2CAM,
                                        names=["master", "sub"]) for f in files}


def _timed(cfg: BenchmarkConfig, run: Callable[[int], None]) -> list[float]:
    """Wall time [s] of ``run(k)`` for each repeat ``k``."""
    samples = []
    for k in range(cfg.repeats):
        t0 = time.perf_counter()
        run(k)
        samples.append(time.perf_counter() - t0)
    return samples


def sensor_fit(cfg: BenchmarkConfig) -> list[float]:
    """Statistics of the nine sessions (body-calibrated, bootstrap intervals) and the analytic fit."""
    from scenarios.sensor_fit import fit_profile, measure
    from sim.sensor_profile import load_profile

    def run(k: int) -> None:
        recordings = azure_sessions(9)
        rng = np.random.default_rng(k)
        stats = {n: measure(r, n_boot=100, rng=rng) for n, r in recordings.items()}
        fit_profile(recordings, stats, load_profile("azure_kinect"), name="bench")

    return _timed(cfg, run)


def sim_to_real_bench(cfg: BenchmarkConfig) -> list[float]:
    """Import, body calibration, replica (fuse and retarget), simulation and statistics of one session."""
    import tempfile

    from scenarios.replica import build_replica, write_replica
    from scenarios.sensor_fit import body_calibration
    from scenarios.sim_to_real import sim_to_real

    def run(k: int) -> None:
        (real,) = azure_sessions(1).values()
        rng = np.random.default_rng(k)
        calibration = body_calibration(real, rng=rng)
        with tempfile.TemporaryDirectory() as tmp:
            replica = build_replica(real, calibration, name="bench", motion_path=Path(tmp) / "motion.npz")
            write_replica(replica, Path(tmp) / "replica.toml")
            sim_to_real(real, replica.scenario, T_world_cam=calibration.T_world_cam, n_boot=100, rng=rng)

    return _timed(cfg, run)


def sensor_fit_replicas(cfg: BenchmarkConfig) -> list[float]:
    """``sensor-fit --replicas`` over the nine sessions: statistics, analytic fit, replicas, refinement."""
    from scenarios.replica_case import prepare_cases
    from scenarios.sensor_fit import body_calibration, fit_profile, measure
    from scenarios.sensor_fit_replica import refine_on_replicas
    from sim.sensor_profile import load_profile

    def run(k: int) -> None:
        recordings = azure_sessions(9)
        rng = np.random.default_rng(k)
        calibrations = {n: body_calibration(r, rng=rng) for n, r in recordings.items()}
        stats = {n: measure(r, calibrations[n].T_world_cam, n_boot=100, rng=rng) for n, r in recordings.items()}
        fit = fit_profile(recordings, stats, load_profile("azure_kinect"), name="bench")
        refine_on_replicas(fit.profile, prepare_cases(recordings, calibrations, stats, jobs=-1), jobs=-1)

    return _timed(cfg, run)
