"""Rigid transforms: the one place that builds, validates, composes, inverts and applies them.

A transform is a ``(4, 4)`` float64 array named ``T_<to>_<from>``:
``p_world = apply(T_world_cam, p_cam)`` and ``T_a_c = compose(T_a_b, T_b_c)``.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from fusion.errors import BadInputError

_ORTHO_TOL = 1e-6


def make_transform(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Build ``(..., 4, 4)`` transforms from rotations ``(..., 3, 3)`` and translations ``(..., 3)`` [m]."""
    R = np.asarray(R, dtype=float)
    t = np.asarray(t, dtype=float)
    if R.shape[-2:] != (3, 3) or t.shape[-1:] != (3,) or R.shape[:-2] != t.shape[:-1]:
        raise BadInputError(f"rotation (...,3,3) and translation (...,3) expected, got {R.shape} and {t.shape}")
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = t
    T[..., 3, 3] = 1.0
    return T


def validate_transform(T: np.ndarray, name: str = "transform") -> np.ndarray:
    """Return ``T`` as float64 ``(..., 4, 4)`` after checking it is a finite proper rigid transform.

    Raises
    ------
    BadInputError
        Wrong shape, non-finite entries, a non-orthonormal or reflecting rotation, or a bad last row.
    """
    T = np.asarray(T, dtype=float)
    if T.shape[-2:] != (4, 4):
        raise BadInputError(f"{name}: expected shape (..., 4, 4), got {T.shape}")
    if not np.all(np.isfinite(T)):
        raise BadInputError(f"{name}: contains NaN or infinite entries")
    R = T[..., :3, :3]
    err = np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3)).max(initial=0.0)
    if err > _ORTHO_TOL:
        raise BadInputError(f"{name}: rotation part is not orthonormal (max error {err:.2e})")
    if np.any(np.linalg.det(R) < 0):
        raise BadInputError(f"{name}: rotation part is a reflection (det < 0)")
    if np.abs(T[..., 3, :] - [0, 0, 0, 1]).max(initial=0.0) > 0:
        raise BadInputError(f"{name}: last row must be [0, 0, 0, 1]")
    return T


def invert(T_a_b: np.ndarray) -> np.ndarray:
    """Inverse ``T_b_a`` of rigid transforms ``(..., 4, 4)`` (closed form, no matrix inverse)."""
    T_a_b = np.asarray(T_a_b, dtype=float)
    R_t = np.swapaxes(T_a_b[..., :3, :3], -1, -2)
    return make_transform(R_t, -(R_t @ T_a_b[..., :3, 3:4])[..., 0])


def compose(*transforms: np.ndarray) -> np.ndarray:
    """Product of transforms left to right: ``compose(T_a_b, T_b_c) = T_a_c``; broadcasts over ``...``."""
    if not transforms:
        raise BadInputError("compose needs at least one transform")
    out = np.asarray(transforms[0], dtype=float)
    for T in transforms[1:]:
        out = out @ np.asarray(T, dtype=float)
    return out


def apply(T_a_b: np.ndarray, p_b: np.ndarray) -> np.ndarray:
    """Map points ``(..., 3)`` [m] of frame b into frame a; NaN points stay NaN."""
    T_a_b = np.asarray(T_a_b, dtype=float)
    p_b = np.asarray(p_b, dtype=float)
    if p_b.shape[-1:] != (3,):
        raise BadInputError(f"points must have shape (..., 3), got {p_b.shape}")
    return p_b @ T_a_b[:3, :3].T + T_a_b[:3, 3]


def rotate(T_a_b: np.ndarray, v_b: np.ndarray) -> np.ndarray:
    """Rotate direction vectors ``(..., 3)`` of frame b into frame a (no translation)."""
    return np.asarray(v_b, dtype=float) @ np.asarray(T_a_b, dtype=float)[:3, :3].T


def rotation_angle(R: np.ndarray) -> np.ndarray:
    """Rotation angle [rad] of rotation matrices ``(..., 3, 3)``, in [0, pi], numerically robust."""
    R = np.asarray(R, dtype=float)
    return Rotation.from_matrix(R.reshape(-1, 3, 3)).magnitude().reshape(R.shape[:-2])


def transform_difference(T_a_b: np.ndarray, T_a_b_ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation angle [deg] and translation distance [m] between two estimates of the same transform."""
    T_a_b = np.asarray(T_a_b, dtype=float)
    T_a_b_ref = np.asarray(T_a_b_ref, dtype=float)
    R_delta = np.swapaxes(T_a_b_ref[..., :3, :3], -1, -2) @ T_a_b[..., :3, :3]
    angle = np.degrees(rotation_angle(R_delta))
    dist = np.linalg.norm(T_a_b[..., :3, 3] - T_a_b_ref[..., :3, 3], axis=-1)
    return angle, dist


def from_rotvec(rotvec: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Transforms from rotation vectors ``(..., 3)`` [rad] and translations ``(..., 3)`` [m]."""
    rotvec = np.asarray(rotvec, dtype=float)
    R = Rotation.from_rotvec(rotvec.reshape(-1, 3)).as_matrix().reshape(rotvec.shape[:-1] + (3, 3))
    return make_transform(R, t)


def to_rotvec(T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation vectors ``(..., 3)`` [rad] and translations ``(..., 3)`` [m] of transforms."""
    T = np.asarray(T, dtype=float)
    rv = Rotation.from_matrix(T[..., :3, :3].reshape(-1, 3, 3)).as_rotvec().reshape(T.shape[:-2] + (3,))
    return rv, T[..., :3, 3].copy()
