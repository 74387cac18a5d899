"""Virtual skeleton tracker: Kinect v2 / K4ABT-style noisy, confidence-tagged skeletons.

The error model follows ``reference/sensors.md``. A reported joint is

    true joint (of the swapped side when flipped)
    + model bias      (the tracker's body-model error: per subject, shared by every camera, fixed in
                       the body frame, hips high and wide; with an arm bias the shoulders, elbows and
                       wrists follow the arm instead, :mod:`sim.tracker_arm_bias`, with a trunk bias the
                       spine joints the thorax, :mod:`sim.tracker_trunk_bias`)
    + view bias       (per camera and joint, fixed for the session, mostly along the viewing ray,
                       scaled with the body's yaw to the camera; optionally shared along each limb, and
                       leaning along the limb's bones)
    + inferred offset (per camera and joint, only while the joint is hidden from the camera and reported
                       at low confidence; optionally, in a share of the hidden frames reported confident
                       all the same, one drawn anew for each run of such frames)
    + jitter          (white, per frame, scaled with yaw and the joint's speed, larger while inferred)
    + wobble          (slow AR(1) error with a time constant, scaled with yaw; its innovations scale
                       with the joint's speed)
    + outliers        (bursts of a few frames, worst at the extremities)
    (jitter, wobble and outliers optionally leaning along the limb's bones)
    (view bias, jitter and wobble times a factor that grows with the session's activity, the mean
     joint speed, within the range of activities it was fitted on: a tracker errs more in a busier session;
     optionally the jitter and wobble of each joint group by a factor of its own)
    -> bone lengths held toward their session median (bone rigidity, per sensor: a tracker with a
       fixed-length body model moves a glitching joint along its bone, not off it; optionally toward the
       person's own lengths, the same in every camera), then all of them times the frame's body scale by
       the smallest displacement (a template tracker, :mod:`sim.tracker_bones`) and, optionally, by a
       factor of the camera's own
    -> optionally the trunk joints turned about the pelvis by a small rotation drawn per camera session
       (:mod:`sim.tracker_trunk_turn`)

in the world frame, expressed in the camera frame at the end. Seen from behind (yaw to the camera past
a threshold, with hysteresis) the tracker returns a confident front-facing skeleton: the left labels
sit on the true right joints and vice versa. Joints hidden from the camera are Inferred (a share of
the hidden frames per joint group, in runs), and so is a share of the visible ones (in runs), as
real trackers report low confidence for hands they see; joints outside
the field of view or the depth range are NotTracked (NaN), and so is the whole skeleton when too little
of the body is in view.

Body frame of the model bias: x forward (the facing direction), y to the subject's left, z up.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr

from fusion.errors import BadInputError
from fusion.merge.body_scale import stretch_bones
from fusion.merge.limb_sharing import limb_links
from fusion.skeleton import SkeletonStream
from fusion.topology import Landmark, Topology, TrackingState
from fusion.transforms import apply, invert
from sim.rig import CameraPlacement
from sim.tracker_arm_bias import arm_offsets
from sim.tracker_axes import bone_aligned
from sim.tracker_bones import body_scale, hold_bone_lengths
from sim.tracker_draws import (
    chain_ordered,
    outlier_bursts,
    run_vectors,
    session_vectors,
)
from sim.tracker_model_bias import TrackerModelBias
from sim.tracker_noise import TrackerNoise, ar1, magnitudes
from sim.tracker_trunk_bias import trunk_offsets
from sim.tracker_trunk_turn import turn_trunk
from sim.visibility import yaw_to_camera


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
    view_rng: np.random.Generator | None = None,
    shared_scale: np.ndarray | None = None,
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
        Source of the inferred offsets, jitter and outliers (and of the view bias without ``view_rng``).
    view_rng : np.random.Generator or None
        Source of the per-camera view bias: the person's stream for this camera
        (:func:`sim.sensor_population.person_streams`), so that sessions of one person keep it.
    shared_scale : np.ndarray or None
        (T,) the session's shared body-scale process (:func:`sim.tracker_bones.session_waves`) at the
        frames' true times; None: this camera draws its own (with a body scale in ``noise``).

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
    a = float(np.exp(-np.median(np.diff(ts)) / noise.wobble_tau_s)) if T > 1 else 0.0
    hidden = reported & ~vis[rows, src]
    inferred = hidden
    hidden_share = noise.per_joint(topology, "hidden_low_confidence")
    if np.any(hidden_share < 1):
        inferred = hidden & (ndtr(ar1((T, J), a, rng)) < hidden_share[None, :])
    confident_guess = None  # hidden, reported confident, yet guessed: drawn only with a share (else as before)
    if noise.hidden_offset_share > 0:
        confident_guess = hidden & ~inferred & (ndtr(ar1((T, J), a, rng)) < noise.hidden_offset_share)
    P_lab = P[rows, src]
    gain = speed_gain(P_lab, ts, noise.speed_ref_m_s)

    k = np.interp(np.where(flipped, 180.0 - yaw_deg, yaw_deg), *np.asarray(noise.yaw_multiplier).T)
    mk = activity_factor(P, ts, noise) * k  # what scales the view bias, jitter and wobble
    f = noise.model_fraction

    # flipped: believed to face the camera
    model_world = k[:, None, None] * _body_to_world(model_bias.offsets_body, yaw + np.pi * flipped)
    if model_bias.arm_coefficients is not None:
        arm_k = k[:, None, None] if noise.arm_bias is not None and noise.arm_bias.yaw_scaled else 1.0
        model_world = model_world + arm_k * arm_offsets(P_lab, topology, model_bias.arm_coefficients)
    if model_bias.trunk_coefficients is not None:  # not yaw-scaled either: measured facing the camera
        model_world = model_world + trunk_offsets(P_lab, topology, model_bias.trunk_coefficients)

    bias_ranges = np.sqrt(1 - f) * noise.per_joint(topology, "bias_m")
    links = limb_links(topology)
    view = session_vectors(bias_ranges, noise.lateral_ratio, noise.toward_camera_fraction, view_rng or rng,
                            chain_ordered(links, topology), noise.view_limb_correlation)
    size = np.exp(noise.camera_scale_sd * (view_rng or rng).standard_normal()) if noise.camera_scale_sd > 0 else 1.0
    guess = session_vectors(np.tile(noise.inferred_offset_m, (J, 1)), 1.0, 0.5, rng)
    coeff = mk[:, None, None] * view + np.where(inferred[..., None], guess, 0.0)
    if confident_guess is not None:  # guessed anew each time the joint is lost
        coeff = coeff + run_vectors(confident_guess, noise.inferred_offset_m, rng)
    u, e1, e2 = _ray_frame(P_lab - placement.position)
    view_world = bone_aligned(coeff[..., 0:1] * u + coeff[..., 1:2] * e1 + coeff[..., 2:3] * e2, P_lab, links,
                              noise.view_bone_alignment)

    own = activity_factor(P, ts, noise, noise.per_joint(topology, "activity_exponent"))  # the groups' own growth
    sigma = noise.per_joint(topology, "jitter_m")[None, :] * own * mk[:, None] * gain
    sigma = np.where(inferred, noise.inferred_jitter_scale * sigma, sigma)
    jitter = bone_aligned(sigma[..., None] * rng.standard_normal((T, J, 3)), P_lab, links, noise.noise_bone_alignment)
    outliers, outlier_offsets = outlier_bursts(
        noise.per_joint(topology, "outlier_rate"), noise.per_joint(topology, "outlier_m"), T,
        noise.outlier_mean_frames, rng,
    )

    measured_world = P_lab + model_world + view_world + jitter
    wobble = noise.per_joint(topology, "wobble_m")
    if np.any(wobble > 0):
        slow = (mk[:, None] * (own * wobble)[None, :])[..., None] * ar1((T, J, 3), a, rng, scale=gain[..., None])
        measured_world = measured_world + bone_aligned(slow, P_lab, links, noise.noise_bone_alignment)
    measured_world = measured_world + bone_aligned(outlier_offsets, P_lab, links, noise.noise_bone_alignment)
    rigidity = noise.per_joint(topology, "bone_rigidity")
    if np.any(rigidity > 0):
        measured_world = hold_bone_lengths(measured_world, reported, topology, rigidity,
                                           truth=P_lab, shared=noise.shared_bone_lengths)
    low_range = noise.per_joint(topology, "low_confidence")
    if np.any(low_range[:, 1] > 0):
        share = magnitudes(low_range, rng)
        inferred = inferred | (reported & (ndtr(ar1((T, J), a, rng)) < share[None, :]))
    if noise.body_scale_sd > 0:  # drawn last: a tracker without one draws the same as before
        measured_world = stretch_bones(measured_world, topology, size * body_scale(ts, noise, shared_scale, rng))
    elif size != 1.0:
        measured_world = stretch_bones(measured_world, topology, np.full(len(ts), size))
    if noise.trunk_turn_sd_deg > 0:  # drawn after all else: a tracker without one draws the same as before
        turn = np.radians(noise.trunk_turn_sd_deg) * rng.standard_normal(3)
        measured_world = turn_trunk(measured_world, topology, turn)
    positions = np.where(reported[..., None], apply(T_cam_world, measured_world), np.nan)
    states = np.where(inferred, TrackingState.INFERRED, TrackingState.TRACKED)
    states = np.where(reported, states, TrackingState.NOT_TRACKED).astype(np.int8)
    stream = SkeletonStream(topology, ts, positions, states)
    truth = TrackerTruth(yaw_rad, flipped, body_tracked, in_view, vis, outliers & reported, joints_cam)
    return stream, truth


def speed_gain(joints: np.ndarray, timestamps: np.ndarray, speed_ref_m_s: float) -> np.ndarray:
    """(T, J) error factor ``1 + |v| / speed_ref`` of joints (T, J, 3) [m] at ``timestamps`` (T,) [s]; ones when
    ``speed_ref_m_s`` is 0 or there is a single frame."""
    if speed_ref_m_s <= 0 or joints.shape[0] < 2:
        return np.ones(joints.shape[:2])
    speed = np.linalg.norm(np.gradient(joints, timestamps, axis=0), axis=-1)
    return 1.0 + speed / speed_ref_m_s


def session_activity(joints: np.ndarray, timestamps: np.ndarray) -> float:
    """A session's activity [m/s]: the mean speed of the joints (T, J, 3) [m] at ``timestamps`` (T,) [s]
    over frames and joints; 0 for fewer than two frames."""
    if joints.shape[0] < 2:
        return 0.0
    return float(np.nanmean(np.linalg.norm(np.gradient(joints, timestamps, axis=0), axis=-1)))


def activity_factor(joints: np.ndarray, timestamps: np.ndarray, noise: TrackerNoise, exponent: float | None = None
                    ) -> float | np.ndarray:
    """Error factor ``(A / activity_ref) ** exponent`` of a camera session with true joints (T, J, 3) [m] at
    ``timestamps`` (T,) [s], ``A`` its :func:`session_activity` clipped to ``activity_range_m_s``; ``exponent``
    the tracker's ``activity_exponent`` unless given (one per joint gives one factor per joint)."""
    exponent = noise.activity_exponent if exponent is None else exponent
    if np.all(np.asarray(exponent) == 0):
        return 1.0
    ratio = float(np.clip(session_activity(joints, timestamps), *noise.activity_range_m_s)) / noise.activity_ref_m_s
    return float(ratio ** float(exponent)) if np.ndim(exponent) == 0 else ratio ** np.asarray(exponent, dtype=float)


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
