"""The tracker's arm landmarks relative to the arm: an offset that follows the limb and changes with
its elevation, fitted against an optical reference (``angle-validate --fit``).

A body tracker's shoulder, elbow and wrist joints do not sit on the joint centres, and where they sit
depends on the pose: a Kinect's shoulder joint rises with the arm, as the acromion does. Per joint
the offset is a 3-vector [m] in a frame that swings with the limb, given at three humerothoracic
elevations (:data:`KNOTS_DEG`) and interpolated between them by the quadratic through the three
(elevations outside the knots take the nearest end: the model does not extrapolate), plus an offset
per unit of the forearm's direction across the upper arm (:data:`FOREARM_TERMS`): a Kinect's elbow
joint moves forward as the forearm of a bent elbow turns outward, which shakes the elevation of an arm
rotating about its own axis (UI-PRMD's internal-external rotation). A straight arm has no such part.

The *swing frame* of a segment is the thorax frame (:func:`fusion.facing.thorax_frame`: ``X``
forward, ``Y`` up, ``Z`` right) turned by the smallest rotation that takes its downward axis ``-Y``
onto the segment's direction (shoulder to elbow for the shoulder and elbow joints, elbow to wrist
for the wrist): the offset follows the limb as it swings, without needing the arm's axial rotation,
which a straight arm does not define. The left arm uses the mirror image (``Z`` pointing laterally
on both sides), so one set of values serves both.

A person's values are drawn once (with the rest of the body-model bias) as the population's mean
plus its modes of variation, each times a standard normal draw: ``mean + sum_k z_k mode_k``. The
modes are the principal components of the fitted people's deviations from the mean, scaled so the
draws have the people's covariance (as in statistical shape models). Drawing each value on its own
would lose what the people share: one person's shoulder, elbow and wrist landmarks shift together,
which leaves the elbow straight; independent draws of the same size bend it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from fusion.errors import BadInputError
from fusion.facing import thorax_frame
from fusion.topology import Landmark, Topology

ARM_JOINTS = ("shoulder", "elbow", "wrist")
"""The joints the arm bias moves, in the coefficients' first axis."""

KNOTS_DEG = (0.0, 90.0, 150.0)
"""Humerothoracic elevations [deg] the offsets are given at: the arm hanging, horizontal, and as high
as the fitting movements reached."""

POWERS = len(KNOTS_DEG)
"""Values per joint and axis of an elevation-only bias (one per knot)."""

FOREARM_TERMS = ("forward", "lateral")
"""The arm bias's values per joint and axis after the knots: the offset [m] per unit of the forearm's
direction's forward and lateral components in the upper arm's swing frame (zero for a straight arm)."""

_SIDES = {"left": -1.0, "right": 1.0}


@dataclass(frozen=True)
class KnotBias:
    """Offsets of some landmarks at the elevation knots, for a population of people (the module
    docstring's draw); subclasses name the landmarks (``JOINTS``) and the frame the offsets are in.

    Attributes
    ----------
    mean_m : (J, P, 3) [m] the typical offsets: joint (``JOINTS``), term (``TERMS``: the knots of
        :data:`KNOTS_DEG`, then any further terms), axis of the frame (``X`` forward, ``Y`` up, ``Z``
        lateral or right). Values with the knots alone (P = 3) get zeros for the further terms.
    person_modes_m : (K, J, P, 3) [m] the modes of variation between people (module docstring); K may
        be 0 (every person the typical one).
    """

    JOINTS: ClassVar[tuple[str, ...]] = ()
    TERMS: ClassVar[int] = POWERS
    mean_m: tuple
    person_modes_m: tuple

    def __post_init__(self) -> None:
        label = type(self).__name__.replace("Bias", "").lower() + " bias"
        shape = (len(self.JOINTS), self.TERMS, 3)
        for name in ("mean_m", "person_modes_m"):
            arr = np.asarray(getattr(self, name), dtype=float)
            if name == "person_modes_m" and arr.size == 0:
                arr = arr.reshape((0, *shape))
            if arr.ndim >= 3 and arr.shape[-3:] == (len(self.JOINTS), POWERS, 3) and self.TERMS > POWERS:
                arr = np.concatenate([arr, np.zeros((*arr.shape[:-2], self.TERMS - POWERS, 3))], axis=-2)
            wanted = shape if name == "mean_m" else arr.shape[:1] + shape
            if arr.shape != wanted or not np.all(np.isfinite(arr)):
                raise BadInputError(f"{label} {name} must be finite numbers nested "
                                    f"{'(joint, term, axis)' if name == 'mean_m' else '(mode, joint, term, axis)'} = "
                                    f"{wanted}, got shape {arr.shape}")
            if np.any(np.abs(arr) > 0.5):
                raise BadInputError(f"{label} {name} holds a value over 0.5 m; offsets are metres")
            object.__setattr__(self, name, _nested_tuple(arr.tolist()))

    def draw(self, rng: np.random.Generator) -> np.ndarray:
        """(J, P, 3) [m] one person's values (``mean_m``'s shape)."""
        shape = (len(self.JOINTS), self.TERMS, 3)
        modes = np.asarray(self.person_modes_m, dtype=float).reshape((-1, *shape))
        return np.asarray(self.mean_m) + np.einsum("k,kjpa->jpa", rng.standard_normal(len(modes)), modes)


@dataclass(frozen=True)
class ArmBias(KnotBias):
    """How the arm landmarks sit on the arm (:data:`ARM_JOINTS`, swing-frame axes ``X`` forward, ``Y``
    along the segment's up, ``Z`` lateral), for a population of people: per joint the knots' values, then
    one per :data:`FOREARM_TERMS`.

    Attributes
    ----------
    yaw_scaled : bool
        Whether the tracker's yaw multiplier (``TrackerNoise.yaw_multiplier``, up to 3 seen from the side
        or behind) also scales these offsets. Off by default: they were measured on people facing the
        camera, and scaled three times a shoulder's medial offset crosses the shoulders of a skeleton seen
        from behind, which turns its chest normal around.
    """

    JOINTS: ClassVar[tuple[str, ...]] = ARM_JOINTS
    TERMS: ClassVar[int] = POWERS + len(FOREARM_TERMS)
    yaw_scaled: bool = False

    def __post_init__(self) -> None:
        super().__post_init__()
        if not isinstance(self.yaw_scaled, bool):
            raise BadInputError(f"arm bias yaw_scaled must be true or false, got {self.yaw_scaled!r}")


def _nested_tuple(value: object) -> object:
    return tuple(_nested_tuple(v) for v in value) if isinstance(value, list) else value


def _swing(R_thorax: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """(T, 3, 3) the thorax frame turned by the smallest rotation taking its ``-Y`` onto ``direction``
    (T, 3) (unit); NaN where the segment points straight up along ``+Y``."""
    a = -R_thorax[..., :, 1]
    v = np.cross(a, direction)
    c = np.einsum("...k,...k->...", a, direction)
    K = np.zeros(v.shape[:-1] + (3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    K[..., 1, 0], K[..., 2, 0], K[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        rotation = np.eye(3) + K + K @ K / np.where(c > -1 + 1e-9, 1 + c, np.nan)[..., None, None]
    return rotation @ R_thorax


@dataclass(frozen=True, eq=False)
class ArmFrames:
    """Per side, the frames and elevation the arm bias is expressed in (module docstring).

    Attributes
    ----------
    joints : side -> (3,) joint indices (shoulder, elbow, wrist).
    frames : side -> (T, 3, 3, 3) per joint the swing frame (columns ``X``, ``Y``, lateral ``Z``).
    elevation_deg : side -> (T,) [deg] the humerothoracic elevation.
    forearm : side -> (T, 2) the forearm's unit direction's components along :data:`FOREARM_TERMS` in
        the upper arm's swing frame.
    """

    joints: dict[str, np.ndarray]
    frames: dict[str, np.ndarray]
    elevation_deg: dict[str, np.ndarray]
    forearm: dict[str, np.ndarray]

    def basis(self, side: str) -> np.ndarray:
        """(T, P) weights of :class:`ArmBias`'s values at ``side``'s pose: the knots' (the quadratic's
        Lagrange basis, the elevation held within the knots), then the forearm's components."""
        return np.concatenate([knot_weights(self.elevation_deg[side]), self.forearm[side]], axis=-1)


def knot_weights(elevation_deg: np.ndarray) -> np.ndarray:
    """(..., 3) Lagrange weights of :data:`KNOTS_DEG` at ``elevation_deg`` (...), clipped to the knots' range."""
    e = np.clip(elevation_deg, KNOTS_DEG[0], KNOTS_DEG[-1])
    k = KNOTS_DEG
    return np.stack([np.prod([(e - k[m]) / (k[i] - k[m]) for m in range(len(k)) if m != i], axis=0)
                     for i in range(len(k))], axis=-1)


def _unit(v: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return v / np.linalg.norm(v, axis=-1, keepdims=True)


def arm_elevations(positions: np.ndarray, topology: Topology, R_thorax: np.ndarray | None = None
                   ) -> dict[str, np.ndarray]:
    """Per side (T,) [deg] the humerothoracic elevation of a skeleton (T, J, 3) [m]; ``R_thorax`` its
    (T, 3, 3) :func:`~fusion.facing.thorax_frame` when already at hand."""
    up = (thorax_frame(positions, topology) if R_thorax is None else R_thorax)[..., :, 1]
    out = {}
    for side in _SIDES:
        s, e = (positions[:, topology.index(Landmark[f"{j.upper()}_{side.upper()}"])] for j in ARM_JOINTS[:2])
        out[side] = np.degrees(np.arccos(np.clip(-np.einsum("tk,tk->t", up, _unit(e - s)), -1.0, 1.0)))
    return out


def arm_frames(positions: np.ndarray, topology: Topology) -> ArmFrames:
    """The swing frames and elevations of both arms of a skeleton (T, J, 3) [m] (module docstring)."""
    R = thorax_frame(positions, topology)
    joints, frames, forearm = {}, {}, {}
    for side, sign in _SIDES.items():
        idx = np.array([topology.index(Landmark[f"{j.upper()}_{side.upper()}"]) for j in ARM_JOINTS])
        mirror = R * np.array([1.0, 1.0, sign])
        s, e, w = (positions[:, i] for i in idx)
        hum = _swing(mirror, _unit(e - s))
        joints[side] = idx
        frames[side] = np.stack([hum, hum, _swing(mirror, _unit(w - e))], axis=1)
        forearm[side] = np.einsum("tka,tk->ta", hum[..., [0, 2]], _unit(w - e))
    return ArmFrames(joints, frames, arm_elevations(positions, topology, R), forearm)


def arm_offsets(positions: np.ndarray, topology: Topology, coefficients: np.ndarray) -> np.ndarray:
    """(T, J, 3) [m] the arm bias of a person with values ``coefficients`` (3, P, 3) (:class:`ArmBias`'s
    terms) on a skeleton (T, J, 3) [m] in the world frame; zero for every other joint and where a frame is
    undefined."""
    frames = arm_frames(positions, topology)
    out = np.zeros_like(positions)
    for side in _SIDES:
        local = np.einsum("tp,jpa->tja", frames.basis(side), coefficients)  # (T, 3 joints, 3 axes)
        world = np.einsum("tjka,tja->tjk", frames.frames[side], local)
        out[:, frames.joints[side]] = np.nan_to_num(world)
    return out
