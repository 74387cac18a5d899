"""Measured camera-pair transforms with their uncertainty: the edges of the rig graph.

Edges are keyed ``(a, b)`` with value :class:`PairEdge` holding ``T_a_b``; an edge is usable in
both directions.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from fusion.errors import BadInputError
from fusion.transforms import invert, validate_transform

EdgeKey = tuple[str, str]


@dataclass(frozen=True, eq=False)
class PairEdge:
    """A measured transform between two cameras and its confidence.

    Attributes
    ----------
    T_a_b : np.ndarray
        (4, 4) measured transform, for the edge key ``(a, b)``.
    information : np.ndarray
        (6, 6) symmetric positive-definite inverse covariance of the error
        ``[rotation vector (rad), translation (m)]`` of ``inv(T_a_b) @ T_a_b_true``, i.e. expressed
        in frame b. Default: that of :meth:`from_std` with 1 degree and 1 cm.
    """

    T_a_b: np.ndarray
    information: np.ndarray | None = None

    def __post_init__(self) -> None:
        T = validate_transform(np.array(self.T_a_b, dtype=float), "T_a_b")
        info = _std_information(1.0, 0.01) if self.information is None else np.array(self.information, dtype=float)
        symmetric = info.shape == (6, 6) and np.allclose(info, info.T, rtol=1e-9, atol=1e-12)
        if not symmetric or not np.all(np.isfinite(info)):
            raise BadInputError(f"information must be a finite symmetric (6, 6) matrix, got shape {info.shape}")
        if np.linalg.eigvalsh(info)[0] <= 0:
            raise BadInputError("information must be positive definite")
        for name, arr in (("T_a_b", T), ("information", info)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @classmethod
    def from_std(cls, T_a_b: np.ndarray, rotation_std_deg: float, translation_std_m: float) -> PairEdge:
        """Edge with independent errors: rotation std [deg] about each axis, translation std [m] per axis."""
        return cls(T_a_b, _std_information(rotation_std_deg, translation_std_m))

    @property
    def variance(self) -> float:
        """Trace of the error covariance (rad^2 counted as m^2 at a 1 m lever arm): lower is better."""
        return float(np.trace(np.linalg.inv(self.information)))


def _std_information(rotation_std_deg: float, translation_std_m: float) -> np.ndarray:
    if not (np.isfinite(rotation_std_deg) and rotation_std_deg > 0 and np.isfinite(translation_std_m)
            and translation_std_m > 0):
        raise BadInputError(f"standard deviations must be positive, got {rotation_std_deg} deg, {translation_std_m} m")
    sigma = np.r_[np.full(3, np.radians(rotation_std_deg)), np.full(3, translation_std_m)]
    return np.diag(1.0 / sigma**2)


def check_edges(edges: Mapping[EdgeKey, PairEdge]) -> list[str]:
    """Validate edge keys and values; return the sorted camera names.

    Raises
    ------
    BadInputError
        A key that is not a pair of two different names, or a value that is not a PairEdge.
    """
    names = set()
    for key, edge in edges.items():
        if not (isinstance(key, tuple) and len(key) == 2 and all(isinstance(k, str) for k in key) and key[0] != key[1]):
            raise BadInputError(f"edge keys must be (a, b) pairs of two different camera names, got {key!r}")
        if not isinstance(edge, PairEdge):
            raise BadInputError(f"edge {key!r} must be a PairEdge, got {type(edge).__name__}")
        names.update(key)
    return sorted(names)


def best_edges(edges: Mapping[EdgeKey, PairEdge]) -> dict[frozenset, tuple[EdgeKey, PairEdge]]:
    """Per unordered camera pair, the measurement with the lowest variance (ties: first key in sort order)."""
    best: dict[frozenset, tuple[EdgeKey, PairEdge]] = {}
    for key in sorted(edges):
        pair = frozenset(key)
        if pair not in best or edges[key].variance < best[pair][1].variance:
            best[pair] = (key, edges[key])
    return best


def oriented_transform(key: EdgeKey, edge: PairEdge, to: str) -> np.ndarray:
    """``T_to_other`` from an edge between ``to`` and another camera."""
    return edge.T_a_b if key[0] == to else invert(edge.T_a_b)
