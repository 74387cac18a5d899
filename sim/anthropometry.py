"""Subject body dimensions from stature, build and per-segment multipliers.

Every dimension is a ratio times the stature ``H`` (:attr:`Anthropometry.height_m`). Lengths are
also multiplied by the segment's length multiplier, radii and trunk depths/breadths by the girth
factor ``g`` (:attr:`Anthropometry.girth_factor` = build factor x girth multiplier: SLIM 0.88,
AVERAGE 1.00, HEAVY 1.20). Longitudinal ratios are Drillis & Contini (1966) as tabulated in Winter,
*Biomechanics and Motor Control of Human Movement* (4th ed., 2009, Fig. 4.1); widths and radii
(marked *model*) are chosen so that the surface matches typical adult breadths and circumferences.

==========================  =======  ===========  =================================================
dimension                   ratio    scaled by    note
==========================  =======  ===========  =================================================
ankle height                0.039    H            sole to ankle centre (Winter 0.039)
shank                       0.246    H*shank      knee to ankle centre (Winter 0.285 - 0.039)
thigh                       0.245    H*thigh      hip to knee centre (Winter 0.530 - 0.285)
trunk                       0.288    H*trunk      hip-centre level to shoulder level (0.818 - 0.530)
neck                        0.072    H            shoulder level to atlanto-occipital joint
head                        0.110    H            atlanto-occipital joint to vertex (chin 0.870)
upper arm                   0.186    H*upper_arm  shoulder to elbow centre (Winter)
forearm                     0.146    H*forearm    elbow to wrist centre (Winter)
hand                        0.108    H*hand       wrist centre to middle finger tip (Winter)
foot length                 0.152    H*foot       heel to toe tip (Winter)
foot width                  0.055    H*foot       Winter
shoulder width              0.210    H            glenohumeral centres; model (bideltoid 0.259)
hip width                   0.100    H            hip joint centres; model (bitrochanteric 0.191)
hand breadth                0.050    H*hand       model
hand thickness              0.016    H*g          model
upper arm radius            0.026    H*g          model (circumference ~0.29 m at H = 1.75 m)
forearm radius              0.021    H*g          model
thigh radius                0.038    H*g          model
shank radius                0.029    H*g          model
neck radius                 0.032    H*g          model
shoulder girdle radius      0.022    H*g          model (clavicle capsule)
thumb radius                0.0055   H            model
pelvis semi-axes x, y       0.058,   H*g          model; z semi-axis 0.26 x trunk
                            0.085
abdomen semi-axes x, y      0.052,   H*g          model; z semi-axis 0.22 x trunk
                            0.075
chest semi-axes x, y        0.062,   H*g          model; z semi-axis 0.30 x trunk
                            0.082
head semi-axes x, y, z      0.056,   H            model; head length 0.196 m, breadth 0.154 m,
                            0.044,                chin-vertex 0.228 m at H = 1.75 m
                            0.065
==========================  =======  ===========  =================================================

With all multipliers 1 the longitudinal ratios add up to 1, so the standing height of the head top
equals ``height_m``; other multipliers change it (:attr:`BodyDimensions.stature`).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, fields
from functools import cached_property

import numpy as np

from fusion.errors import BadInputError

HEIGHT_RANGE_M = (1.2, 2.2)
"""Accepted stature range, metres."""

MULTIPLIER_RANGE = (0.5, 2.0)
"""Accepted range of every length and girth multiplier."""


class Build(enum.Enum):
    """Body build; scales every girth (radii, trunk depth and breadth)."""

    SLIM = "slim"
    AVERAGE = "average"
    HEAVY = "heavy"

    @property
    def girth_factor(self) -> float:
        """Girth scale of this build (SLIM 0.88, AVERAGE 1.0, HEAVY 1.2)."""
        return _BUILD_GIRTH[self]


_BUILD_GIRTH = {Build.SLIM: 0.88, Build.AVERAGE: 1.0, Build.HEAVY: 1.2}

_MULTIPLIERS = ("trunk", "upper_arm", "forearm", "hand", "thigh", "shank", "foot", "girth")


@dataclass(frozen=True)
class BodyDimensions:
    """Segment dimensions of one subject, all in metres (see the module table).

    Lengths run between joint centres unless stated otherwise. Semi-axes are ``(x, y, z)`` =
    (forward, left, up) in the neutral stance.
    """

    ankle_height: float
    shank: float
    thigh: float
    trunk: float
    neck: float
    head: float
    upper_arm: float
    forearm: float
    hand: float
    foot_length: float
    foot_width: float
    shoulder_width: float
    hip_width: float
    hand_breadth: float
    hand_thickness: float
    upper_arm_radius: float
    forearm_radius: float
    thigh_radius: float
    shank_radius: float
    neck_radius: float
    shoulder_girdle_radius: float
    thumb_radius: float
    pelvis_semi_axes: tuple[float, float, float]
    abdomen_semi_axes: tuple[float, float, float]
    chest_semi_axes: tuple[float, float, float]
    head_semi_axes: tuple[float, float, float]

    @property
    def stature(self) -> float:
        """Standing height of the head top above the soles in the neutral stance, metres."""
        return self.ankle_height + self.shank + self.thigh + self.trunk + self.neck + self.head


@dataclass(frozen=True)
class Anthropometry:
    """One subject's body proportions.

    Attributes
    ----------
    height_m : float
        Stature in metres, within :data:`HEIGHT_RANGE_M`.
    build : Build
        Body build, scales girths.
    trunk, upper_arm, forearm, hand, thigh, shank, foot : float
        Dimensionless length multipliers of each segment (1 = the standard proportion).
    girth : float
        Dimensionless girth multiplier on top of the build.

    Raises
    ------
    BadInputError
        If the height or a multiplier is not a finite number within its accepted range, or
        ``build`` is not a :class:`Build`.
    """

    height_m: float = 1.75
    build: Build = Build.AVERAGE
    trunk: float = 1.0
    upper_arm: float = 1.0
    forearm: float = 1.0
    hand: float = 1.0
    thigh: float = 1.0
    shank: float = 1.0
    foot: float = 1.0
    girth: float = 1.0

    def __post_init__(self) -> None:
        if not isinstance(self.build, Build):
            raise BadInputError(f"build must be a Build ({', '.join(b.name for b in Build)}), got {self.build!r}")
        _check_number("height_m", self.height_m, HEIGHT_RANGE_M, "metres")
        for name in _MULTIPLIERS:
            _check_number(name, getattr(self, name), MULTIPLIER_RANGE, "a dimensionless multiplier")
        for f in fields(self):
            if f.name != "build":
                object.__setattr__(self, f.name, float(getattr(self, f.name)))

    @property
    def girth_factor(self) -> float:
        """Overall girth scale ``g`` = build factor x girth multiplier."""
        return self.build.girth_factor * self.girth

    @cached_property
    def dimensions(self) -> BodyDimensions:
        """Segment lengths, widths and radii in metres (ratios in the module table)."""
        h, g, trunk = self.height_m, self.girth_factor, 0.288 * self.height_m * self.trunk
        return BodyDimensions(
            ankle_height=0.039 * h,
            shank=0.246 * h * self.shank,
            thigh=0.245 * h * self.thigh,
            trunk=trunk,
            neck=0.072 * h,
            head=0.110 * h,
            upper_arm=0.186 * h * self.upper_arm,
            forearm=0.146 * h * self.forearm,
            hand=0.108 * h * self.hand,
            foot_length=0.152 * h * self.foot,
            foot_width=0.055 * h * self.foot,
            shoulder_width=0.210 * h,
            hip_width=0.100 * h,
            hand_breadth=0.050 * h * self.hand,
            hand_thickness=0.016 * h * g,
            upper_arm_radius=0.026 * h * g,
            forearm_radius=0.021 * h * g,
            thigh_radius=0.038 * h * g,
            shank_radius=0.029 * h * g,
            neck_radius=0.032 * h * g,
            shoulder_girdle_radius=0.022 * h * g,
            thumb_radius=0.0055 * h,
            pelvis_semi_axes=(0.058 * h * g, 0.085 * h * g, 0.26 * trunk),
            abdomen_semi_axes=(0.052 * h * g, 0.075 * h * g, 0.22 * trunk),
            chest_semi_axes=(0.062 * h * g, 0.082 * h * g, 0.30 * trunk),
            head_semi_axes=(0.056 * h, 0.044 * h, 0.065 * h),
        )


def sample_anthropometry(
    *,
    rng: np.random.Generator,
    height_mean: float = 1.72,
    height_sd: float = 0.09,
    limb_sd: float = 0.03,
) -> Anthropometry:
    """Draw a random subject.

    Parameters
    ----------
    rng : numpy.random.Generator
        Source of randomness.
    height_mean, height_sd : float
        Normal distribution of the stature, metres; draws are clipped to :data:`HEIGHT_RANGE_M`.
    limb_sd : float
        Standard deviation of every length multiplier and of the girth multiplier around 1
        (clipped to :data:`MULTIPLIER_RANGE`). The build is SLIM / AVERAGE / HEAVY with
        probabilities 0.25 / 0.5 / 0.25.

    Returns
    -------
    Anthropometry

    Raises
    ------
    BadInputError
        If ``height_mean`` is outside :data:`HEIGHT_RANGE_M` or a standard deviation is outside
        [0, 1].
    """
    _check_number("height_mean", height_mean, HEIGHT_RANGE_M, "metres")
    for name, sd in (("height_sd", height_sd), ("limb_sd", limb_sd)):
        _check_number(name, sd, (0.0, 1.0), "a standard deviation")
    height = float(np.clip(rng.normal(height_mean, height_sd), *HEIGHT_RANGE_M))
    build = list(Build)[rng.choice(len(Build), p=[0.25, 0.5, 0.25])]
    multipliers = np.clip(1.0 + limb_sd * rng.standard_normal(len(_MULTIPLIERS)), *MULTIPLIER_RANGE)
    return Anthropometry(height_m=height, build=build, **dict(zip(_MULTIPLIERS, multipliers.tolist())))


def _check_number(name: str, value: object, bounds: tuple[float, float], what: str) -> None:
    lo, hi = bounds
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise BadInputError(f"{name} must be a real number ({what}), got {value!r}")
    if not lo <= float(value) <= hi:
        raise BadInputError(f"{name} = {value!r} is out of range: it must be {what} in [{lo}, {hi}]")
