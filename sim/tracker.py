"""Virtual skeleton tracker: Kinect v2 / K4ABT-style noisy, confidence-tagged skeletons.

The error model follows ``reference/sensors.md``. A reported joint is

    true joint (of the swapped side when flipped)
    + model bias      (the tracker's body-model error: per subject, shared by every camera, fixed in
                       the body frame, hips high and wide)
    + view bias       (per camera and joint, fixed for the session, mostly along the viewing ray,
                       scaled with the body's yaw to the camera)
    + inferred offset (per camera and joint, only while the joint is hidden from the camera)
    + jitter          (white, per frame, scaled with yaw, larger while inferred)
    + outliers        (bursts of a few frames, worst at the extremities)

in the world frame, expressed in the camera frame at the end. Seen from behind (yaw to the camera past
a threshold, with hysteresis) the tracker returns a confident front-facing skeleton: the left labels
sit on the true right joints and vice versa. Joints hidden from the camera are Inferred; joints outside
the field of view or the depth range are NotTracked (NaN), and so is the whole skeleton when too little
of the body is in view.

Body frame of the model bias: x forward (the facing direction), y to the subject's left, z up.
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from types import MappingProxyType

import mujoco
import numpy as np

from fusion.errors import BadInputError
from fusion.skeleton import SkeletonStream
from fusion.topology import Landmark, Topology, TrackingState
from fusion.transforms import apply, invert
from sim.humanoid import BODY_GEOM_GROUP, Humanoid
from sim.raycast import RayBatchCaster, cast_rays
from sim.rig import CameraPlacement


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
    """

    bias_m: tuple[float, float]
    jitter_m: float
    outlier_rate: float
    outlier_m: tuple[float, float]

    def __post_init__(self) -> None:
        _check_range("bias_m", self.bias_m)
        _check_range("outlier_m", self.outlier_m)
        if not np.isfinite(self.jitter_m) or self.jitter_m < 0:
            raise BadInputError(f"jitter_m must be finite and >= 0, got {self.jitter_m}")
        if not 0 <= self.outlier_rate < 1:
            raise BadInputError(f"outlier_rate must lie in [0, 1), got {self.outlier_rate}")


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

    def __post_init__(self) -> None:
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
        if not 0 < self.min_fraction_in_view <= 1:
            raise BadInputError(f"min_fraction_in_view must lie in (0, 1], got {self.min_fraction_in_view}")

    @classmethod
    def none(cls) -> "TrackerNoise":
        """An ideal tracker: no bias, jitter, outliers or inferred error, and no flip."""
        return cls(
            groups={g: _QUIET for g in JointGroup}, hip_up_m=0.0, hip_out_m=0.0,
            inferred_offset_m=(0.0, 0.0), flip_enabled=False,
        )

    def per_joint(self, topology: Topology, attribute: str) -> np.ndarray:
        """A :class:`GroupNoise` attribute for every joint, shape (J,) or (J, 2) for ranges."""
        return np.array([getattr(self.groups[g], attribute) for g in joint_groups(topology)], dtype=float)


@dataclass(frozen=True, eq=False)
class TrackerModelBias:
    """The tracker's body-model error for one subject, shared by every camera.

    Attributes
    ----------
    topology : Topology
        Joint set (J joints).
    offsets_body : np.ndarray
        (J, 3) float64 [m] per-joint offset in the body frame (x forward, y left, z up).
    """

    topology: Topology
    offsets_body: np.ndarray

    def __post_init__(self) -> None:
        if not isinstance(self.topology, Topology):
            raise BadInputError(f"topology must be a Topology, got {type(self.topology).__name__}")
        off = np.array(self.offsets_body, dtype=np.float64)
        if off.shape != (self.topology.n_joints, 3) or not np.all(np.isfinite(off)):
            raise BadInputError(f"offsets_body must be finite, shape ({self.topology.n_joints}, 3); got {off.shape}")
        off.setflags(write=False)
        object.__setattr__(self, "offsets_body", off)


def _unit_vectors(n: int, rng: np.random.Generator) -> np.ndarray:
    v = rng.standard_normal((n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _magnitudes(ranges: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    return rng.uniform(ranges[:, 0], ranges[:, 1])


def sample_model_bias(topology: Topology, noise: TrackerNoise, *, rng: np.random.Generator) -> TrackerModelBias:
    """Draw the body-model bias of one subject.

    Each joint gets a random direction with magnitude ``sqrt(model_fraction) * U(bias_m)``; the hips
    add the systematic ``hip_up_m`` up and ``hip_out_m`` outward.

    Parameters
    ----------
    topology : Topology
        Joint set (J joints).
    noise : TrackerNoise
        Error parameters.
    rng : np.random.Generator
        Source of the draws.

    Returns
    -------
    TrackerModelBias
        Offsets (J, 3) [m] in the body frame.
    """
    J = topology.n_joints
    mags = np.sqrt(noise.model_fraction) * _magnitudes(noise.per_joint(topology, "bias_m"), rng)
    offsets = mags[:, None] * _unit_vectors(J, rng)
    hips = np.array([g is JointGroup.HIP for g in joint_groups(topology)])
    side = np.zeros(J)
    side[topology.lr_pairs[:, 0]], side[topology.lr_pairs[:, 1]] = 1.0, -1.0
    offsets[:, 1] += hips * side * noise.hip_out_m
    offsets[:, 2] += hips * noise.hip_up_m
    return TrackerModelBias(topology, offsets)


@dataclass(frozen=True, eq=False)
class TrackerTruth:
    """What the tracker really did, per frame of one camera (never part of the observation).

    Attributes
    ----------
    yaw_to_camera : np.ndarray
        (T,) float64 [rad] in [0, pi]: angle between the body's facing direction and the horizontal
        direction from the pelvis to the camera (0 = facing the camera).
    flipped : np.ndarray
        (T,) bool, the skeleton was reported left/right swapped.
    body_tracked : np.ndarray
        (T,) bool, enough of the body was in view for a skeleton.
    in_view : np.ndarray
        (T, J) bool per true joint: inside the image and the depth range.
    visible : np.ndarray
        (T, J) bool per true joint: in the camera's line of sight (the visibility used).
    outliers : np.ndarray
        (T, J) bool per reported joint label: an outlier displacement was applied.
    joints_cam : np.ndarray
        (T, J, 3) float64 [m] true joints in the camera frame, by true label.
    """

    yaw_to_camera: np.ndarray
    flipped: np.ndarray
    body_tracked: np.ndarray
    in_view: np.ndarray
    visible: np.ndarray
    outliers: np.ndarray
    joints_cam: np.ndarray

    def __post_init__(self) -> None:
        T = np.shape(self.yaw_to_camera)[0]
        J = np.shape(self.in_view)[1] if np.ndim(self.in_view) == 2 else -1
        expected = {
            "yaw_to_camera": (T,), "flipped": (T,), "body_tracked": (T,), "in_view": (T, J),
            "visible": (T, J), "outliers": (T, J), "joints_cam": (T, J, 3),
        }
        for name, shape in expected.items():
            arr = np.array(getattr(self, name))
            if arr.shape != shape:
                raise BadInputError(f"tracker truth {name} must have shape {shape}, got {arr.shape}")
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)


def yaw_to_camera(root_world: np.ndarray, facing_yaw: np.ndarray, camera_position: np.ndarray) -> np.ndarray:
    """Unsigned horizontal angle [rad] (T,) between the facing direction and the body-to-camera direction.

    Parameters
    ----------
    root_world : np.ndarray
        (T, 3) [m] pelvis positions in the world frame.
    facing_yaw : np.ndarray
        (T,) [rad] facing direction, counter-clockwise from world +x.
    camera_position : np.ndarray
        (3,) [m] camera centre in the world frame.
    """
    to_cam = np.asarray(camera_position, dtype=float)[:2] - np.asarray(root_world, dtype=float)[:, :2]
    fx, fy = np.cos(facing_yaw), np.sin(facing_yaw)
    return np.abs(np.arctan2(fx * to_cam[:, 1] - fy * to_cam[:, 0], fx * to_cam[:, 0] + fy * to_cam[:, 1]))


_BODY_GROUP_MASK = tuple(g == BODY_GEOM_GROUP for g in range(6))


def joint_visibility(
    model: mujoco.MjModel,
    data: mujoco.MjData,
    cam_position_world: np.ndarray,
    joints_world: np.ndarray,
    joint_body_ids: np.ndarray,
    *,
    parent_of_body: np.ndarray | None = None,
) -> np.ndarray:
    """Which joints each camera sees directly, by casting a ray from the camera to each joint.

    A joint is visible when its ray hits no body geom before the joint, or when the first geom hit
    belongs to the joint's own body or a neighbour: its parent, a child or a sibling (same parent).
    Joints sit inside the surface of the segments that meet there, so that surface hides nothing;
    siblings count because junction joints (the neck base, between the clavicles) lie behind them.

    Parameters
    ----------
    model, data : mujoco.MjModel, mujoco.MjData
        The posed humanoid (``data`` after ``mj_kinematics``, e.g. ``Humanoid.set_pose``).
    cam_position_world : np.ndarray
        (3,) [m] camera centre in the world frame, or (C, 3) for several cameras at once (faster).
    joints_world : np.ndarray
        (J, 3) [m] joint positions in the world frame.
    joint_body_ids : np.ndarray
        (J,) int MuJoCo body of each joint (``model.site_bodyid`` of its site).
    parent_of_body : np.ndarray or None
        (nbody,) int parent body of each body; None uses ``model.body_parentid``.

    Returns
    -------
    np.ndarray
        (J,) bool, or (C, J) for several cameras: True where the camera sees the joint.
    """
    cams = np.asarray(cam_position_world, dtype=float)
    joints = np.asarray(joints_world, dtype=float)
    bodies = np.asarray(joint_body_ids)
    parents = np.asarray(model.body_parentid if parent_of_body is None else parent_of_body)
    if cams.shape[-1:] != (3,) or cams.ndim > 2:
        raise BadInputError(f"cam_position_world must have shape (3,) or (C, 3), got {cams.shape}")
    if joints.ndim != 2 or joints.shape[1] != 3 or bodies.shape != joints.shape[:1]:
        raise BadInputError(f"need joints_world (J, 3) and joint_body_ids (J,), got {joints.shape} and {bodies.shape}")
    if parents.shape != (model.nbody,) or np.any((bodies < 0) | (bodies >= model.nbody)):
        raise BadInputError(f"parent_of_body must have shape ({model.nbody},) and body ids lie in [0, {model.nbody})")
    rays = joints - cams[..., None, :]
    dist = np.linalg.norm(rays, axis=-1)
    if not np.all(np.isfinite(dist)) or np.any(dist < 1e-9):
        raise BadInputError("joints and cameras must be finite and distinct")
    dirs = (rays / dist[..., None]).reshape(-1, joints.shape[0], 3)
    flat_cams, flat_dist = cams.reshape(-1, 3), dist.reshape(dirs.shape[:2])
    hit_geom = np.empty(dirs.shape[:2], dtype=int)
    hit_dist = np.empty(dirs.shape[:2])
    for c, (cam, d) in enumerate(zip(flat_cams, flat_dist)):
        hits = cast_rays(model, data, cam, dirs[c], geomgroup=_BODY_GROUP_MASK, cutoff_m=float(d.max()))
        hit_geom[c], hit_dist[c] = hits.geom_id, hits.dist
    return _unoccluded(model, parents, bodies, hit_geom, hit_dist, flat_dist).reshape(dist.shape)


def _unoccluded(
    model: mujoco.MjModel, parents: np.ndarray, bodies: np.ndarray, hit_geom: np.ndarray, hit_dist: np.ndarray,
    joint_dist: np.ndarray,
) -> np.ndarray:
    """(..., J) bool: nothing hit before the joint, or the first hit is on the joint's body or a neighbour."""
    hit_body = np.where(hit_geom >= 0, model.geom_bodyid[np.maximum(hit_geom, 0)], -1)
    hit_parent = parents[np.maximum(hit_body, 0)]
    neighbour = (hit_body == bodies) | (hit_body == parents[bodies]) | (hit_parent == bodies) | (
        (hit_parent == parents[bodies]) & (hit_body > 0)
    )
    return (hit_geom < 0) | (hit_dist >= joint_dist) | neighbour


def visibility_over_time(
    humanoid: Humanoid, qpos: np.ndarray, cam_position_world: np.ndarray, joints_world: np.ndarray,
    joint_body_ids: np.ndarray,
) -> np.ndarray:
    """:func:`joint_visibility` for every frame of a motion seen by one camera, (T, J) bool.

    Parameters
    ----------
    humanoid : the subject; its ``data`` is posed frame by frame.
    qpos : (T, nq) generalised positions (``humanoid.qpos(coords)``).
    cam_position_world : (3,) [m] camera centre.
    joints_world : (T, J, 3) [m] joint positions at those frames.
    joint_body_ids : (J,) int body of each joint.
    """
    cam = np.ascontiguousarray(cam_position_world, dtype=np.float64)
    joints = np.asarray(joints_world, dtype=float)
    if qpos.shape[0] != joints.shape[0] or cam.shape != (3,):
        raise BadInputError(f"need qpos (T, nq), a (3,) camera and joints (T, J, 3); got {qpos.shape}, "
                            f"{cam.shape}, {joints.shape}")
    rays = joints - cam
    dist = np.linalg.norm(rays, axis=-1)
    if not np.all(np.isfinite(dist)) or np.any(dist < 1e-9):
        raise BadInputError("joints and camera must be finite and distinct")
    dirs = np.ascontiguousarray(rays / dist[..., None])
    caster = RayBatchCaster(humanoid.model, joints.shape[1], geomgroup=_BODY_GROUP_MASK)
    hit_geom = np.empty(dist.shape, dtype=np.int32)
    hit_dist = np.empty(dist.shape)
    for t in range(qpos.shape[0]):
        humanoid.set_qpos(qpos[t])
        hit_geom[t], hit_dist[t] = caster.cast(humanoid.data, cam, dirs[t], float(dist[t].max()))
    bodies = np.asarray(joint_body_ids)
    return _unoccluded(humanoid.model, humanoid.model.body_parentid, bodies, hit_geom, hit_dist, dist)


def _flip_states(yaw_deg: np.ndarray, body_tracked: np.ndarray, noise: TrackerNoise) -> np.ndarray:
    flipped = np.zeros(yaw_deg.shape[0], dtype=bool)
    if not noise.flip_enabled:
        return flipped
    enter = noise.flip_threshold_deg + noise.flip_band_deg / 2
    leave = noise.flip_threshold_deg - noise.flip_band_deg / 2
    state: bool | None = None
    for t, (yaw, tracked) in enumerate(zip(yaw_deg, body_tracked)):
        if not tracked:
            state = None
            continue
        if state is None:
            state = bool(yaw > noise.flip_threshold_deg)
        else:
            state = bool(yaw >= leave) if state else bool(yaw > enter)
        flipped[t] = state
    return flipped


def _body_to_world(v_body: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Vectors (J, 3) of the body frame turned by ``yaw`` (T,) [rad] about world z: (T, J, 3)."""
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    z = np.broadcast_to(v_body[:, 2], c.shape[:1] + v_body.shape[:1])
    return np.stack([c * v_body[:, 0] - s * v_body[:, 1], s * v_body[:, 0] + c * v_body[:, 1], z], axis=-1)


def _ray_frame(rays: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit ray ``u`` and two unit lateral axes (horizontal ``e1``, then ``e2 = u x e1``), each (..., 3)."""
    u = rays / np.linalg.norm(rays, axis=-1, keepdims=True)
    e1 = np.stack([-u[..., 1], u[..., 0], np.zeros(u.shape[:-1])], axis=-1)  # world z x u
    n = np.linalg.norm(e1, axis=-1, keepdims=True)
    e1 = np.where(n > 1e-9, e1 / np.where(n > 1e-9, n, 1.0), [1.0, 0.0, 0.0])
    return u, e1, np.cross(u, e1)


def _session_vectors(
    ranges: np.ndarray, lateral_ratio: float, toward: float, rng: np.random.Generator
) -> np.ndarray:
    """(J, 3) coefficients in the (ray, e1, e2) frame: magnitude U(range), mostly along the ray,
    pointing back toward the camera with probability ``toward``."""
    J = ranges.shape[0]
    along = np.where(rng.random(J) < toward, -1.0, 1.0)
    direction = np.column_stack([along, lateral_ratio * rng.standard_normal((J, 2))])
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    return _magnitudes(ranges, rng)[:, None] * direction


def _outlier_bursts(
    rate: np.ndarray, sizes: np.ndarray, T: int, mean_frames: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Active mask (T, J) and displacement (T, J, 3) [m] of outlier bursts; a new burst replaces a running one."""
    J = rate.shape[0]
    starts = rng.random((T, J)) < rate / mean_frames
    t_idx, j_idx = np.nonzero(starts)
    end = np.full((T, J), -1)
    end[t_idx, j_idx] = t_idx + rng.geometric(1.0 / mean_frames, t_idx.size)
    offset = np.zeros((T, J, 3))
    offset[t_idx, j_idx] = _magnitudes(sizes[j_idx], rng)[:, None] * _unit_vectors(t_idx.size, rng)
    frames = np.arange(T)[:, None]
    last = np.maximum.accumulate(np.where(starts, frames, -1), axis=0)
    cols = np.arange(J)[None, :]
    safe = np.maximum(last, 0)
    active = (last >= 0) & (frames < end[safe, cols])
    return active, np.where(active[..., None], offset[safe, cols], 0.0)


def track(
    joints_world: np.ndarray,
    facing_yaw: np.ndarray,
    timestamps: np.ndarray,
    placement: CameraPlacement,
    topology: Topology,
    noise: TrackerNoise,
    model_bias: TrackerModelBias,
    visibility: np.ndarray | None = None,
    *,
    rng: np.random.Generator,
) -> tuple[SkeletonStream, TrackerTruth]:
    """Skeletons one camera's body tracker reports for a whole session.

    One call is one camera session: the view bias and inferred offsets are drawn once per call.

    Parameters
    ----------
    joints_world : np.ndarray
        (T, J, 3) [m] true joint positions in the world frame at each frame's capture time.
    facing_yaw : np.ndarray
        (T,) [rad] facing direction of the body, counter-clockwise from world +x.
    timestamps : np.ndarray
        (T,) [s] the camera's timestamps of those frames, strictly increasing.
    placement : CameraPlacement
        True camera pose and intrinsics (which define the camera frame and the field of view).
    topology : Topology
        Joint set (J joints).
    noise : TrackerNoise
        Error parameters.
    model_bias : TrackerModelBias
        The subject's body-model bias, the same for every camera.
    visibility : np.ndarray or None
        (T, J) bool per true joint: in the camera's line of sight (see :func:`joint_visibility`);
        hidden joints are Inferred. None treats every joint as visible.
    rng : np.random.Generator
        Source of the per-camera view bias, inferred offsets, jitter and outliers.

    Returns
    -------
    stream : SkeletonStream
        Reported joints in the camera frame with ``timestamps``; states Tracked (2), Inferred (1),
        NotTracked (0, NaN position).
    truth : TrackerTruth
        Yaw to the camera, flip state, visibility and outliers per frame.
    """
    P, yaw, ts, vis = _validated(joints_world, facing_yaw, timestamps, topology, model_bias, visibility)
    T, J = P.shape[:2]
    intr = placement.intrinsics
    T_cam_world = invert(placement.T_world_cam)

    yaw_rad = yaw_to_camera(P[:, topology.index(Landmark.PELVIS)], yaw, placement.position)
    yaw_deg = np.degrees(yaw_rad)
    joints_cam = apply(T_cam_world, P)
    uv, z = intr.project(joints_cam)
    in_view = intr.in_image(uv) & (z >= intr.min_depth_m) & (z <= intr.max_depth_m)
    body_tracked = in_view.mean(axis=1) >= noise.min_fraction_in_view
    flipped = _flip_states(yaw_deg, body_tracked, noise)

    rows = np.arange(T)[:, None]
    src = np.where(flipped[:, None], topology.mirror[None, :], np.arange(J)[None, :])
    reported = body_tracked[:, None] & in_view[rows, src]
    inferred = reported & ~vis[rows, src]
    P_lab = P[rows, src]

    k = np.interp(np.where(flipped, 180.0 - yaw_deg, yaw_deg), *np.asarray(noise.yaw_multiplier).T)
    f = noise.model_fraction

    # flipped: believed to face the camera
    model_world = k[:, None, None] * _body_to_world(model_bias.offsets_body, yaw + np.pi * flipped)

    bias_ranges = np.sqrt(1 - f) * noise.per_joint(topology, "bias_m")
    view = _session_vectors(bias_ranges, noise.lateral_ratio, noise.toward_camera_fraction, rng)
    guess = _session_vectors(np.tile(noise.inferred_offset_m, (J, 1)), 1.0, 0.5, rng)
    coeff = k[:, None, None] * view + np.where(inferred[..., None], guess, 0.0)
    u, e1, e2 = _ray_frame(P_lab - placement.position)
    view_world = coeff[..., 0:1] * u + coeff[..., 1:2] * e1 + coeff[..., 2:3] * e2

    sigma = noise.per_joint(topology, "jitter_m")[None, :] * k[:, None]
    sigma = np.where(inferred, noise.inferred_jitter_scale * sigma, sigma)
    jitter = sigma[..., None] * rng.standard_normal((T, J, 3))
    outliers, outlier_offsets = _outlier_bursts(
        noise.per_joint(topology, "outlier_rate"), noise.per_joint(topology, "outlier_m"), T,
        noise.outlier_mean_frames, rng,
    )

    measured_world = P_lab + model_world + view_world + jitter + outlier_offsets
    positions = np.where(reported[..., None], apply(T_cam_world, measured_world), np.nan)
    states = np.where(inferred, TrackingState.INFERRED, TrackingState.TRACKED)
    states = np.where(reported, states, TrackingState.NOT_TRACKED).astype(np.int8)
    stream = SkeletonStream(topology, ts, positions, states)
    truth = TrackerTruth(yaw_rad, flipped, body_tracked, in_view, vis, outliers & reported, joints_cam)
    return stream, truth


def _validated(
    joints_world: np.ndarray,
    facing_yaw: np.ndarray,
    timestamps: np.ndarray,
    topology: Topology,
    model_bias: TrackerModelBias,
    visibility: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    P = np.asarray(joints_world, dtype=float)
    J = topology.n_joints
    if P.ndim != 3 or P.shape[1:] != (J, 3):
        raise BadInputError(f"joints_world must have shape (T, {J}, 3) for {topology.name}, got {P.shape}")
    T = P.shape[0]
    if not np.all(np.isfinite(P)):
        raise BadInputError("joints_world must be finite (true joints are never missing)")
    yaw = np.asarray(facing_yaw, dtype=float)
    ts = np.asarray(timestamps, dtype=float)
    for name, arr in (("facing_yaw", yaw), ("timestamps", ts)):
        if arr.shape != (T,) or not np.all(np.isfinite(arr)):
            raise BadInputError(f"{name} must be finite with shape ({T},), got {arr.shape}")
    if np.any(np.diff(ts) <= 0):
        raise BadInputError("timestamps must be strictly increasing")
    if model_bias.topology != topology:
        raise BadInputError(f"model_bias is for {model_bias.topology.name}, the tracker for {topology.name}")
    if visibility is None:
        return P, yaw, ts, np.ones((T, J), dtype=bool)
    vis = np.asarray(visibility)
    if vis.shape != (T, J) or vis.dtype != bool:
        raise BadInputError(f"visibility must be a bool array of shape ({T}, {J}), got {vis.dtype} {vis.shape}")
    return P, yaw, ts, vis
