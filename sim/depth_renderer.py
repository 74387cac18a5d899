"""The choice of depth renderer: MuJoCo's OpenGL renderer, the ray caster, or whichever is faster here."""

from __future__ import annotations

import enum
import logging

from fusion.errors import BadInputError

log = logging.getLogger(__name__)

SOFTWARE_GL = ("llvmpipe", "softpipe", "swrast", "software", "swiftshader", "basic render driver", "gdi generic")
"""Parts of a ``GL_RENDERER`` string (lower case) that name a software rasteriser: Mesa's llvmpipe,
softpipe and swrast ("Software Rasterizer"), Google's SwiftShader, Microsoft's Basic Render Driver and
GDI Generic, Apple's Software Renderer. On such a context MuJoCo's renderer is not faster than the
ray caster and costs a context per session (README, "Depth renderers")."""


class DepthRenderer(enum.Enum):
    """What renders the body's depth."""

    AUTO = "auto"
    """MuJoCo's renderer on a hardware-accelerated OpenGL context whose depth passes the self-check
    (:func:`sim.gl_self_check.depth_self_check`), else the ray caster (with a notice)."""
    RAYCAST = "raycast"
    """Ray casting (:mod:`sim.raycast`); no OpenGL needed."""
    MUJOCO = "mujoco"
    """MuJoCo's OpenGL renderer (``mujoco.Renderer``), software or not; an error where no context can be made."""

    def resolve(self) -> "DepthRenderer":
        """RAYCAST or MUJOCO: what this choice renders with on this machine.

        RAYCAST never probes OpenGL; MUJOCO and AUTO probe it once per process
        (:func:`sim.gl_depth.probe_gl`) and, on a context that MuJoCo would render with, run the
        depth self-check once per process. AUTO logs its choice and the reason once; MUJOCO warns
        once when the self-check fails and renders anyway.

        Raises
        ------
        BadInputError
            MUJOCO where no OpenGL context can be made.
        """
        if self is DepthRenderer.RAYCAST:
            return self
        from sim import gl_depth, gl_self_check  # import mujoco

        gl_renderer, failure = gl_depth.probe_gl()
        if self is DepthRenderer.MUJOCO:
            if failure is not None:
                raise BadInputError(f"the mujoco depth renderer needs an OpenGL context, which failed here "
                                    f"({failure}); set MUJOCO_GL=egl or osmesa, or choose the raycast renderer")
            check = gl_self_check.depth_self_check()
            if check is not None:
                _notice(f"MuJoCo's depth failed its self-check on {gl_renderer} ({check}); rendering with it "
                        "as asked", logging.WARNING)
            return self
        check = None
        if failure is None and gl_renderer is not None and not software_gl(gl_renderer):
            check = gl_self_check.depth_self_check()
        choice, reason = auto_choice(gl_renderer, failure, check)
        _notice(reason, logging.WARNING if failure is not None or check is not None else logging.INFO)
        return choice


def software_gl(gl_renderer: str) -> bool:
    """Whether an OpenGL ``GL_RENDERER`` string names a software rasteriser (:data:`SOFTWARE_GL`)."""
    name = gl_renderer.lower()
    return any(part in name for part in SOFTWARE_GL)


def auto_choice(
    gl_renderer: str | None, failure: str | None, check: str | None = None
) -> tuple[DepthRenderer, str]:
    """What AUTO renders with, given the probe's and the self-check's results, and the one-line reason.

    Parameters
    ----------
    gl_renderer : the context's ``GL_RENDERER`` string; None where no context could be made.
    failure : why no context could be made; None where one could.
    check : why MuJoCo's depth failed its self-check (:func:`sim.gl_self_check.depth_self_check`);
        None where it passed or did not run.

    Returns
    -------
    MUJOCO on a hardware-accelerated context whose depth passed the self-check, else RAYCAST; and
    the notice naming the choice and why.
    """
    if failure is not None or gl_renderer is None:
        return DepthRenderer.RAYCAST, f"no OpenGL context for MuJoCo's renderer ({failure}): depth by ray casting"
    if software_gl(gl_renderer):
        return DepthRenderer.RAYCAST, f"software OpenGL ({gl_renderer}): depth by ray casting"
    if check is not None:
        return DepthRenderer.RAYCAST, (f"hardware OpenGL ({gl_renderer}) but MuJoCo's depth failed its self-check "
                                       f"({check}): depth by ray casting")
    return DepthRenderer.MUJOCO, f"hardware OpenGL ({gl_renderer}): depth by MuJoCo's renderer"


_NOTICED: set[str] = set()


def _notice(reason: str, level: int) -> None:
    if reason not in _NOTICED:
        _NOTICED.add(reason)
        log.log(level, "%s", reason)
