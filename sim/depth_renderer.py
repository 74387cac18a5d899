"""The choice of depth renderer: MuJoCo's OpenGL renderer, the ray caster, or whichever works here."""

from __future__ import annotations

import enum
import logging

from fusion.errors import BadInputError

log = logging.getLogger(__name__)


class DepthRenderer(enum.Enum):
    """What renders the body's depth."""

    AUTO = "auto"
    """MuJoCo's renderer where an OpenGL context can be made, else the ray caster (with a notice)."""
    RAYCAST = "raycast"
    """Ray casting (``mujoco.mj_multiRay``); no OpenGL needed."""
    MUJOCO = "mujoco"
    """MuJoCo's OpenGL renderer (``mujoco.Renderer``); an error where no context can be made."""

    def resolve(self) -> "DepthRenderer":
        """RAYCAST or MUJOCO: what this choice renders with on this machine.

        Raises
        ------
        BadInputError
            MUJOCO where no OpenGL context can be made.
        """
        from sim.gl_depth import gl_unavailable  # imports mujoco

        reason = None if self is DepthRenderer.RAYCAST else gl_unavailable()
        if self is DepthRenderer.MUJOCO and reason is not None:
            raise BadInputError(f"the mujoco depth renderer needs an OpenGL context, which failed here ({reason}); "
                                "set MUJOCO_GL=egl or osmesa, or choose the raycast renderer")
        if self is DepthRenderer.AUTO and reason is not None:
            _notice_fallback(reason)
        return DepthRenderer.RAYCAST if self is DepthRenderer.RAYCAST or reason is not None else DepthRenderer.MUJOCO


_NOTICED: set[str] = set()


def _notice_fallback(reason: str) -> None:
    if reason not in _NOTICED:
        _NOTICED.add(reason)
        log.warning("no OpenGL context for MuJoCo's renderer (%s): depth is ray-cast", reason)
