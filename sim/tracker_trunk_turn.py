"""The trunk turned against the limbs: a tracker's small error in the trunk's orientation.

On the real two-camera Azure Kinect rig the cameras disagree on the trunk's orientation once they
agree on the whole body (:func:`fusion.merge.residual_parts.trunk_turn`), and that disagreement
changes from session to session more than the simulated tracker's joint errors make it: a calibration
that leans on the trunk joints then spreads over one person's sessions as it does on the real rig. A
camera session turns its reported trunk joints (:func:`fusion.merge.residual_parts.trunk_joints`) about
the reported pelvis by one rotation, each axis drawn with the standard deviation
:attr:`sim.tracker_noise.TrackerNoise.trunk_turn_sd_deg`.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from fusion.merge.residual_parts import trunk_joints
from fusion.topology import Landmark, Topology


def turn_trunk(positions: np.ndarray, topology: Topology, rotation_vector_rad: np.ndarray) -> np.ndarray:
    """(T, J, 3) [m] joints ``positions`` (T, J, 3) [m] with the trunk joints turned by
    ``rotation_vector_rad`` (3,) [rad] about each frame's pelvis; the limb joints unchanged."""
    R = Rotation.from_rotvec(np.asarray(rotation_vector_rad, dtype=float)).as_matrix()
    trunk = trunk_joints(topology)
    pelvis = positions[:, topology.index(Landmark.PELVIS)][:, None, :]
    out = np.array(positions, dtype=float)
    out[:, trunk] = pelvis + (out[:, trunk] - pelvis) @ R.T
    return out
