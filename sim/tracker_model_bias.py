"""The tracker's body-model error of one subject: drawn once, shared by every camera (:mod:`sim.tracker`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fusion.errors import BadInputError
from fusion.topology import Landmark, Topology
from sim.tracker_arm_bias import ARM_JOINTS
from sim.tracker_noise import (
    JointGroup,
    TrackerNoise,
    joint_groups,
    magnitudes,
    unit_vectors,
)
from sim.tracker_trunk_bias import TRUNK_JOINTS


@dataclass(frozen=True, eq=False)
class TrackerModelBias:
    """The tracker's body-model error for one subject, shared by every camera.

    Attributes
    ----------
    topology : Topology
        Joint set (J joints).
    offsets_body : np.ndarray
        (J, 3) float64 [m] per-joint offset in the body frame (x forward, y left, z up).
    arm_coefficients, trunk_coefficients : np.ndarray or None
        (3, P, 3) [m] this subject's arm and trunk biases (:func:`sim.tracker_arm_bias.arm_offsets`,
        :func:`sim.tracker_trunk_bias.trunk_offsets`); None: none.
    """

    topology: Topology
    offsets_body: np.ndarray
    arm_coefficients: np.ndarray | None = None
    trunk_coefficients: np.ndarray | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.topology, Topology):
            raise BadInputError(f"topology must be a Topology, got {type(self.topology).__name__}")
        off = np.array(self.offsets_body, dtype=np.float64)
        if off.shape != (self.topology.n_joints, 3) or not np.all(np.isfinite(off)):
            raise BadInputError(f"offsets_body must be finite, shape ({self.topology.n_joints}, 3); got {off.shape}")
        off.setflags(write=False)
        object.__setattr__(self, "offsets_body", off)


def sample_model_bias(topology: Topology, noise: TrackerNoise, *, rng: np.random.Generator) -> TrackerModelBias:
    """Draw the body-model bias of one subject.

    Each joint gets a random direction with magnitude ``sqrt(model_fraction) * U(bias_m)``; the hips
    add the systematic ``hip_up_m`` up and ``hip_out_m`` outward. With an arm bias the shoulders,
    elbows and wrists get the person's arm coefficients instead, with a trunk bias the pelvis, spine-mid
    and spine-shoulder its trunk coefficients.

    Parameters
    ----------
    topology : Topology
        Joint set (J joints).
    noise : TrackerNoise
        Error parameters.
    rng : np.random.Generator
        Source of the draws.

    Returns
    -------
    TrackerModelBias
        Offsets (J, 3) [m] in the body frame.
    """
    J = topology.n_joints
    mags = np.sqrt(noise.model_fraction) * magnitudes(noise.per_joint(topology, "bias_m"), rng)
    offsets = mags[:, None] * unit_vectors(J, rng)
    hips = np.array([g is JointGroup.HIP for g in joint_groups(topology)])
    side = np.zeros(J)
    side[topology.lr_pairs[:, 0]], side[topology.lr_pairs[:, 1]] = 1.0, -1.0
    offsets[:, 1] += hips * side * noise.hip_out_m
    offsets[:, 2] += hips * noise.hip_up_m
    arm = trunk = None
    if noise.arm_bias is not None:
        offsets[[topology.index(Landmark[f"{j.upper()}_{s}"]) for j in ARM_JOINTS for s in ("LEFT", "RIGHT")]] = 0.0
        arm = noise.arm_bias.draw(rng)
    if noise.trunk_bias is not None:  # drawn after the arm's: a profile without one draws as before
        offsets[[topology.index(Landmark[j.upper()]) for j in TRUNK_JOINTS]] = 0.0
        trunk = noise.trunk_bias.draw(rng)
    return TrackerModelBias(topology, offsets, arm, trunk)
