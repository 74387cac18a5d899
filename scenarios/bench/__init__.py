"""Benchmarks (``bench``): scenario files that measure speed and memory, their runner and the
results table ``BENCHMARKS.md``.

May import the core of :mod:`scenarios` and any workflow sub-package; never the CLI.
"""
