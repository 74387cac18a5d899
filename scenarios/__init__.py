"""Orchestration: the only layer that sees both simulated truth and fusion output.

The core (modules at this level): scenario files (:mod:`~scenarios.config`), the runner that turns a
scenario into a simulated recording and reads or writes run directories (:mod:`~scenarios.runner`,
:mod:`~scenarios.replay_source`), scoring against truth (:mod:`~scenarios.evaluate`,
:mod:`~scenarios.skeleton_eval`), fusion of a calibrated recording (:mod:`~scenarios.fusing`), live
runs (:mod:`~scenarios.live`), Dask sweeps (:mod:`~scenarios.sweep`), report pictures
(:mod:`~scenarios.show`), TOML tables (:mod:`~scenarios.toml_tables`), and the public Python API
(:mod:`~scenarios.api`) over them.

One sub-package per workflow, each importing the core (and ``fusion``, ``fma``, ``sim``), never the
command line: :mod:`~scenarios.studies`, :mod:`~scenarios.clinical`, :mod:`~scenarios.sensors`,
:mod:`~scenarios.interop`, :mod:`~scenarios.plan`, :mod:`~scenarios.hostile`; the benchmarks
(:mod:`~scenarios.bench`) may import any workflow; :mod:`~scenarios.cli` alone parses arguments and
imports everything above. The core imports no sub-package.
"""
