"""The constants of the limb-axis fit (:func:`fusion.merge.limb_axes.limb_axes`) and the parts of it that
can be left out."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from fusion.errors import BadInputError
from fusion.merge.hand_ends import HandOptions
from fusion.merge.pivots import PIVOT_PAIRS

OPTIONAL_PARTS = {"centres": "the shoulders' and hips' functional centres (fusion.merge.pivots)",
                  "shoulder-centres": "the shoulders' functional centres alone (a single arm's session may do "
                                      "better without them)",
                  "hip-centres": "the hips' functional centres alone",
                  "hands": "the hands from the clouds (fusion.merge.hand_ends)"}
"""The parts of the correction :meth:`LimbAxisOptions.without` can leave out, with what each is."""


@dataclass(frozen=True)
class LimbAxisOptions:
    """Constants of the limb-axis fit (module docstring).

    Attributes
    ----------
    tolerance_s : largest time [s] between a depth instant and the skeleton frame (and other cameras'
        depth frames) it is paired with.
    reach_m : a segment's points lie within its radius plus this [m] of the skeleton's segment.
    span : the part of the segment's length (fractions from the proximal joint) its points come from.
    max_points : points per segment and instant, evenly strided.
    max_cloud_points : body points per instant assigned to bones, evenly strided.
    huber_m, trim_m, iterations : the cylinder fit's constants (:func:`~fusion.merge.cylinder_fit.fit_cylinders`).
    min_points, min_inlier_share, max_rms_m, max_turn_deg : the checks a fit must pass to count.
    radius_instants : instants per segment its radius is measured at.
    pull : weight [1] of a joint's measured position against the axes' pull (per unit projector).
    anchor_pull : weight [1] of the points the pivots and the hands give their joints (per unit
        projector); 0 for none.
    pivots : the joint pairs (of :data:`~fusion.merge.pivots.PIVOT_PAIRS`) placed at their functional
        centres (:mod:`fusion.merge.pivots`); empty for none.
    hands : constants of the hands from the clouds (:mod:`fusion.merge.hand_ends`); None for none.
    pivot_min_spread : the least smallest eigenvalue of the axes' mean projector for a pivot to count.
    pivot_min_instants : the fewest counted axes a pivot is found from.
    pivot_huber_m : [m] Huber scale of the axes' distances from the pivot.
    max_gap_s : a skeleton frame farther than this [s] from a counted instant is not corrected.
    """

    tolerance_s: float = 0.02
    reach_m: float = 0.06
    span: tuple[float, float] = (0.2, 0.8)
    max_points: int = 300
    max_cloud_points: int = 8000
    huber_m: float = 0.005
    trim_m: float = 0.015
    iterations: int = 8
    min_points: int = 40
    min_inlier_share: float = 0.6
    max_rms_m: float = 0.006
    max_turn_deg: float = 30.0
    radius_instants: int = 30
    pull: float = 0.05
    anchor_pull: float = 1.0
    pivots: tuple[str, ...] = tuple(PIVOT_PAIRS)
    hands: HandOptions | None = HandOptions()
    pivot_min_spread: float = 0.05
    pivot_min_instants: int = 20
    pivot_huber_m: float = 0.01
    max_gap_s: float = 0.25

    def __post_init__(self) -> None:
        positive = ("tolerance_s", "reach_m", "huber_m", "trim_m", "max_rms_m", "max_turn_deg", "pull", "max_gap_s",
                    "pivot_huber_m")
        for name in positive:
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise BadInputError(f"limb axes: {name} must be positive and finite, got {getattr(self, name)}")
        if not 0.0 <= self.span[0] < self.span[1] <= 1.0:
            raise BadInputError(f"limb axes: span must be (start, end) fractions, 0 <= start < end <= 1, "
                                f"got {self.span}")
        for name in ("max_points", "max_cloud_points", "iterations", "min_points", "radius_instants",
                     "pivot_min_instants"):
            if getattr(self, name) < 1:
                raise BadInputError(f"limb axes: {name} must be at least 1, got {getattr(self, name)}")
        if not (np.isfinite(self.anchor_pull) and self.anchor_pull >= 0):
            raise BadInputError(f"limb axes: anchor_pull must be 0 (no pivots or hands) or positive, got "
                                f"{self.anchor_pull}")
        if not 0.0 < self.pivot_min_spread <= 1.0:
            raise BadInputError(f"limb axes: pivot_min_spread must lie in (0, 1], got {self.pivot_min_spread}")
        if not isinstance(self.pivots, tuple) or not set(self.pivots) <= set(PIVOT_PAIRS):
            raise BadInputError(f"limb axes: pivots must be a tuple of {', '.join(PIVOT_PAIRS)}, got {self.pivots!r}")
        if not 0.0 < self.min_inlier_share <= 1.0:
            raise BadInputError(f"limb axes: min_inlier_share must lie in (0, 1], got {self.min_inlier_share}")

    def without(self, parts: Sequence[str]) -> LimbAxisOptions:
        """These options with the :data:`OPTIONAL_PARTS` named in ``parts`` left out."""
        unknown = sorted(set(parts) - set(OPTIONAL_PARTS))
        if unknown:
            raise BadInputError(f"limb axes: no part {', '.join(unknown)}; the parts are {', '.join(OPTIONAL_PARTS)}")
        dropped = {"shoulders": {"centres", "shoulder-centres"}, "hips": {"centres", "hip-centres"}}
        return replace(self, pivots=tuple(p for p in self.pivots if not dropped[p] & set(parts)),
                       hands=None if "hands" in parts else self.hands)
