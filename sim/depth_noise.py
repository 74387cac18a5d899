"""The depth sensor's noise model: its parameters and the axial sigma.

Noise (``reference/sensors.md``), applied in this order:

1. Lateral noise: each pixel samples along a ray through a jittered sub-pixel position (Gaussian,
   ``lateral_sigma_px`` per axis, its length clipped at 4 sigma). The jittered ray decides which
   surface the pixel sees, so silhouettes fray. The reported depth is where the pixel-centre ray
   meets the tangent plane at the jittered hit: exact on flat surfaces, so lateral noise does not
   add depth noise on slanted planes on top of the axial model (Fankhauser's sigma was measured on
   planes and already contains it). Where the pixel-centre ray meets that tangent plane beyond the
   grazing limit, the jittered hit's own depth is used. The floor is a plane, so floor pixels away
   from the person are computed at their pixel centre directly, with no jitter draw.
2. Grazing dropouts: no return with probability rising linearly from 0 at ``grazing_start_deg`` to
   1 at ``grazing_end_deg`` (a hard cut when they are equal).
3. Axial noise: Gaussian with :func:`sigma_axial_mm` (Fankhauser et al. 2015).
4. Flying pixels: a pixel on a depth edge (a 4-neighbour's noise-free depth differs by more than
   ``max(edge_jump_min_m, edge_jump_rel * depth)``) becomes, with probability ``flying_prob``, a
   mixture moved ``U(0, flying_spread)`` of the way to the neighbour across the largest jump. A
   plane's depth is continuous, so edges are only looked for around the person.
5. Constant offset, then range dropouts (measured z outside the intrinsics' ``[min_depth_m,
   max_depth_m]``), then rounding to whole millimetres.

:class:`sim.depth_camera.DepthCamera` applies it while rendering.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numba
import numpy as np

from fusion.errors import BadInputError

JITTER_CLIP = 4.0
"""Lateral jitter is clipped to this many sigmas (radially), so the pixels that can see the body are known."""

KINECT_V2_OFFSET_MM = -18.0
"""Constant depth offset reported for Kinect v2 (Wasenmueller & Stricker 2016) [mm]; use as ``offset_mm``."""


@dataclass(frozen=True)
class DepthNoise:
    """Parameters of the Kinect v2 depth noise model; defaults from ``reference/sensors.md``.

    Attributes
    ----------
    axial_c0_mm, axial_c1_mm_per_m, axial_c2_mm_per_m2, axial_c3_mm_per_m15 : float
        Coefficients of ``sigma_z = c0 + c1 z + c2 z^2 + c3 z^1.5 theta^2 / (pi/2 - theta)^2`` [mm],
        z in metres, theta the incidence angle (Fankhauser et al. 2015: 1.5, -0.5, 0.3, 0.1).
    lateral_sigma_px : float
        Standard deviation of the sub-pixel jitter of where each pixel samples, per axis [px].
    flying_prob : float
        Probability that a pixel on a depth edge becomes a flying pixel (*default* 0.5).
    flying_spread : float
        A flying pixel moves ``U(0, flying_spread)`` of the way across the depth jump, in [0, 1].
    edge_jump_min_m, edge_jump_rel : float
        A depth edge is a jump to a 4-neighbour larger than ``max(edge_jump_min_m, edge_jump_rel * z)``.
    grazing_start_deg, grazing_end_deg : float
        Incidence angles [deg] where the dropout probability starts rising from 0 and reaches 1.
    offset_mm : float
        Constant depth offset [mm] (0; :data:`KINECT_V2_OFFSET_MM` for the reported -18 mm).
    """

    axial_c0_mm: float = 1.5
    axial_c1_mm_per_m: float = -0.5
    axial_c2_mm_per_m2: float = 0.3
    axial_c3_mm_per_m15: float = 0.1
    lateral_sigma_px: float = 1.6
    flying_prob: float = 0.5
    flying_spread: float = 1.0
    edge_jump_min_m: float = 0.02
    edge_jump_rel: float = 0.03
    grazing_start_deg: float = 80.0
    grazing_end_deg: float = 85.0
    offset_mm: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
                raise BadInputError(f"DepthNoise.{f.name} must be a finite number, got {value!r}")
        c0, c1, c2, c3 = self.axial_c0_mm, self.axial_c1_mm_per_m, self.axial_c2_mm_per_m2, self.axial_c3_mm_per_m15
        z_star = max(-c1 / (2 * c2), 0.0) if c2 > 0 else 0.0  # where c0 + c1 z + c2 z^2 is smallest on z >= 0
        if min(c0, c2, c3) < 0 or (c2 == 0 and c1 < 0) or c0 + c1 * z_star + c2 * z_star**2 < 0:
            raise BadInputError("axial coefficients must give sigma_z >= 0 for every depth (c0, c2, c3 >= 0)")
        if self.lateral_sigma_px < 0 or self.edge_jump_min_m < 0 or self.edge_jump_rel < 0:
            raise BadInputError("lateral_sigma_px, edge_jump_min_m and edge_jump_rel must be >= 0")
        if not (0 <= self.flying_prob <= 1 and 0 <= self.flying_spread <= 1):
            raise BadInputError(
                f"flying_prob and flying_spread must lie in [0, 1], got {self.flying_prob}, {self.flying_spread}"
            )
        if not 0 <= self.grazing_start_deg <= self.grazing_end_deg <= 90:
            raise BadInputError(
                "need 0 <= grazing_start_deg <= grazing_end_deg <= 90, "
                f"got {self.grazing_start_deg}, {self.grazing_end_deg}"
            )

    @classmethod
    def none(cls) -> "DepthNoise":
        """An ideal sensor: no noise, jitter, flying pixels, grazing dropouts or offset.

        Range limits and millimetre quantisation still apply.
        """
        return cls(axial_c0_mm=0.0, axial_c1_mm_per_m=0.0, axial_c2_mm_per_m2=0.0, axial_c3_mm_per_m15=0.0,
                   lateral_sigma_px=0.0, flying_prob=0.0, grazing_start_deg=90.0, grazing_end_deg=90.0, offset_mm=0.0)

    def grazing_drop_prob(self, theta_rad: np.ndarray) -> np.ndarray:
        """Probability ``(...)`` that a return at incidence ``theta_rad`` ``(...)`` is missing; NaN stays NaN."""
        theta = np.asarray(theta_rad, dtype=float)
        start, end = np.radians(self.grazing_start_deg), np.radians(self.grazing_end_deg)
        if end > start:
            return np.clip((theta - start) / (end - start), 0.0, 1.0)
        with np.errstate(invalid="ignore"):
            return np.where(np.isnan(theta), np.nan, (theta > end).astype(float))


def lateral_jitter_px(n: int, sigma_px: float, rng: np.random.Generator) -> np.ndarray:
    """(n, 2) sub-pixel shifts (u, v) [px]: Gaussian, ``sigma_px`` per axis, length clipped at :data:`JITTER_CLIP` sigmas.

    The draws are ``rng.standard_normal((n, 2))``'s, in a compiled loop.
    """
    return _jitter(int(n), float(sigma_px), JITTER_CLIP, rng)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _jitter(n, sigma_px, clip, rng):
    shift = np.empty((n, 2))
    for i in range(n):
        u, v = rng.standard_normal(), rng.standard_normal()
        r2 = u * u + v * v
        scale = sigma_px * clip / math.sqrt(r2) if r2 > clip * clip else sigma_px
        shift[i, 0], shift[i, 1] = u * scale, v * scale
    return shift


def sigma_axial_mm(z_m: np.ndarray, theta_rad: np.ndarray, noise: DepthNoise) -> np.ndarray:
    """Axial (depth) noise standard deviation of Fankhauser et al. (2015).

    ``sigma = c0 + c1 z + c2 z^2 + c3 z^1.5 theta^2 / (pi/2 - theta)^2`` with the coefficients of
    ``noise``; defaults give 1.3 mm at 1 m, 2.1 mm at 2.5 m, 4.3 mm at 4 m head-on and 12 mm at
    2.5 m and 75 degrees.

    Parameters
    ----------
    z_m : (...) depth [m], >= 0.
    theta_rad : (...) incidence angle [rad] in [0, pi/2]; broadcast against ``z_m``.
    noise : the model's coefficients.

    Returns
    -------
    (...) float64 sigma [mm]; inf at theta = pi/2 (when c3 > 0), NaN where an input is NaN.
    """
    try:
        z, theta = np.broadcast_arrays(np.asarray(z_m, dtype=float), np.asarray(theta_rad, dtype=float))
    except ValueError:
        raise BadInputError(f"z_m and theta_rad do not broadcast: {np.shape(z_m)} vs {np.shape(theta_rad)}") from None
    with np.errstate(invalid="ignore"):
        if np.any(z < 0) or np.any((theta < 0) | (theta > np.pi / 2)) or np.any(np.isinf(z)):
            raise BadInputError("need finite z_m >= 0 and theta_rad in [0, pi/2]")
    sigma = noise.axial_c0_mm + noise.axial_c1_mm_per_m * z + noise.axial_c2_mm_per_m2 * z**2
    if noise.axial_c3_mm_per_m15 > 0:
        with np.errstate(divide="ignore"):
            sigma = sigma + noise.axial_c3_mm_per_m15 * z**1.5 * theta**2 / ((np.pi / 2) - theta) ** 2
    return np.where(np.isnan(theta), np.nan, sigma)
