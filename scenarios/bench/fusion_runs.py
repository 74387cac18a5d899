"""Benchmark runs of the fusion stage: merging, the kinematic fit and the limb axes of a simulated session.

Each run takes a :class:`scenarios.bench.benchmarks.BenchmarkConfig` (its ``scenario``, ``duration_s``,
``depth_rate_hz`` and ``repeats``) and returns one figure per repeat.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Any

from scenarios.config import Scenario, load_scenario


def scenario_of(cfg: Any) -> Scenario:
    """The benchmark's scenario with its duration and depth rate."""
    scenario = load_scenario(cfg.scenario)
    if cfg.duration_s is not None:
        scenario = scenario.replace(duration_s=cfg.duration_s)
    if cfg.depth_rate_hz is not None:
        scenario = dataclasses.replace(
            scenario, sensors=dataclasses.replace(scenario.sensors, depth_rate_hz=cfg.depth_rate_hz)
        )
    return scenario


def views_of(cfg: Any):
    """The scenario's simulated skeletons on the reference clock in the world frame (true poses)."""
    from fusion.merge.fuse import camera_views
    from scenarios import api

    session = api.simulate(scenario_of(cfg))
    return camera_views(session.recording, api.true_calibration(session.recording, session.truth))


def merge_rate(cfg: Any) -> list[float]:
    """Merged frames per second of the slowest merging method on the scenario's skeletons."""
    from fusion.merge.methods import MergeMethod, merge

    views = views_of(cfg)
    samples = []
    for _ in range(cfg.repeats):
        per_method = []
        for method in MergeMethod:
            t0 = time.perf_counter()
            merge(views, method)
            per_method.append(views.times.size / (time.perf_counter() - t0))
        samples.append(min(per_method))
    return samples


def kinematic_rate(cfg: Any) -> list[float]:
    """Frames per second of the kinematic fit of the scenario's skeletons."""
    from fusion.merge.kinematic import fit_kinematic

    views = views_of(cfg)
    samples = []
    for _ in range(cfg.repeats):
        t0 = time.perf_counter()
        fit_kinematic(views)
        samples.append(views.times.size / (time.perf_counter() - t0))
    return samples


def limb_axes_rate(cfg: Any) -> list[float]:
    """Depth instants per second of :func:`fusion.merge.limb_axes.limb_axes` on the scenario's session."""
    from fusion.merge.fuse import camera_views
    from fusion.merge.limb_axes import limb_axes
    from scenarios import api

    session = api.simulate(scenario_of(cfg))
    calibration = api.true_calibration(session.recording, session.truth)
    views = camera_views(session.recording, calibration)
    samples = []
    for _ in range(cfg.repeats):
        t0 = time.perf_counter()
        axes = limb_axes(views, session.recording, calibration)
        samples.append(axes.times.size / (time.perf_counter() - t0))
    return samples
