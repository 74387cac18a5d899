"""How far a tracker's errors are shared along a limb, measured truth-free.

A tracker that misplaces a limb segment in one camera's view misplaces the joints at both of its ends
together: the steady parts of their cross-camera residuals (:mod:`fusion.merge.residual_parts`) then
point the same way. :func:`limb_cosine` measures it over the limb bones (:func:`limb_links`), on real and
simulated recordings alike.
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
