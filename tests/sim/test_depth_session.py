"""A session's depth frames rendered with cameras in parallel: the same arrays for any number of workers."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fusion.errors import BadInputError
from sim.depth_renderer import DepthRenderer
from sim.depth_session import depth_workers, render_depth, usable_cores
from sim.session import simulate_session


@pytest.fixture(scope="module")
def ring6():
    from scenarios.config import load_scenario
    from scenarios.runner import build_simulation

    sim = build_simulation(load_scenario("ring6"))
    return sim, dataclasses.replace(sim.sensors, depth_rate_hz=5.0, depth_renderer=DepthRenderer.RAYCAST)


def test_frames_do_not_depend_on_the_number_of_workers(ring6):
    sim, sensors = ring6
    runs = []
    for workers in (1, 2, 4):
        ticks = []
        rec, _ = simulate_session(sim.humanoid, sim.motion, sim.rig, sensors, seed=2, duration_s=1.0,
                                  depth_workers=workers, progress=ticks.append)
        runs.append(rec)
        assert sum(ticks) == sum(c.skeleton.timestamps.size + c.depth.timestamps.size for c in rec.cameras)
    first = runs[0].cameras
    assert len(first) == 6 and all(c.depth.depth_mm.shape[0] == 5 for c in first)
    for rec in runs[1:]:
        for a, b in zip(first, rec.cameras):
            assert np.array_equal(a.depth.depth_mm, b.depth.depth_mm)
            assert np.array_equal(a.depth.labels, b.depth.labels)
            assert np.array_equal(a.depth.timestamps, b.depth.timestamps)
            assert np.array_equal(a.skeleton.positions, b.skeleton.positions, equal_nan=True)


def test_worker_counts(ring6):
    sim, sensors = ring6
    assert depth_workers(DepthRenderer.RAYCAST, 6) == min(6, usable_cores())
    assert depth_workers(DepthRenderer.RAYCAST, 1) == 1
    for bad in (0, -1, 1.5, True):
        with pytest.raises(BadInputError, match="workers"):
            render_depth(sim.humanoid.model, [], sensors.depth, DepthRenderer.RAYCAST, tick=lambda n: None,
                         depth_dir=None, workers=bad)


def test_mujoco_renders_one_camera_at_a_time(monkeypatch, ring6):
    from sim import gl_depth, gl_self_check

    sim, sensors = ring6
    monkeypatch.setattr(gl_depth, "probe_gl", lambda: ("llvmpipe (LLVM 15.0.6, 256 bits)", None))
    monkeypatch.setattr(gl_self_check, "depth_self_check", lambda: None)
    assert depth_workers(DepthRenderer.MUJOCO, 6) == 1
    with pytest.raises(BadInputError, match="one camera at a time"):
        render_depth(sim.humanoid.model, [], sensors.depth, DepthRenderer.MUJOCO, tick=lambda n: None,
                     depth_dir=None, workers=2)
