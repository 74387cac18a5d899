"""Names of the humanoid's generalised coordinates, in clinical terms.

A motion is a ``(T, K)`` array over :data:`COORDINATES` (metres for ``root_x``/``root_y``,
radians for everything else). Angles follow the clinical sign conventions below, for either side,
so the same number means the same movement of the left and of the right arm.

- ``root_x``, ``root_y``: pelvis position on the floor, world frame (z up, floor at z = 0).
- ``root_yaw``: facing direction; 0 faces world +x, positive turns counter-clockwise seen from above.
- ``trunk_flexion`` (+ forward bend), ``trunk_lateral`` (+ lean to the subject's right),
  ``trunk_rotation`` (+ shoulders turn to the subject's left), pivoting between the hip centres
  (so that every bone of the skeleton stays rigid).
- ``neck_flexion`` (+ chin down), ``neck_rotation`` (+ look to the subject's left).
- per side ``_l`` / ``_r``:
  ``clav_elevation`` (+ shoulder hiking), ``clav_retraction`` (+ shoulder blade back),
  ``sh_plane`` (plane of elevation: 0 = frontal/abduction plane, pi/2 = sagittal/flexion plane, forward),
  ``sh_elevation`` (0 = arm hanging, pi/2 = horizontal, pi = overhead),
  ``sh_rotation`` (+ external rotation), ``elbow_flexion`` (0 = straight),
  ``forearm_rotation`` (+ supination, 0 = mid position, thumb forward when the arm hangs),
  ``wrist_flexion`` (+ palmar flexion),
  ``hip_flexion`` (+ thigh forward), ``hip_abduction`` (+ thigh outward), ``hip_rotation`` (+ external),
  ``knee_flexion`` (0 = straight, + bends), ``ankle_flexion`` (+ dorsiflexion).
"""

from __future__ import annotations

SIDES = ("l", "r")

ROOT = ("root_x", "root_y", "root_yaw")
TRUNK = ("trunk_flexion", "trunk_lateral", "trunk_rotation", "neck_flexion", "neck_rotation")
ARM = (
    "clav_elevation",
    "clav_retraction",
    "sh_plane",
    "sh_elevation",
    "sh_rotation",
    "elbow_flexion",
    "forearm_rotation",
    "wrist_flexion",
)
LEG = ("hip_flexion", "hip_abduction", "hip_rotation", "knee_flexion", "ankle_flexion")

COORDINATES: tuple[str, ...] = (
    ROOT
    + TRUNK
    + tuple(f"{c}_{s}" for s in SIDES for c in ARM)
    + tuple(f"{c}_{s}" for s in SIDES for c in LEG)
)
"""All coordinate names, in the column order of a motion array."""

INDEX: dict[str, int] = {name: i for i, name in enumerate(COORDINATES)}
