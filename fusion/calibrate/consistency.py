"""Cycle consistency of pair measurements: which edges disagree with the rest of the rig.

Every measured pair transform is evidence with an uncertainty (its information matrix). An edge
``(a, b)`` together with any other path from a to b forms a cycle, which closes at the identity if
both are right. :func:`check_cycles` predicts ``T_a_b`` along every other path from a to b and
keeps the cycle that closes best, measuring its disagreement in units of the combined standard
deviation of the edge and of that path. Edges beyond ``threshold_sigma`` are distrusted:
:func:`down_weight` scales their information by ``(threshold_sigma / z)^2``, worst first, so that a
wrong edge weighs like one whose uncertainty covers its disagreement, and the rig solver (and the
most-certain-path chaining) leans on the others.
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from fusion.calibrate.edges import EdgeKey, PairEdge, check_edges, oriented_transform
from fusion.errors import BadInputError
from fusion.transforms import compose, invert, to_rotvec


@dataclass(frozen=True)
class EdgeCheck:
    """Agreement of one edge with the rest of the rig.

    Attributes
    ----------
    key : the edge ``(a, b)``.
    rotation_deg, translation_mm : disagreement of the measured ``T_a_b`` with the one predicted by
        the other edges (NaN when no other path links a and b).
    z : disagreement in standard deviations: the larger of the rotation and translation ratios to
        the combined uncertainty of the edge and the predicting path (NaN when not checkable).
    path : cameras of the best-closing predicting path, a first, b last (empty when not checkable).
    distrusted : ``z`` exceeded the threshold.
    weight : factor applied to the edge's information by :func:`down_weight` (1 when trusted).
    """

    key: EdgeKey
    rotation_deg: float
    translation_mm: float
    z: float
    path: tuple[str, ...]
    distrusted: bool
    weight: float

    def __post_init__(self) -> None:
        if not (0 < self.weight <= 1):
            raise BadInputError(f"weight must lie in (0, 1], got {self.weight}")

    @property
    def checkable(self) -> bool:
        """Whether another path predicted this edge."""
        return bool(np.isfinite(self.z))


def _variances(edge: PairEdge) -> tuple[float, float]:
    """Rotation [rad^2] and translation [m^2] variances per axis of an edge (mean over the axes)."""
    cov = np.linalg.inv(edge.information)
    return float(np.trace(cov[:3, :3]) / 3), float(np.trace(cov[3:, 3:]) / 3)


def _paths(neighbours: dict[str, list[str]], start: str, end: str, max_hops: int) -> list[list[str]]:
    """Simple paths from start to end of at most ``max_hops`` edges (depth-first, sorted neighbours)."""
    found, stack = [], [[start]]
    while stack:
        path = stack.pop()
        for nxt in sorted(neighbours[path[-1]], reverse=True):
            if nxt == end:
                found.append(path + [nxt])
            elif nxt not in path and len(path) < max_hops:
                stack.append(path + [nxt])
    return found


def _cycle_z(edges: Mapping[EdgeKey, PairEdge], key: EdgeKey, path: list[str]) -> tuple[float, float, float]:
    """Closure error of the edge against one path: (rotation [rad], translation [m], z)."""
    edge = edges[key]
    T_a_b, (var_rot, var_t) = np.eye(4), _variances(edge)
    for u, v in itertools.pairwise(path):
        step = oriented_transform(*_find(edges, u, v), u)
        T_a_b = compose(T_a_b, step)
        r, t = _variances(_find(edges, u, v)[1])
        var_rot, var_t = var_rot + r, var_t + t
    var_t += var_rot * float(np.sum(edge.T_a_b[:3, 3] ** 2))
    rv, t = to_rotvec(invert(edge.T_a_b) @ T_a_b)
    rot, shift = float(np.linalg.norm(rv)), float(np.linalg.norm(t))
    # a 3-D error's norm against a per-axis standard deviation: compare with sqrt(3) of it
    return rot, shift, max(rot / np.sqrt(3 * var_rot), shift / np.sqrt(3 * var_t))


def _find(edges: Mapping[EdgeKey, PairEdge], u: str, v: str) -> tuple[EdgeKey, PairEdge]:
    key = (u, v) if (u, v) in edges else (v, u)
    return key, edges[key]


def check_cycles(edges: Mapping[EdgeKey, PairEdge], *, threshold_sigma: float = 3.0,
                 max_hops: int = 5) -> tuple[EdgeCheck, ...]:
    """Check every edge against every cycle it closes, keeping the cycle that closes best.

    For edge ``(a, b)`` each simple path from a to b of at most ``max_hops`` other edges predicts
    ``T_a_b``; the disagreement is measured in units of the combined standard deviation of the
    edge and the path (the path's variances summed, the rotation variances also entering the
    translation through the lever arm of the edge's baseline: an isotropic approximation that
    ignores how the frames turn along the path). A wrong edge fails every cycle it is in; a good
    edge closes at least the cycles that avoid the wrong ones, so the best-closing cycle decides.

    Parameters
    ----------
    edges : (a, b) -> PairEdge, at most one per unordered pair.
    threshold_sigma : disagreement [standard deviations] beyond which an edge is distrusted.
    max_hops : longest predicting path [edges].

    Returns
    -------
    tuple of EdgeCheck
        One per edge, in sorted key order.

    Raises
    ------
    BadInputError
        Malformed edges, two edges for one pair, or a non-positive threshold or hop count.
    """
    names = check_edges(edges)
    if not (np.isfinite(threshold_sigma) and threshold_sigma > 0) or max_hops < 2:
        raise BadInputError(f"need threshold_sigma > 0 and max_hops >= 2, got {threshold_sigma}, {max_hops}")
    if len({frozenset(k) for k in edges}) != len(edges):
        raise BadInputError("check_cycles needs at most one edge per camera pair")
    checks = []
    for key in sorted(edges):
        a, b = key
        neighbours: dict[str, list[str]] = {n: [] for n in names}
        for u, v in edges:
            if (u, v) != key:
                neighbours[u].append(v)
                neighbours[v].append(u)
        best = None
        for path in _paths(neighbours, a, b, max_hops):
            rot, shift, z = _cycle_z(edges, key, path)
            if best is None or z < best[2]:
                best = (rot, shift, z, tuple(path))
        if best is None:
            checks.append(EdgeCheck(key, float("nan"), float("nan"), float("nan"), (), False, 1.0))
            continue
        rot, shift, z, path = best
        distrusted = z > threshold_sigma
        weight = float((threshold_sigma / z) ** 2) if distrusted else 1.0
        checks.append(EdgeCheck(key, float(np.degrees(rot)), shift * 1e3, float(z), path, distrusted, weight))
    return tuple(checks)


def down_weight(
    edges: Mapping[EdgeKey, PairEdge], *, threshold_sigma: float = 3.0
) -> tuple[dict[EdgeKey, PairEdge], tuple[EdgeCheck, ...]]:
    """Down-weight inconsistent edges one at a time, worst first, until the rest agree.

    A wrong edge also spoils the predictions of the good edges whose best other path runs through
    it; so only the edge that disagrees most is down-weighted (information scaled by
    ``(threshold_sigma / z)^2``), then every edge is checked again with the new weights, until no
    edge that is still at full weight is beyond ``threshold_sigma``.

    Parameters
    ----------
    edges : (a, b) -> PairEdge, at most one per unordered pair.
    threshold_sigma : see :func:`check_cycles`.

    Returns
    -------
    edges : dict
        The edges, the distrusted ones with scaled information.
    checks : tuple of EdgeCheck
        Per edge (sorted keys): its disagreement with the final weights, ``distrusted`` and
        ``weight`` saying whether and how much it was down-weighted.

    Raises
    ------
    BadInputError
        As for :func:`check_cycles`.
    """
    current = dict(edges)
    weights = {k: 1.0 for k in current}
    while True:
        checks = check_cycles(current, threshold_sigma=threshold_sigma)
        fresh = [c for c in checks if c.distrusted and weights[c.key] == 1.0]
        if not fresh:
            break
        worst = max(fresh, key=lambda c: c.z)
        weights[worst.key] = worst.weight
        current[worst.key] = PairEdge(edges[worst.key].T_a_b, edges[worst.key].information * worst.weight)
    final = tuple(EdgeCheck(c.key, c.rotation_deg, c.translation_mm, c.z, c.path, weights[c.key] < 1.0,
                            weights[c.key]) for c in checks)
    return current, final
