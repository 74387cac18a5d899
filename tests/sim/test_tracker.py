"""Virtual skeleton tracker: exactness when ideal, flips, states, noise statistics, determinism."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fusion.errors import BadInputError
from fusion.skeleton import SkeletonStream
from fusion.topology import K4ABT, KINECT_V2, Landmark, Topology, TrackingState
from fusion.transforms import apply, invert
from sim.anthropometry import Anthropometry
from sim.coordinates import COORDINATES
from sim.humanoid_model import build_humanoid
from sim.rig import CameraPlacement, look_at
from sim.scenes import hand_behind_back
from sim.tracker import TrackerTruth, track
from sim.tracker_model_bias import TrackerModelBias, sample_model_bias
from sim.tracker_noise import (
    DEFAULT_GROUP_NOISE,
    GroupNoise,
    JointGroup,
    TrackerNoise,
    joint_groups,
)
from sim.visibility import joint_visibility, yaw_to_camera
from tests.strategies import seeds

TOPOLOGIES = [KINECT_V2, K4ABT]

# Standing pose in the body frame (x forward, y left, z up) [m]; right side mirrors y.
_LEFT_POSE = {
    "shoulder": (0.0, 0.18, 1.40), "elbow": (0.0, 0.20, 1.12), "wrist": (0.0, 0.21, 0.88),
    "hand": (0.0, 0.21, 0.82), "handtip": (0.0, 0.21, 0.74), "thumb": (0.03, 0.21, 0.82),
    "hip": (0.0, 0.09, 0.95), "knee": (0.0, 0.09, 0.52), "ankle": (0.0, 0.09, 0.09), "foot": (0.12, 0.09, 0.03),
}
_CENTRE_POSE = {
    Landmark.PELVIS: (0.0, 0.0, 0.95), Landmark.SPINE_MID: (0.0, 0.0, 1.15),
    Landmark.SPINE_SHOULDER: (0.0, 0.0, 1.40), Landmark.NECK: (0.0, 0.0, 1.50), Landmark.HEAD: (0.0, 0.0, 1.62),
}
_K4ABT_EXTRA_LEFT = {"CLAVICLE": (0.0, 0.05, 1.42), "EYE": (0.08, 0.03, 1.66), "EAR": (0.0, 0.07, 1.63)}


def body_pose(topology: Topology) -> np.ndarray:
    """(J, 3) standing pose in the body frame."""
    p = np.full((topology.n_joints, 3), np.nan)
    for lm, xyz in _CENTRE_POSE.items():
        p[topology.index(lm)] = xyz
    for stem, (x, y, z) in _LEFT_POSE.items():
        p[topology.index(Landmark(f"{stem}_left"))] = (x, y, z)
        p[topology.index(Landmark(f"{stem}_right"))] = (x, -y, z)
    if topology is K4ABT:
        for stem, (x, y, z) in _K4ABT_EXTRA_LEFT.items():
            p[topology.index(f"{stem}_LEFT")] = (x, y, z)
            p[topology.index(f"{stem}_RIGHT")] = (x, -y, z)
        p[topology.index("NOSE")] = (0.10, 0.0, 1.62)
    assert not np.isnan(p).any()
    return p


def world_joints(topology: Topology, yaw: np.ndarray, root_xy: np.ndarray | None = None) -> np.ndarray:
    """(T, J, 3) world joints of the standing pose turned to ``yaw`` (T,) and moved to ``root_xy`` (T, 2)."""
    b = body_pose(topology)
    c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
    z = np.broadcast_to(b[:, 2], c.shape[:1] + b.shape[:1])
    p = np.stack([c * b[:, 0] - s * b[:, 1], s * b[:, 0] + c * b[:, 1], z], -1)
    if root_xy is not None:
        p[..., :2] += np.asarray(root_xy)[:, None, :]
    return p


def front_camera(distance: float = 2.5, angle_deg: float = 0.0, name: str = "cam") -> CameraPlacement:
    a = np.radians(angle_deg)
    pos = [distance * np.cos(a), distance * np.sin(a), 1.0]
    return CameraPlacement(name, look_at(pos, [0.0, 0.0, 1.0]))


def run(topology, yaw, noise, *, seed=0, camera=None, visibility=None, root_xy=None, model_bias=None):
    P = world_joints(topology, yaw, root_xy)
    rng = np.random.default_rng(seed)
    if model_bias is None:
        model_bias = sample_model_bias(topology, noise, rng=rng)
    ts = np.arange(len(yaw)) / 30.0
    cam = camera or front_camera()
    stream, truth = track(P, yaw, ts, cam, topology, noise, model_bias, visibility, rng=rng)
    return stream, truth, P, cam


def quiet(noise: TrackerNoise, **changes) -> TrackerNoise:
    """``noise`` with every group's outliers (and any given group fields) replaced."""
    changes = {"outlier_rate": 0.0, **changes}
    return dataclasses.replace(noise, groups={g: dataclasses.replace(n, **changes) for g, n in noise.groups.items()})


@pytest.mark.parametrize("topology", TOPOLOGIES)
def test_ideal_tracker_reproduces_truth(topology):
    yaw = np.linspace(-1.0, 1.0, 50)
    root = np.column_stack([np.linspace(0, 0.3, 50), np.linspace(-0.2, 0.2, 50)])
    stream, truth, P, cam = run(topology, yaw, TrackerNoise.none(), root_xy=root)
    assert isinstance(stream, SkeletonStream) and isinstance(truth, TrackerTruth)
    expected = apply(invert(cam.T_world_cam), P)
    np.testing.assert_allclose(stream.positions, expected, atol=1e-12)
    np.testing.assert_allclose(truth.joints_cam, expected, atol=1e-12)
    assert np.all(stream.states == TrackingState.TRACKED)
    np.testing.assert_array_equal(stream.timestamps, np.arange(50) / 30.0)
    assert not truth.flipped.any() and truth.body_tracked.all() and not truth.outliers.any()


@given(seed=seeds, cam_angle=st.floats(0.0, 360.0), yaw=st.floats(-np.pi, np.pi), dist=st.floats(1.0, 4.0))
def test_ideal_tracker_reproduces_truth_from_any_side(seed, cam_angle, yaw, dist):
    stream, truth, P, cam = run(KINECT_V2, np.full(3, yaw), TrackerNoise.none(), seed=seed,
                                camera=front_camera(dist, cam_angle))
    seen = stream.states == TrackingState.TRACKED
    np.testing.assert_array_equal(seen, truth.in_view & truth.body_tracked[:, None])
    np.testing.assert_allclose(stream.positions[seen], apply(invert(cam.T_world_cam), P)[seen], atol=1e-12)
    expected_yaw = abs((np.radians(cam_angle) - yaw + np.pi) % (2 * np.pi) - np.pi)
    np.testing.assert_allclose(truth.yaw_to_camera, expected_yaw, atol=1e-9)


def test_yaw_to_camera():
    root = np.zeros((4, 3))
    yaw = np.radians([0.0, 90.0, 180.0, -135.0])
    np.testing.assert_allclose(np.degrees(yaw_to_camera(root, yaw, [3.0, 0.0, 1.0])), [0, 90, 180, 135], atol=1e-9)


@pytest.mark.parametrize("topology", TOPOLOGIES)
def test_facing_away_swaps_left_and_right(topology):
    flipping = dataclasses.replace(TrackerNoise.none(), flip_enabled=True)
    stream, truth, P, cam = run(topology, np.full(10, np.pi), flipping)
    true_cam = apply(invert(cam.T_world_cam), P)
    assert truth.flipped.all()
    np.testing.assert_allclose(stream.positions, true_cam[:, topology.mirror], atol=1e-12)
    assert np.all(stream.states == TrackingState.TRACKED)

    stream, truth, P, cam = run(topology, np.full(10, np.pi), TrackerNoise(), seed=3)
    true_cam = apply(invert(cam.T_world_cam), P)
    sl, sr = topology.index(Landmark.SHOULDER_LEFT), topology.index(Landmark.SHOULDER_RIGHT)
    to_right = np.linalg.norm(stream.positions[:, sl] - true_cam[:, sr], axis=-1)
    to_left = np.linalg.norm(stream.positions[:, sl] - true_cam[:, sl], axis=-1)
    assert truth.flipped.all() and np.median(to_right) < np.median(to_left)


@pytest.mark.parametrize("topology", TOPOLOGIES)
def test_facing_the_camera_does_not_swap(topology):
    stream, truth, P, cam = run(topology, np.zeros(10), TrackerNoise(), seed=3)
    true_cam = apply(invert(cam.T_world_cam), P)
    sl, sr = topology.index(Landmark.SHOULDER_LEFT), topology.index(Landmark.SHOULDER_RIGHT)
    to_left = np.linalg.norm(stream.positions[:, sl] - true_cam[:, sl], axis=-1)
    to_right = np.linalg.norm(stream.positions[:, sl] - true_cam[:, sr], axis=-1)
    assert not truth.flipped.any() and np.median(to_left) < np.median(to_right)


def test_flip_hysteresis():
    noise = dataclasses.replace(TrackerNoise.none(), flip_enabled=True)  # enter above 135, leave below 105
    wobble = 10.0 * np.sin(np.linspace(0, 6 * np.pi, 60))
    yaw_deg = np.concatenate([
        np.zeros(5), 122 + wobble,   # inside the band, coming from the front: stays unflipped
        np.full(5, 140.0),           # past the band: flips
        118 + wobble,                # back inside the band: stays flipped
        np.full(5, 100.0),           # below the band: unflips
    ])
    _, truth, _, _ = run(KINECT_V2, np.radians(yaw_deg), noise)
    expected = np.concatenate([np.zeros(65), np.ones(65), np.zeros(5)]).astype(bool)
    np.testing.assert_array_equal(truth.flipped, expected)


def test_flip_state_restarts_when_the_body_is_reacquired():
    noise = dataclasses.replace(TrackerNoise.none(), flip_enabled=True)
    yaw = np.radians(np.full(12, 125.0))  # inside the band: a fresh acquisition decides by the threshold
    root = np.zeros((12, 2))
    root[4:8, 1] = 10.0  # walks out of view and back
    _, truth, _, _ = run(KINECT_V2, yaw, noise, root_xy=root)
    np.testing.assert_array_equal(truth.body_tracked, [1] * 4 + [0] * 4 + [1] * 4)
    np.testing.assert_array_equal(truth.flipped, truth.body_tracked)


@pytest.mark.parametrize("topology", TOPOLOGIES)
def test_not_tracked_outside_field_of_view_and_range(topology):
    root = np.array([[0.0, 0.0], [0.0, 10.0], [-3.0, 0.0]])  # in view, far to the side, 5.5 m away
    stream, truth, _, _ = run(topology, np.zeros(3), TrackerNoise(), root_xy=root)
    np.testing.assert_array_equal(truth.body_tracked, [True, False, False])
    assert np.all(stream.states[1:] == TrackingState.NOT_TRACKED) and np.isnan(stream.positions[1:]).all()
    assert np.all(stream.states[0] == TrackingState.TRACKED)


def test_joints_outside_the_image_are_not_tracked():
    stream, truth, _, cam = run(KINECT_V2, np.zeros(4), TrackerNoise(), camera=front_camera(1.0))
    lost = [KINECT_V2.index(n) for n in ("Head", "AnkleLeft", "AnkleRight", "FootLeft", "FootRight")]
    assert truth.body_tracked.all()
    np.testing.assert_array_equal(truth.in_view.all(axis=0), ~np.isin(np.arange(25), lost))
    assert np.all(stream.states[:, lost] == TrackingState.NOT_TRACKED)
    assert np.isnan(stream.positions[:, lost]).all()
    assert np.all(np.delete(stream.states, lost, axis=1) == TrackingState.TRACKED)


@pytest.mark.parametrize("topology", TOPOLOGIES)
def test_hidden_joints_are_inferred(topology):
    vis = np.ones((6, topology.n_joints), dtype=bool)
    hr = topology.index(Landmark.HAND_RIGHT)
    vis[:, hr] = False
    stream, truth, P, cam = run(topology, np.zeros(6), TrackerNoise.none(), visibility=vis)
    expected_states = np.full((6, topology.n_joints), TrackingState.TRACKED)
    expected_states[:, hr] = TrackingState.INFERRED  # K4ABT: 1 LOW, 2 MEDIUM
    np.testing.assert_array_equal(stream.states, expected_states)
    np.testing.assert_allclose(stream.positions, apply(invert(cam.T_world_cam), P), atol=1e-12)
    np.testing.assert_array_equal(truth.visible, vis)

    # flipped: the label HAND_LEFT sits on the hidden true right hand, so it is the inferred one
    flipping = dataclasses.replace(TrackerNoise.none(), flip_enabled=True)
    stream, *_ = run(topology, np.full(6, np.pi), flipping, visibility=vis)
    hl = topology.index(Landmark.HAND_LEFT)
    assert np.all(stream.states[:, hl] == TrackingState.INFERRED)
    assert np.all(np.delete(stream.states, hl, axis=1) == TrackingState.TRACKED)


def test_inferred_joints_err_more():
    noise = quiet(TrackerNoise())
    vis = np.ones((3000, 25), dtype=bool)
    vis[:, KINECT_V2.index("ElbowLeft")] = False
    errs = []
    for v in (None, vis):
        stream, truth, *_ = run(KINECT_V2, np.zeros(3000), noise, seed=9, visibility=v)
        errs.append(stream.positions - truth.joints_cam)
    el = KINECT_V2.index("ElbowLeft")
    jitter = [np.std(e[:, el] - e[:, el].mean(axis=0)) for e in errs]
    assert jitter[1] == pytest.approx(2 * jitter[0], rel=0.05)
    guess = np.linalg.norm(errs[1][:, el].mean(axis=0) - errs[0][:, el].mean(axis=0))
    assert 0.03 - 0.002 <= guess <= 0.10 + 0.002  # inferred_offset_m, same seed so same view bias


def _residuals(topology, noise, n_frames, seed, yaw_deg=0.0):
    stream, truth, *_ = run(topology, np.full(n_frames, np.radians(yaw_deg)), noise, seed=seed)
    return stream.positions - truth.joints_cam, stream, truth


def _group_index(topology, group):
    return np.array([g is group for g in joint_groups(topology)])


@pytest.mark.parametrize("topology", TOPOLOGIES)
def test_jitter_std_per_group(topology):
    err, *_ = _residuals(topology, quiet(TrackerNoise()), 4000, seed=11)
    jitter = err - err.mean(axis=0)
    for group, g in DEFAULT_GROUP_NOISE.items():
        measured = np.std(jitter[:, _group_index(topology, group)])
        assert measured == pytest.approx(g.jitter_m, rel=0.05), group


def test_jitter_and_bias_grow_with_yaw():
    noise = quiet(TrackerNoise())
    front, *_ = _residuals(KINECT_V2, noise, 2000, seed=12, yaw_deg=0.0)
    side, *_ = _residuals(KINECT_V2, noise, 2000, seed=12, yaw_deg=90.0)
    ratio = np.std(side - side.mean(axis=0)) / np.std(front - front.mean(axis=0))
    assert ratio == pytest.approx(2.7, rel=0.05)  # knots (60, 1.8), (100, 3.0) -> 2.7 at 90 degrees


def test_static_bias_per_group_matches_sensor_ranges():
    """RMS over sessions of the static error equals the RMS of U(low, high) for each group at yaw 0."""
    noise = dataclasses.replace(quiet(TrackerNoise(), jitter_m=0.0), hip_up_m=0.0, hip_out_m=0.0)
    err = np.concatenate([_residuals(KINECT_V2, noise, 1, seed=s)[0] for s in range(600)])
    for group, g in DEFAULT_GROUP_NOISE.items():
        lo, hi = g.bias_m
        expected_rms = np.sqrt((lo**2 + lo * hi + hi**2) / 3)
        rms = np.sqrt(np.mean(np.sum(err[:, _group_index(KINECT_V2, group)] ** 2, axis=-1)))
        assert rms == pytest.approx(expected_rms, rel=0.1), group


def test_hips_sit_high_and_wide():
    noise = TrackerNoise()
    up, out = [], []
    for s in range(300):
        b = sample_model_bias(KINECT_V2, noise, rng=np.random.default_rng(s)).offsets_body
        up += [b[KINECT_V2.index("HipLeft"), 2], b[KINECT_V2.index("HipRight"), 2]]
        out += [b[KINECT_V2.index("HipLeft"), 1], -b[KINECT_V2.index("HipRight"), 1]]
    assert np.mean(up) == pytest.approx(noise.hip_up_m, abs=0.005)
    assert np.mean(out) == pytest.approx(noise.hip_out_m, abs=0.005)


def test_model_bias_is_shared_and_view_bias_lies_along_the_ray():
    base = quiet(TrackerNoise(), jitter_m=0.0)
    # with a flat yaw multiplier, the model part is identical in every camera
    shared = dataclasses.replace(base, model_fraction=1.0, yaw_multiplier=((0.0, 1.0), (180.0, 1.0)))
    bias = sample_model_bias(KINECT_V2, shared, rng=np.random.default_rng(0))
    errs = []
    for k, angle in enumerate((0.0, 40.0)):
        stream, truth, P, cam = run(KINECT_V2, np.zeros(2), shared, seed=k, camera=front_camera(2.5, angle),
                                    model_bias=bias)
        errs.append(apply(cam.T_world_cam, stream.positions) - P)
    np.testing.assert_allclose(errs[0], errs[1], atol=1e-12)

    view_only = dataclasses.replace(base, model_fraction=0.0, hip_up_m=0.0, hip_out_m=0.0)
    err, stream, truth = _residuals(KINECT_V2, view_only, 1, seed=4)
    ray = truth.joints_cam[0] / np.linalg.norm(truth.joints_cam[0], axis=-1, keepdims=True)
    cosine = np.abs(np.sum(err[0] * ray, axis=-1)) / np.linalg.norm(err[0], axis=-1)
    assert np.median(cosine) > 0.9


@pytest.mark.parametrize("topology", TOPOLOGIES)
def test_outlier_rate_per_group(topology):
    _, stream, truth = _residuals(topology, TrackerNoise(), 20000, seed=13)
    for group, g in DEFAULT_GROUP_NOISE.items():
        rate = truth.outliers[:, _group_index(topology, group)].mean()
        assert rate == pytest.approx(g.outlier_rate, rel=0.25), group


def _bone_length_std(stream, a, b):
    i, j = stream.topology.index(a), stream.topology.index(b)
    return np.std(np.linalg.norm(stream.positions[:, i] - stream.positions[:, j], axis=-1))


def test_bone_length_spread():
    """A still subject facing the camera, default noise, outliers included.

    With 6 mm per-axis jitter at both ends the shoulder-elbow length alone spreads by about
    sqrt(2) * 6 = 8.5 mm; outliers (1-2 % of frames, 8-30 cm) add to it. Measured (seeds 1, 2, 14):
    spine-shoulder to shoulder 1.1-1.2 cm, shoulder-elbow 1.3-1.5 cm, elbow-wrist 2.1-2.4 cm; without
    outliers 0.7 / 0.85 / 1.2 cm. The paper reports 0.9 / 1.5 / 2.5 cm for six merged real cameras.
    """
    _, stream, _ = _residuals(KINECT_V2, TrackerNoise(), 9000, seed=14)
    spreads = [
        _bone_length_std(stream, Landmark.SPINE_SHOULDER, Landmark.SHOULDER_RIGHT),
        _bone_length_std(stream, Landmark.SHOULDER_RIGHT, Landmark.ELBOW_RIGHT),
        _bone_length_std(stream, Landmark.ELBOW_RIGHT, Landmark.WRIST_RIGHT),
    ]
    assert 0.005 < spreads[0] < spreads[1] < spreads[2] < 0.04
    no_outliers = _residuals(KINECT_V2, quiet(TrackerNoise()), 9000, seed=14)[1]
    assert _bone_length_std(no_outliers, Landmark.SHOULDER_RIGHT, Landmark.ELBOW_RIGHT) == pytest.approx(
        np.sqrt(2) * 0.006, rel=0.1
    )


def test_same_seed_same_stream_different_seed_different():
    a, ta, *_ = run(K4ABT, np.linspace(0, 3, 100), TrackerNoise(), seed=5)
    b, tb, *_ = run(K4ABT, np.linspace(0, 3, 100), TrackerNoise(), seed=5)
    c, *_ = run(K4ABT, np.linspace(0, 3, 100), TrackerNoise(), seed=6)
    assert a.equals(b) and np.array_equal(ta.outliers, tb.outliers)
    assert not a.equals(c)


def test_bad_input():
    P = world_joints(KINECT_V2, np.zeros(4))
    yaw, ts, cam = np.zeros(4), np.arange(4) / 30.0, front_camera()
    noise = TrackerNoise()
    bias = sample_model_bias(KINECT_V2, noise, rng=np.random.default_rng(0))
    rng = np.random.default_rng(0)
    cases = [
        (P[:, :10], yaw, ts, KINECT_V2, bias, None),
        (np.where(np.eye(25, 3, dtype=bool), np.nan, P), yaw, ts, KINECT_V2, bias, None),
        (P, yaw[:3], ts, KINECT_V2, bias, None),
        (P, yaw, ts[::-1], KINECT_V2, bias, None),
        (P, yaw, ts, KINECT_V2, sample_model_bias(K4ABT, noise, rng=rng), None),
        (P, yaw, ts, KINECT_V2, bias, np.ones((4, 25))),
        (P, yaw, ts, KINECT_V2, bias, np.ones((4, 24), dtype=bool)),
    ]
    for P_, yaw_, ts_, topo, mb, vis in cases:
        with pytest.raises(BadInputError):
            track(P_, yaw_, ts_, cam, topo, noise, mb, vis, rng=rng)


@pytest.mark.parametrize(
    "changes",
    [
        {"model_fraction": 1.5},
        {"yaw_multiplier": ((0.0, 1.0), (90.0, 2.0))},
        {"yaw_multiplier": ((0.0, 0.5), (180.0, 2.0))},
        {"outlier_mean_frames": 0.5},
        {"inferred_offset_m": (0.1, 0.05)},
        {"flip_threshold_deg": 10.0},
        {"min_fraction_in_view": 0.0},
        {"groups": {JointGroup.TORSO: DEFAULT_GROUP_NOISE[JointGroup.TORSO]}},
        {"lateral_ratio": float("nan")},
    ],
)
def test_bad_noise(changes):
    with pytest.raises(BadInputError):
        dataclasses.replace(TrackerNoise(), **changes)


@pytest.mark.parametrize(
    "args",
    [
        ((0.05, 0.02), 0.01, 0.01, (0.1, 0.2)),
        ((0.0, 0.1), -0.01, 0.0, (0.1, 0.2)),
        ((0.0, 0.1), 0.0, 1.0, (0.1, 0.2)),
        ((0.0, 0.1), 0.0, 0.1, (0.3, 0.2)),
    ],
)
def test_bad_group_noise(args):
    with pytest.raises(BadInputError):
        GroupNoise(*args)


def test_bad_model_bias():
    with pytest.raises(BadInputError):
        TrackerModelBias(KINECT_V2, np.zeros((24, 3)))


@pytest.fixture(scope="module")
def humanoid():
    return build_humanoid(Anthropometry())


@pytest.mark.parametrize("topology", TOPOLOGIES)
def test_hand_behind_the_back_is_inferred_only_from_the_front(humanoid, topology):
    coords = hand_behind_back()
    humanoid.set_pose(coords)
    P = humanoid.joint_positions(coords[None], topology)[0]
    bodies = humanoid.model.site_bodyid[humanoid.site_ids(topology)]
    hand = topology.index(Landmark.HAND_RIGHT)
    assert P[hand, 0] < -0.1  # behind the subject, who faces +x
    hidden = {}
    for name, angle in (("front", 0.0), ("back", 180.0)):
        cam = front_camera(2.5, angle, name)
        vis = joint_visibility(humanoid.model, humanoid.data, cam.position, P, bodies)
        hidden[name] = {topology.joints[j] for j in np.flatnonzero(~vis)}
        ideal = TrackerNoise.none()
        bias = sample_model_bias(topology, ideal, rng=np.random.default_rng(0))
        stream, _ = track(np.repeat(P[None], 3, 0), np.zeros(3), np.arange(3) / 30.0, cam, topology, ideal, bias,
                          np.repeat(vis[None], 3, 0), rng=np.random.default_rng(1))
        expected = TrackingState.INFERRED if name == "front" else TrackingState.TRACKED
        assert np.all(stream.states[:, hand] == expected)
    right_hand = {topology.index(lm) for lm in (Landmark.WRIST_RIGHT, Landmark.HAND_RIGHT, Landmark.HANDTIP_RIGHT,
                                                 Landmark.THUMB_RIGHT)}
    assert hidden["front"] == {topology.joints[i] for i in right_hand}
    assert not hidden["back"]


def test_visibility_of_a_standing_subject(humanoid):
    coords = np.zeros(len(COORDINATES))
    humanoid.set_pose(coords)
    P = humanoid.joint_positions(coords[None], KINECT_V2)[0]
    bodies = humanoid.model.site_bodyid[humanoid.site_ids(KINECT_V2)]
    cams = np.array([[2.5, 0.0, 1.0], [0.0, 2.5, 1.0], [-2.5, 0.0, 1.0]])  # front, subject's left, back
    front, side, back = joint_visibility(humanoid.model, humanoid.data, cams, P, bodies)
    assert front.all() and back.all()
    assert side[KINECT_V2.indices(["ShoulderLeft", "ElbowLeft", "HandLeft", "KneeLeft", "Head"])].all()
    assert not side[KINECT_V2.indices(["ShoulderRight", "ElbowRight", "HandRight", "KneeRight"])].any()
    one = joint_visibility(humanoid.model, humanoid.data, cams[1], P, bodies)
    assert one.shape == (25,) and np.array_equal(one, side)


def test_visibility_bad_input(humanoid):
    coords = np.zeros(len(COORDINATES))
    humanoid.set_pose(coords)
    P = humanoid.joint_positions(coords[None], KINECT_V2)[0]
    bodies = humanoid.model.site_bodyid[humanoid.site_ids(KINECT_V2)]
    m, d, cam = humanoid.model, humanoid.data, np.array([2.5, 0.0, 1.0])
    for args, kwargs in [
        ((cam, P[:, :2], bodies), {}),
        ((cam, P, bodies[:3]), {}),
        ((cam, P, bodies + 1000), {}),
        ((cam, P, bodies), {"parent_of_body": np.zeros(3, dtype=int)}),
        ((P[0], P, bodies), {}),
        ((cam[:2], P, bodies), {}),
        ((np.full(3, np.nan), P, bodies), {}),
    ]:
        with pytest.raises(BadInputError):
            joint_visibility(m, d, *args, **kwargs)


def test_bad_truth():
    with pytest.raises(BadInputError, match="joints_cam"):
        TrackerTruth(np.zeros(2), np.zeros(2, bool), np.ones(2, bool), np.ones((2, 25), bool),
                     np.ones((2, 25), bool), np.zeros((2, 25), bool), np.zeros((2, 24, 3)))
