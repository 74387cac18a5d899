"""Clinical joint angles of a skeleton stream after the ISB recommendations (Wu et al. 2005).

Segment frames (columns ``X`` forward, ``Y`` up / proximal, ``Z`` to the subject's right):

- **thorax**: :func:`fusion.facing.thorax_frame` (``Y`` pelvis to spine-shoulder, ``Z`` the shoulder
  line made orthogonal to ``Y``);
- **pelvis**: ``Z`` from the left to the right hip centre, ``Y`` the world's up made orthogonal to
  ``Z`` (the skeleton has no landmark for pelvic tilt, so the pelvis is taken as level);
- **humerus** (ISB option 2): ``Y`` from the elbow to the shoulder centre, ``Z`` perpendicular to
  ``Y`` and the forearm (elbow to wrist), ``X = Y x Z``; defined only while the elbow is bent.

Angles [deg]:

- **trunk** (thorax against pelvis, Z-X-Y): ``trunk_flexion`` (+ forward), ``trunk_lateral_lean``
  (+ toward the subject's right), ``trunk_axial_rotation`` (+ chest turned to the subject's left);
- **humerothoracic** (humerus against thorax, Y-X-Y): ``ht_plane_of_elevation`` (0 abduction in
  the frontal plane, 90 forward flexion, in (-180, 180]), ``ht_elevation`` (0 hanging, 180 straight
  up), ``ht_axial_rotation`` (+ internal);
- ``elbow_flexion`` (0 straight);
- the paper's Table 4 angles at a vertex: ``spineshoulder_shoulder_elbow``,
  ``shoulder_spineshoulder_spinemid``, ``hip_shoulder_elbow``, ``knee_hip_spinemid``.

Left-side angles are computed on the mirror image (``Z`` pointing laterally), so both sides share
the signs above.

**The Y-X-Y singularity.** At zero elevation the first and last rotations share one axis: only
their sum, the total rotation about the humerus, is defined, and the error of the plane of elevation
grows as ``1 / sin(elevation)``. Below ``min_elevation_deg`` the plane of elevation is NaN, and the
axial rotation fades from the ISB value (at and above the threshold) to the total rotation (at zero
elevation): ``axial = total - w * plane`` with ``w = smoothstep(elevation / min_elevation_deg)``.
This is continuous in the humerus orientation everywhere except where the plane crosses its branch
cut at +-180 deg (elbow pointing to the body's midline) inside the fading zone, a pose the trunk
blocks. Axial rotation is NaN while the elbow is straighter than ``min_elbow_flexion_deg`` (the
humerus frame needs the forearm).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fusion.arrays import frozen, unit
from fusion.errors import BadInputError, UnknownNameError
from fusion.facing import thorax_frame
from fusion.topology import Landmark, Topology

SIDES = ("left", "right")
TRUNK_ANGLES = ("trunk_flexion", "trunk_lateral_lean", "trunk_axial_rotation")
ARM_ANGLES = ("ht_plane_of_elevation", "ht_elevation", "ht_axial_rotation", "elbow_flexion")
TABLE4_ANGLES = {
    "spineshoulder_shoulder_elbow": ("SPINE_SHOULDER", "SHOULDER_{s}", "ELBOW_{s}"),
    "shoulder_spineshoulder_spinemid": ("SHOULDER_{s}", "SPINE_SHOULDER", "SPINE_MID"),
    "hip_shoulder_elbow": ("HIP_{s}", "SHOULDER_{s}", "ELBOW_{s}"),
    "knee_hip_spinemid": ("KNEE_{s}", "HIP_{s}", "SPINE_MID"),
}
"""Table 4's vertex angles: name -> (A, vertex B, C) landmark names, ``{s}`` the side."""

_MIRROR_SIGNS = np.outer([1.0, 1.0, -1.0], [1.0, 1.0, -1.0])


def mirrored(R: np.ndarray) -> np.ndarray:
    """(..., 3, 3) ``M R M`` with ``M = diag(1, 1, -1)``: a relative rotation between two ISB frames
    of a left limb seen as the right one (elementwise, so NaN axes stay in their own entries)."""
    return R * _MIRROR_SIGNS


def angle_names() -> tuple[str, ...]:
    """Names of the columns of :class:`JointAngles`, in order."""
    sided = [f"{a}_{s}" for s in SIDES for a in (*ARM_ANGLES, *TABLE4_ANGLES)]
    return (*TRUNK_ANGLES, *sided)


@dataclass(frozen=True)
class AngleOptions:
    """Constants of the angle definitions.

    Attributes
    ----------
    min_elevation_deg : below this humerothoracic elevation the plane of elevation is NaN and the
        axial rotation fades to the total rotation about the humerus (see the module docstring).
    min_elbow_flexion_deg : below this elbow flexion the humerus frame, hence the axial rotation, is
        undefined (NaN).
    up : (3,) the world's up direction (the pelvis frame's ``Y``); the world frame of fused
        skeletons has +z up.
    """

    min_elevation_deg: float = 20.0
    min_elbow_flexion_deg: float = 15.0
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)

    def __post_init__(self) -> None:
        if not 0.0 < self.min_elevation_deg < 90.0:
            raise BadInputError(f"min_elevation_deg must lie in (0, 90), got {self.min_elevation_deg}")
        if not 0.0 < self.min_elbow_flexion_deg < 90.0:
            raise BadInputError(f"min_elbow_flexion_deg must lie in (0, 90), got {self.min_elbow_flexion_deg}")
        up = np.asarray(self.up, dtype=float)
        if up.shape != (3,) or not np.all(np.isfinite(up)) or np.linalg.norm(up) < 1e-9:
            raise BadInputError(f"up must be a finite non-zero 3-vector, got {self.up!r}")


@dataclass(frozen=True, eq=False)
class JointAngles:
    """Joint angles per frame.

    Attributes
    ----------
    names : (K,) angle names (see :func:`angle_names`).
    degrees : (T, K) float64 [deg]; NaN where an angle is undefined or its joints are absent.
    offsets : (K,) float64 [deg] constant offsets already subtracted (a neutral-pose trial), 0 if none.
    """

    names: tuple[str, ...]
    degrees: np.ndarray
    offsets: np.ndarray

    def __post_init__(self) -> None:
        d = np.asarray(self.degrees, dtype=float)
        o = np.asarray(self.offsets, dtype=float)
        if d.ndim != 2 or d.shape[1] != len(self.names):
            raise BadInputError(f"degrees must have shape (T, {len(self.names)}), got {d.shape}")
        if o.shape != (len(self.names),) or not np.all(np.isfinite(o)):
            raise BadInputError(f"offsets must be a finite ({len(self.names)},) array, got shape {o.shape}")
        object.__setattr__(self, "degrees", frozen(d))
        object.__setattr__(self, "offsets", frozen(o))

    def __getitem__(self, name: str) -> np.ndarray:
        """(T,) degrees of one angle."""
        try:
            return self.degrees[:, self.names.index(name)]
        except ValueError:
            raise UnknownNameError("joint angle", name, self.names) from None

    def as_dict(self) -> dict[str, np.ndarray]:
        """Angle name -> (T,) degrees."""
        return {n: self.degrees[:, k] for k, n in enumerate(self.names)}


def vertex_angle_deg(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Angle ABC at vertex ``b`` in degrees, shape (...,), for points of shape (..., 3).

    NaN where a point is NaN or a segment has zero length.
    """
    cos = np.einsum("...i,...i->...", unit(a - b), unit(c - b))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def pelvis_frame(positions: np.ndarray, topology: Topology, up: np.ndarray) -> np.ndarray:
    """(..., 3, 3) level pelvis frame, columns ``X`` forward, ``Y`` up, ``Z`` right (see the module
    docstring); ``positions`` is (..., J, 3), ``up`` (3,) the world's up direction."""
    right = positions[..., topology.index(Landmark.HIP_RIGHT), :] - positions[..., topology.index(Landmark.HIP_LEFT), :]
    z = unit(right)
    u = unit(np.asarray(up, dtype=float))
    y = unit(u - np.einsum("...k,k->...", z, u)[..., None] * z)
    return np.stack([np.cross(y, z), y, z], axis=-1)


def humerus_frame(shoulder: np.ndarray, elbow: np.ndarray, wrist: np.ndarray, min_elbow_flexion_deg: float) -> np.ndarray:
    """(..., 3, 3) ISB humerus frame (option 2), columns ``X`` forward, ``Y`` elbow to shoulder,
    ``Z`` right, from (..., 3) joint positions; ``X`` and ``Z`` NaN while the elbow flexion is below
    ``min_elbow_flexion_deg``."""
    y = unit(shoulder - elbow)
    z = unit(np.cross(y, elbow - wrist))
    bent = vertex_angle_deg(shoulder, elbow, wrist) <= 180.0 - min_elbow_flexion_deg
    z = np.where(bent[..., None], z, np.nan)
    return np.stack([np.cross(y, z), y, z], axis=-1)


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _wrap_deg(a: np.ndarray) -> np.ndarray:
    return -((180.0 - a) % 360.0) + 180.0


def humerothoracic_deg(R_thorax_humerus: np.ndarray, min_elevation_deg: float = 20.0) -> np.ndarray:
    """(..., 3) plane of elevation, elevation and axial rotation [deg] of the humerus frame expressed
    in the thorax frame, ``R_thorax_humerus`` (..., 3, 3) with the ISB axes of both (right side, or
    the mirror image of a left arm). Y-X-Y with the singularity treatment of the module docstring;
    NaN entries of the matrix give NaN angles (the axial rotation alone when only ``X``/``Z`` of the
    humerus are NaN)."""
    R = np.asarray(R_thorax_humerus, dtype=float)
    yh = R[..., :, 1]
    elevation = np.degrees(np.arccos(np.clip(yh[..., 1], -1.0, 1.0)))
    plane = np.degrees(np.arctan2(-yh[..., 0], -yh[..., 2]))
    total = np.degrees(np.arctan2(R[..., 0, 2] - R[..., 2, 0], R[..., 0, 0] + R[..., 2, 2]))
    w = _smoothstep(elevation / min_elevation_deg)
    axial = _wrap_deg(total - w * plane)
    plane = np.where(elevation >= min_elevation_deg, plane, np.nan)
    return np.stack([plane, elevation, axial], axis=-1)


def trunk_deg(R_pelvis_thorax: np.ndarray) -> np.ndarray:
    """(..., 3) trunk flexion, lateral lean and axial rotation [deg] from the thorax frame expressed
    in the pelvis frame, (..., 3, 3), Z-X-Y; signs as in the module docstring."""
    R = np.asarray(R_pelvis_thorax, dtype=float)
    flexion = -np.degrees(np.arctan2(-R[..., 0, 1], R[..., 1, 1]))
    lean = np.degrees(np.arcsin(np.clip(R[..., 2, 1], -1.0, 1.0)))
    rotation = np.degrees(np.arctan2(-R[..., 2, 0], R[..., 2, 2]))
    return np.stack([flexion, lean, rotation], axis=-1)


def relative_rotation(R_world_a: np.ndarray, R_world_b: np.ndarray) -> np.ndarray:
    """(..., 3, 3) ``R_a_b = R_world_a^T R_world_b`` for (..., 3, 3) frames (NaN propagates)."""
    return np.einsum("...ki,...kj->...ij", R_world_a, R_world_b)


def joint_angles(positions: np.ndarray, topology: Topology, options: AngleOptions = AngleOptions()) -> JointAngles:
    """The clinical angles of the module docstring for every frame of a skeleton stream.

    Parameters
    ----------
    positions : (T, J, 3) joint positions [m]; NaN where absent. Any frame whose up direction is
        ``options.up`` (the world frame of fused skeletons by default).
    topology : the J joints.
    options : thresholds and the up direction.

    Returns
    -------
    JointAngles
        (T, K) degrees, columns :func:`angle_names`; no offsets.

    Raises
    ------
    BadInputError
        ``positions`` is not (T, J, 3).
    """
    P = np.asarray(positions, dtype=float)
    if P.ndim != 3 or P.shape[1:] != (topology.n_joints, 3):
        raise BadInputError(f"positions must have shape (T, {topology.n_joints}, 3), got {P.shape}")

    def j(name: str) -> np.ndarray:
        return P[:, topology.index(Landmark[name])]

    thorax = thorax_frame(P, topology)
    columns = {n: c for n, c in zip(TRUNK_ANGLES, np.moveaxis(trunk_deg(relative_rotation(
        pelvis_frame(P, topology, np.asarray(options.up)), thorax)), -1, 0))}
    for side in SIDES:
        s = side.upper()
        shoulder, elbow, wrist = j(f"SHOULDER_{s}"), j(f"ELBOW_{s}"), j(f"WRIST_{s}")
        R = relative_rotation(thorax, humerus_frame(shoulder, elbow, wrist, options.min_elbow_flexion_deg))
        if side == "left":
            R = mirrored(R)
        ht = humerothoracic_deg(R, options.min_elevation_deg)
        columns |= {f"{n}_{side}": ht[:, k] for k, n in enumerate(ARM_ANGLES[:3])}
        columns[f"elbow_flexion_{side}"] = 180.0 - vertex_angle_deg(shoulder, elbow, wrist)
        for name, (a, b, c) in TABLE4_ANGLES.items():
            columns[f"{name}_{side}"] = vertex_angle_deg(j(a.format(s=s)), j(b.format(s=s)), j(c.format(s=s)))
    names = angle_names()
    return JointAngles(names, np.stack([columns[n] for n in names], axis=1), np.zeros(len(names)))


NEUTRAL_ANGLES = (*TRUNK_ANGLES, *(f"{a}_{s}" for s in SIDES for a in ("ht_elevation", "elbow_flexion")))
"""Angles a neutral-pose trial zeroes: those whose neutral value is 0 by definition and defined there."""


def neutral_offsets(angles: JointAngles, frames: np.ndarray) -> np.ndarray:
    """(K,) constant offsets [deg] of a neutral-pose trial: the median of each of
    :data:`NEUTRAL_ANGLES` over ``frames`` (a (T,) bool mask of the trial), 0 for the other angles.

    Raises
    ------
    BadInputError
        ``frames`` is not a (T,) bool mask, or a neutral angle has no finite value in it.
    """
    mask = np.asarray(frames)
    if mask.dtype != bool or mask.shape != (angles.degrees.shape[0],):
        raise BadInputError(f"frames must be a ({angles.degrees.shape[0]},) bool mask, got {mask.dtype} {mask.shape}")
    offsets = np.zeros(len(angles.names))
    for name in NEUTRAL_ANGLES:
        v = angles[name][mask]
        v = v[np.isfinite(v)]
        if v.size == 0:
            raise BadInputError(f"the neutral-pose trial has no frame with {name}: choose frames where the "
                                f"subject stands still and fully tracked")
        offsets[angles.names.index(name)] = float(np.median(v))
    return offsets


def remove_offsets(angles: JointAngles, offsets: np.ndarray) -> JointAngles:
    """``angles`` minus constant per-angle ``offsets`` (K,) [deg] (e.g. :func:`neutral_offsets`)."""
    o = np.asarray(offsets, dtype=float)
    if o.shape != (len(angles.names),):
        raise BadInputError(f"offsets must have shape ({len(angles.names)},), got {o.shape}")
    return JointAngles(angles.names, angles.degrees - o, angles.offsets + o)
