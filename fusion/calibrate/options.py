"""Options of the calibration from the body: refinement, rig solver, thresholds."""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from fusion.errors import BadInputError


class IcpMethod(enum.Enum):
    """ICP error metric."""

    POINT_TO_PLANE = "point_to_plane"
    """Distance of source points to the target's tangent planes."""
    SYMMETRIC = "symmetric"
    """Symmetric point-to-plane (Rusinkiewicz 2019): both clouds' normals."""
    POINT_TO_POINT = "point_to_point"
    """Euclidean distance between corresponding points; slow to converge along surfaces."""


class Refinement(enum.Enum):
    """Refinement of the skeleton-based pair transforms."""

    NONE = "none"
    ICP = "icp"


class SkeletonFit(enum.Enum):
    """How a pair's transform is fitted to the skeletons."""

    ROBUST = "robust"
    """RANSAC, then refits on the inliers with joints weighted as ``joint_weighting`` says, back-facing
    skeletons excluded."""
    PLAIN = "plain"
    """The textbook baseline: RANSAC and one unweighted Kabsch refit on its inliers, every frame used."""


class JointWeighting(enum.Enum):
    """How the refits of the robust skeleton fit weight the joints."""

    RESIDUAL = "residual"
    """Each joint by the inverse square of its mean cross-camera residual, so joints whose tracker
    bias differs between the views pull less. On real two-camera Azure Kinect rigs it makes the
    calibration vary more from session to session than equal weights (docs/studies/calibration_real_azure.md)."""
    UNIFORM = "uniform"
    """Every joint equally (the default)."""


class RigMethod(enum.Enum):
    """How pairwise transforms become one consistent rig."""

    CHAIN = "chain"
    """The paper's chaining along the shortest path to the reference camera."""
    GRAPH = "graph"
    """Global least-squares pose graph over all measured pairs."""


@dataclass(frozen=True)
class CalibrationOptions:
    """Settings of :func:`calibrate_rig` (defaults suit Kinect v2 class sensors at 1.5-3 m).

    Attributes
    ----------
    refine, rig, skeleton_fit : see :class:`Refinement`, :class:`RigMethod` and :class:`SkeletonFit`.
    joint_weighting : joint weights of the robust fit's refits, see :class:`JointWeighting` (the plain
        fit always weighs the joints equally).
    reference : name of the reference camera; default the first camera.
    n_trials : RANSAC hypotheses per pair.
    inlier_threshold_m : RANSAC inlier distance [m].
    tolerance_s : frames of two cameras closer than this in time [s] are simultaneous.
    estimate_clock : estimate residual clock offsets from the motion (else trust the timestamps).
    max_clock_offset_s : largest clock offset searched [s].
    min_candidates : shared Tracked joint measurements a pair needs to be calibrated at all.
    bootstrap : bootstrap resamples of the inliers for the uncertainty.
    icp_instants : depth frame pairs used by ICP, spread over the session (varied poses and
        orientations constrain ICP best).
    icp_min_instants : fewest depth frame pairs ICP is run on (a single pose lets it slide).
    icp_max_speed_mps : only depth frame pairs where the body's median joint speed is below this
        [m/s] are used, so the two cameras' frames, captured milliseconds apart, show the same body.
    icp_max_angle_deg : ICP only for pairs whose viewing directions differ by at most this [deg]:
        cameras further apart see different sides of the body, and ICP would slide one onto the other.
    icp_rotation_std_deg, icp_translation_std_mm : uncertainty given to an ICP-refined pair in the
        pose graph (its systematic accuracy in simulation).
    skeleton_rotation_std_deg, skeleton_translation_std_mm : systematic uncertainty of a skeleton-only
        pair (the tracker's view-dependent bias), added in quadrature to its bootstrap spread, which
        measures only the random part.
    min_motion_m : a pair needs the person to move at least this much [m] (see :func:`motion_extent_m`)
        while both cameras see them; a static body gives too little geometry.
    depth_tolerance_s : depth frames of two cameras closer than this [s] (after the clock offset) may form
        an ICP instant. Generous, because depth frames are sparse and a clock offset estimated from the
        motion can be a frame off: what decides is ``icp_max_shift_m``.
    icp_max_shift_m : a depth frame pair is an ICP instant only if the body moves less than this [m]
        between its two frames (median joint speed times their time difference).
    icp_method : ICP error metric.
    estimate_confidence : for a skeleton stream without confidences (every present joint Tracked),
        estimate them from the joints' consistency (:func:`fusion.calibrate.reliability.estimate_states`).
    """

    refine: Refinement = Refinement.ICP
    rig: RigMethod = RigMethod.GRAPH
    skeleton_fit: SkeletonFit = SkeletonFit.ROBUST
    joint_weighting: JointWeighting = JointWeighting.UNIFORM
    reference: str | None = None
    n_trials: int = 2000
    inlier_threshold_m: float = 0.08
    tolerance_s: float = 1.0 / 60.0
    estimate_clock: bool = True
    max_clock_offset_s: float = 0.2
    min_candidates: int = 200
    bootstrap: int = 50
    icp_instants: int = 6
    icp_min_instants: int = 3
    depth_tolerance_s: float = 0.1
    icp_max_shift_m: float = 0.003
    icp_method: IcpMethod = IcpMethod.POINT_TO_PLANE
    icp_max_speed_mps: float = 0.3
    icp_max_angle_deg: float = 100.0
    icp_rotation_std_deg: float = 0.2
    icp_translation_std_mm: float = 3.0
    skeleton_rotation_std_deg: float = 1.0
    skeleton_translation_std_mm: float = 30.0
    min_motion_m: float = 0.10
    estimate_confidence: bool = True

    def __post_init__(self) -> None:
        if not (isinstance(self.refine, Refinement) and isinstance(self.rig, RigMethod)
                and isinstance(self.skeleton_fit, SkeletonFit) and isinstance(self.joint_weighting, JointWeighting)):
            raise BadInputError("refine must be a Refinement, rig a RigMethod, skeleton_fit a SkeletonFit and "
                                "joint_weighting a JointWeighting")
        positive = {k: getattr(self, k) for k in ("n_trials", "inlier_threshold_m", "tolerance_s",
                                                  "max_clock_offset_s", "min_candidates", "bootstrap",
                                                  "icp_instants", "icp_min_instants", "depth_tolerance_s",
                                                  "icp_max_shift_m", "icp_max_speed_mps",
                                                  "icp_max_angle_deg", "icp_rotation_std_deg",
                                                  "icp_translation_std_mm", "skeleton_rotation_std_deg",
                                                  "skeleton_translation_std_mm", "min_motion_m")}
        bad = {k: v for k, v in positive.items() if not (np.isfinite(v) and v > 0)}
        if bad:
            raise BadInputError(f"calibration options must be positive: {bad}")
        if self.icp_min_instants > self.icp_instants:
            raise BadInputError(f"icp_min_instants ({self.icp_min_instants}) must not exceed icp_instants "
                                f"({self.icp_instants})")
