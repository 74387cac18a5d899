"""The paper's ring measure (3.8): loop closure of pairwise calibrations and of solved rigs."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from fusion.calibrate.edges import (
    EdgeKey,
    PairEdge,
    best_edges,
    check_edges,
    oriented_transform,
)
from fusion.errors import BadInputError
from fusion.transforms import apply, compose, invert, validate_transform


@dataclass(frozen=True, eq=False)
class LoopClosure:
    """The paper's ring measure: how differently a camera's points land at the farthest camera.

    Attributes
    ----------
    order : tuple of str
        The ring order (clockwise).
    farthest : dict
        Camera -> the camera ``len(order) // 2`` steps clockwise, where its points are mapped.
    per_camera_mm : dict
        Camera -> mean distance [mm] between its points mapped clockwise and anticlockwise.
    mean_mm, max_mm : float
        Mean and maximum of ``per_camera_mm``.
    """

    order: tuple[str, ...]
    farthest: dict[str, str]
    per_camera_mm: dict[str, float]
    mean_mm: float
    max_mm: float

    def __post_init__(self) -> None:
        if set(self.per_camera_mm) != set(self.order) or set(self.farthest) != set(self.order):
            raise BadInputError("per_camera_mm and farthest must have one entry per camera of the order")
        values = [*self.per_camera_mm.values(), self.mean_mm, self.max_mm]
        if not all(np.isfinite(v) and v >= 0 for v in values):
            raise BadInputError(f"loop-closure distances must be finite and >= 0, got {values}")


def _ring(order: Sequence[str]) -> tuple[str, ...]:
    ring = tuple(order)
    if len(ring) < 3 or len(set(ring)) != len(ring) or not all(isinstance(n, str) for n in ring):
        raise BadInputError(f"order must list at least three distinct camera names, got {order!r}")
    return ring


def _points_per_camera(
    points_cam: Mapping[str, np.ndarray] | np.ndarray, ring: tuple[str, ...]
) -> dict[str, np.ndarray]:
    if isinstance(points_cam, Mapping):
        missing = [n for n in ring if n not in points_cam]
        if missing:
            raise BadInputError(f"points_cam lacks cameras {missing}")
        chosen = {n: np.asarray(points_cam[n], dtype=float) for n in ring}
    else:
        chosen = {n: np.asarray(points_cam, dtype=float) for n in ring}
    for n, p in chosen.items():
        if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] == 0 or not np.all(np.isfinite(p)):
            raise BadInputError(f"points for camera {n!r} must be a finite non-empty (N, 3) array, got {p.shape}")
    return chosen


def _ring_measure(ring: tuple[str, ...], T_next_cam: list[np.ndarray], points: dict[str, np.ndarray]) -> LoopClosure:
    """Core of the ring measure; ``T_next_cam[k]`` is ``T_{ring[k+1]}_{ring[k]}`` (cyclically)."""
    n = len(ring)
    half = n // 2
    farthest, per_camera = {}, {}
    for i, name in enumerate(ring):
        clockwise = np.eye(4)
        for k in range(i, i + half):
            clockwise = compose(T_next_cam[k % n], clockwise)
        anticlockwise = np.eye(4)
        for k in range(i - 1, i + half - n - 1, -1):
            anticlockwise = compose(invert(T_next_cam[k % n]), anticlockwise)
        p = points[name]
        farthest[name] = ring[(i + half) % n]
        per_camera[name] = float(np.mean(np.linalg.norm(apply(clockwise, p) - apply(anticlockwise, p), axis=1)) * 1e3)
    values = np.array(list(per_camera.values()))
    return LoopClosure(order=ring, farthest=farthest, per_camera_mm=per_camera, mean_mm=float(values.mean()),
                       max_mm=float(values.max()))


def loop_closure(
    edges: Mapping[EdgeKey, PairEdge], order: Sequence[str], points_cam: Mapping[str, np.ndarray] | np.ndarray
) -> LoopClosure:
    """Ring loop-closure error of pairwise calibrations (before any global optimisation).

    Each camera's points are mapped to the camera half-way round the ring twice: by composing the
    neighbour edges clockwise and anticlockwise; the mean distance between the two images measures
    how inconsistent the pairwise transforms are.

    Parameters
    ----------
    edges : (a, b) -> PairEdge; every pair of ring neighbours needs an edge in either direction (of
        two, the lower-variance one is used).
    order : camera names in clockwise ring order, at least three.
    points_cam : camera name -> (N, 3) points [m] in that camera's frame (e.g. its body cloud), or
        one (N, 3) array used in every camera's frame.

    Returns
    -------
    LoopClosure

    Raises
    ------
    BadInputError
        A bad ring order, points, or a missing neighbour edge.
    """
    ring = _ring(order)
    check_edges(edges)
    best = best_edges(edges)
    T_next_cam = []
    for k, name in enumerate(ring):
        nxt = ring[(k + 1) % len(ring)]
        if frozenset((name, nxt)) not in best:
            raise BadInputError(f"no edge between ring neighbours {name!r} and {nxt!r}")
        key, edge = best[frozenset((name, nxt))]
        T_next_cam.append(oriented_transform(key, edge, nxt))
    return _ring_measure(ring, T_next_cam, _points_per_camera(points_cam, ring))


def rig_loop_closure(
    T_ref_cam: Mapping[str, np.ndarray], order: Sequence[str], points_cam: Mapping[str, np.ndarray] | np.ndarray
) -> LoopClosure:
    """Ring loop-closure error of a solved rig: the neighbour transforms come from the camera poses.

    For a rig given as one transform per camera the ring closes by construction, so the result is
    zero up to round-off: a consistency check of the solution's arithmetic and of the order. See
    :func:`loop_closure` for the parameters.
    """
    ring = _ring(order)
    missing = [n for n in ring if n not in T_ref_cam]
    if missing:
        raise BadInputError(f"T_ref_cam lacks cameras {missing}")
    poses = {n: validate_transform(T_ref_cam[n], f"T_ref_cam[{n!r}]") for n in ring}
    T_next_cam = [compose(invert(poses[ring[(k + 1) % len(ring)]]), poses[n]) for k, n in enumerate(ring)]
    return _ring_measure(ring, T_next_cam, _points_per_camera(points_cam, ring))
