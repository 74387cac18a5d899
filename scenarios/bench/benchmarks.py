"""Benchmarks: scenarios that measure speed, run by ``mocap-bench bench``, results in a Markdown table.

Each ``scenarios/bench/*.toml`` has one ``[benchmark]`` table (see :class:`BenchmarkConfig`).
Figures are medians over repeats; single-core benchmarks pin the process to one CPU.
"""

from __future__ import annotations

import enum
import json
import os
import platform
import statistics
import time
import tomllib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fusion.errors import ScenarioError
from fusion.io.atomic import write_text_atomic
from scenarios.bench import real_samples
from scenarios.bench.fusion_runs import (
    kinematic_rate,
    limb_axes_rate,
    merge_rate,
    scenario_of,
)
from scenarios.config import load_scenario
from scenarios.toml_tables import build_table
from sim.depth_renderer import DepthRenderer

BENCH_DIR = Path(__file__).resolve().parent


class BenchKind(enum.Enum):
    """What a benchmark measures."""

    DEPTH_RENDER = "depth_render"
    """Milliseconds per rendered depth frame of the humanoid (camera 1 of the scenario), with ``renderer``."""
    SIMULATE = "simulate"
    """A whole session simulated in memory (:func:`scenarios.api.simulate`): wall seconds, or the real-time
    factor (session length / wall time)."""
    CALIBRATE = "calibrate"
    """Seconds to calibrate a simulated session (simulated once, outside the timing)."""
    MERGE = "merge"
    """Merged frames per second of a simulated session's skeletons (views prepared outside the timing)."""
    KINEMATIC = "kinematic"
    """Frames per second of the kinematic fit of a simulated session's skeletons (views prepared outside)."""
    LIMB_AXES = "limb_axes"
    """Depth instants per second of the limb-axis fit of a simulated session (:mod:`fusion.merge.limb_axes`;
    session and views prepared outside the timing)."""
    COHORT = "cohort"
    """Minutes to generate a cohort (``scenario`` names the cohort file) and run the Fugl-Meyer analysis."""
    LIVE = "live"
    """p99 latency [ms] of the live server on loopback from an instant's last camera frame to its fused
    frame, the scenario (``duration_s``) looped to ``stream_s`` and replayed at ``speed``
    (:func:`scenarios.live.load_test`)."""
    PLAN = "plan"
    """Minutes to plan a room (``scenario`` names the room file) on a local Dask cluster of every core."""
    SWEEP = "sweep"
    """Speed-up of a calibration study (``scenario``, ``repeats`` seeds) on 2 Dask workers over 1; a
    result differing between the two runs is an error."""
    SENSOR_FIT = "sensor_fit"  # on the shared azure_2cam samples: statistics and fit of the first person's nine
    SIM_TO_REAL = "sim_to_real"  # sim-to-real of the first session against its replica
    SIM_TO_REAL_DRAWS = "sim_to_real_draws"  # the same with --draws 6
    ANGLE_VALIDATE = "angle_validate"  # angle-validate --fit --leave-one-out of UI-PRMD s01-s05 (200 episodes, 2 seeds)
    SENSOR_FIT_REPLICAS = "sensor_fit_replicas"  # sensor-fit --replicas of the first person's nine sessions
    SENSOR_FIT_POPULATION = "sensor_fit_population"  # sensor-fit --population of every session
    SENSOR_FIT_POPULATION_KINECT_V2 = "sensor_fit_population_kinect_v2"  # the same of the Kinect v2's seven people
    RETARGET = "retarget"
    """Frames per second retargeted: camera 1's skeletons of a simulated session at its true pose (scaling untimed)."""
    DEPTH_MEMORY = "depth_memory"
    """Peak resident memory [MiB] of a fresh process simulating the scenario to disk (:mod:`scenarios.bench.memory`)."""


class Goal(enum.Enum):
    """Whether the measured figure must stay at most or at least the target."""

    AT_MOST = "at_most"
    AT_LEAST = "at_least"


@dataclass(frozen=True)
class BenchmarkConfig:
    """One benchmark scenario."""

    name: str
    kind: BenchKind
    scenario: str
    target: float
    goal: Goal
    unit: str
    description: str = ""
    repeats: int = 3
    frames: int = 30
    duration_s: float | None = None
    depth_rate_hz: float | None = None
    refine: str = "icp"
    rig: str = "graph"
    single_core: bool = True
    stream_s: float = 60.0
    speed: float = 1.0
    renderer: DepthRenderer = DepthRenderer.RAYCAST


@dataclass(frozen=True)
class BenchResult:
    """Median of the repeats, with all samples."""

    config: BenchmarkConfig
    median: float
    samples: tuple[float, ...]

    @property
    def passed(self) -> bool:
        """True when the median meets the target."""
        if self.config.goal is Goal.AT_MOST:
            return self.median <= self.config.target
        return self.median >= self.config.target


def load_benchmarks(directory: Path = BENCH_DIR) -> list[BenchmarkConfig]:
    """Every benchmark scenario in ``directory``, sorted by file name."""
    configs = []
    for path in sorted(directory.glob("*.toml")):
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
        if set(doc) != {"benchmark"}:
            raise ScenarioError(f"{path}: a benchmark file holds exactly one [benchmark] table")
        configs.append(build_table(BenchmarkConfig, doc["benchmark"], f"{path.name}: benchmark"))
    return configs


def _depth_render(cfg: BenchmarkConfig) -> list[float]:
    from scenarios.runner import build_simulation
    from sim.depth_camera import DepthCamera

    sim = build_simulation(load_scenario(cfg.scenario))
    camera = DepthCamera(sim.rig.cameras[0], sim.sensors.depth, renderer=cfg.renderer)
    times = np.linspace(0.0, sim.motion.duration, cfg.frames, endpoint=False)
    qpos = sim.humanoid.qpos(sim.motion.sample(times))
    rng = np.random.default_rng(0)
    samples = []
    for _ in range(cfg.repeats):
        per_frame = []
        for q in qpos:
            sim.humanoid.set_qpos(q)
            t0 = time.perf_counter()
            camera.render(sim.humanoid.model, sim.humanoid.data, rng=rng)
            per_frame.append(time.perf_counter() - t0)
        samples.append(1e3 * statistics.median(per_frame))
    return samples


def _simulate(cfg: BenchmarkConfig) -> list[float]:
    from scenarios import api

    scenario = scenario_of(cfg)
    samples = []
    for _ in range(cfg.repeats):
        t0 = time.perf_counter()
        recording = api.simulate(scenario).recording
        wall = time.perf_counter() - t0
        length = recording.metadata["duration_s"]
        samples.append(length / wall if cfg.unit == "x real time" else wall)
    return samples


def _calibrate(cfg: BenchmarkConfig) -> list[float]:
    from fusion.calibrate.options import CalibrationOptions, Refinement, RigMethod
    from fusion.calibrate.pipeline import calibrate_rig
    from scenarios.runner import simulate

    recording, _ = simulate(scenario_of(cfg), progress=False)
    options = CalibrationOptions(refine=Refinement(cfg.refine), rig=RigMethod(cfg.rig))
    samples = []
    for k in range(cfg.repeats):
        t0 = time.perf_counter()
        calibrate_rig(recording, options, rng=np.random.default_rng(k))
        samples.append(time.perf_counter() - t0)
    return samples


def _cohort(cfg: BenchmarkConfig) -> list[float]:
    import tempfile

    from scenarios.clinical.cohort import generate_cohort
    from scenarios.clinical.cohort_file import load_cohort
    from scenarios.clinical.fma_study import analyse
    from scenarios.sweep import SweepOptions

    cohort = load_cohort(cfg.scenario)
    samples = []
    for _ in range(cfg.repeats):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            generate_cohort(cohort, Path(tmp) / "cohort", sweep=SweepOptions(workers=cohort.study.workers, progress=False))
            analyse(Path(tmp) / "cohort")
            samples.append((time.perf_counter() - t0) / 60.0)
    return samples


def _live(cfg: BenchmarkConfig) -> list[float]:
    from scenarios.live import load_test, load_test_session

    recording, calibration = load_test_session(cfg.scenario, cfg.duration_s or 40.0, cfg.stream_s)
    samples = []
    for _ in range(cfg.repeats):
        report = load_test(recording, calibration, speed=cfg.speed, progress=False)
        print(f"{cfg.name}: {report['fused_received']}/{report['instants_expected']} fused, lost {report['lost']}, "
              f"latency {report['latency_ms']} ms, server CPU {report['server_cpu_s']} s, "
              f"peak RSS {report['server_max_rss_mb']} MB", flush=True)
        samples.append(float(report["latency_ms"]["p99"]))
    return samples
def _plan(cfg: BenchmarkConfig) -> list[float]:
    from scenarios.plan.room import load_room
    from scenarios.plan.search import plan_layouts
    from scenarios.sweep import SweepOptions

    room = load_room(cfg.scenario)
    t0 = time.perf_counter()
    plan_layouts(room, sweep=SweepOptions(progress=False))
    return [(time.perf_counter() - t0) / 60.0]


def _sweep(cfg: BenchmarkConfig) -> list[float]:
    from fusion.errors import BenchError
    from scenarios.studies.calib_study import run_study
    from scenarios.sweep import SweepOptions

    seeds = list(range(1, cfg.repeats + 1))
    walls, results = [], []
    for workers in (1, 2):
        t0 = time.perf_counter()
        results.append(run_study(cfg.scenario, seeds, duration_s=cfg.duration_s,
                                 sweep=SweepOptions(workers=workers, progress=False)))
        walls.append(time.perf_counter() - t0)
    if results[0] != results[1]:
        raise BenchError(f"{cfg.name}: the study differs between 1 and 2 workers")
    return [walls[0] / walls[1]]
def _retarget(cfg: BenchmarkConfig) -> list[float]:
    from fusion.io.mocap import trajectory_from_stream
    from scenarios.runner import simulate
    from sim.humanoid_model import build_humanoid
    from sim.retarget import retarget
    from sim.retarget_scale import estimate_anthropometry

    recording, truth = simulate(scenario_of(cfg), progress=False)
    trajectory = trajectory_from_stream(recording.cameras[0].skeleton, truth.cameras[0].T_world_cam)
    humanoid = build_humanoid(estimate_anthropometry(trajectory).anthropometry)
    samples = []
    for _ in range(cfg.repeats):
        t0 = time.perf_counter()
        retarget(humanoid, trajectory)
        samples.append(trajectory.n_frames / (time.perf_counter() - t0))
    return samples


def _depth_memory(cfg: BenchmarkConfig) -> list[float]:
    from scenarios.bench.memory import measure_in_subprocess

    samples = []
    for _ in range(cfg.repeats):
        m = measure_in_subprocess(cfg.scenario, cfg.duration_s, cfg.depth_rate_hz)
        print(f"{cfg.name}: peak RSS {m['peak_rss_mb']:.0f} MiB, {m['wall_s']:.0f} s wall, {m['depth_frames']} depth "
              f"frames, {m['recording_mb']:.0f} MB on disk", flush=True)
        samples.append(m["peak_rss_mb"])
    return samples


_RUNNERS: dict[BenchKind, Callable[[BenchmarkConfig], list[float]]] = {
    BenchKind.DEPTH_RENDER: _depth_render,
    BenchKind.SIMULATE: _simulate,
    BenchKind.CALIBRATE: _calibrate,
    BenchKind.MERGE: merge_rate,
    BenchKind.KINEMATIC: kinematic_rate,
    BenchKind.LIMB_AXES: limb_axes_rate,
    BenchKind.COHORT: _cohort,
    BenchKind.LIVE: _live,
    BenchKind.PLAN: _plan,
    BenchKind.SWEEP: _sweep,
    BenchKind.SENSOR_FIT: lambda cfg: real_samples.sensor_fit(cfg.repeats),
    BenchKind.SIM_TO_REAL: lambda cfg: real_samples.sim_to_real_bench(cfg.repeats),
    BenchKind.SENSOR_FIT_REPLICAS: lambda cfg: real_samples.sensor_fit_replicas(cfg.repeats),
    BenchKind.SENSOR_FIT_POPULATION: lambda cfg: real_samples.sensor_fit_population(cfg.repeats),
    BenchKind.SENSOR_FIT_POPULATION_KINECT_V2: lambda cfg: real_samples.sensor_fit_population_kinect_v2(cfg.repeats),
    BenchKind.SIM_TO_REAL_DRAWS: lambda cfg: real_samples.sim_to_real_bench(cfg.repeats, draws=6),
    BenchKind.ANGLE_VALIDATE: lambda cfg: real_samples.angle_validate_bench(cfg.repeats),
    BenchKind.RETARGET: _retarget,
    BenchKind.DEPTH_MEMORY: _depth_memory,
}


def run_benchmark(cfg: BenchmarkConfig) -> BenchResult:
    """Run one benchmark (pinned to one CPU if ``single_core``) and return its median."""
    affinity = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
    try:
        if cfg.single_core and affinity:
            os.sched_setaffinity(0, {min(affinity)})
        samples = _RUNNERS[cfg.kind](cfg)
    finally:
        if cfg.single_core and affinity:
            os.sched_setaffinity(0, affinity)
    return BenchResult(cfg, statistics.median(samples), tuple(samples))


def results_table(rows: list[dict[str, object]]) -> str:
    """Markdown document with one row per benchmark (rows as stored in ``BENCHMARKS.json``)."""
    lines = [
        "# Benchmarks",
        "",
        "Written by `mocap-bench bench` (`./run.sh bench`). Each figure is the median over the repeats, "
        "measured on the machine and date given per row.",
        "",
        "| benchmark | what | median | target | met | samples | cores | machine, date |",
        "| --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        sign = "<=" if r["goal"] == Goal.AT_MOST.value else ">="
        samples = ", ".join(f"{v:.3g}" for v in r["samples"])
        lines.append(
            f"| {r['name']} | {r['description']} | {r['median']:.3g} {r['unit']} | {sign} {r['target']:g} {r['unit']} | "
            f"{'yes' if r['passed'] else 'NO'} | {samples} | {r['cores']} | {r['machine']} |"
        )
    return "\n".join(lines) + "\n"


def result_row(result: BenchResult) -> dict[str, object]:
    c = result.config
    machine = (f"{platform.machine()}, {os.cpu_count()} cores, Python {platform.python_version()}, "
               f"NumPy {np.__version__}, {time.strftime('%Y-%m-%d')}")
    return {"name": c.name, "description": c.description, "median": result.median, "samples": list(result.samples),
            "target": c.target, "goal": c.goal.value, "unit": c.unit, "passed": result.passed,
            "cores": "1" if c.single_core else "all", "machine": machine}


def run_benchmarks(out: Path, only: list[str] | None = None) -> list[BenchResult]:
    """Run the benchmark scenarios (all, or those named in ``only``) and update the table at ``out``.

    Results are kept in ``out`` with suffix ``.json``; a partial run replaces only its own rows.
    """
    configs = load_benchmarks()
    if only:
        unknown = sorted(set(only) - {c.name for c in configs})
        if unknown:
            raise ScenarioError(f"unknown benchmark(s) {unknown}; available: {[c.name for c in configs]}")
        configs = [c for c in configs if c.name in only]
    store = Path(out).with_suffix(".json")
    rows = {r["name"]: r for r in (json.loads(store.read_text()) if store.is_file() else [])}
    results = []
    for cfg in configs:
        results.append(r := run_benchmark(cfg))
        rows[cfg.name] = result_row(r)
        print(f"{cfg.name}: {r.median:.3g} {cfg.unit} (target {cfg.goal.value} {cfg.target:g}) "
              f"{'ok' if r.passed else 'MISSED'}", flush=True)
    ordered = [rows[n] for n in sorted(rows)]
    write_text_atomic(store, json.dumps(ordered, indent=1) + "\n")
    write_text_atomic(out, results_table(ordered))
    return results
