"""The tracker's trunk landmarks relative to the thorax: an offset that follows the trunk and changes
with the arms' elevation, fitted against an optical reference (``angle-validate --fit``).

A Kinect's ``SpineBase`` does not sit between the hip joint centres, nor its ``SpineMid`` and
``SpineShoulder`` on the thorax's landmarks; the axis between them is the clinical angles' thorax axis
(:func:`fusion.facing.thorax_frame`), so where they sit tilts every humerothoracic angle. Per joint
(:data:`TRUNK_JOINTS`) the offset is a 3-vector [m] in the thorax frame (``X`` forward, ``Y`` up, ``Z``
right), given at the elevation knots of :mod:`sim.tracker_arm_bias` and interpolated the same way, at
the higher of the two arms' humerothoracic elevations (raising an arm lifts the shoulder girdle and
moves the tracker's trunk joints with it). A person's values are drawn as the arm bias's are: the
population's mean plus its modes of variation between people, each times a standard normal draw (drawn
after and apart from the arm bias: five people cannot measure how the two covary).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from fusion.facing import thorax_frame
from fusion.topology import Landmark, Topology
from sim.tracker_arm_bias import KnotBias, arm_elevations, knot_weights

TRUNK_JOINTS = ("pelvis", "spine_mid", "spine_shoulder")
"""The joints the trunk bias moves, in the coefficients' first axis."""


@dataclass(frozen=True)
class TrunkBias(KnotBias):
    """How the trunk landmarks (:data:`TRUNK_JOINTS`) sit relative to the thorax frame, for a population
    of people (:class:`~sim.tracker_arm_bias.KnotBias`; axes ``X`` forward, ``Y`` up, ``Z`` right)."""

    JOINTS: ClassVar[tuple[str, ...]] = TRUNK_JOINTS


@dataclass(frozen=True, eq=False)
class TrunkFrames:
    """The frame and elevation the trunk bias is expressed in.

    Attributes
    ----------
    joints : (3,) joint indices of :data:`TRUNK_JOINTS`.
    frames : (T, 3, 3) the thorax frame (columns ``X`` forward, ``Y`` up, ``Z`` right).
    basis : (T, 3) weights of the knots' values at the higher arm's elevation.
    """

    joints: np.ndarray
    frames: np.ndarray
    basis: np.ndarray


def trunk_frames(positions: np.ndarray, topology: Topology) -> TrunkFrames:
    """The thorax frames and knot weights of a skeleton (T, J, 3) [m] (module docstring); a frame's
    weights are NaN where neither arm's elevation is defined."""
    R = thorax_frame(positions, topology)
    elevation = arm_elevations(positions, topology, R)
    higher = np.fmax(elevation["left"], elevation["right"])
    basis = np.where(np.isnan(higher)[:, None], np.nan, knot_weights(np.nan_to_num(higher)))
    joints = np.array([topology.index(Landmark[j.upper()]) for j in TRUNK_JOINTS])
    return TrunkFrames(joints, R, basis)


def trunk_offsets(positions: np.ndarray, topology: Topology, coefficients: np.ndarray) -> np.ndarray:
    """(T, J, 3) [m] the trunk bias of a person with knot values ``coefficients`` (3, 3, 3) on a skeleton
    (T, J, 3) [m] in the world frame; zero for every other joint and where the frame is undefined."""
    frames = trunk_frames(positions, topology)
    local = np.einsum("tp,jpa->tja", frames.basis, coefficients)
    out = np.zeros_like(positions)
    out[:, frames.joints] = np.nan_to_num(np.einsum("tka,tja->tjk", frames.frames, local))
    return out
