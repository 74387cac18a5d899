"""Sensor-check sections of the body tracker: back-facing, occlusion and bone lengths.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, Landmark, TrackingState
from scenarios.sensors.check.check_results import Check, Section, around
from sim.coordinates import COORDINATES, INDEX
from sim.humanoid import Humanoid
from sim.motions import calibration_turn, hand_lift, idle, salute
from sim.patient_motion import Movement, Side, SubjectProfile
from sim.rig import CameraPlacement, ring_rig
from sim.scenes import hand_behind_back
from sim.timeline import compose
from sim.tracker import TrackerTruth, track
from sim.tracker_model_bias import sample_model_bias
from sim.tracker_noise import JointGroup, TrackerNoise, joint_groups
from sim.visibility import visibility_over_time

_RATE_HZ = 30.0
"""Skeleton frame rate of the humanoid sessions [Hz] (Kinect v2)."""


_STILL_S = 10.0


_SWAP_PAIRS = ("shoulder", "elbow", "hip")  # landmark stems of the left/right pairs compared


_SWAP_TOL = 0.01


_HIDDEN = (Landmark.WRIST_RIGHT, Landmark.HAND_RIGHT)


_STATE_TOL = 0.05


_SUBJECT_CAMERA_M = 2.5


_TURN_S = 20.0


_RIGID_TOL_M = 1e-9


BONES = (
    (Landmark.SPINE_SHOULDER, Landmark.SHOULDER_RIGHT, 0.009),
    (Landmark.SHOULDER_RIGHT, Landmark.ELBOW_RIGHT, 0.015),
    (Landmark.ELBOW_RIGHT, Landmark.WRIST_RIGHT, 0.025),
)
"""Bones of the spread check with the paper's spread for six merged real cameras [m]."""


_JITTER_RANGE_M = MappingProxyType({
    JointGroup.TORSO: (0.002, 0.005),
    JointGroup.LIMB: (0.002, 0.015),  # sensors.md lists none for shoulders and elbows: torso low to wrist high
    JointGroup.HAND: (0.005, 0.015),
})
"""Frame-to-frame jitter per axis [m] by joint group, from sensors.md."""


_OUTLIER_RATE_MAX = 0.05
"""Largest fraction of frames with an outlier, from sensors.md (0.5-5 %)."""


def _ring_camera(angle_deg: float) -> CameraPlacement:
    """A camera 1 m high, ``_SUBJECT_CAMERA_M`` from the origin at ``angle_deg`` from the subject's front, facing it."""
    return ring_rig(1, radius_m=_SUBJECT_CAMERA_M, angles_deg=[angle_deg]).cameras[0]


def _still(pose: np.ndarray, *, rng: np.random.Generator) -> np.ndarray:
    """(T, K) coordinates at 30 Hz for ``_STILL_S`` seconds: ``pose`` with postural sway and breathing."""
    return idle(_STILL_S, rng=rng).sample(np.arange(0.0, _STILL_S, 1.0 / _RATE_HZ)) + pose


def _observe(
    humanoid: Humanoid, coords: np.ndarray, placement: CameraPlacement, noise: TrackerNoise, *,
    rng: np.random.Generator,
) -> tuple[SkeletonStream, TrackerTruth]:
    """One camera's Kinect v2 skeleton session of ``coords`` (T, K) at 30 Hz, with occlusion."""
    qpos, joints, facing = humanoid.track(coords, KINECT_V2)
    bodies = humanoid.model.site_bodyid[humanoid.site_ids(KINECT_V2)]
    visible = visibility_over_time(humanoid, qpos, placement.position, joints, bodies)
    bias = sample_model_bias(KINECT_V2, noise, rng=rng)
    times = np.arange(len(coords)) / _RATE_HZ
    return track(joints, facing, times, placement, KINECT_V2, noise, bias, visible, rng=rng)


def swapped_frames(stream: SkeletonStream, joints_cam: np.ndarray) -> np.ndarray:
    """Frames whose reported left/right labels sit nearer the opposite side's true joints.

    Parameters
    ----------
    stream : SkeletonStream
        Reported Kinect v2 skeletons (T frames), camera frame [m].
    joints_cam : np.ndarray
        (T, J, 3) true joints [m] in the same frame, by true label.

    Returns
    -------
    np.ndarray
        (T,) bool: summed over the shoulder, elbow and hip pairs, the distance of each reported
        joint to its mirror's true position is smaller than to its own (False where one is absent).
    """
    topo = stream.topology
    own = mirrored = 0.0
    for stem in _SWAP_PAIRS:
        left, right = topo.index(Landmark(f"{stem}_left")), topo.index(Landmark(f"{stem}_right"))
        rep, true = stream.positions[:, [left, right]], joints_cam[:, [left, right]]
        own = own + np.linalg.norm(rep - true, axis=-1).sum(axis=1)
        mirrored = mirrored + np.linalg.norm(rep - true[:, ::-1], axis=-1).sum(axis=1)
    return mirrored < own


def check_back_facing(humanoid: Humanoid, *, rng: np.random.Generator, noise: TrackerNoise = TrackerNoise()) -> Section:
    """The subject facing a camera and turned away from it: fraction of frames with swapped labels."""
    camera = _ring_camera(0.0)
    checks = []
    for case, yaw, expected in (("facing the camera", 0.0, 0.0), ("back to the camera", np.pi, 1.0)):
        pose = np.zeros(len(COORDINATES))
        pose[INDEX["root_yaw"]] = yaw
        stream, truth = _observe(humanoid, _still(pose, rng=rng), camera, noise, rng=rng)
        swapped = swapped_frames(stream, truth.joints_cam)
        checks.append(around(case, "frames with left/right swapped", "fraction", swapped.mean(), expected, _SWAP_TOL,
                              f"+-{_SWAP_TOL}", lowest=0.0, highest=1.0, frames=swapped.size,
                              **{"yaw to camera [deg]": np.degrees(truth.yaw_to_camera.mean()),
                                 "flipped by the tracker (truth)": truth.flipped.mean()}))
    method = (
        f"The humanoid stands {_SUBJECT_CAMERA_M} m in front of a camera (1 m high) for {_STILL_S:g} s at 30 Hz "
        "(postural sway and breathing), facing it (root_yaw 0) and with its back to it (root_yaw pi); default "
        "tracker noise. A frame counts as swapped when the reported shoulder, elbow and hip joints lie, summed over "
        "both sides, nearer the opposite side's true joints than their own (e.g. the reported ShoulderLeft nearer "
        "the true right shoulder). Expected from sensors.md: a person seen from behind is reported as a confident "
        f"front-facing skeleton with left and right swapped (flip past about 120 deg): no frame swapped facing the "
        f"camera, every frame swapped from behind; tolerance {_SWAP_TOL:.0%} of the frames for outliers."
    )
    return Section("back_facing", method, tuple(checks))


def states_by_true_joint(stream: SkeletonStream, truth: TrackerTruth) -> np.ndarray:
    """(T, J) int8 tracking state of each true joint: a flipped frame reports joint j under its mirror label."""
    topo = stream.topology
    label = np.where(truth.flipped[:, None], topo.mirror[None, :], np.arange(topo.n_joints)[None, :])
    return np.take_along_axis(stream.states, label, axis=1)


def check_occlusion(humanoid: Humanoid, *, rng: np.random.Generator, noise: TrackerNoise = TrackerNoise()) -> Section:
    """A right hand behind the back: Inferred in a camera in front, Tracked in a camera behind."""
    coords = _still(hand_behind_back(), rng=rng)
    checks = []
    for case, angle, state in (("camera in front", 0.0, TrackingState.INFERRED),
                               ("camera behind", 180.0, TrackingState.TRACKED)):
        stream, truth = _observe(humanoid, coords, _ring_camera(angle), noise, rng=rng)
        states = states_by_true_joint(stream, truth)
        for lm in _HIDDEN:
            j = KINECT_V2.index(lm)
            checks.append(around(
                case, f"{KINECT_V2.joints[j]} {state.name.lower()}", "fraction", np.mean(states[:, j] == state), 1.0,
                _STATE_TOL, f">= {1 - _STATE_TOL:.2f}", highest=1.0,
                **{"hidden by the body (truth)": np.mean(~truth.visible[:, j]),
                   "flipped by the tracker (truth)": truth.flipped.mean()},
            ))
    method = (
        f"The humanoid stands with its right hand behind its lower back (`sim.scenes.hand_behind_back`) for "
        f"{_STILL_S:g} s with postural sway; cameras {_SUBJECT_CAMERA_M} m in front and behind, default tracker "
        "noise. States are read per true joint: seen from behind the skeleton is flipped, so the true right hand is "
        "reported under the label HandLeft. Expected from sensors.md: a joint hidden from the camera in the depth "
        f"image becomes Inferred, a visible one stays Tracked; tolerance {_STATE_TOL:.0%} of the frames for sway."
    )
    return Section("occlusion", method, tuple(checks))


def _second_moment(r: tuple[float, float]) -> float:
    """E[m^2] of m uniform on the range ``r``."""
    lo, hi = r
    return (lo * lo + lo * hi + hi * hi) / 3


def bone_spread_range(
    groups: tuple[JointGroup, JointGroup], direction_cov: np.ndarray, yaw_multiplier: float,
    noise: TrackerNoise = TrackerNoise(),
) -> tuple[float, float]:
    """Range [m] of a bone length's standard deviation over time that the sensor facts imply.

    ``low = sqrt(s_lo,a^2 + s_lo,b^2)``, jitter alone, and ``high = sqrt(k^2 (s_hi,a^2 + s_hi,b^2 +
    (b_a + b_b)^2 lambda_max) + r_max (E[m_a^2] + E[m_b^2]) / 3)``, with ``s`` the per-axis jitter
    range and ``r_max`` the largest outlier rate of sensors.md, ``b`` the largest static bias
    (``noise.groups[..].bias_m``, the sensors.md ranges), ``m`` an outlier's size (uniform on
    ``noise.groups[..].outlier_m``), ``k`` the yaw multiplier and ``lambda_max`` the largest
    eigenvalue of ``direction_cov``. The report's bone-length section gives the derivation.

    Parameters
    ----------
    groups : the joint groups of the bone's two ends (TORSO, LIMB or HAND).
    direction_cov : (3, 3) covariance over time of the bone's true unit direction.
    yaw_multiplier : error multiplier at the largest yaw to the camera, >= 1.
    noise : outlier sizes and bias ranges.

    Returns
    -------
    (low, high) : float
    """
    jitter = np.array([_JITTER_RANGE_M[g] for g in groups])
    outliers = sum(_second_moment(noise.groups[g].outlier_m) for g in groups) / 3
    bias = sum(noise.groups[g].bias_m[1] for g in groups)
    lam = np.linalg.eigvalsh(direction_cov)[-1]
    low = np.sqrt(np.sum(jitter[:, 0] ** 2))
    high = np.sqrt(yaw_multiplier**2 * (np.sum(jitter[:, 1] ** 2) + bias**2 * lam) + _OUTLIER_RATE_MAX * outliers)
    return float(low), float(high)


def check_bone_lengths(
    humanoid: Humanoid, *, rng: np.random.Generator, noise: TrackerNoise = TrackerNoise()
) -> Section:
    """True bone lengths over a session are constant; a frontal Kinect's spread lies in the implied range."""
    healthy = SubjectProfile.healthy()
    motion = compose([
        calibration_turn(_TURN_S, rng=rng),
        salute(Side.RIGHT, 3, healthy.movement(Movement.SALUTE, Side.RIGHT), rng=rng),
        hand_lift(Side.RIGHT, 3, healthy.movement(Movement.HAND_LIFT, Side.RIGHT), rng=rng),
    ])
    times = np.arange(0.0, motion.duration, 1.0 / _RATE_HZ)
    coords = motion.sample(times)
    topo = KINECT_V2
    joints = humanoid.joint_positions(coords, topo)
    bones = topo.bones
    true_lengths = np.linalg.norm(joints[:, bones[:, 0]] - joints[:, bones[:, 1]], axis=-1)
    ptp = np.ptp(true_lengths, axis=0)
    worst = int(np.argmax(ptp))
    checks = [Check("whole session (turn, salute, hand lift)", "max over bones of length max - min", "m", ptp[worst],
                    0.0, 0.0, _RIGID_TOL_M, f"<= {_RIGID_TOL_M:g} m",
                    {"bones": len(bones), "frames": len(times),
                     f"worst: {topo.joints[bones[worst, 0]]}-{topo.joints[bones[worst, 1]]} [m]": ptp[worst]})]

    facing = times >= _TURN_S
    stream, truth = _observe(humanoid, coords[facing], _ring_camera(0.0), noise, rng=rng)
    yaw_deg = np.degrees(truth.yaw_to_camera.max())
    k = float(np.interp(yaw_deg, *np.asarray(noise.yaw_multiplier).T))
    groups = joint_groups(topo)
    sim_lengths, truth_lengths = [], []
    for a, b, paper in BONES:
        i, j = topo.index(a), topo.index(b)
        length = np.linalg.norm(stream.positions[:, i] - stream.positions[:, j], axis=-1)
        u = truth.joints_cam[:, i] - truth.joints_cam[:, j]
        true_length = np.linalg.norm(u, axis=-1)
        low, high = bone_spread_range((groups[i], groups[j]), np.cov((u / true_length[:, None]).T), k, noise)
        checks.append(Check(
            f"{topo.joints[i]}-{topo.joints[j]}", "length std over time (1 camera)", "cm", 100 * np.nanstd(length),
            None, 100 * low, 100 * high, "range from sensors.md",
            {"paper, 6 merged cameras [cm]": 100 * paper, "true length [cm]": 100 * true_length.mean(),
             "frames reported": np.mean(np.isfinite(length))},
        ))
        sim_lengths.append(length)
        truth_lengths.append(true_length)
    method = (
        f"True lengths: the Kinect v2 joints of the humanoid over a {motion.duration:.1f} s session (a {_TURN_S:g} s "
        f"calibration turn, then three salutes and three hand lifts with the right arm, healthy profile) at 30 Hz; "
        f"every one of the {len(bones)} bones must keep its length. Simulated Kinect: the salutes and hand lifts "
        f"({facing.sum()} frames, largest yaw to the camera {yaw_deg:.1f} deg) seen by one camera "
        f"{_SUBJECT_CAMERA_M} m in front, default tracker noise, standard deviation over time of each reported "
        "length. Expected range (`bone_spread_range`): to first order a reported length is L + u(t).(db + dj(t) + "
        "do(t)), u the bone's unit direction and d the difference of the two ends' errors. Jitter adds "
        "s_a^2 + s_b^2 (sensors.md: torso 2-5 mm, wrists 5-15 mm per axis; shoulders and elbows are not listed, "
        "taken as 2-15 mm); outliers in 0.5-5 % of the frames, displaced by m in a random direction, add "
        "r E[m^2]/3 per end (sizes are the simulator's defaults, sensors.md gives none); a static bias (sensors.md: "
        "2-5 cm torso, 3-6 cm shoulders and elbows, 3-8 cm wrists) does not change a still bone's length over time, "
        "but as the bone turns it adds var_t(u.db) <= |db|^2 lambda_max, lambda_max the largest eigenvalue of the "
        "covariance of u(t) over the motion. Low end: the smallest jitter alone (a session may happen to have no "
        "outliers, and the two ends' biases may nearly cancel); high end: the largest jitter and bias times the "
        "yaw multiplier (1.0-1.2 facing the camera), 5 % outliers, "
        "|db| the sum of both ends' largest biases. For the arm bones much of a single camera's spread comes from the "
        "static bias turning with the arm (the forearm trace jumps between levels as the forearm turns); merging "
        "cameras averages the view-dependent part of it down (the paper's six merged cameras: 0.9 / 1.5 / 2.5 cm)."
    )
    arrays = {"times": times[facing], "simulated_m": np.stack(sim_lengths, axis=1),
              "true_m": np.stack(truth_lengths, axis=1)}
    return Section("bone_lengths", method, tuple(checks), arrays)
