"""Sweeps on Dask: options, per-task seeds, results in task order whatever the cluster."""


import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fusion.errors import BadInputError
from scenarios.cli import main
from scenarios.studies.calib_study import run_study
from scenarios.sweep import SweepOptions, run_sweep, task_seeds
from tests.scenarios.sweep_tasks import draw

TINY = """
[scenario]
name = "tiny"
seed = 1
[rig]
angles_deg = [45.0, -45.0]
radius_m = 2.0
[sensors]
depth_rate_hz = 0.0
[[session.segment]]
kind = "idle"
duration_s = 1.0
[[session.segment]]
kind = "calibration_turn"
duration_s = 8.0
"""


def test_task_seeds_are_spawned_and_stable():
    a = task_seeds(5, 4)
    assert a == task_seeds(5, 4) and len(set(a)) == 4
    assert a[:2] == task_seeds(5, 2)  # a task's seed does not depend on how many follow
    assert a != task_seeds(6, 4)
    expected = [int(c.generate_state(1)[0]) for c in np.random.SeedSequence(5).spawn(4)]
    assert a == expected
    assert task_seeds(0, 0) == []


@given(st.integers(0, 2**63), st.integers(0, 20))
def test_task_seeds_shape(seed, n):
    seeds = task_seeds(seed, n)
    assert len(seeds) == n and all(0 <= s < 2**32 for s in seeds)


@pytest.mark.parametrize("seed, n", [(-1, 2), (1, -1), (1.5, 2), (True, 2)])
def test_task_seeds_bad_input(seed, n):
    with pytest.raises(BadInputError):
        task_seeds(seed, n)


@pytest.mark.parametrize("kwargs", [{"workers": -1}, {"workers": 1.5}, {"workers": True}, {"scheduler": ""},
                                    {"scheduler": 8786}])
def test_sweep_options_bad_input(kwargs):
    with pytest.raises(BadInputError):
        SweepOptions(**kwargs)


def test_sweep_options_default_is_one_worker_per_core():
    import os

    assert SweepOptions().n_workers == (os.cpu_count() or 1) and SweepOptions(workers=3).n_workers == 3


def test_run_sweep_bad_input():
    with pytest.raises(BadInputError, match="callable"):
        run_sweep(42, [(1,)])


def test_empty_and_in_process_sweeps():
    assert run_sweep(draw, [], options=SweepOptions(workers=2, progress=False)) == []
    seen = []
    out = run_sweep(draw, [(s, k) for k, s in enumerate(task_seeds(1, 3))],
                    options=SweepOptions(workers=0, progress=False), on_result=lambda k, r: seen.append(k))
    assert [r[0] for r in out] == [0, 1, 2] and seen == [0, 1, 2]


def test_results_in_task_order_and_identical_on_one_and_two_workers():
    tasks = [(s, k) for k, s in enumerate(task_seeds(11, 6))]
    inline = run_sweep(draw, tasks, options=SweepOptions(workers=0, progress=False))
    finished = []
    one = run_sweep(draw, tasks, options=SweepOptions(workers=1, progress=False))
    two = run_sweep(draw, tasks, options=SweepOptions(workers=2, progress=False),
                    on_result=lambda k, r: finished.append(k))
    assert inline == one == two
    assert [r[0] for r in two] == list(range(6)) and sorted(finished) == list(range(6))
    assert inline[0][1] == np.random.default_rng(tasks[0][0]).normal(size=5).tolist()


def test_task_errors_reach_the_caller():
    with pytest.raises(BadInputError, match="at least one seed"):
        run_sweep(run_study, [("x", [])], options=SweepOptions(workers=1, progress=False))


def test_calibration_study_identical_in_process_and_on_two_workers(tmp_path):
    """A whole study, in this process and on a two-worker cluster (one worker: the sweep tests above)."""
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    inline = run_study(str(path), [2, 1], sweep=SweepOptions(workers=0, progress=False))
    two = run_study(str(path), [2, 1], sweep=SweepOptions(workers=2, progress=False))
    assert [r["seed"] for r in inline] == [2, 1]
    assert inline == two


def test_cli_calib_study_on_an_existing_scheduler(tmp_path, capsys):
    from distributed import LocalCluster

    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    with LocalCluster(n_workers=1, threads_per_worker=1, dashboard_address=":0") as cluster:
        assert main(["calib-study", str(path), "--out", str(tmp_path / "s"), "--seeds", "2",
                     "--scheduler", cluster.scheduler_address]) == 0
    assert "icp+graph" in (tmp_path / "s" / "table1.md").read_text()
    assert main(["calib-study", str(path), "--out", str(tmp_path / "t"), "--seeds", "1", "--workers", "-1"]) == 2
