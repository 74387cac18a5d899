"""Sensor-agnostic data model, I/O, calibration, merging and metrics.

Never imports :mod:`sim` or :mod:`mujoco`: everything here works on real recordings.
"""
