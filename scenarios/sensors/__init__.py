"""Sensor models against real recordings: fitting a sensor profile (``sensor-fit``, one pipeline in
:mod:`~scenarios.sensors.fit_and_compare` for the command and the benchmarks), replicas of real sessions,
``sim-to-real`` comparisons, ``device-swap`` (a real session's replica simulated with two sensor
profiles over the same seeds: :mod:`~scenarios.sensors.device_swap` and its report), their reports, and the ``sensor-check`` of the simulated sensors
(:mod:`~scenarios.sensors.check`).

May import the core of :mod:`scenarios` and ``fusion``, ``fma``, ``sim``; no other workflow, no CLI.
"""
