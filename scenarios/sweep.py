"""Sweeps of independent tasks on Dask distributed: the one place multi-run commands go parallel.

A sweep is a module-level function applied to a list of argument tuples. By default the tasks run on
a local Dask cluster started for the sweep (one single-threaded worker process per core); with a
scheduler address they run on an existing cluster, e.g. one started by hand::

    dask scheduler --port 8786                      # on one machine
    dask worker tcp://HOST:8786 --nthreads 1        # on every machine, as many as wanted

Workers must import this package (same code, ``PYTHONPATH``) and, for commands that write files
(``cohort``), see the output directory at the same path. ``workers=0`` runs the tasks one after the
other in this process (no cluster; for debugging and small tests; Open3D keeps its threads there, so ICP
results may differ from a cluster's in their last digits).

Results come back in task order, whatever the number of workers or the order in which they finish;
every worker runs Open3D on one thread, so multithreaded sums cannot make them differ.
Tasks that need randomness take their own seed (see :func:`task_seeds`), never a shared generator,
so a sweep gives identical results on any cluster.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
from tqdm import tqdm

from fusion.errors import BadInputError


@dataclass(frozen=True)
class SweepOptions:
    """Where a sweep runs.

    Attributes
    ----------
    workers : worker processes of the local cluster; None = one per core; 0 = in this process.
        Ignored when ``scheduler`` is given.
    scheduler : address of a running Dask scheduler (``tcp://host:8786``); None = a local cluster.
    progress : show a progress bar (on stderr) that advances as tasks finish.
    """

    workers: int | None = None
    scheduler: str | None = None
    progress: bool = True

    def __post_init__(self) -> None:
        if self.workers is not None and (isinstance(self.workers, bool) or not isinstance(self.workers, int)
                                         or self.workers < 0):
            raise BadInputError(f"workers must be an integer >= 0 (0 = in this process), got {self.workers!r}")
        if self.scheduler is not None and (not isinstance(self.scheduler, str) or not self.scheduler.strip()):
            raise BadInputError(f"scheduler must be an address such as tcp://host:8786, got {self.scheduler!r}")

    @property
    def n_workers(self) -> int:
        """Worker processes of the local cluster (every core when ``workers`` is None)."""
        return (os.cpu_count() or 1) if self.workers is None else self.workers


def task_seeds(seed: int, n: int) -> list[int]:
    """``n`` independent task seeds split from ``seed`` with ``SeedSequence.spawn`` (one per task).

    Parameters
    ----------
    seed : root seed (>= 0).
    n : number of tasks (>= 0).

    Returns
    -------
    list of int
        One 32-bit seed per task; task ``k`` gets the same seed whatever the cluster.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise BadInputError(f"seed must be an integer >= 0, got {seed!r}")
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 0:
        raise BadInputError(f"the number of tasks must be an integer >= 0, got {n!r}")
    return [int(child.generate_state(1)[0]) for child in np.random.SeedSequence(int(seed)).spawn(int(n))]


class Sweep:
    """An open cluster connection (or the in-process runner) that runs several sweeps in a row."""

    def __init__(self, options: SweepOptions, client: Any = None) -> None:
        self.options = options
        self._client = client

    def map(self, fn: Callable[..., Any], tasks: Sequence[tuple[Any, ...]], *, desc: str = "sweep",
            on_result: Callable[[int, Any], None] | None = None) -> list[Any]:
        """Apply ``fn(*task)`` to every task; the results in task order (see :func:`run_sweep`)."""
        if not callable(fn):
            raise BadInputError(f"fn must be callable, got {type(fn).__name__}")
        tasks = [tuple(t) for t in tasks]
        results: list[Any] = [None] * len(tasks)
        with tqdm(total=len(tasks), desc=desc, unit="task", leave=False,
                  **({} if self.options.progress else {"disable": True})) as bar:  # TQDM_DISABLE applies
            def done(k: int, value: Any) -> None:
                results[k] = value
                if on_result is not None:
                    on_result(k, value)
                bar.update(1)

            if self._client is None:
                for k, task in enumerate(tasks):
                    done(k, fn(*task))
                return results
            from distributed import as_completed

            futures = [self._client.submit(fn, *task, pure=False) for task in tasks]
            index = {f.key: k for k, f in enumerate(futures)}
            for future in as_completed(futures):
                done(index[future.key], future.result())
        return results


def _one_open3d_thread() -> None:
    """Limit Open3D's thread pool (oneAPI TBB, which ``OMP_NUM_THREADS`` does not reach) to one thread on
    a worker: a worker runs one task at a time, and a multithreaded ICP sums in a varying order, so its
    results would differ in the last digits from run to run and with the number of workers."""
    import open3d

    open3d.utility.set_max_threads(1)


@contextmanager
def open_sweep(options: SweepOptions = SweepOptions(), *, max_tasks: int | None = None) -> Iterator[Sweep]:
    """Connect to the scheduler, or start a local cluster, for the ``with`` block; close it after.

    ``max_tasks`` caps the local cluster's size (no idle workers for a short sweep).
    """
    if options.scheduler is None and options.n_workers == 0:
        yield Sweep(options)
        return
    from distributed import Client, LocalCluster

    if logging.getLogger().getEffectiveLevel() > logging.DEBUG:  # Dask's own chatter only with -v
        logging.getLogger("distributed").setLevel(logging.WARNING)
    cluster = None
    if options.scheduler is None:
        n = options.n_workers if max_tasks is None else max(1, min(options.n_workers, max_tasks))
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                               silence_logs=logging.ERROR)
    client = Client(options.scheduler if cluster is None else cluster)
    client.run(_one_open3d_thread)
    try:
        yield Sweep(options, client)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


def run_sweep(fn: Callable[..., Any], tasks: Sequence[tuple[Any, ...]], *, options: SweepOptions = SweepOptions(),
              desc: str = "sweep", on_result: Callable[[int, Any], None] | None = None) -> list[Any]:
    """Apply ``fn(*task)`` to every task on Dask; return the results in task order.

    Parameters
    ----------
    fn : a module-level (picklable) function.
    tasks : argument tuples, one per task.
    options : where to run (see :class:`SweepOptions`).
    desc : label of the progress bar.
    on_result : called with (task index, result) as each task finishes (in finishing order).

    Returns
    -------
    list
        ``[fn(*tasks[0]), fn(*tasks[1]), ...]``. An exception raised by a task is raised here.
    """
    if not callable(fn):
        raise BadInputError(f"fn must be callable, got {type(fn).__name__}")
    if not tasks:
        return []
    with open_sweep(options, max_tasks=len(tasks)) as sweep:
        return sweep.map(fn, tasks, desc=desc, on_result=on_result)
