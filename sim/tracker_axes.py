"""Tracker errors leaning along the limb bones.

A body tracker finds a limb's axis from its silhouette and depth, and is less sure where along that axis
a joint sits. :func:`bone_aligned` reshapes error vectors of the limb joints so that their part along the
bone from the parent joint is ``exp(log_ratio)`` times the part across it, keeping an isotropic
vector's mean square.
"""

from __future__ import annotations

import numpy as np


def bone_aligned(vectors: np.ndarray, joints: np.ndarray, links: np.ndarray, log_ratio: float) -> np.ndarray:
    """Error vectors (T, J, 3) [m] with each child joint of ``links`` ((B, 2) int parent, child) scaled
    along its bone (the direction from the parent to the child in ``joints``, (T, J, 3) [m]) by ``q s``
    and across it by ``s``, ``q = exp(log_ratio)``, ``s = sqrt(3 / (q^2 + 2))``; other joints, and
    frames where a bone has no length, unchanged; ``vectors`` itself when ``log_ratio`` is 0."""
    if log_ratio == 0 or links.size == 0:
        return vectors
    q = float(np.exp(log_ratio))
    s = np.sqrt(3.0 / (q * q + 2.0))
    out = np.array(vectors, dtype=float, copy=True)
    parent, child = links[:, 0], links[:, 1]
    bone = joints[:, child] - joints[:, parent]
    length = np.linalg.norm(bone, axis=-1, keepdims=True)
    axis = np.divide(bone, length, out=np.zeros_like(bone), where=length > 0)
    v = out[:, child]
    along = np.sum(v * axis, axis=-1, keepdims=True)
    out[:, child] = np.where(length > 0, s * (v + (q - 1.0) * along * axis), v)
    return out
