"""The tracker's random draws (:mod:`sim.tracker`): offset vectors fixed for a session (optionally shared
along a limb), outlier bursts, and offsets drawn anew for each run of frames.

Offset vectors are coefficients in a camera's viewing-ray frame ``(ray, e1, e2)``; the tracker turns them
into world offsets along each joint's ray.
"""

from __future__ import annotations

import numpy as np
from scipy.special import ndtr

from fusion.topology import Topology
from sim.tracker_noise import magnitudes, unit_vectors


def session_vectors(
    ranges: np.ndarray, lateral_ratio: float, toward: float, rng: np.random.Generator,
    links: np.ndarray | None = None, correlation: float = 0.0,
) -> np.ndarray:
    """(J, 3) coefficients in the (ray, e1, e2) frame: magnitude U(range), mostly along the ray,
    pointing back toward the camera with probability ``toward``. With ``correlation`` > 0 the draws of
    each child of ``links`` ((B, 2) parent, child bones, parents before children down a chain) follow
    its parent's with that correlation (a Gaussian copula: the same marginals)."""
    J = ranges.shape[0]
    if correlation > 0 and links is not None and links.size:
        z = follow_parents(rng.standard_normal((J, 4)), links, correlation)
        along = np.where(ndtr(z[:, 0]) < toward, -1.0, 1.0)
        direction = np.column_stack([along, lateral_ratio * z[:, 1:3]])
        size = ranges[:, 0] + (ranges[:, 1] - ranges[:, 0]) * ndtr(z[:, 3])
    else:
        along = np.where(rng.random(J) < toward, -1.0, 1.0)
        direction = np.column_stack([along, lateral_ratio * rng.standard_normal((J, 2))])
        size = None
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    return (magnitudes(ranges, rng) if size is None else size)[:, None] * direction


def follow_parents(z: np.ndarray, links: np.ndarray, correlation: float) -> np.ndarray:
    """Standard normal draws ``z`` (J, ...) with each child joint of ``links`` (:func:`chain_ordered`) mixed
    with its parent's, ``c * parent + sqrt(1 - c^2) * own``: still standard normal, and correlated ``c``
    between a joint and its parent (``c ** k`` ``k`` links apart down a limb)."""
    out = np.array(z, dtype=float)
    for parent, child in links:
        out[child] = correlation * out[parent] + np.sqrt(1 - correlation**2) * out[child]
    return out


def chain_ordered(links: np.ndarray, topology: Topology) -> np.ndarray:
    """``links`` (B, 2) parent, child bones of ``topology`` sorted by the child's depth in the tree: a joint's
    draw is final before its children's follow it."""
    depth = np.zeros(topology.n_joints, dtype=int)
    for j in range(topology.n_joints):
        k = j
        while topology.parents[k] >= 0:
            depth[j], k = depth[j] + 1, topology.parents[k]
    return links[np.argsort(depth[links[:, 1]], kind="stable")] if links.size else links


def outlier_bursts(
    rate: np.ndarray, sizes: np.ndarray, T: int, mean_frames: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Active mask (T, J) and displacement (T, J, 3) [m] of outlier bursts; a new burst replaces a running one."""
    J = rate.shape[0]
    starts = rng.random((T, J)) < rate / mean_frames
    t_idx, j_idx = np.nonzero(starts)
    end = np.full((T, J), -1)
    end[t_idx, j_idx] = t_idx + rng.geometric(1.0 / mean_frames, t_idx.size)
    offset = np.zeros((T, J, 3))
    offset[t_idx, j_idx] = magnitudes(sizes[j_idx], rng)[:, None] * unit_vectors(t_idx.size, rng)
    frames = np.arange(T)[:, None]
    last = np.maximum.accumulate(np.where(starts, frames, -1), axis=0)
    cols = np.arange(J)[None, :]
    safe = np.maximum(last, 0)
    active = (last >= 0) & (frames < end[safe, cols])
    return active, np.where(active[..., None], offset[safe, cols], 0.0)


def run_vectors(mask: np.ndarray, ranges: tuple[float, float], rng: np.random.Generator) -> np.ndarray:
    """(T, J, 3) coefficients in the (ray, e1, e2) frame, zero outside ``mask`` (T, J): one vector of
    magnitude U(``ranges``) in a direction uniform on the sphere per run of ``True`` frames of a joint,
    held over the run."""
    T, J = mask.shape
    starts = mask & ~np.vstack([np.zeros((1, J), dtype=bool), mask[:-1]])
    t_idx, j_idx = np.nonzero(starts)
    table = np.zeros((T, J, 3))
    table[t_idx, j_idx] = magnitudes(np.tile(ranges, (t_idx.size, 1)), rng)[:, None] * unit_vectors(t_idx.size, rng)
    last = np.maximum.accumulate(np.where(starts, np.arange(T)[:, None], -1), axis=0)
    return np.where(mask[..., None], table[np.maximum(last, 0), np.arange(J)[None, :]], 0.0)
