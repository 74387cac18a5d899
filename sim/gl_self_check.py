"""A self-check of MuJoCo's rendered depth against a closed form, run before ``auto`` trusts it.

MuJoCo's renderer is only as exact as the OpenGL driver under it: on an NVIDIA GPU its depth of
sloped surfaces was biased by about 0.24 mm per m^2 of distance (2.7 mm at 3.4 m on a wall at 60
degrees), what a multisampled depth buffer resolved from one sample an eighth of a pixel off the
pixel centre gives (``docs/reference/depth-renderers.md``). :func:`depth_self_check` renders a wall tilted 60 degrees at 2-5.5 m,
through the same code as every depth frame (:class:`sim.gl_depth.GLBodyDepth`), the whole image and
a box of it (as frames render the body's box), and compares them with the wall's closed-form depth
(:class:`sim.scenes.Wall`).
"""

from __future__ import annotations

import functools

import numpy as np

from fusion.camera import Intrinsics
from sim.gl_depth import GLBodyDepth
from sim.humanoid_model import BODY_GEOM_GROUP
from sim.rig import CameraPlacement, look_at
from sim.scenes import Wall, compile_scene

CHECK_TOL_M = 2e-4
"""Bound on the 99th percentile of |rendered - closed-form z-depth| [m] over the check's wall. Mesa's
software rasteriser stays under 0.003 mm; depth read an eighth of a pixel off the centre is 18 mm off
on this wall."""

CHECK_CAMERA = CameraPlacement(
    "depth-self-check", look_at([0.0, 0.0, 1.5], [1.0, 0.0, 1.5]),
    Intrinsics(width=64, height=48, fx=120.0, fy=120.0, cx=31.5, cy=23.5, min_depth_m=0.5, max_depth_m=10.0),
)
"""The check's camera: a narrow field of view (30 x 23 degrees), so every pixel sees the wall."""

CHECK_WALL = Wall([3.0, 0.0, 1.5], 60.0)
"""The check's wall: 3 m ahead on the optical axis, turned 60 degrees (z-depth 2.1-5.5 m over the image)."""

CHECK_BOX = (10, 40, 5, 37)
"""Image rows and columns ``(r0, r1, c0, c1)`` rendered on their own as well, off the image's centre."""


@functools.cache
def depth_self_check() -> str | None:
    """Why MuJoCo's rendered depth cannot be trusted here, or None when it passes; once per process.

    Renders :data:`CHECK_WALL` with :data:`CHECK_CAMERA`, the whole image and :data:`CHECK_BOX` (a fresh
    OpenGL context, about half a second with Mesa's software EGL), and bounds the error by
    :data:`CHECK_TOL_M`. A context that
    cannot be made is reported as a failure.
    """
    model, data = compile_scene(CHECK_WALL, floor=False)
    try:
        gl = GLBodyDepth(model, CHECK_CAMERA, BODY_GEOM_GROUP)
        whole, box = gl.render(data), gl.render(data, CHECK_BOX)
    except Exception as exc:  # whatever stops the render stops MuJoCo's depth
        return f"the check's render failed: {type(exc).__name__}: {exc}"
    r0, r1, c0, c1 = CHECK_BOX
    true, _ = CHECK_WALL.depth(CHECK_CAMERA)
    z, z_true = np.concatenate([whole.ravel(), box.ravel()]), np.concatenate([true.ravel(), true[r0:r1, c0:c1].ravel()])
    seen = np.isfinite(z)
    if seen.sum() < 0.99 * z.size:
        return f"the check's wall filled {seen.sum()} of {z.size} pixels, not all"
    err = np.percentile(np.abs(z[seen] - z_true[seen]), 99)
    if err > CHECK_TOL_M:
        return (f"a plane at {z_true.min():.1f}-{z_true.max():.1f} m rendered {1e3 * err:.2f} mm off its closed form "
                f"(99th percentile; bound {1e3 * CHECK_TOL_M:.1f} mm)")
    return None
