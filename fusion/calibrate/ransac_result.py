"""What the skeleton RANSAC of a camera pair returns (:func:`fusion.calibrate.ransac.ransac_skeleton_pair`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fusion.errors import BadInputError
from fusion.topology import Region
from fusion.transforms import validate_transform


@dataclass(frozen=True, eq=False)
class PairCalibration:
    """Result of :func:`ransac_skeleton_pair`.

    Attributes
    ----------
    T_a_b : np.ndarray
        (4, 4) pose of camera b in camera a's frame: ``p_a = apply(T_a_b, p_b)``.
    candidates : np.ndarray
        (K, 3) int64 candidate correspondences: frame index in a, frame index in b, joint index.
    inlier_mask : np.ndarray
        (K,) bool, candidates within ``inlier_threshold_m`` of their partner under ``T_a_b``.
    n_trials : int
        Hypotheses drawn.
    n_valid_trials : int
        Hypotheses that were scored: non-degenerate and with the three points' mutual distances
        agreeing between the cameras to within twice the threshold.
    n_inliers : int
        Number of inliers.
    support : float
        Inlier fraction ``n_inliers / K``.
    residuals_per_joint : np.ndarray
        (J,) median over frames of ``|apply(T_a_b, p_b) - p_a|`` [m] over each joint's candidates
        (inliers and outliers); NaN for joints without candidates.
    rmse : float
        Root mean square residual [m] of the inliers.
    region_counts : np.ndarray
        (3,) int64 candidates per :class:`Region` (upper, mid, lower).
    inlier_threshold_m : float
        Inlier distance [m] used.
    n_refits : int
        Refits on the inliers that were applied after the best hypothesis.
    fit_weights : np.ndarray
        (K,) weight of each candidate in the fit that produced ``T_a_b`` (0 for non-inliers).
    """

    T_a_b: np.ndarray
    candidates: np.ndarray
    inlier_mask: np.ndarray
    n_trials: int
    n_valid_trials: int
    n_inliers: int
    support: float
    residuals_per_joint: np.ndarray
    rmse: float
    region_counts: np.ndarray
    inlier_threshold_m: float
    n_refits: int
    fit_weights: np.ndarray

    def __post_init__(self) -> None:
        T = validate_transform(self.T_a_b, "T_a_b").copy()
        cand = np.asarray(self.candidates, dtype=np.int64)
        mask = np.asarray(self.inlier_mask, dtype=bool)
        res = np.asarray(self.residuals_per_joint, dtype=np.float64)
        counts = np.asarray(self.region_counts, dtype=np.int64)
        if cand.ndim != 2 or cand.shape[1] != 3 or mask.shape != (cand.shape[0],):
            raise BadInputError(f"candidates (K, 3) and inlier_mask (K,) expected, got {cand.shape} and {mask.shape}")
        if res.ndim != 1 or counts.shape != (len(Region),):
            raise BadInputError(
                f"residuals_per_joint (J,) and region_counts (3,) expected, got {res.shape} and {counts.shape}"
            )
        if int(mask.sum()) != self.n_inliers or counts.sum() != cand.shape[0]:
            raise BadInputError("n_inliers / region_counts disagree with inlier_mask / candidates")
        if not 0 <= self.n_valid_trials <= self.n_trials:
            raise BadInputError(f"need 0 <= n_valid_trials <= n_trials, got {self.n_valid_trials}, {self.n_trials}")
        weights = np.asarray(self.fit_weights, dtype=np.float64)
        if weights.shape != mask.shape:
            raise BadInputError(f"fit_weights must have shape {mask.shape}, got {weights.shape}")
        arrays = {"T_a_b": T, "candidates": cand, "inlier_mask": mask, "residuals_per_joint": res,
                  "region_counts": counts, "fit_weights": weights}
        for name, arr in arrays.items():
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
