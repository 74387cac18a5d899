"""Sensor-agnostic data model, I/O, calibration, merging and metrics.

The data model sits at this level and imports no stage: recordings (:mod:`~fusion.recording`),
calibrations (:mod:`~fusion.calibration`), frames and axis conventions (:mod:`~fusion.frames`),
transforms, cameras, depth and skeleton streams, topologies, errors. The stages import one way:
:mod:`~fusion.io` <- :mod:`~fusion.calibrate` <- :mod:`~fusion.merge` <- :mod:`~fusion.live`.

Never imports :mod:`sim` or :mod:`mujoco`: everything here works on real recordings.
"""
