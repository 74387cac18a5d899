"""Functional centres of the shoulders and hips from the limb axes: where a limb pivots on the trunk.

A limb axis fitted to the depth clouds (:mod:`fusion.merge.limb_axes`) says where the upper arm or
thigh lies across its length but not where along it its proximal joint sits, and the tracker's
shoulder slides along the arm as it rises (its body-model bias). Every axis of the segment passes
through the joint centre, and the centre is fixed in the trunk: expressed in a trunk-fixed frame,
the axes of a limb that moves through different directions meet at it. This is the idea of the
functional joint centres of optical motion capture (a segment's motion relative to its parent, as in
Gamage & Lasenby 2002 for markers; methods compared by Ehrig et al. 2006, J Biomech 39:2798), with the
segment's long axis in place of its markers.

- **Frame.** Per instant the project's thorax frame (:func:`fusion.facing.thorax_frame`: up from the
  pelvis to the spine-shoulder joint, lateral along the shoulders' line) with its origin at the
  spine-shoulder joint. It follows the thorax's axial rotation; its lateral axis turns a little as one
  shoulder slides forward with its arm (a frame on the hips' line avoids that but not the thorax's
  rotation, and did no better in simulation). The tracker's trunk joints carry their own bias,
  constant in the trunk for a standing person, which the pivot (a point fixed in that frame) absorbs.
- **Pivot.** The point nearest in least squares to the segment's counted axes in that frame,
  iteratively reweighted (Huber weights of scale ``huber_m``).
- **Check.** Axes that all point one way (an arm that never leaves the side, legs that stand) meet
  anywhere along them: a pivot counts only when the smallest eigenvalue of the axes' weighted mean
  projector ``I - d d^T`` is at least ``min_spread`` (about the mean squared sine of their spread
  about the worst-constrained direction).
- **Twins.** A joint whose own axes fail the check while its twin's pass (the hanging arm of a
  one-arm movement) takes the twin's pivot mirrored across the trunk frame's sagittal plane, moved
  sideways to the median midpoint of the two joints as the tracker measured them: the spine-shoulder
  joint, the frame's origin, may sit centimetres to one side. The body is taken to be symmetric. (The
  plane bisecting the two measured joints, tilted as well, did worse in simulation: the tracker's
  biases of a joint and its twin differ.)
- **Anchor.** At every instant the pivot, back in the world, is where the joint is pulled to along
  its axis (:func:`fusion.merge.limb_corrections.joint_offsets`). With both hips' pivots the pelvis
  joint (the project's landmark midway between the hip centres) is anchored at their midpoint.

What it cannot see: a joint centre that moves in the trunk (shoulder hiking, the scapula's rotation)
is found where it sits on average; the hips sit on the pelvis, which the thorax frame follows only as
far as the pelvis turns and tilts with the thorax.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from fusion.facing import thorax_frame
from fusion.topology import Landmark, Topology

PIVOT_PAIRS = {"shoulders": (Landmark.SHOULDER_LEFT, Landmark.SHOULDER_RIGHT),
               "hips": (Landmark.HIP_LEFT, Landmark.HIP_RIGHT)}
"""The proximal joints whose centres a pivot may give, in named pairs of twins."""

FRAME_JOINTS = (Landmark.SPINE_SHOULDER, Landmark.PELVIS, Landmark.SPINE_MID, Landmark.SHOULDER_LEFT,
                Landmark.SHOULDER_RIGHT, Landmark.HIP_LEFT, Landmark.HIP_RIGHT)
"""The joints the trunk frame (:func:`trunk_poses`) and the pelvis between the hips (:func:`anchors`) need."""


@dataclass(frozen=True)
class Pivot:
    """One joint's functional centre (:func:`pivots`).

    Attributes
    ----------
    joint : the joint's index in the topology.
    segment : the index of the segment whose axes gave it.
    point : (3,) [m] the pivot in the trunk frame (NaN when it did not count).
    spread : the smallest eigenvalue of the axes' weighted mean projector (the check).
    rms_m : [m] RMS distance of the counted axes from the pivot, Huber-weighted.
    instants : counted axes used.
    twin : the point is the twin joint's pivot mirrored across the trunk's midplane (this joint's own
        axes did not pass the check).
    """

    joint: int
    segment: int
    point: np.ndarray
    spread: float
    rms_m: float
    instants: int
    twin: bool = False

    @property
    def counts(self) -> bool:
        return bool(np.isfinite(self.point).all())


def trunk_poses(targets: np.ndarray, topology: Topology) -> tuple[np.ndarray, np.ndarray]:
    """(K, 3) origins [m] (the spine-shoulder joint) and (K, 3, 3) rotations (the project's thorax frame,
    :func:`fusion.facing.thorax_frame`) of the trunk at each instant of ``targets`` (K, J, 3); NaN where a
    joint they need is absent."""
    return targets[:, topology.index(Landmark.SPINE_SHOULDER)], thorax_frame(targets, topology)


def nearest_point(centres: np.ndarray, directions: np.ndarray, huber_m: float,
                  iterations: int = 10) -> tuple[np.ndarray, float, float]:
    """The point nearest in least squares to the lines through ``centres`` (N, 3) along unit
    ``directions`` (N, 3), reweighted with Huber weights of scale ``huber_m`` [m]; returns the point (3,),
    the smallest eigenvalue of the weighted mean projector and the weighted RMS distance [m]."""
    P = np.eye(3) - directions[:, :, None] * directions[:, None, :]  # (N, 3, 3)
    Pc = np.einsum("nij,nj->ni", P, centres)
    w = np.ones(len(centres))
    for _ in range(iterations):
        M = np.einsum("n,nij->ij", w, P)
        p = np.linalg.lstsq(M, w @ Pc, rcond=None)[0]  # parallel lines: the point nearest the origin
        r = np.linalg.norm(Pc - P @ p, axis=-1)
        w = 1.0 / np.maximum(1.0, r / huber_m)
    spread = float(np.linalg.eigvalsh(np.einsum("n,nij->ij", w, P) / w.sum())[0])
    return p, spread, float(np.sqrt(w @ r**2 / w.sum()))


def _pivot(origin: np.ndarray, R: np.ndarray, framed: np.ndarray, j: int, s: int, centres: np.ndarray,
           directions: np.ndarray, counted: np.ndarray, huber_m: float, min_spread: float, min_instants: int) -> Pivot:
    k = counted[:, s] & framed
    if k.sum() < min_instants:
        return Pivot(j, s, np.full(3, np.nan), 0.0, float("nan"), int(k.sum()))
    c = np.einsum("kji,kj->ki", R[k], centres[k, s] - origin[k])
    d = np.einsum("kji,kj->ki", R[k], directions[k, s])
    p, spread, rms = nearest_point(c, d, huber_m)
    return Pivot(j, s, p if spread >= min_spread else np.full(3, np.nan), spread, rms, int(k.sum()))


def mirrored(point: np.ndarray, joint: np.ndarray, twin: np.ndarray, origin: np.ndarray, R: np.ndarray) -> np.ndarray:
    """(3,) ``point`` (trunk frame: forward, up, right) mirrored across the frame's sagittal plane moved
    to the median midpoint, in the frame (``origin`` (K, 3), ``R`` (K, 3, 3)), of a measured ``joint`` and
    its ``twin`` (K, 3) [m]."""
    mid = np.nanmedian(np.einsum("kji,kj->ki", R, 0.5 * (joint + twin) - origin)[:, 2])
    return np.array([point[0], point[1], 2.0 * mid - point[2]])


def pivots(targets: np.ndarray, topology: Topology, segments: np.ndarray, centres: np.ndarray,
           directions: np.ndarray, counted: np.ndarray, *, huber_m: float, min_spread: float,
           min_instants: int, pairs: Sequence[str] = tuple(PIVOT_PAIRS)) -> list[Pivot]:
    """The functional centre of each joint of the :data:`PIVOT_PAIRS` named in ``pairs`` that is the
    proximal joint of one of ``segments`` (S, 2), from that segment's axes (points ``centres`` and unit ``directions``, (K, S, 3),
    world; ``counted`` (K, S)) in the trunk frame of ``targets`` (K, J, 3) (module docstring); a joint
    whose own axes fail the checks takes its twin's pivot mirrored across the pair's midplane. None
    when the topology lacks a joint of :data:`FRAME_JOINTS`."""
    if not all(lm in topology.landmarks for lm in FRAME_JOINTS):
        return []
    origin, R = trunk_poses(targets, topology)
    framed = np.isfinite(origin).all(axis=-1) & np.isfinite(R).all(axis=(-2, -1))
    out = []
    for pair in (PIVOT_PAIRS[name] for name in pairs):
        found = {}
        for lm in pair:
            j = topology.index(lm) if lm in topology.landmarks else -1
            for s in np.flatnonzero(segments[:, 0] == j)[:1]:
                found[lm] = _pivot(origin, R, framed, j, int(s), centres, directions, counted, huber_m, min_spread,
                                   min_instants)
        for lm, twin in zip(pair, pair[::-1]):
            if lm in found and not found[lm].counts and twin in found and found[twin].counts:
                found[lm] = replace(found[lm], point=mirrored(found[twin].point, targets[:, topology.index(lm)],
                                                              targets[:, topology.index(twin)], origin, R), twin=True)
        out += list(found.values())
    return out


def anchors(targets: np.ndarray, topology: Topology, found: list[Pivot]) -> np.ndarray:
    """(K, J, 3) [m] each counting pivot back in the world at every instant of ``targets`` (K, J, 3), and
    the pelvis at the hips' midpoint when both count; NaN for the other joints and where the trunk frame is
    absent."""
    out = np.full(targets.shape, np.nan)
    if not any(p.counts for p in found):
        return out
    origin, R = trunk_poses(targets, topology)
    for p in found:
        if p.counts:
            out[:, p.joint] = origin + R @ p.point
    hips = [topology.index(lm) for lm in (Landmark.HIP_LEFT, Landmark.HIP_RIGHT)]
    if {p.joint for p in found if p.counts} >= set(hips):
        out[:, topology.index(Landmark.PELVIS)] = out[:, hips].mean(axis=1)
    return out
