"""Parameters of the virtual tracker's error model: joint groups, per-group noise, the model bias.

See :mod:`sim.tracker` for how they combine. Body frame of the model bias: x forward (the facing
direction), y to the subject's left, z up.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from types import MappingProxyType

import numpy as np
from scipy.signal import lfilter

from fusion.errors import BadInputError
from fusion.topology import Landmark, Topology
from sim.tracker_arm_bias import ArmBias
from sim.tracker_trunk_bias import TrunkBias


class JointGroup(enum.Enum):
    """Joint families that share error parameters."""

    TORSO = "torso"
    """Spine, neck, head, clavicles and face joints."""
    HIP = "hip"
    LIMB = "limb"
    """Shoulders, elbows, knees."""
    HAND = "hand"
    """Wrists and hands."""
    TIP = "tip"
    """Hand tips and thumbs."""
    FOOT = "foot"
    """Ankles and feet."""


_GROUP_OF_LANDMARK: dict[Landmark, JointGroup] = {
    lm: group
    for group, stems in (
        (JointGroup.HIP, ("hip",)),
        (JointGroup.LIMB, ("shoulder", "elbow", "knee")),
        (JointGroup.HAND, ("wrist", "hand")),
        (JointGroup.TIP, ("handtip", "thumb")),
        (JointGroup.FOOT, ("ankle", "foot")),
    )
    for stem in stems
    for lm in (Landmark(f"{stem}_left"), Landmark(f"{stem}_right"))
}


def joint_groups(topology: Topology) -> tuple[JointGroup, ...]:
    """Group of each joint of ``topology`` (J,); joints without a limb landmark are TORSO."""
    groups = [JointGroup.TORSO] * topology.n_joints
    for lm, group in _GROUP_OF_LANDMARK.items():
        groups[topology.index(lm)] = group
    return tuple(groups)


def _check_range(name: str, r: tuple[float, float]) -> None:
    if len(r) != 2 or not np.all(np.isfinite(r)) or not 0 <= r[0] <= r[1]:
        raise BadInputError(f"{name} must be a range (low, high) with 0 <= low <= high, got {r}")


@dataclass(frozen=True)
class GroupNoise:
    """Error parameters of one :class:`JointGroup`.

    Attributes
    ----------
    bias_m : (float, float)
        Range of the static bias magnitude [m] (model and view parts together, RMS sense).
    jitter_m : float
        Per-axis standard deviation of the frame-to-frame jitter [m] at yaw 0.
    outlier_rate : float
        Fraction of frames in which a joint is an outlier, in [0, 1).
    outlier_m : (float, float)
        Range of an outlier's displacement magnitude [m].
    wobble_m : float
        Per-axis standard deviation [m] of the slow, temporally correlated error (an AR(1) process
        with time constant :attr:`TrackerNoise.wobble_tau_s`) at yaw 0; 0 for none.
    low_confidence : (float, float)
        Range of the share of frames in which a visible joint is still reported at low confidence
        (Inferred / LOW), drawn per camera and joint; the low frames come in runs.
    hidden_low_confidence : float
        Share of the frames in which a joint hidden from the camera is reported at low confidence,
        with the guessed offset of :attr:`TrackerNoise.inferred_offset_m`, in [0, 1] (runs, like
        ``low_confidence``); in the other hidden frames it is reported Tracked with the ordinary
        errors (a body-model tracker keeps the trunk at full confidence while the arms hide it).
    bone_rigidity : float
        How far the tracker holds the length of the bones that end at the group's joints at its
        session median, in [0, 1]: each such reported length is ``(1 - r) * measured + r * median``
        (0 leaves the noise as it is; the Azure tracker keeps its bones nearly constant).
    activity_exponent : float
        How the group's jitter and slow error grow with a camera session's activity beyond the
        tracker's common factor (:attr:`TrackerNoise.activity_exponent`): both times
        ``(A / activity_ref_m_s) ** activity_exponent``, ``A`` the session's activity as there; 0: no
        growth of its own (a trunk whose jitter follows the whole body's motion has one; a wrist whose
        jitter follows its own speed need not).
    """

    bias_m: tuple[float, float]
    jitter_m: float
    outlier_rate: float
    outlier_m: tuple[float, float]
    wobble_m: float = 0.0
    low_confidence: tuple[float, float] = (0.0, 0.0)
    hidden_low_confidence: float = 1.0
    bone_rigidity: float = 0.0
    activity_exponent: float = 0.0

    def __post_init__(self) -> None:
        _check_range("bias_m", self.bias_m)
        _check_range("outlier_m", self.outlier_m)
        for name in ("jitter_m", "wobble_m"):
            if not np.isfinite(getattr(self, name)) or getattr(self, name) < 0:
                raise BadInputError(f"{name} must be finite and >= 0, got {getattr(self, name)}")
        _check_range("low_confidence", self.low_confidence)
        if self.low_confidence[1] > 1:
            raise BadInputError(f"low_confidence must lie within [0, 1], got {self.low_confidence}")
        if not 0 <= self.outlier_rate < 1:
            raise BadInputError(f"outlier_rate must lie in [0, 1), got {self.outlier_rate}")
        if not 0 <= self.bone_rigidity <= 1:
            raise BadInputError(f"bone_rigidity must lie in [0, 1], got {self.bone_rigidity}")
        if not 0 <= self.hidden_low_confidence <= 1:
            raise BadInputError(f"hidden_low_confidence must lie in [0, 1], got {self.hidden_low_confidence}")
        if not -3 <= self.activity_exponent <= 3:  # NaN fails too
            raise BadInputError(f"a group's activity_exponent must lie in [-3, 3], got {self.activity_exponent}")


_QUIET = GroupNoise((0.0, 0.0), 0.0, 0.0, (0.0, 0.0))


DEFAULT_GROUP_NOISE: Mapping[JointGroup, GroupNoise] = MappingProxyType(
    {
        JointGroup.TORSO: GroupNoise((0.02, 0.05), 0.0035, 0.005, (0.05, 0.15)),
        JointGroup.HIP: GroupNoise((0.02, 0.06), 0.004, 0.005, (0.05, 0.15)),
        JointGroup.LIMB: GroupNoise((0.03, 0.06), 0.006, 0.01, (0.08, 0.20)),
        JointGroup.HAND: GroupNoise((0.03, 0.08), 0.010, 0.02, (0.10, 0.30)),
        JointGroup.TIP: GroupNoise((0.05, 0.10), 0.020, 0.04, (0.10, 0.30)),
        JointGroup.FOOT: GroupNoise((0.05, 0.10), 0.015, 0.03, (0.10, 0.30)),
    }
)
"""Defaults from sensors.md (frontal, 2-3 m). Hip bias adds a systematic up/out part, see TrackerNoise."""


DEFAULT_YAW_MULTIPLIER: tuple[tuple[float, float], ...] = (
    (0.0, 1.0), (30.0, 1.2), (60.0, 1.8), (100.0, 3.0), (180.0, 3.0)
)
"""(yaw [deg], error multiplier) knots, interpolated linearly."""


@dataclass(frozen=True)
class TrackerNoise:
    """Every parameter of the skeleton tracker's error model.

    Attributes
    ----------
    groups : mapping JointGroup -> GroupNoise
        Bias, jitter and outlier parameters per joint group.
    model_fraction : float
        Share of the random static bias variance that belongs to the body model (common to all
        cameras), in [0, 1]; the rest is view-dependent.
    lateral_ratio : float
        Size of the view bias across the viewing ray relative to along it (per lateral axis).
    toward_camera_fraction : float
        Probability that a joint's view bias along the ray points toward the camera: a tracker fits
        joints to the surface it sees, so they tend to come out nearer the camera than the true
        joint centre.
    hip_up_m, hip_out_m : float
        Systematic model offset of the hip joints [m]: up, and away from the mid-sagittal plane.
    yaw_multiplier : tuple of (yaw_deg, multiplier)
        Error multiplier versus the apparent yaw to the camera, knots from 0 to 180 degrees with
        multipliers >= 1 (seen from behind and flipped, the apparent yaw is 180 minus the yaw). It
        scales the jitter and both parts of the static bias by ``k``: the body-model fit degrades
        with yaw as much as the view-dependent part.
    outlier_mean_frames : float
        Mean length of an outlier burst [frames], >= 1.
    inferred_offset_m : (float, float)
        Range of the extra offset magnitude [m] of a joint while it is Inferred (guessed from its
        neighbours); fixed per camera and joint, in the viewing-ray frame.
    inferred_jitter_scale : float
        Jitter factor while a joint is Inferred.
    flip_enabled : bool
        Whether back-facing people are reported as left/right-swapped front-facing skeletons.
    flip_threshold_deg, flip_band_deg : float
        The skeleton flips when the yaw to the camera rises above ``threshold + band / 2`` and flips
        back when it falls below ``threshold - band / 2``; a newly acquired body starts flipped when
        above ``threshold``.
    min_fraction_in_view : float
        The whole skeleton is NotTracked when a smaller fraction of its joints is in the field of
        view and depth range.
    wobble_tau_s : float
        Time constant [s] of the slow error (see :attr:`GroupNoise.wobble_m`) and of the runs of
        low-confidence frames, > 0.
    speed_ref_m_s : float
        Joint speed [m/s] at which the jitter and the wobble's innovations of a joint have doubled:
        both scale with ``1 + |v| / speed_ref_m_s``, ``v`` the joint's true velocity (a moving limb
        blurs and the tracker's temporal model lags); 0 for no speed dependence.
    activity_exponent : float
        How a camera session's view bias, jitter and wobble grow with the session's activity ``A``
        (:func:`sim.tracker.session_activity`, the mean true joint speed): all three scale with
        ``(A / activity_ref_m_s) ** activity_exponent``, ``A`` clipped to ``activity_range_m_s``; 0 for none.
    activity_ref_m_s : float
        Activity [m/s] at which that factor is 1, inside ``activity_range_m_s``.
    activity_range_m_s : (float, float)
        Activities [m/s] the factor follows (those of the recordings it was fitted on); a session
        outside takes the nearest end: the model does not extrapolate.
    body_scale_sd : float
        Standard deviation of the body scale (a fraction of the length; :mod:`sim.tracker_bones`), the
        factor that moves every reported bone length together, in [0, 0.2]; 0 for a tracker whose bones
        vary each on its own.
    body_scale_tau_s : float
        Time constant [s] of the body scale, > 0.
    body_scale_shared : float
        Share of the body scale's variance common to a session's cameras, in [0, 1].
    arm_bias : ArmBias or None
        Where the shoulder, elbow and wrist joints sit on the arm as it moves
        (:mod:`sim.tracker_arm_bias`), fitted against an optical reference; it replaces those joints'
        body-frame model bias. None: the body-frame model bias for every joint.
    trunk_bias : TrunkBias or None
        Where the pelvis, spine-mid and spine-shoulder joints sit relative to the thorax
        (:mod:`sim.tracker_trunk_bias`), fitted against an optical reference; it replaces those joints'
        body-frame model bias. None: the body-frame model bias.
    view_limb_correlation : float
        Correlation, in [0, 0.99], of the random draws of a limb joint's view bias with those of its
        parent limb joint (:func:`fusion.merge.limb_sharing.limb_links`; a Gaussian copula along each
        limb from the shoulder or knee outward): a tracker that misplaces a limb segment in one camera's
        view misplaces the joints at both of its ends together. 0: each joint's view bias its own.
    hidden_offset_share : float
        Share, in [0, 1], of the frames in which a joint hidden from the camera but reported at full
        confidence (the rest of ``hidden_low_confidence``) still carries the guessed offset of
        ``inferred_offset_m`` (in runs, as the low-confidence frames): a body tracker keeps an occluded
        limb confident while guessing where it is. 0: those frames carry the ordinary errors only.
    view_bone_alignment, noise_bone_alignment : float
        Natural log, in [-2, 2], of how much larger a limb joint's view bias (respectively its jitter,
        slow error and outliers) is along its bone than across it (:func:`sim.tracker_axes.bone_aligned`; the bone from
        its parent limb joint): a tracker sure of a limb's axis but not of where along it the joint sits
        errs along the bone. 0: as drawn (view bias mostly along the viewing ray, noise isotropic).
    camera_scale_sd : float
        Standard deviation, in [0, 0.2], of the natural log of a factor by which each camera scales the
        whole skeleton it reports, drawn once per camera with its view bias: two cameras of a rig disagree
        on a person's size by the same factor in every session. 0: none.
    shared_bone_lengths : float
        In [0, 1], how far the bone rigidity holds each bone at the person's own length, the same in every
        camera, instead of at the camera's session median, which its view bias has moved: a body-model
        tracker finds one set of proportions from any view. 0: the camera's median.
    trunk_turn_sd_deg : float
        Standard deviation [deg], in [0, 5], of each axis of a rotation by which a camera session turns the
        trunk joints (:func:`fusion.merge.residual_parts.trunk_joints`) about the pelvis, drawn once per camera
        and session (:func:`sim.tracker_bones.turn_trunk`): a tracker misjudges the trunk's orientation
        against the limbs a little, differently in each session. 0: none.
    """

    groups: Mapping[JointGroup, GroupNoise] = field(default_factory=lambda: DEFAULT_GROUP_NOISE, hash=False)
    model_fraction: float = 0.8
    lateral_ratio: float = 0.3
    toward_camera_fraction: float = 0.9
    hip_up_m: float = 0.05
    hip_out_m: float = 0.03
    yaw_multiplier: tuple[tuple[float, float], ...] = DEFAULT_YAW_MULTIPLIER
    outlier_mean_frames: float = 2.0
    inferred_offset_m: tuple[float, float] = (0.03, 0.10)
    inferred_jitter_scale: float = 2.0
    flip_enabled: bool = True
    flip_threshold_deg: float = 120.0
    flip_band_deg: float = 30.0
    min_fraction_in_view: float = 0.5
    wobble_tau_s: float = 1.0
    speed_ref_m_s: float = 0.0
    activity_exponent: float = 0.0
    activity_ref_m_s: float = 0.3
    activity_range_m_s: tuple[float, float] = (0.3, 0.3)
    body_scale_sd: float = 0.0
    body_scale_tau_s: float = 0.5
    body_scale_shared: float = 0.0
    arm_bias: ArmBias | None = None
    trunk_bias: TrunkBias | None = None
    view_limb_correlation: float = 0.0
    hidden_offset_share: float = 0.0
    view_bone_alignment: float = 0.0
    noise_bone_alignment: float = 0.0
    camera_scale_sd: float = 0.0
    shared_bone_lengths: float = 0.0
    trunk_turn_sd_deg: float = 0.0

    def __post_init__(self) -> None:
        for name, kind in (("arm_bias", ArmBias), ("trunk_bias", TrunkBias)):
            if getattr(self, name) is not None and not isinstance(getattr(self, name), kind):
                raise BadInputError(f"{name} must be a {kind.__name__} or None, got {type(getattr(self, name)).__name__}")
        if set(self.groups) != set(JointGroup) or not all(isinstance(g, GroupNoise) for g in self.groups.values()):
            raise BadInputError(f"groups must map every JointGroup {[g.value for g in JointGroup]} to a GroupNoise")
        object.__setattr__(self, "groups", MappingProxyType(dict(self.groups)))
        scalars = {f.name: getattr(self, f.name) for f in fields(self) if f.type == "float"}
        if not np.all(np.isfinite(list(scalars.values()))):
            raise BadInputError(f"noise parameters must be finite, got {scalars}")
        if not 0 <= self.model_fraction <= 1:
            raise BadInputError(f"model_fraction must lie in [0, 1], got {self.model_fraction}")
        if not 0 <= self.toward_camera_fraction <= 1:
            raise BadInputError(f"toward_camera_fraction must lie in [0, 1], got {self.toward_camera_fraction}")
        if min(self.lateral_ratio, self.hip_up_m, self.hip_out_m) < 0:
            raise BadInputError("lateral_ratio, hip_up_m and hip_out_m must be >= 0")
        knots = np.asarray(self.yaw_multiplier, dtype=float)
        if (
            knots.ndim != 2 or knots.shape[1] != 2 or knots.shape[0] < 2 or not np.all(np.isfinite(knots))
            or knots[0, 0] != 0 or knots[-1, 0] != 180 or np.any(np.diff(knots[:, 0]) <= 0)
            or np.any(knots[:, 1] < 1)
        ):
            raise BadInputError(
                "yaw_multiplier must be (yaw_deg, multiplier) knots with yaw increasing from 0 to 180 "
                f"and multipliers >= 1, got {self.yaw_multiplier}"
            )
        if self.outlier_mean_frames < 1:
            raise BadInputError(f"outlier_mean_frames must be >= 1, got {self.outlier_mean_frames}")
        _check_range("inferred_offset_m", self.inferred_offset_m)
        if self.inferred_jitter_scale < 0:
            raise BadInputError(f"inferred_jitter_scale must be >= 0, got {self.inferred_jitter_scale}")
        if self.flip_band_deg < 0 or not 0 < self.flip_threshold_deg - self.flip_band_deg / 2:
            raise BadInputError("need flip_band_deg >= 0 and flip_threshold_deg - flip_band_deg / 2 > 0")
        if not self.wobble_tau_s > 0:
            raise BadInputError(f"wobble_tau_s must be positive, got {self.wobble_tau_s}")
        if self.speed_ref_m_s < 0:
            raise BadInputError(f"speed_ref_m_s must be >= 0 (0: no speed dependence), got {self.speed_ref_m_s}")
        lo, hi = self.activity_range_m_s
        if not (np.isfinite([lo, hi]).all() and 0 < lo <= self.activity_ref_m_s <= hi):
            raise BadInputError(f"need 0 < activity_range_m_s[0] <= activity_ref_m_s <= activity_range_m_s[1], got "
                                f"{self.activity_ref_m_s} and {self.activity_range_m_s}")
        if not (0 <= self.body_scale_sd <= 0.2 and self.body_scale_tau_s > 0 and 0 <= self.body_scale_shared <= 1):
            raise BadInputError("need body_scale_sd in [0, 0.2], body_scale_tau_s > 0 and body_scale_shared in [0, 1], got "
                                f"{self.body_scale_sd}, {self.body_scale_tau_s} and {self.body_scale_shared}")
        if not 0 < self.min_fraction_in_view <= 1:
            raise BadInputError(f"min_fraction_in_view must lie in (0, 1], got {self.min_fraction_in_view}")
        if not 0 <= self.view_limb_correlation <= 0.99:
            raise BadInputError(f"view_limb_correlation must lie in [0, 0.99], got {self.view_limb_correlation}")
        if not 0 <= self.hidden_offset_share <= 1:
            raise BadInputError(f"hidden_offset_share must lie in [0, 1], got {self.hidden_offset_share}")
        for name in ("view_bone_alignment", "noise_bone_alignment"):
            if not -2 <= getattr(self, name) <= 2:
                raise BadInputError(f"{name} must lie in [-2, 2], got {getattr(self, name)}")
        if not 0 <= self.trunk_turn_sd_deg <= 5:
            raise BadInputError(f"trunk_turn_sd_deg must lie in [0, 5], got {self.trunk_turn_sd_deg}")
        if not (0 <= self.camera_scale_sd <= 0.2 and 0 <= self.shared_bone_lengths <= 1):
            raise BadInputError("need camera_scale_sd in [0, 0.2] and shared_bone_lengths in [0, 1], got "
                                f"{self.camera_scale_sd} and {self.shared_bone_lengths}")

    @classmethod
    def none(cls) -> TrackerNoise:
        """An ideal tracker: no bias, jitter, outliers or inferred error, and no flip."""
        return cls(
            groups={g: _QUIET for g in JointGroup}, hip_up_m=0.0, hip_out_m=0.0,
            inferred_offset_m=(0.0, 0.0), flip_enabled=False,
        )

    def per_joint(self, topology: Topology, attribute: str) -> np.ndarray:
        """A :class:`GroupNoise` attribute for every joint, shape (J,) or (J, 2) for ranges."""
        return np.array([getattr(self.groups[g], attribute) for g in joint_groups(topology)], dtype=float)


def unit_vectors(n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 3) directions drawn uniformly on the unit sphere."""
    v = rng.standard_normal((n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def magnitudes(ranges: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """(N,) values drawn uniformly within each row's [low, high] of (N, 2) ``ranges``."""
    return rng.uniform(ranges[:, 0], ranges[:, 1])


def ar1(shape: tuple[int, ...], coefficient: float, rng: np.random.Generator,
        scale: np.ndarray | None = None) -> np.ndarray:
    """AR(1) series along axis 0: ``x[t] = a x[t-1] + sqrt(1 - a^2) s[t] e[t]``, ``x[0] = s[0] e[0]``.

    With ``scale`` None (``s = 1``) the series is stationary with unit variance; a varying ``s``
    scales the innovations, so the series' spread follows ``s`` over the time constant.

    Parameters
    ----------
    shape : tuple of int
        (T, ...) output shape.
    coefficient : float
        ``a`` in [0, 1): the lag-one correlation (``exp(-dt / tau)`` for a time constant tau).
    rng : np.random.Generator
        Source of the innovations.
    scale : np.ndarray, optional
        Innovation scale ``s``, broadcastable to ``shape``.
    """
    if not 0 <= coefficient < 1:
        raise BadInputError(f"the AR(1) coefficient must lie in [0, 1), got {coefficient}")
    e = rng.standard_normal(shape)
    if scale is not None:
        e *= scale
    e[1:] *= np.sqrt(1 - coefficient**2)
    return lfilter([1.0], [1.0, -coefficient], e, axis=0)
