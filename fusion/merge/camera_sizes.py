"""How the cameras of a recording agree on a person's size and proportions, truth-free.

Per camera, each limb bone's median length over the frames where both of its joints are Tracked; per
camera other than the reference, the natural log of each bone's ratio to the reference camera's. Their
median over the bones is how much larger the camera sees the whole person (a scale); their spread over
the bones is how far the two disagree on the proportions. Two real Azure Kinect cameras of one rig see
a person 1.4 % apart in size but agree on each bone to 0.3-0.4 % (docs/studies/population_validation.md).
"""

from __future__ import annotations

import numpy as np

from fusion.recording import Recording
from fusion.topology import Landmark, TrackingState

SIZE_BONES = tuple((Landmark[f"{a}_{side}"], Landmark[f"{b}_{side}"])
                   for a, b in (("SHOULDER", "ELBOW"), ("ELBOW", "WRIST"), ("HIP", "KNEE"), ("KNEE", "ANKLE"))
                   for side in ("LEFT", "RIGHT"))
"""The bones compared: upper arm, forearm, thigh and shank of both sides."""

MIN_FRAMES = 30
"""Fewest frames with both ends Tracked for a bone's median to count."""


def bone_medians(recording: Recording, camera: str) -> np.ndarray:
    """(B,) [m] the median length of each :data:`SIZE_BONES` bone in ``camera``'s skeleton stream over
    the frames where both ends are Tracked; NaN where the joint set lacks it or it has too few frames."""
    sk = recording.camera(camera).skeleton
    topology = sk.topology
    out = np.full(len(SIZE_BONES), np.nan)
    for k, (a, b) in enumerate(SIZE_BONES):
        if a not in topology.landmarks or b not in topology.landmarks:
            continue
        i, j = topology.index(a), topology.index(b)
        both = (sk.states[:, i] >= TrackingState.TRACKED) & (sk.states[:, j] >= TrackingState.TRACKED)
        if both.sum() >= MIN_FRAMES:
            out[k] = float(np.median(np.linalg.norm(sk.positions[both, i] - sk.positions[both, j], axis=-1)))
    return out


def size_agreement(recording: Recording, reference: str) -> tuple[float, float]:
    """``(scale, spread)``: over the cameras other than ``reference`` with skeletons, the median of the
    absolute median log bone-length ratio to the reference (module docstring), and the median of its
    standard deviation over the bones; NaN for one camera or too few bones seen in both (fewer than 3)."""
    ref = bone_medians(recording, reference)
    scales, spreads = [], []
    for cam in recording.cameras:
        if cam.name == reference or cam.skeleton is None:
            continue
        with np.errstate(divide="ignore", invalid="ignore"):
            logs = np.log(bone_medians(recording, cam.name) / ref)
        logs = logs[np.isfinite(logs)]
        if logs.size >= 3:
            scales.append(abs(float(np.median(logs))))
            spreads.append(float(np.std(logs, ddof=1)))
    if not scales:
        return float("nan"), float("nan")
    return float(np.median(scales)), float(np.median(spreads))
