"""Whole-rig camera poses from pairwise calibrations: chaining, pose-graph optimisation, loop closure.

Edges are measured pairwise transforms keyed ``(a, b)`` with value :class:`PairEdge` holding
``T_a_b``; an edge is usable in both directions. Rig solutions are ``T_ref_cam`` per camera, with the
reference camera at the identity.

- :func:`chain_to_reference` is the paper's method (3.5): concatenate the pairwise transforms along
  the shortest path to the reference.
- :func:`optimise_pose_graph` fits all measured pairs at once by weighted (optionally robust)
  least squares. It uses ``scipy.optimize.least_squares`` on rotation-vector increments rather
  than Open3D's pose graph: the rigs are small (at most tens of parameters), scipy returns an
  explicit convergence status, iteration count and cost, offers robust losses with a scale in
  units of the edges' standard deviations, and has no process-global state or log-only
  diagnostics; Open3D's optimiser mutates the graph in place, reports only through its logger, and
  prunes edges by its own line-process rule.
- :mod:`fusion.calibrate.edges` holds the edges, :mod:`fusion.calibrate.loop` the paper's ring measure (3.8).
"""

from __future__ import annotations

import enum
import heapq
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from fusion.calibrate.edges import (
    EdgeKey,
    PairEdge,
    best_edges,
    check_edges,
    oriented_transform,
)
from fusion.errors import BadInputError, CalibrationError, UnknownNameError
from fusion.transforms import (
    compose,
    from_rotvec,
    invert,
    to_rotvec,
    transform_difference,
    validate_transform,
)


def _shortest_paths(
    edges: Mapping[EdgeKey, PairEdge], reference: str, cameras: Iterable[str] | None
) -> tuple[list[str], dict[str, str], dict[frozenset, tuple[EdgeKey, PairEdge]]]:
    """Cameras, parent of each reached camera on its shortest path to the reference, and the best edges."""
    names = check_edges(edges)
    if not names:
        names = [reference]
    if reference not in names:
        raise UnknownNameError("camera", reference, names)
    all_names = sorted(set(names) | set(cameras or ()))
    best = best_edges(edges)
    neighbours: dict[str, list[str]] = {n: [] for n in all_names}
    for pair in best:
        a, b = sorted(pair)
        neighbours[a].append(b)
        neighbours[b].append(a)
    # Dijkstra on (summed variance, hops, name): the most certain path, then the fewest hops.
    settled: dict[str, tuple[float, int]] = {}
    parent: dict[str, str] = {}
    heap: list[tuple[float, int, str, str | None]] = [(0.0, 0, reference, None)]
    while heap:
        var, hops, node, via = heapq.heappop(heap)
        if node in settled:
            continue
        settled[node] = (var, hops)
        if via is not None:
            parent[node] = via
        for nxt in neighbours[node]:
            if nxt not in settled:
                heapq.heappush(heap, (var + best[frozenset((node, nxt))][1].variance, hops + 1, nxt, node))
    missing = [n for n in all_names if n not in settled]
    if missing:
        raise CalibrationError(
            f"cameras {missing} cannot be reached from reference {reference!r} through the measured pairs; "
            "calibrate a pair linking them to the rest of the rig"
        )
    return all_names, parent, best


def shortest_path(edges: Mapping[EdgeKey, PairEdge], start: str, end: str) -> list[str]:
    """Cameras on the most certain path (smallest summed edge variance) from ``start`` to ``end``.

    Raises
    ------
    UnknownNameError, CalibrationError, BadInputError
        As for :func:`chain_to_reference` with ``start`` as the reference.
    """
    _, parent, _ = _shortest_paths(edges, start, None)
    if end != start and end not in parent:
        raise UnknownNameError("camera", end, sorted(parent) + [start])
    path = [end]
    while path[-1] != start:
        path.append(parent[path[-1]])
    return path[::-1]


def chain_to_reference(
    edges: Mapping[EdgeKey, PairEdge], reference: str, *, cameras: Iterable[str] | None = None
) -> dict[str, np.ndarray]:
    """Camera transforms by concatenating pairwise transforms along the shortest path to the reference.

    Shortest means the smallest summed edge variance (:attr:`PairEdge.variance`), so that two
    well-measured neighbour pairs beat one poor direct pair; with equally certain edges it is the
    path of fewest edges, as in the paper. Of two measurements of the same pair, the one with the
    lower variance is used.

    Parameters
    ----------
    edges : (a, b) -> PairEdge with ``T_a_b``.
    reference : name of the reference camera.
    cameras : optional names of every camera of the rig, so that cameras without any edge are
        reported too.

    Returns
    -------
    dict
        Camera name -> (4, 4) ``T_ref_cam``; the reference maps to the identity.

    Raises
    ------
    UnknownNameError
        The reference camera appears in no edge.
    CalibrationError
        Some cameras cannot be reached; the message names them.
    BadInputError
        Malformed edges.
    """
    names, parent, best = _shortest_paths(edges, reference, cameras)
    T_ref_cam = {reference: np.eye(4)}

    def resolve(name: str) -> np.ndarray:
        if name not in T_ref_cam:
            up = parent[name]
            key, edge = best[frozenset((up, name))]
            T_ref_cam[name] = compose(resolve(up), oriented_transform(key, edge, up))
        return T_ref_cam[name]

    return {name: resolve(name) for name in names}


class GraphLoss(enum.Enum):
    """Loss applied to each whitened residual component in :func:`optimise_pose_graph`."""

    LINEAR = "linear"
    """Plain least squares (Gaussian errors)."""
    HUBER = "huber"
    """Quadratic within ``loss_scale`` standard deviations, linear beyond."""
    CAUCHY = "cauchy"
    """Strongly down-weights edges far beyond ``loss_scale`` (a failed pair calibration)."""


_CONTINUATION = {
    GraphLoss.LINEAR: (GraphLoss.LINEAR,),
    GraphLoss.HUBER: (GraphLoss.LINEAR, GraphLoss.HUBER),
    GraphLoss.CAUCHY: (GraphLoss.LINEAR, GraphLoss.HUBER, GraphLoss.CAUCHY),
}
"""Losses solved in turn, each from the previous solution: a chained start may sit on a failed edge,
where the non-convex Cauchy loss alone would discount the good edges instead."""


@dataclass(frozen=True, eq=False)
class RigSolution:
    """Outcome of :func:`optimise_pose_graph`.

    Attributes
    ----------
    T_ref_cam : dict
        Camera name -> (4, 4) transform; the reference maps to the identity.
    reference : str
        The reference camera.
    converged : bool
        The optimiser met a tolerance (not the evaluation limit).
    iterations : int
        Jacobian evaluations (optimiser iterations), all continuation stages together.
    cost : float
        Final value of half the summed (robust) squared whitened residuals.
    edge_keys : tuple
        The edges, in sorted order, that the residual arrays refer to.
    residual_rotation_deg, residual_translation_mm : np.ndarray
        (E,) disagreement of each measured ``T_a_b`` with the solution's ``inv(T_ref_a) @ T_ref_b``:
        rotation [deg] and translation difference [mm].
    message : str
        The optimiser's termination message.
    """

    T_ref_cam: dict[str, np.ndarray]
    reference: str
    converged: bool
    iterations: int
    cost: float
    edge_keys: tuple[EdgeKey, ...]
    residual_rotation_deg: np.ndarray
    residual_translation_mm: np.ndarray
    message: str

    def __post_init__(self) -> None:
        if self.reference not in self.T_ref_cam:
            raise BadInputError(f"reference {self.reference!r} missing from T_ref_cam")
        poses = {}
        for name, T in self.T_ref_cam.items():
            T = validate_transform(np.array(T, dtype=float), f"T_ref_cam[{name!r}]")
            T.setflags(write=False)
            poses[name] = T
        object.__setattr__(self, "T_ref_cam", poses)
        for name in ("residual_rotation_deg", "residual_translation_mm"):
            arr = np.array(getattr(self, name), dtype=float)
            if arr.shape != (len(self.edge_keys),):
                raise BadInputError(f"{name} must have shape ({len(self.edge_keys)},), got {arr.shape}")
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)


def optimise_pose_graph(
    edges: Mapping[EdgeKey, PairEdge],
    reference: str,
    initial: Mapping[str, np.ndarray] | None = None,
    *,
    loss: GraphLoss = GraphLoss.LINEAR,
    loss_scale: float = 3.0,
    max_iterations: int = 100,
) -> RigSolution:
    """Camera transforms that best agree with all measured pairs, the reference fixed at the identity.

    Minimises ``sum rho(r_i^2)`` over the components of ``r = L^T e`` of all edges, with ``e`` the
    6-vector (rotation vector, translation) of ``inv(T_a_b) @ inv(T_ref_a) @ T_ref_b``, ``L L^T`` the edge's information and ``rho`` the loss.
    Each camera other than the reference has six parameters, a rotation-vector and translation
    increment applied on the right of its initial transform, so large rotations cause no
    singularity. Solved by ``scipy.optimize.least_squares`` (trust region, numerical Jacobian); a
    robust loss is approached through plain least squares first (then Huber, for Cauchy).

    Parameters
    ----------
    edges : (a, b) -> PairEdge with ``T_a_b``; each pair's information weights its residual.
    reference : camera fixed at the identity.
    initial : optional camera name -> (4, 4) starting transforms in any common frame (re-expressed
        relative to the reference); default :func:`chain_to_reference`.
    loss : robust loss on the whitened residuals.
    loss_scale : residual (in standard deviations) where a robust loss starts to flatten.
    max_iterations : limit on the optimiser's iterations.

    Returns
    -------
    RigSolution

    Raises
    ------
    UnknownNameError, CalibrationError, BadInputError
        As for :func:`chain_to_reference`; also ``initial`` missing a camera, or bad parameters.
    """
    if not isinstance(loss, GraphLoss):
        raise BadInputError(f"loss must be a GraphLoss, got {loss!r}")
    if not (np.isfinite(loss_scale) and loss_scale > 0) or max_iterations < 1:
        raise BadInputError(f"need loss_scale > 0 and max_iterations >= 1, got {loss_scale}, {max_iterations}")
    start = chain_to_reference(edges, reference)  # also checks that every camera is connected
    names = sorted(start)
    if initial is not None:
        missing = [n for n in names if n not in initial]
        if missing:
            raise BadInputError(f"initial lacks cameras {missing}")
        T_ref_world = invert(validate_transform(initial[reference], f"initial[{reference!r}]"))
        start = {n: compose(T_ref_world, validate_transform(initial[n], f"initial[{n!r}]")) for n in names}
    free = [n for n in names if n != reference]
    keys = tuple(sorted(edges))
    if not keys:
        return RigSolution(T_ref_cam={reference: np.eye(4)}, reference=reference, converged=True, iterations=0,
                           cost=0.0, edge_keys=(), residual_rotation_deg=np.empty(0),
                           residual_translation_mm=np.empty(0), message="no edges: the reference camera alone")
    index = {n: i for i, n in enumerate(free)} | {reference: len(free)}
    T_start = np.stack([start[n] for n in free])
    T_meas_b_a = np.stack([invert(edges[k].T_a_b) for k in keys])
    L_t = np.stack([np.linalg.cholesky(edges[k].information).T for k in keys])

    def poses(x: np.ndarray) -> np.ndarray:
        """(n_cameras, 4, 4) T_ref_cam indexed by ``index``: the free cameras, then the reference."""
        delta = x.reshape(-1, 6)
        return np.concatenate([T_start @ from_rotvec(delta[:, :3], delta[:, 3:]), np.eye(4)[None]])

    ia = np.array([index[a] for a, _ in keys])
    ib = np.array([index[b] for _, b in keys])

    def residuals(x: np.ndarray) -> np.ndarray:
        T = poses(x)
        rv, t = to_rotvec(T_meas_b_a @ invert(T[ia]) @ T[ib])
        return np.einsum("eij,ej->ei", L_t, np.concatenate([rv, t], axis=1)).ravel()

    x, iterations = np.zeros(6 * len(free)), 0
    for stage in _CONTINUATION[loss]:
        fit = least_squares(residuals, x, method="trf", loss=stage.value, f_scale=loss_scale, max_nfev=max_iterations,
                            x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-10)
        x, iterations = fit.x, iterations + int(fit.njev)
    T = poses(x)
    rot, dist = transform_difference(invert(T[ia]) @ T[ib], np.stack([edges[k].T_a_b for k in keys]))
    return RigSolution(
        T_ref_cam={n: T[index[n]] for n in names}, reference=reference, converged=bool(fit.status > 0),
        iterations=iterations, cost=float(fit.cost), edge_keys=keys, residual_rotation_deg=rot,
        residual_translation_mm=dist * 1e3, message=fit.message,
    )
