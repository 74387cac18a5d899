"""``mocap-bench sensor-check``: measure the simulated sensors against the facts they model.

Six sections, each a table of checks (measured value, expected value, accepted interval, pass):

1. render-then-measure: spheres seen by an ideal depth camera land where the intrinsics say;
2. depth noise: walls at several distances and tilts, residual std against Fankhauser's sigma;
3. back-facing: the skeleton's left/right labels swap when the subject turns its back;
4. occlusion: a hand behind the back is Inferred from the front and Tracked from behind;
5. bone lengths: rigid in the truth; their spread in a single simulated Kinect against the range
   the sensor facts imply;
6. clocks: frame rate, dropped frames, timestamp jitter and offsets of the camera clocks.

Everything is drawn from one seed (split with ``SeedSequence.spawn`` per section). Expected values
come from ``reference/sensors.md`` (through the sensor models' defaults) or from closed forms.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np

from fusion.depth import Label
from fusion.errors import BadInputError
from fusion.io.atomic import atomic_directory, write_text_atomic
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, Landmark, TrackingState
from scenarios.plots import plt, save_figure
from scenarios.runner import VERSION
from sim.anthropometry import Anthropometry
from sim.clock import ClockModel, sample_clock
from sim.coordinates import COORDINATES, INDEX
from sim.depth_camera import DepthCamera, DepthNoise, sigma_axial_mm
from sim.humanoid import Humanoid, build_humanoid
from sim.motions import calibration_turn, compose, hand_lift, idle, salute
from sim.profile import Movement, Side, SubjectProfile
from sim.rig import CameraPlacement, look_at, ring_rig
from sim.scenes import Sphere, Wall, compile_scene, hand_behind_back
from sim.tracker import (
    JointGroup,
    TrackerNoise,
    TrackerTruth,
    joint_groups,
    sample_model_bias,
    track,
    visibility_over_time,
)

REPORT_NAME = "sensor_check.md"
RESULT_NAME = "sensor_check.json"
SECTION_TITLES: Mapping[str, str] = MappingProxyType({
    "projection": "Render-then-measure", "depth_noise": "Depth noise", "back_facing": "Back-facing",
    "occlusion": "Occlusion", "bone_lengths": "Bone lengths", "clocks": "Clocks",
})
"""Section key -> heading, in report order."""

_RATE_HZ = 30.0
"""Skeleton frame rate of the humanoid sessions [Hz] (Kinect v2)."""
_CAMERA = CameraPlacement("front", look_at([0.0, 0.0, 1.5], [1.0, 0.0, 1.5]))
"""Camera of the static scenes: 1.5 m above the floor, looking along world +x."""

_SPHERE_RADIUS_M = 0.1
_SPHERES = (  # name, (u, v) offset from the principal point in half image sizes, z [m] of the centre
    ("centre, 2 m", (0.0, 0.0), 2.0),
    ("top left, 2 m", (-0.8, -0.8), 2.0),
    ("top right, 2 m", (0.8, -0.8), 2.0),
    ("bottom left, 2 m", (-0.8, 0.8), 2.0),
    ("bottom right, 2 m", (0.8, 0.8), 2.0),
    ("near, 0.8 m", (-0.45, 0.3), 0.8),
    ("far, 4 m", (0.45, -0.3), 4.0),
)
_CENTROID_TOL_PX = 0.1
_NEAREST_TOL_MM = 1.0

_WALLS = ((1.0, 0.0), (2.5, 0.0), (4.0, 0.0), (2.5, 60.0), (2.5, 75.0))  # distance [m], tilt [deg]
_WALL_FRAMES = 3
_WINDOW_HALF_PX = (100, 10)  # rows, columns either side of the principal point: 201 x 21 px
_NOISE_REL_TOL = 0.15

_STILL_S = 10.0
_SWAP_PAIRS = ("shoulder", "elbow", "hip")  # landmark stems of the left/right pairs compared
_SWAP_TOL = 0.01
_HIDDEN = (Landmark.WRIST_RIGHT, Landmark.HAND_RIGHT)
_STATE_TOL = 0.05
_SUBJECT_CAMERA_M = 2.5

_TURN_S = 20.0
_RIGID_TOL_M = 1e-9
_BONES = (
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

_CLOCK_CAMERAS = 6
_CLOCK_S = 600.0
_RATE_TOL_HZ = 1e-3
_OFFSET_TOL_S = 5e-5
_JITTER_REL_TOL = 0.05


@dataclass(frozen=True, eq=False)
class Check:
    """One measured number and the interval it must lie in.

    Attributes
    ----------
    case : str
        What was set up, e.g. ``"wall 2.5 m, 60 deg"``.
    quantity : str
        What was measured.
    unit : str
        Unit of ``measured``, ``expected``, ``low`` and ``high``.
    measured : float
        The measurement.
    expected : float or None
        The value the sensor facts predict; None when they predict only the interval.
    low, high : float
        Accepted interval, inclusive.
    tolerance : str
        How the interval follows from the expected value, e.g. ``"+-15 %"``.
    extra : Mapping[str, float]
        Further numbers of the measurement, name (with unit) -> value.
    """

    case: str
    quantity: str
    unit: str
    measured: float
    expected: float | None
    low: float
    high: float
    tolerance: str
    extra: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.low <= self.high:
            raise BadInputError(f"check {self.case!r}: accepted interval [{self.low}, {self.high}] is empty")
        object.__setattr__(self, "extra", MappingProxyType({k: float(v) for k, v in self.extra.items()}))
        for name in ("measured", "low", "high"):
            object.__setattr__(self, name, float(getattr(self, name)))

    @property
    def passed(self) -> bool:
        """True when ``measured`` lies in ``[low, high]`` (NaN fails)."""
        return bool(self.low <= self.measured <= self.high)

    def to_dict(self) -> dict:
        """Plain-type dictionary for JSON."""
        d = {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self)}
        return d | {"extra": {k: _plain(v) for k, v in self.extra.items()}, "passed": self.passed}


def _plain(value: object) -> object:
    """``value`` for JSON: non-finite floats become None."""
    return None if isinstance(value, float) and not np.isfinite(value) else value


def _around(case: str, quantity: str, unit: str, measured: float, expected: float, tol: float, tolerance: str, *,
            lowest: float = -np.inf, highest: float = np.inf, **extra: float) -> Check:
    """A check accepting ``expected +- tol``, clipped to the quantity's domain ``[lowest, highest]``."""
    return Check(case, quantity, unit, measured, expected, max(expected - tol, lowest), min(expected + tol, highest),
                 tolerance, extra)


def _relative(case: str, quantity: str, unit: str, measured: float, expected: float, rel: float,
              **extra: float) -> Check:
    """A check accepting ``expected`` within a relative tolerance ``rel``."""
    return _around(case, quantity, unit, measured, expected, rel * expected, f"+-{rel:.0%}", **extra)


@dataclass(frozen=True, eq=False)
class Section:
    """One part of the sensor check.

    Attributes
    ----------
    key : str
        One of :data:`SECTION_TITLES`; also the name of the section's figure, ``<key>.png``, if it has one.
    method : str
        Markdown: the set-up, and where the expected values and tolerances come from.
    checks : tuple of Check
    arrays : Mapping[str, np.ndarray]
        The data behind the section's figure.
    """

    key: str
    method: str
    checks: tuple[Check, ...]
    arrays: Mapping[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.key not in SECTION_TITLES:
            raise BadInputError(f"unknown section {self.key!r}; the sections are {list(SECTION_TITLES)}")

    @property
    def title(self) -> str:
        """Heading."""
        return SECTION_TITLES[self.key]

    @property
    def passed(self) -> bool:
        """True when every check passed."""
        return all(c.passed for c in self.checks)


@dataclass(frozen=True, eq=False)
class SensorCheck:
    """The result of :func:`run_sensor_check`: the seed and the sections in order."""

    seed: int
    sections: tuple[Section, ...]

    @property
    def checks(self) -> tuple[Check, ...]:
        """Every check of every section."""
        return tuple(c for s in self.sections for c in s.checks)

    @property
    def passed(self) -> bool:
        """True when every check passed."""
        return all(s.passed for s in self.sections)

    def to_dict(self) -> dict:
        """Plain-type dictionary for JSON (the figures' arrays are left out)."""
        return {
            "format": "mocap-bench-sensor-check", "version": VERSION, "seed": self.seed, "passed": self.passed,
            "sections": [{"key": s.key, "title": s.title, "passed": s.passed,
                          "checks": [c.to_dict() for c in s.checks]} for s in self.sections],
        }


# --- 1. render-then-measure ------------------------------------------------------------------------


def check_projection(*, rng: np.random.Generator) -> Section:
    """Spheres at known places, rendered by an ideal camera: silhouette centroid and nearest depth.

    The centroid [px] of each sphere's BODY pixels is compared with the centre of its image ellipse
    (:meth:`sim.scenes.Sphere.image_centre`), the smallest depth [mm] with ``z_centre - radius``.
    """
    camera = DepthCamera(_CAMERA, DepthNoise.none())
    intr = _CAMERA.intrinsics
    composite = np.full((intr.height, intr.width), np.nan)
    expected_uv, measured_uv, offsets, checks = [], [], [], []
    for name, (du, dv), z in _SPHERES:
        uv_target = np.array([intr.cx + du * intr.width / 2, intr.cy + dv * intr.height / 2])
        p_cam = intr.backproject(uv_target, z)
        sphere = Sphere(_CAMERA.T_world_cam[:3, :3] @ p_cam + _CAMERA.position, _SPHERE_RADIUS_M)
        frame = camera.render(*compile_scene(sphere), rng=rng)
        v, u = np.nonzero(frame.labels == Label.BODY)
        centroid = np.array([u.mean(), v.mean()]) if u.size else np.full(2, np.nan)
        centre = sphere.image_centre(_CAMERA)
        depth_mm = frame.depth_mm[v, u].astype(float)
        nearest = depth_mm.min() if depth_mm.size else np.nan
        composite[v, u] = np.fmin(composite[v, u], depth_mm)
        expected_uv.append(centre)
        measured_uv.append(centroid)
        offsets.append(np.linalg.norm(centre - uv_target))
        checks += [
            _around(name, "silhouette centroid error", "px", np.linalg.norm(centroid - centre), 0.0, _CENTROID_TOL_PX,
                    f"<= {_CENTROID_TOL_PX} px", lowest=0.0, pixels=u.size,
                    **{"ellipse centre - projected centre [px]": offsets[-1]}),
            _around(name, "nearest depth error", "mm", abs(nearest - 1e3 * z + 1e3 * _SPHERE_RADIUS_M), 0.0,
                    _NEAREST_TOL_MM, f"<= {_NEAREST_TOL_MM} mm", lowest=0.0, **{"nearest depth [mm]": nearest}),
        ]
    method = (
        f"Spheres of radius {_SPHERE_RADIUS_M} m, one at a time, seen by an ideal camera (`DepthNoise.none()`: no "
        "noise, only millimetre rounding) 1.5 m above the floor. Each sphere's centre is put on a known pixel (the "
        "principal point, 80 % of the way to a corner, or in between for the near and far ones) at a known depth. "
        "Expected: the centroid of its BODY pixels is the centre of the sphere's image, an ellipse computed in "
        "closed form from the intrinsics (off-axis it lies outward of the projected sphere centre, here by up to "
        f"{max(offsets):.1f} px, see notes); the tolerance covers sampling the silhouette at pixel centres. The "
        "smallest depth is the centre's z minus the radius; tolerance 0.5 mm rounding plus 0.5 mm for pixel centres "
        "missing the tangent point."
    )
    return Section("projection", method, tuple(checks),
                   {"depth_mm": composite, "expected_uv": np.array(expected_uv), "measured_uv": np.array(measured_uv)})


# --- 2. depth noise --------------------------------------------------------------------------------


def check_depth_noise(*, rng: np.random.Generator, noise: DepthNoise = DepthNoise()) -> Section:
    """Walls at 1, 2.5, 4 m head-on and 2.5 m at 60 and 75 degrees: residual std vs sigma(z, theta)."""
    camera = DepthCamera(_CAMERA, noise)
    intr = _CAMERA.intrinsics
    (hr, hc), r0, c0 = _WINDOW_HALF_PX, round(intr.cy), round(intr.cx)
    window = (slice(r0 - hr, r0 + hr + 1), slice(c0 - hc, c0 + hc + 1))
    checks, rows = [], []
    for dist, tilt in _WALLS:
        wall = Wall([dist, 0.0, _CAMERA.position[2]], tilt)
        model, data = compile_scene(wall)
        z, theta = (a[window] for a in wall.depth(_CAMERA))
        frames = np.stack([camera.render(model, data, rng=rng).depth_mm[window] for _ in range(_WALL_FRAMES)])
        returned = frames > 0
        residual = frames[returned] - 1e3 * np.broadcast_to(z, frames.shape)[returned]
        sigma = sigma_axial_mm(z, theta, noise)
        expected = np.sqrt(np.mean(sigma**2) + 1 / 12)
        std = residual.std()
        checks.append(_relative(
            f"wall {dist:g} m, {tilt:g} deg", "residual depth std", "mm", std, expected, _NOISE_REL_TOL,
            **{"ratio": std / expected, "sigma(z, theta) RMS [mm]": np.sqrt(np.mean(sigma**2)),
               "mean residual [mm]": residual.mean(), "returned fraction": returned.mean()},
        ))
        rows.append((dist, tilt, np.degrees(theta.mean()), std, expected))
    method = (
        f"A flat wall (a 20 m box face) at {', '.join(f'{d:g} m / {t:g} deg' for d, t in _WALLS)} (distance along "
        f"the optical axis / incidence at the image centre), seen by the default noisy camera (lateral jitter and "
        f"flying pixels on). In a {2 * hr + 1} x {2 * hc + 1} px window at the image centre over {_WALL_FRAMES} "
        "frames, the residual is the measured depth minus the closed-form plane depth. Expected: Fankhauser's "
        "sigma(z, theta) (`sigma_axial_mm`, the values of sensors.md) per pixel, pooled as the root mean square "
        "over the window (theta varies across a tilted window). Quantisation: depths are rounded to whole "
        "millimetres, which adds an independent uniform error of variance 1/12 mm^2 (Sheppard's correction, "
        "accurate for sigma above about half the 1 mm step; here sigma >= 1.3 mm), so the expected std is "
        "sqrt(mean(sigma^2) + 1/12). Pass if the ratio measured / expected lies within 15 %."
    )
    return Section("depth_noise", method, tuple(checks), {"walls": np.array(rows)})


# --- 3 and 4. back-facing and occlusion -------------------------------------------------------------


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
        checks.append(_around(case, "frames with left/right swapped", "fraction", swapped.mean(), expected, _SWAP_TOL,
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
            checks.append(_around(
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


# --- 5. bone lengths -------------------------------------------------------------------------------


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
    for a, b, paper in _BONES:
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


# --- 6. clocks -------------------------------------------------------------------------------------


def check_clocks(*, rng: np.random.Generator, model: ClockModel = ClockModel()) -> Section:
    """Several free-running camera clocks: frame rate, drops, jitter from timestamps; offsets against truth.

    A reader's view: the period is the median timestamp step, each step is counted as a whole number
    of periods (the gaps are dropped frames), and a line fitted to timestamp versus frame number gives
    the rate and, from its residuals, the jitter. The offset to true time uses the simulator's truth.
    """
    checks, residuals = [], []
    delivered = dropped = 0
    for c in range(1, _CLOCK_CAMERAS + 1):
        clock = sample_clock(_CLOCK_S, model, rng=rng)
        ts = clock.camera_timestamps
        steps = np.rint(np.diff(ts) / np.median(np.diff(ts)))
        frame = np.concatenate([[0.0], np.cumsum(steps)])
        slope, intercept = np.polyfit(frame, ts, 1)
        residuals.append(ts - (intercept + slope * frame))
        delivered += ts.size
        dropped += int(np.sum(steps - 1))
        checks += [
            _around(f"cam{c}", "frame rate", "Hz", 1.0 / slope, model.rate_hz, _RATE_TOL_HZ, f"+-{_RATE_TOL_HZ:g} Hz"),
            _around(f"cam{c}", "offset: mean(timestamp - true time)", "ms", 1e3 * np.mean(ts - clock.true_times),
                    1e3 * clock.offset_s, 1e3 * _OFFSET_TOL_S, f"+-{1e3 * _OFFSET_TOL_S:g} ms"),
        ]
    fraction = dropped / (delivered + dropped)
    p = model.drop_probability
    se = np.sqrt(p * (1 - p) / (delivered + dropped))
    jitter = np.concatenate(residuals).std()
    checks += [
        _around(f"all {_CLOCK_CAMERAS} cameras", "dropped frames", "fraction", fraction, p, 3 * se,
                "3 binomial std errors", lowest=0.0, **{"frames delivered": delivered, "frames dropped": dropped}),
        _relative(f"all {_CLOCK_CAMERAS} cameras", "timestamp jitter std", "ms", 1e3 * jitter,
                  1e3 * model.jitter_sigma_s, _JITTER_REL_TOL),
    ]
    offsets = [c.expected for c in checks if c.quantity.startswith("offset")]
    method = (
        f"{_CLOCK_CAMERAS} cameras with the default clock model ({model.rate_hz:g} Hz, offset sd "
        f"{1e3 * model.offset_sigma_s:g} ms, jitter {1e3 * model.jitter_sigma_s:g} ms, drop probability "
        f"{model.drop_probability:g}) record {_CLOCK_S:g} s each. From the timestamps alone, as a reader would: the "
        "period is the median step; each step counts as a whole number of periods, the extra ones are dropped "
        "frames; a line through timestamp versus frame number gives the rate, its residuals the jitter. The offset "
        "to true time (the simulator's truth) is the mean of timestamp minus true capture time; expected is the "
        f"offset the clock drew (these {_CLOCK_CAMERAS}: {', '.join(f'{o:+.2f}' for o in offsets)} ms). "
        "Tolerances are far above the estimates' standard errors, except for the drop fraction (3 standard errors)."
    )
    return Section("clocks", method, tuple(checks))


# --- running and writing ---------------------------------------------------------------------------


def run_sensor_check(seed: int = 0, *, progress: Callable[[int, int, str], None] | None = None) -> SensorCheck:
    """Run every section of the sensor check.

    Parameters
    ----------
    seed : int
        Seed of everything random, >= 0; split with ``SeedSequence.spawn`` into one stream per section.
    progress : callable or None
        Called as ``progress(i, n, title)`` before section ``i`` of ``n`` (1-based) starts.

    Returns
    -------
    SensorCheck
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise BadInputError(f"seed must be an integer >= 0, got {seed!r}")
    rngs = [np.random.default_rng(s) for s in np.random.SeedSequence(int(seed)).spawn(len(SECTION_TITLES))]
    humanoid = build_humanoid(Anthropometry())
    steps: dict[str, Callable[[np.random.Generator], Section]] = {
        "projection": lambda rng: check_projection(rng=rng),
        "depth_noise": lambda rng: check_depth_noise(rng=rng),
        "back_facing": lambda rng: check_back_facing(humanoid, rng=rng),
        "occlusion": lambda rng: check_occlusion(humanoid, rng=rng),
        "bone_lengths": lambda rng: check_bone_lengths(humanoid, rng=rng),
        "clocks": lambda rng: check_clocks(rng=rng),
    }
    sections = []
    for i, ((key, title), rng) in enumerate(zip(SECTION_TITLES.items(), rngs), start=1):
        if progress is not None:
            progress(i, len(SECTION_TITLES), title)
        sections.append(steps[key](rng))
    return SensorCheck(int(seed), tuple(sections))


def _number(value: float | None) -> str:
    return "" if value is None else f"{value:.5g}"


def _rows(section: Section) -> list[list[str]]:
    """Header and one row of cells per check."""
    rows = [["case", "quantity", "measured", "expected", "accepted", "tolerance", "pass", "notes"]]
    for c in section.checks:
        notes = "; ".join(f"{k} {v:.4g}" for k, v in c.extra.items())
        rows.append([c.case, c.quantity, f"{_number(c.measured)} {c.unit}", _number(c.expected),
                     f"{_number(c.low)} - {_number(c.high)}", c.tolerance, "pass" if c.passed else "FAIL", notes])
    return rows


def format_summary(result: SensorCheck) -> str:
    """Plain-text tables of every check, one block per section, for a terminal."""
    lines = [f"sensor check, seed {result.seed}: {sum(c.passed for c in result.checks)} of {len(result.checks)} "
             f"checks pass"]
    for k, section in enumerate(result.sections, start=1):
        rows = [r[:7] for r in _rows(section)]
        widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
        lines += ["", f"{k}. {section.title}"]
        lines += ["  ".join(cell.ljust(w) for cell, w in zip(r, widths)).rstrip() for r in rows]
    return "\n".join(lines)


def format_report(result: SensorCheck, figures: Mapping[str, str]) -> str:
    """The Markdown report; ``figures`` maps a section key to its PNG file name."""
    n_pass = sum(c.passed for c in result.checks)
    lines = ["# Sensor check", "",
             f"Seed {result.seed}, mocap-bench {VERSION}. **{n_pass} of {len(result.checks)} checks pass.** "
             "The simulated sensors measured against the facts they model (`reference/sensors.md`) and closed forms.",
             "", "| section | checks | passed |", "| --- | --- | --- |"]
    lines += [f"| {k}. {s.title} | {len(s.checks)} | {sum(c.passed for c in s.checks)} |"
              for k, s in enumerate(result.sections, start=1)]
    for k, section in enumerate(result.sections, start=1):
        rows = _rows(section)
        lines += ["", f"## {k}. {section.title}", "", section.method, ""]
        lines += ["| " + " | ".join(rows[0]) + " |", "|" + " --- |" * len(rows[0])]
        lines += ["| " + " | ".join(r) + " |" for r in rows[1:]]
        if section.key in figures:
            lines += ["", f"![{section.title}]({figures[section.key]})"]
    return "\n".join(lines) + "\n"


def _plot_projection(arrays: Mapping[str, np.ndarray], path: Path) -> None:
    fig, ax = plt.subplots(figsize=(7, 6))
    im = ax.imshow(arrays["depth_mm"], cmap="viridis", interpolation="nearest")
    fig.colorbar(im, ax=ax, shrink=0.8, label="depth [mm]")
    ax.scatter(*arrays["expected_uv"].T, marker="+", s=120, color="red", label="image ellipse centre (closed form)")
    ax.scatter(*arrays["measured_uv"].T, marker="o", s=60, facecolor="none", edgecolor="white",
               label="silhouette centroid (rendered)")
    ax.set_xlim(-0.5, _CAMERA.intrinsics.width - 0.5)
    ax.set_ylim(_CAMERA.intrinsics.height - 0.5, -0.5)
    ax.set_xlabel("u [px]")
    ax.set_ylabel("v [px]")
    ax.set_title("Spheres rendered one at a time by an ideal camera (overlaid)", fontsize=10)
    ax.legend(loc="lower center", fontsize=8, facecolor="0.75")
    save_figure(fig, path)


def _plot_depth_noise(arrays: Mapping[str, np.ndarray], path: Path) -> None:
    walls = arrays["walls"]  # (distance, tilt, mean theta [deg], measured std, expected std)
    noise = DepthNoise()
    fig, (ax_z, ax_t) = plt.subplots(1, 2, figsize=(11, 4.2))
    z = np.linspace(0.5, 4.5, 200)
    theta = np.radians(np.linspace(0.0, 80.0, 200))
    for ax, x, sigma, sel, px, xlabel, title in (
        (ax_z, z, sigma_axial_mm(z, 0.0, noise), walls[:, 1] == 0, walls[:, 0], "depth z [m]", "head-on (theta = 0)"),
        (ax_t, np.degrees(theta), sigma_axial_mm(2.5, theta, noise), walls[:, 0] == 2.5, walls[:, 2],
         "incidence theta [deg]", "z = 2.5 m"),
    ):
        expected = np.sqrt(sigma**2 + 1 / 12)
        ax.plot(x, sigma, color="#90a4ae", lw=1, ls="--", label="sigma(z, theta), Fankhauser")
        ax.plot(x, expected, color="#1565c0", lw=1.5, label="with mm rounding: sqrt(sigma^2 + 1/12)")
        ax.fill_between(x, (1 - _NOISE_REL_TOL) * expected, (1 + _NOISE_REL_TOL) * expected, color="#1565c0",
                        alpha=0.12, label=f"+-{_NOISE_REL_TOL:.0%}")
        ax.scatter(px[sel], walls[sel, 3], color="#c62828", zorder=3, label="measured (wall; window mean theta)")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("depth std [mm]")
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
    ax_z.legend(fontsize=8)
    fig.suptitle("Depth noise: measured residual std against the model")
    save_figure(fig, path)


def _plot_bone_lengths(arrays: Mapping[str, np.ndarray], path: Path) -> None:
    t, sim, true = arrays["times"], arrays["simulated_m"], arrays["true_m"]
    fig, axes = plt.subplots(len(_BONES), 1, figsize=(10, 7), sharex=True)
    for ax, (a, b, _), k in zip(axes, _BONES, range(len(_BONES))):
        ax.plot(t, 100 * sim[:, k], color="#1565c0", lw=0.8, label="simulated Kinect (1 camera)")
        ax.plot(t, 100 * true[:, k], color="#c62828", lw=1.5, label="true")
        ax.set_ylabel("length [cm]")
        name = f"{KINECT_V2.joints[KINECT_V2.index(a)]}-{KINECT_V2.joints[KINECT_V2.index(b)]}"
        ax.set_title(f"{name}: std {100 * np.nanstd(sim[:, k]):.2f} cm", fontsize=9)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, loc="lower left")
    axes[-1].set_xlabel("session time [s] (salutes, then hand lifts, right arm)")
    save_figure(fig, path)


_PLOTS: Mapping[str, Callable[[Mapping[str, np.ndarray], Path], None]] = MappingProxyType({
    "projection": _plot_projection, "depth_noise": _plot_depth_noise, "bone_lengths": _plot_bone_lengths,
})


def write_sensor_check(result: SensorCheck, out_dir: str | Path) -> list[Path]:
    """Write ``sensor_check.md``, ``sensor_check.json`` and the figures (``<section key>.png``) into ``out_dir``.

    Returns the written paths, the report first.
    """
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    figures = {s.key: f"{s.key}.png" for s in result.sections if s.key in _PLOTS}
    written = [out_dir / REPORT_NAME, out_dir / RESULT_NAME]
    for section in result.sections:
        if section.key in figures:
            written.append(out_dir / figures[section.key])
            _PLOTS[section.key](section.arrays, written[-1])
    write_text_atomic(written[1], json.dumps(result.to_dict(), indent=2) + "\n")
    write_text_atomic(written[0], format_report(result, figures))
    return written


def sensor_check_to_disk(
    out_dir: str | Path, *, seed: int = 0, overwrite: bool = False,
    progress: Callable[[int, int, str], None] | None = None,
) -> tuple[SensorCheck, list[Path]]:
    """Run the sensor check and write it into ``out_dir`` atomically (see :func:`write_sensor_check`).

    Parameters
    ----------
    out_dir : the output directory; created, or replaced when ``overwrite``.
    seed : seed of every random draw, >= 0.
    overwrite : replace an existing non-empty ``out_dir``.
    progress : called as ``progress(i, n, title)`` before each section.

    Returns
    -------
    result : SensorCheck
    written : list of Path, the files in ``out_dir``, the report first.

    Raises
    ------
    BadInputError
        ``out_dir`` exists and is not empty (and ``overwrite`` is False) or is a file, checked before
        anything runs; or a bad ``seed``.
    """
    out_dir = Path(out_dir)
    with atomic_directory(out_dir, overwrite=overwrite) as tmp:
        result = run_sensor_check(seed, progress=progress)
        written = write_sensor_check(result, tmp)
    return result, [out_dir / p.name for p in written]
