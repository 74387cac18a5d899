"""Stage merge: back-facing detection, per-joint merging, filters, the kinematic fit, joint angles,
merged clouds and meshes, and the truth-free statistics of a sensor.

May import the data model at the top of :mod:`fusion`, :mod:`fusion.io` and :mod:`fusion.calibrate`; not live.
"""
