"""How far a tracker's errors are shared along a limb, and how far they lie along its bones, measured
truth-free.

A tracker that misplaces a limb segment in one camera's view misplaces the joints at both of its ends
together: the steady parts of their cross-camera residuals (:mod:`fusion.merge.residual_parts`) then
point the same way. :func:`limb_cosine` measures it over the limb bones (:func:`limb_links`), on real and
simulated recordings alike. A tracker sure of a limb's axis but not of where along it a joint sits moves
the joint along the bone from frame to frame, and errs along it between views: :func:`bone_step_parts`
measures how much of the elbows' and wrists' frame-to-frame steps lies along their bones, and
:func:`residual_bone_share` how much of their steady cross-camera residual does.
"""

from __future__ import annotations

import numpy as np

from fusion.arrays import nanmedian
from fusion.topology import Landmark, Topology

LIMB_STEMS = ("shoulder", "elbow", "wrist", "hand", "handtip", "thumb", "knee", "ankle", "foot")
"""Landmark stems of the limb joints (both sides), from the shoulders and knees outward."""


def limb_links(topology: Topology) -> np.ndarray:
    """(B, 2) int (parent, child) bones of ``topology`` with both ends limb joints (:data:`LIMB_STEMS`):
    shoulder-elbow, elbow-wrist, wrist-hand, hand-tip, hand-thumb, knee-ankle, ankle-foot (those the
    topology has)."""
    limb = np.zeros(topology.n_joints, dtype=bool)
    for stem in LIMB_STEMS:
        for side in ("left", "right"):
            lm = Landmark(f"{stem}_{side}")
            if lm in topology.landmarks:
                limb[topology.index(lm)] = True
    bones = topology.bones
    return bones[limb[bones[:, 0]] & limb[bones[:, 1]]].reshape(-1, 2)


def limb_cosine(steady: np.ndarray, topology: Topology) -> float:
    """Median over camera pairs and limb bones (:func:`limb_links`) of the cosine between the steady
    residual vectors (P, J, 3) [mm] of the bone's two joints: near 0 when each joint's steady error is
    its own, near 1 when a limb's joints err together; NaN without any such pair of vectors."""
    links = limb_links(topology)
    if steady.size == 0 or links.size == 0:
        return float("nan")
    a, b = steady[:, links[:, 0]], steady[:, links[:, 1]]
    norms = np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1)
    cos = np.where(norms > 0, np.sum(a * b, axis=-1) / np.where(norms > 0, norms, 1.0), np.nan)
    return float(nanmedian(cos.ravel())) if np.isfinite(cos).any() else float("nan")


STEP_JOINTS = ("elbow", "wrist")
"""Landmark stems (both sides) whose frame-to-frame steps and residuals are split along and across their
bones."""

MIN_STEP_M = 0.002
"""Second differences shorter than this [m] are left out of :func:`bone_step_parts`."""

MIN_FRAMES = 30
"""Frames a joint's residual needs in a camera pair for :func:`residual_bone_share` to count it."""


def _arm_links(topology: Topology) -> tuple[np.ndarray, np.ndarray]:
    """(parent, child) joint indices of the limb bones that end in a :data:`STEP_JOINTS` joint."""
    links = limb_links(topology)
    keep = np.isin(links[:, 1], [topology.index(Landmark(f"{stem}_{side}")) for stem in STEP_JOINTS
                                 for side in ("left", "right") if Landmark(f"{stem}_{side}") in topology.landmarks])
    return links[keep, 0], links[keep, 1]


def bone_step_parts(steps: np.ndarray, positions: np.ndarray, topology: Topology) -> tuple[float, int]:
    """The squared cosines between the second differences ``steps`` (T, J, 3) [m] of one camera's joints
    ``positions`` (T, J, 3) [m] of the :data:`STEP_JOINTS` and the bone from the parent limb joint (the
    reported bone at that frame), summed, and the number of steps, over frames and joints. Their mean is
    1/3 for isotropic steps, near 1 for steps along the bone; each step counts once, however long. Steps
    shorter than :data:`MIN_STEP_M` (quantisation, the motion's own) and absent ones are left out."""
    parent, child = _arm_links(topology)
    bone = positions[:, child] - positions[:, parent]
    axis = bone / np.linalg.norm(bone, axis=-1, keepdims=True)
    d = steps[:, child]
    size = np.linalg.norm(d, axis=-1)
    cos2 = np.sum(d * axis, axis=-1) ** 2 / np.where(size > 0, size, 1.0) ** 2
    ok = np.isfinite(cos2) & (size >= MIN_STEP_M)
    return float(cos2[ok].sum()), int(ok.sum())


def residual_bone_share(parts: list[np.ndarray], joints: np.ndarray, camera: np.ndarray, topology: Topology) -> float:
    """How much of the elbows' and wrists' steady cross-camera residual lies along their bones.

    Each residual (``parts``: one (T, J, 3) series [m] per camera pair, as
    :func:`fusion.merge.residual_parts.cross_camera_residuals` gives) is expressed at every frame in the
    joint's bone frame: along the bone from its parent limb joint, across it toward the reference camera
    (at ``camera``, (3,) [m]), and across both; ``joints`` (T, J, 3) [m] are the reference camera's joints
    in the same frame. The steady residual is the median of each component over the frames (at least
    :data:`MIN_FRAMES`); its share along the bone is 1/3 for an isotropic one. Returns the median share over
    camera pairs and joints; NaN without any."""
    parent, child = _arm_links(topology)
    bone = joints[:, child] - joints[:, parent]
    a = bone / np.linalg.norm(bone, axis=-1, keepdims=True)
    ray = joints[:, child] - camera
    b = ray - np.sum(ray * a, axis=-1, keepdims=True) * a
    b = b / np.linalg.norm(b, axis=-1, keepdims=True)
    c = np.cross(a, b)
    shares = []
    for part in parts:
        r = part[:, child]
        comp = np.stack([np.sum(r * e, axis=-1) for e in (a, b, c)], axis=-1)  # (T, K, 3)
        for k in range(comp.shape[1]):
            ok = np.isfinite(comp[:, k]).all(axis=-1)
            if ok.sum() >= MIN_FRAMES:
                steady = np.median(comp[ok, k], axis=0)
                if steady @ steady > 0:
                    shares.append(steady[0] ** 2 / (steady @ steady))
    return float(np.median(shares)) if shares else float("nan")
