"""Stage merge: back-facing detection, per-joint merging, filters, the kinematic fit, joint angles,
merged clouds and meshes, the truth-free statistics of a sensor, and an optical reference: joint
centres from Plug-in-Gait markers, the alignment of a Kinect episode with an optical one, and the
signed angle errors between them.

May import the data model at the top of :mod:`fusion`, :mod:`fusion.io` and :mod:`fusion.calibrate`; not live.
"""
