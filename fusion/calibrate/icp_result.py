"""The outcome of an ICP refinement of a camera pair (:func:`fusion.calibrate.icp.refine_pair_icp`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fusion.errors import BadInputError
from fusion.transforms import validate_transform


@dataclass(frozen=True, eq=False)
class IcpResult:
    """Outcome of :func:`refine_pair_icp`.

    Attributes
    ----------
    T_a_b : np.ndarray
        (4, 4) the transform to use: ``T_a_b_icp`` if accepted, else ``T_a_b_init``.
    T_a_b_icp : np.ndarray
        (4, 4) what ICP converged to (equal to ``T_a_b_init`` when ICP was not run).
    T_a_b_init : np.ndarray
        (4, 4) the initial (skeleton) transform.
    accepted : bool
        Whether ``T_a_b_icp`` replaced the initial transform.
    reason : str
        Why, in words, with the numbers that decided it.
    fitness, inlier_rmse_m : float
        Of ``T_a_b_icp`` at the finest correspondence distance: fraction of b points with an a point
        within it, and the RMS distance of those pairs [m].
    initial_fitness, initial_inlier_rmse_m : float
        The same for ``T_a_b_init``.
    converged : bool
        The last iteration of the finest scale moved the b cloud by less than 0.01 deg and 0.1 mm.
    constraint_ratio : float
        Weakest / strongest eigenvalue of the point-to-plane information matrix at ``T_a_b_icp``
        (0 when ICP was not run).
    opposite_fraction : float
        Fraction of the final correspondences matching surfaces seen from opposite sides (0 when ICP
        was not run), see :class:`IcpLimits`.
    rotation_change_deg, translation_change_m : float
        Rotation [deg] and b-centroid displacement [m] from ``T_a_b_init`` to ``T_a_b_icp``.
    n_points_a, n_points_b : int
        Points per cloud after voxelisation, all instants together.
    """

    T_a_b: np.ndarray
    T_a_b_icp: np.ndarray
    T_a_b_init: np.ndarray
    accepted: bool
    reason: str
    fitness: float
    inlier_rmse_m: float
    initial_fitness: float
    initial_inlier_rmse_m: float
    converged: bool
    constraint_ratio: float
    opposite_fraction: float
    rotation_change_deg: float
    translation_change_m: float
    n_points_a: int
    n_points_b: int

    def __post_init__(self) -> None:
        for name in ("T_a_b", "T_a_b_icp", "T_a_b_init"):
            T = validate_transform(np.array(getattr(self, name), dtype=float), name)
            T.setflags(write=False)
            object.__setattr__(self, name, T)
        fractions = (self.fitness, self.initial_fitness, self.constraint_ratio, self.opposite_fraction)
        if not all(np.isfinite(v) and 0 <= v <= 1 for v in fractions):
            raise BadInputError(f"fitness, constraint_ratio and opposite_fraction must lie in [0, 1], got {fractions}")
