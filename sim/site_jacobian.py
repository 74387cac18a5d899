"""Jacobians of many MuJoCo sites at once, from the joints' world axes and anchors.

``mujoco.mj_jacSite`` gives one site's Jacobian per call; an inverse-kinematics fit that needs thirty
sites at every step spends most of its time in those calls. :class:`SiteJacobian` gives the same
numbers for all of them in a few array operations: a rotational degree of freedom moves a site below
its joint by the axis crossed with the lever from the joint's anchor, a translational one along its
axis, and neither moves the sites of other branches.
"""

from __future__ import annotations

import mujoco
import numpy as np


def _ancestry(model: mujoco.MjModel, body: int) -> set[int]:
    """The body and every body above it, the world (0) left out."""
    out = set()
    while body > 0:
        out.add(body)
        body = int(model.body_parentid[body])
    return out


class SiteJacobian:
    """Position Jacobians of ``sites`` over the degrees of freedom ``dofs`` of ``model``.

    Parameters
    ----------
    model : mujoco.MjModel
    sites : (S,) int site ids.
    dofs : (D,) int degree-of-freedom indices (free, ball, hinge or slide joints).
    """

    def __init__(self, model: mujoco.MjModel, sites: np.ndarray, dofs: np.ndarray) -> None:
        self.sites, dofs = np.asarray(sites, dtype=int), np.asarray(dofs, dtype=int)
        self.joint = model.dof_jntid[dofs]
        kind = model.jnt_type[self.joint]
        self.body = model.jnt_bodyid[self.joint]
        local = dofs - model.jnt_dofadr[self.joint]  # which of its joint's dofs
        free, ball = kind == mujoco.mjtJoint.mjJNT_FREE, kind == mujoco.mjtJoint.mjJNT_BALL
        self.shift = (kind == mujoco.mjtJoint.mjJNT_SLIDE) | (free & (local < 3))
        self.world_shift = free & (local < 3)  # a free joint translates along the world axes
        self.world_axes = np.eye(3)[local[self.world_shift]]
        self.body_axis = np.flatnonzero((free & (local >= 3)) | ball)  # these turn about their body's axes
        self.body_axis_k = np.where(free, local - 3, local)[self.body_axis]
        self.moves = np.array([[b in _ancestry(model, int(model.site_bodyid[s])) for b in self.body]
                               for s in self.sites], dtype=float)

    def __call__(self, data: mujoco.MjData, rows: np.ndarray | None = None) -> np.ndarray:
        """(S', 3, D) Jacobians [m per unit of each dof] of the sites ``rows`` (indices into ``sites``;
        default all) at ``data``'s pose, which ``mujoco.mj_kinematics`` must have computed."""
        rows = slice(None) if rows is None else rows
        axes = data.xaxis[self.joint]
        axes[self.body_axis] = data.xmat[self.body[self.body_axis]].reshape(-1, 3, 3)[
            np.arange(self.body_axis.size), :, self.body_axis_k]
        axes[self.world_shift] = self.world_axes
        lever = data.site_xpos[self.sites[rows]][:, None] - data.xanchor[self.joint]  # (S', D, 3)
        cols = np.where(self.shift[:, None], axes, np.cross(axes, lever))
        return (cols * self.moves[rows][..., None]).transpose(0, 2, 1)
