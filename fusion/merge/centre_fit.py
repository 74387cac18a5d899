"""Least-squares centre of rotation shared by several markers (Gamage & Lasenby 2002, J Biomech 35:87).

Markers fixed to one segment that rotates about a point fixed in the observing frame move on spheres
about that point. :func:`fit_common_centre` solves the linear least-squares problem of Gamage &
Lasenby for the common centre, and reports along which directions the motion determined it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fusion.arrays import frozen
from fusion.errors import BadInputError


@dataclass(frozen=True, eq=False)
class CentreFit:
    """A least-squares common centre of rotation of several markers (Gamage & Lasenby 2002).

    Attributes
    ----------
    centre : (3,) [m] the centre, in the frame of the fitted points; NaN where undetermined and no
        prior was given.
    spreads_m : (3,) [m] RMS excursion of the markers along the fit's principal directions, descending.
    directions : (3, 3) those directions as columns.
    n_determined : how many directions the motion determined (spread >= the threshold).
    residual_rms_m : RMS over markers and frames of (distance to the centre - that marker's mean
        distance) [m]: how far the markers are from moving on spheres; NaN without a centre.
    n_frames : frames used (a frame counts for a marker when that marker is finite).
    """

    centre: np.ndarray
    spreads_m: np.ndarray
    directions: np.ndarray
    n_determined: int
    residual_rms_m: float
    n_frames: int

    def __post_init__(self) -> None:
        for name, shape in (("centre", (3,)), ("spreads_m", (3,)), ("directions", (3, 3))):
            arr = np.array(getattr(self, name), dtype=float)
            if arr.shape != shape:
                raise BadInputError(f"{name} must have shape {shape}, got {arr.shape}")
            object.__setattr__(self, name, frozen(arr))
        if not 0 <= self.n_determined <= 3:
            raise BadInputError(f"n_determined must lie in 0..3, got {self.n_determined}")


def fit_common_centre(points: np.ndarray, *, min_spread_m: float = 0.02,
                      prior: np.ndarray | None = None) -> CentreFit:
    """Least-squares centre of rotation shared by markers moving on spheres (Gamage & Lasenby 2002).

    Each marker ``m`` satisfies ``|p_m(t) - c|^2 = r_m^2``; subtracting each marker's mean gives the
    linear system ``2 (p_m - mean p_m) . c = |p_m|^2 - mean |p_m|^2``, solved in the eigenbasis of
    its normal matrix. Along a principal direction whose spread is below ``min_spread_m`` the centre
    takes ``prior``'s component (NaN without one).

    Parameters
    ----------
    points : (T, M, 3) [m] marker positions in the frame in which the centre is fixed; NaN where absent.
    min_spread_m : smallest RMS excursion [m] that determines the centre along a direction.
    prior : (3,) [m] centre to use along undetermined directions, or None.

    Returns
    -------
    CentreFit

    Raises
    ------
    BadInputError
        ``points`` is not (T, M, 3), or ``prior`` not a finite (3,) vector.
    """
    P = np.asarray(points, dtype=float)
    if P.ndim != 3 or P.shape[2] != 3:
        raise BadInputError(f"points must have shape (T, M, 3), got {P.shape}")
    if prior is not None:
        prior = np.asarray(prior, dtype=float)
        if prior.shape != (3,) or not np.isfinite(prior).all():
            raise BadInputError(f"prior must be a finite (3,) vector, got {prior!r}")
    S, g, n, used = np.zeros((3, 3)), np.zeros(3), 0, []
    for m in range(P.shape[1]):
        p = P[:, m][np.isfinite(P[:, m]).all(axis=1)]
        if len(p) < 2:
            continue
        d = p - p.mean(axis=0)
        sq = np.einsum("ti,ti->t", p, p)
        S += d.T @ d
        g += 0.5 * d.T @ (sq - sq.mean())
        n += len(p)
        used.append(p)
    lam, V = np.linalg.eigh(S)
    lam, V = lam[::-1], V[:, ::-1]
    spreads = np.sqrt(np.clip(lam, 0.0, None) / max(n, 1))
    ok = (spreads >= min_spread_m) & (spreads > 0.0)
    base = prior if prior is not None else np.full(3, np.nan)
    coords = np.where(ok, (V.T @ g) / np.where(ok, lam, 1.0), V.T @ np.nan_to_num(base, nan=0.0))
    centre = V @ coords
    if prior is None and not ok.all():
        centre = np.full(3, np.nan)
    residuals = [np.linalg.norm(p - centre, axis=1) for p in used]
    res = np.concatenate([r - r.mean() for r in residuals]) if residuals else np.array([np.nan])
    rms = float(np.sqrt(np.mean(res ** 2))) if np.isfinite(centre).all() and n else float("nan")
    return CentreFit(centre, spreads, V, int(ok.sum()), rms, int(max((len(p) for p in used), default=0)))
