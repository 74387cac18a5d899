"""Simulation: humanoid, motions, camera rig, virtual depth cameras and body trackers.

Every simulator returns ``(observation, truth)``; truth never travels inside an observation.

On Linux, MuJoCo's renderer is pointed at headless EGL (``MUJOCO_GL=egl``) unless ``MUJOCO_GL`` is
already set; this must happen before ``mujoco`` is first imported (see :mod:`sim.gl_depth`). PyOpenGL,
which MuJoCo's EGL backend imports, logs at INFO that its optional C accelerator is missing; that
says nothing about rendering, so its logger is kept at WARNING.
"""

import logging
import os
import sys

if sys.platform.startswith("linux"):
    os.environ.setdefault("MUJOCO_GL", "egl")
logging.getLogger("OpenGL.acceleratesupport").setLevel(logging.WARNING)
