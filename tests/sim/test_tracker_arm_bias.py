"""The tracker's arm bias: swing frames and elevation of constructed arms, the offsets of known
coefficients on both sides, the forearm's terms of a bent elbow, validation, the person draw, the model
bias and the tracker that adds it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from fusion.errors import BadInputError
from fusion.topology import KINECT_V2, Landmark
from fusion.transforms import apply
from sim.rig import CameraPlacement, look_at
from sim.tracker import track
from sim.tracker_arm_bias import (
    ARM_JOINTS,
    FOREARM_TERMS,
    KNOTS_DEG,
    POWERS,
    ArmBias,
    arm_frames,
    arm_offsets,
    knot_weights,
)
from sim.tracker_bias import TrackerBias, tracker_with
from sim.tracker_model_bias import sample_model_bias
from sim.tracker_noise import JointGroup, TrackerNoise

TOPO = KINECT_V2
SHOULDER_Y = 0.19
"""Half the shoulder width [m]; the subject faces world +x, +y is its left, +z up."""

_TRUNK = {Landmark.PELVIS: (0.0, 0.0, 0.95), Landmark.SPINE_MID: (0.0, 0.0, 1.15),
          Landmark.SPINE_SHOULDER: (0.0, 0.0, 1.40), Landmark.NECK: (0.0, 0.0, 1.50),
          Landmark.HEAD: (0.0, 0.0, 1.62)}
_LEGS = {"hip": (0.0, 0.09, 0.95), "knee": (0.0, 0.09, 0.52), "ankle": (0.0, 0.09, 0.09), "foot": (0.12, 0.09, 0.03)}
UPPER_ARM, FOREARM = 0.28, 0.25


def _arm_direction(elevation_deg: float, side: str) -> np.ndarray:
    """Unit humerus direction of an arm raised sideways (in the frontal plane) to ``elevation_deg``."""
    e = np.radians(elevation_deg)
    lateral = 1.0 if side == "left" else -1.0
    return np.array([0.0, lateral * np.sin(e), -np.cos(e)])


def skeleton(elevation_deg: float | tuple[float, float] = 0.0, n_frames: int = 1) -> np.ndarray:
    """(T, J, 3) a Kinect v2 skeleton facing +x, both arms straight and raised sideways to
    ``elevation_deg`` (one value, or (left, right)); 0 is hanging straight down."""
    left_e, right_e = (elevation_deg, elevation_deg) if np.isscalar(elevation_deg) else elevation_deg
    p = np.full((TOPO.n_joints, 3), np.nan)
    for lm, xyz in _TRUNK.items():
        p[TOPO.index(lm)] = xyz
    for side, sign, e in (("left", 1.0, left_e), ("right", -1.0, right_e)):
        for stem, (x, y, z) in _LEGS.items():
            p[TOPO.index(Landmark(f"{stem}_{side}"))] = (x, sign * y, z)
        shoulder = np.array([0.0, sign * SHOULDER_Y, 1.40])
        d = _arm_direction(e, side)
        chain = {"shoulder": 0.0, "elbow": UPPER_ARM, "wrist": UPPER_ARM + FOREARM,
                 "hand": UPPER_ARM + FOREARM + 0.06, "handtip": UPPER_ARM + FOREARM + 0.14,
                 "thumb": UPPER_ARM + FOREARM + 0.06}
        for stem, length in chain.items():
            p[TOPO.index(Landmark(f"{stem}_{side}"))] = shoulder + length * d
    assert np.isfinite(p).all()
    return np.tile(p, (n_frames, 1, 1))


def _arm_index(side: str) -> list[int]:
    return [TOPO.index(Landmark(f"{j}_{side}")) for j in ARM_JOINTS]


def _coefficients(term: int, values: np.ndarray) -> np.ndarray:
    """(3, P, 3) coefficients with only term ``term`` set, to ``values`` (3 joints, 3 axes)."""
    c = np.zeros((len(ARM_JOINTS), ArmBias.TERMS, 3))
    c[:, term] = values
    return c


C0 = np.array([[0.01, 0.02, 0.03], [-0.02, 0.015, 0.04], [0.03, -0.01, -0.02]])
"""Per joint (shoulder, elbow, wrist) a swing-frame vector [m] (X forward, Y up, Z lateral)."""

THORAX_RIGHT = np.column_stack([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
"""The thorax frame of a subject facing +x: X forward (+x), Y up (+z), Z right (-y)."""


def test_zero_coefficients_give_zero_offsets():
    for elevation in (0.0, 45.0, 120.0):
        out = arm_offsets(skeleton(elevation, 3), TOPO, np.zeros((3, ArmBias.TERMS, 3)))
        assert out.shape == (3, TOPO.n_joints, 3)
        np.testing.assert_array_equal(out, 0.0)


def test_swing_frame_of_a_hanging_arm_is_the_thorax_frame():
    frames = arm_frames(skeleton(0.0), TOPO)
    for side in ("left", "right"):
        np.testing.assert_allclose(frames.elevation_deg[side], [0.0], atol=1e-6)
        np.testing.assert_array_equal(frames.joints[side], _arm_index(side))
    mirrored = THORAX_RIGHT * np.array([1.0, 1.0, -1.0])  # the left arm's Z points left (+y)
    for j in range(3):
        np.testing.assert_allclose(frames.frames["right"][0, j], THORAX_RIGHT, atol=1e-9)
        np.testing.assert_allclose(frames.frames["left"][0, j], mirrored, atol=1e-9)


def test_hanging_arm_offset_is_c0_in_the_thorax_frame_and_mirrored_on_the_left():
    P = skeleton(0.0, 2)
    out = arm_offsets(P, TOPO, _coefficients(0, C0))
    right = C0 @ THORAX_RIGHT.T  # (X, Y, Z) -> world: (x, -z, y)
    np.testing.assert_allclose(right, np.column_stack([C0[:, 0], -C0[:, 2], C0[:, 1]]))
    left = right * np.array([1.0, -1.0, 1.0])  # Z lateral: the world y component changes sign
    for t in range(2):
        np.testing.assert_allclose(out[t, _arm_index("right")], right, atol=1e-12)
        np.testing.assert_allclose(out[t, _arm_index("left")], left, atol=1e-12)
    others = np.setdiff1d(np.arange(TOPO.n_joints), _arm_index("left") + _arm_index("right"))
    np.testing.assert_array_equal(out[:, others], 0.0)


@pytest.mark.parametrize("elevation", [30.0, 90.0, 135.0])
def test_elevation_of_an_arm_raised_sideways(elevation):
    frames = arm_frames(skeleton((elevation, 0.5 * elevation)), TOPO)
    np.testing.assert_allclose(frames.elevation_deg["left"], [elevation], atol=1e-6)
    np.testing.assert_allclose(frames.elevation_deg["right"], [0.5 * elevation], atol=1e-6)
    np.testing.assert_allclose(frames.basis("left")[:, :POWERS], knot_weights(np.array([elevation])), atol=1e-9)
    np.testing.assert_allclose(frames.basis("left")[:, POWERS:], 0.0, atol=1e-9)  # straight: no forearm terms


def _bend_right_elbow(P: np.ndarray, forearm: np.ndarray) -> np.ndarray:
    """``P`` with the right forearm (and the hand joints with it) pointing along ``forearm`` (unit, world)."""
    P = P.copy()
    elbow = P[:, TOPO.index(Landmark.ELBOW_RIGHT)]
    for stem, length in {"wrist": FOREARM, "hand": FOREARM + 0.06, "handtip": FOREARM + 0.14,
                         "thumb": FOREARM + 0.06}.items():
        P[:, TOPO.index(Landmark(f"{stem}_right"))] = elbow + length * forearm
    return P


@pytest.mark.parametrize("forearm, components", [
    ([1.0, 0.0, 0.0], (1.0, 0.0)),                      # forearm pointing forward, arm hanging
    ([0.0, -1.0, 0.0], (0.0, 1.0)),                     # pointing to the right: lateral for the right arm
    ([0.6, -0.8, 0.0], (0.6, 0.8)),                     # turned outward part of the way
    ([np.sqrt(0.5), 0.0, -np.sqrt(0.5)], (np.sqrt(0.5), 0.0)),  # elbow bent 45 deg forward
])
def test_the_forearm_terms_move_the_joints_by_their_values_times_the_forearms_components(forearm, components):
    P = _bend_right_elbow(skeleton(0.0), np.asarray(forearm))
    frames = arm_frames(P, TOPO)
    np.testing.assert_allclose(frames.basis("right")[0, POWERS:], components, atol=1e-9)
    np.testing.assert_allclose(frames.basis("left")[0, POWERS:], 0.0, atol=1e-9)
    coefficients = _coefficients(POWERS, C0) + _coefficients(POWERS + 1, 2 * C0)
    assert FOREARM_TERMS == ("forward", "lateral")
    out = arm_offsets(P, TOPO, coefficients)
    # shoulder and elbow in the upper arm's swing frame (the thorax frame when hanging)
    size = components[0] + 2 * components[1]
    np.testing.assert_allclose(out[0, _arm_index("right")[:2]], size * C0[:2] @ THORAX_RIGHT.T, atol=1e-9)
    np.testing.assert_array_equal(out[0, _arm_index("left")], 0.0)
    np.testing.assert_allclose(arm_offsets(skeleton(0.0), TOPO, coefficients), 0.0, atol=1e-12)  # straight arms


def test_values_of_the_knots_alone_are_accepted_and_give_the_same_offsets():
    knots = np.stack([C0, 0.5 * C0, -C0], axis=1)  # (3, 3, 3): no forearm terms
    bias = ArmBias(knots, np.stack([knots]))
    np.testing.assert_array_equal(np.asarray(bias.mean_m)[:, :POWERS], knots)
    np.testing.assert_array_equal(np.asarray(bias.mean_m)[:, POWERS:], 0.0)
    assert np.asarray(bias.person_modes_m).shape == (1, 3, ArmBias.TERMS, 3)
    P = _bend_right_elbow(skeleton(60.0), np.array([1.0, 0.0, 0.0]))
    frames = arm_frames(P, TOPO)  # the offsets of the knots alone, as before the forearm terms
    local = np.einsum("tp,jpa->tja", frames.basis("right")[:, :POWERS], knots)
    expected = np.einsum("tjka,tja->tjk", frames.frames["right"], local)
    np.testing.assert_allclose(arm_offsets(P, TOPO, np.asarray(bias.mean_m))[:, _arm_index("right")], expected,
                               atol=1e-12)


def test_swing_frame_of_an_arm_raised_sideways_turns_about_forward():
    frames = arm_frames(skeleton(90.0), TOPO)
    # the right arm points along -y: the thorax frame turned about X (forward) so that -Y points right
    turned = Rotation.from_rotvec([-np.pi / 2, 0.0, 0.0]).as_matrix() @ THORAX_RIGHT
    np.testing.assert_allclose(turned[:, 1], [0.0, 1.0, 0.0], atol=1e-12)  # Y back along the arm
    for j in range(3):
        np.testing.assert_allclose(frames.frames["right"][0, j], turned, atol=1e-9)
        np.testing.assert_allclose(-frames.frames["right"][0, j][:, 1], _arm_direction(90.0, "right"), atol=1e-9)
        np.testing.assert_allclose(-frames.frames["left"][0, j][:, 1], _arm_direction(90.0, "left"), atol=1e-9)


@pytest.mark.parametrize("knot", range(POWERS))
def test_a_knots_value_is_the_offset_at_its_elevation_and_none_at_the_others(knot):
    for k, elevation in enumerate(KNOTS_DEG):
        P = skeleton(elevation)
        frames = arm_frames(P, TOPO)
        out = arm_offsets(P, TOPO, _coefficients(knot, C0))
        for side in ("left", "right"):
            expected = np.einsum("jka,ja->jk", frames.frames[side][0], C0) if k == knot else np.zeros((3, 3))
            np.testing.assert_allclose(out[0, _arm_index(side)], expected, atol=1e-9)


def test_equal_knots_give_a_constant_offset_and_elevations_beyond_the_knots_are_held():
    same = sum(_coefficients(k, C0) for k in range(POWERS))  # every knot C0, no forearm terms
    for elevation in (20.0, 70.0, 120.0):
        P = skeleton(elevation)
        frames = arm_frames(P, TOPO)
        np.testing.assert_allclose(arm_offsets(P, TOPO, same)[0, _arm_index("right")],
                                   np.einsum("jka,ja->jk", frames.frames["right"][0], C0), atol=1e-9)
    np.testing.assert_allclose(knot_weights(np.array([170.0, -5.0])), knot_weights(np.array([KNOTS_DEG[-1], 0.0])))
    np.testing.assert_allclose(knot_weights(np.linspace(0, 150, 7)).sum(axis=-1), 1.0)


def test_arm_straight_up_has_no_offset_rather_than_nan():
    out = arm_offsets(skeleton(180.0), TOPO, _coefficients(0, C0))
    assert np.isfinite(out).all()


SHAPE = (3, ArmBias.TERMS, 3)


def _nested(value: float = 0.0) -> np.ndarray:
    return np.full(SHAPE, value)


def _modes(k: int = 2, value: float = 0.0) -> np.ndarray:
    return np.full((k, *SHAPE), value)


NAN_AT_4 = np.where(np.arange(np.prod(SHAPE)).reshape(SHAPE) == 4, np.nan, 0.0)


@pytest.mark.parametrize("mean, modes, match", [
    (np.zeros((3, 3)), _modes(), "shape"),
    (np.zeros((2, 3, 3)), _modes(), "shape"),
    (_nested(), np.zeros((2, 3, 3, 4)), "shape"),
    (_nested(), _nested(), "shape"),  # a single mode must still carry the mode axis
    (_nested(0.6), _modes(), "0.5 m"),
    (_nested(-0.51), _modes(), "0.5 m"),
    (_nested(), _modes(2, 0.7), "0.5 m"),
    (_nested(), _modes(1, -0.51), "0.5 m"),
    (NAN_AT_4, _modes(), "finite"),
    (_nested(), np.stack([_nested(), NAN_AT_4]), "finite"),
    (_nested(), np.stack([np.where(np.arange(np.prod(SHAPE)).reshape(SHAPE) == 4, np.inf, 0.0)]), "finite"),
])
def test_arm_bias_validation(mean, modes, match):
    with pytest.raises(BadInputError, match=match):
        ArmBias(mean.tolist(), modes.tolist())


def test_arm_bias_accepts_negative_modes_and_no_modes():
    bias = ArmBias(_nested(), _modes(2, -0.01))
    assert np.asarray(bias.person_modes_m).shape == (2, *SHAPE)
    for empty in ([], np.zeros((0, *SHAPE))):
        assert np.asarray(ArmBias(_nested(), empty).person_modes_m).size == 0


def test_arm_bias_stores_nested_tuples_and_draw_without_modes_is_the_mean():
    mean = _coefficients(0, C0) + _coefficients(2, -C0)
    bias = ArmBias(mean, [])
    assert isinstance(bias.mean_m, tuple) and isinstance(bias.mean_m[0][0], tuple)
    assert bias.person_modes_m == ()
    np.testing.assert_array_equal(np.asarray(bias.mean_m), mean)
    for seed in (0, 1):
        np.testing.assert_array_equal(bias.draw(np.random.default_rng(seed)), mean)
    zero = ArmBias(mean, _modes(2))
    np.testing.assert_array_equal(zero.draw(np.random.default_rng(0)), mean)


def test_arm_bias_draw_has_the_covariance_of_the_modes():
    rng = np.random.default_rng(5)
    modes = rng.uniform(-0.02, 0.02, (2, *SHAPE))
    mean = _coefficients(0, C0)
    bias = ArmBias(mean, modes)
    assert isinstance(bias.person_modes_m[0][0][0], tuple)
    np.testing.assert_allclose(np.asarray(bias.person_modes_m), modes)
    n = 4000
    draws = np.stack([bias.draw(np.random.default_rng(s)) for s in range(n)])
    assert draws.shape == (n, *SHAPE)
    flat, m = draws.reshape(n, -1), modes.reshape(2, -1)
    # every draw lies in the span of the modes about the mean
    residual = flat - mean.ravel()
    z, *_ = np.linalg.lstsq(m.T, residual.T, rcond=None)
    np.testing.assert_allclose(m.T @ z, residual.T, atol=1e-12)
    np.testing.assert_allclose(flat.mean(axis=0), mean.ravel(), atol=4 * np.abs(m).sum(axis=0).max() / np.sqrt(n))
    expected = m.T @ m  # sum_k mode_k mode_k^T
    np.testing.assert_allclose(np.cov(flat, rowvar=False), expected, atol=0.08 * np.abs(expected).max())
    # the spread along a mode's direction: its norm (plus the other mode's projection)
    u = m[0] / np.linalg.norm(m[0])
    along = residual @ u
    assert np.std(along, ddof=1) == pytest.approx(np.sqrt(u @ expected @ u), rel=0.05)
    np.testing.assert_array_equal(bias.draw(np.random.default_rng(7)), bias.draw(np.random.default_rng(7)))


ARM = ArmBias(_coefficients(0, C0) + _coefficients(1, 0.5 * C0), [])


def test_model_bias_with_arm_bias_zeroes_the_arm_joints_and_draws_the_coefficients():
    noise = dataclasses.replace(TrackerNoise(), arm_bias=ARM)
    bias = sample_model_bias(TOPO, noise, rng=np.random.default_rng(3))
    arms = _arm_index("left") + _arm_index("right")
    np.testing.assert_array_equal(bias.offsets_body[arms], 0.0)
    others = np.setdiff1d(np.arange(TOPO.n_joints), arms)
    assert np.all(np.linalg.norm(bias.offsets_body[others], axis=-1) > 0)
    np.testing.assert_array_equal(bias.arm_coefficients, np.asarray(ARM.mean_m))

    plain = sample_model_bias(TOPO, TrackerNoise(), rng=np.random.default_rng(3))
    assert plain.arm_coefficients is None
    assert np.all(np.linalg.norm(plain.offsets_body[arms], axis=-1) > 0)


def test_tracker_noise_refuses_a_non_arm_bias():
    with pytest.raises(BadInputError, match="ArmBias"):
        TrackerNoise(arm_bias=np.zeros((3, 3, 3)))


@pytest.mark.parametrize("bias, kept", [
    (TrackerBias.ON, True), (TrackerBias.OFF, False), (TrackerBias.MODEL_OFF, False),
    (TrackerBias.VIEW_OFF, True), (TrackerBias.ARMS_OFF, False),
])
def test_tracker_with_keeps_the_arm_bias_only_with_the_model_part(bias, kept):
    noise = dataclasses.replace(TrackerNoise(), arm_bias=ARM)
    out = tracker_with(noise, bias)
    assert (out.arm_bias is ARM) if kept else out.arm_bias is None
    assert out.groups[JointGroup.TORSO].jitter_m == noise.groups[JointGroup.TORSO].jitter_m


def test_quiet_tracker_reports_the_arm_joints_at_truth_plus_arm_offsets():
    T = 6
    P = skeleton(0.0, T)
    lift = np.linspace(0.0, 100.0, T)  # the right arm abducts, the left hangs
    for t, e in enumerate(lift):
        P[t] = skeleton((0.0, e))[0]
    camera = CameraPlacement("cam", look_at([2.5, 0.0, 1.0], [0.0, 0.0, 1.0]))
    noise = dataclasses.replace(TrackerNoise.none(), arm_bias=ARM)
    rng = np.random.default_rng(0)
    model_bias = sample_model_bias(TOPO, noise, rng=rng)
    np.testing.assert_array_equal(model_bias.offsets_body, 0.0)
    stream, truth = track(P, np.zeros(T), np.arange(T) / 30.0, camera, TOPO, noise, model_bias, rng=rng)
    assert truth.body_tracked.all() and truth.in_view.all()
    seen = apply(camera.T_world_cam, stream.positions)
    expected_offsets = arm_offsets(P, TOPO, np.asarray(ARM.mean_m))
    np.testing.assert_allclose(seen, P + expected_offsets, atol=1e-9)
    arms = _arm_index("left") + _arm_index("right")
    assert np.all(np.linalg.norm(seen[:, arms] - P[:, arms], axis=-1) > 0.01)
    others = np.setdiff1d(np.arange(TOPO.n_joints), arms)
    np.testing.assert_allclose(seen[:, others], P[:, others], atol=1e-9)
    # the hanging left arm: c0 (c1 is scaled by an elevation of 0) mirrored into the world
    np.testing.assert_allclose(seen[:, _arm_index("left")] - P[:, _arm_index("left")],
                               np.broadcast_to(C0 @ THORAX_RIGHT.T * [1.0, -1.0, 1.0], (T, 3, 3)), atol=1e-9)


@pytest.mark.parametrize("yaw_scaled", [False, True])
def test_the_yaw_multiplier_scales_the_arm_bias_only_when_the_profile_says_so(yaw_scaled):
    """Seen from the side, the yaw multiplier (2 here) grows the other biases; scaled by it too, the
    shoulders' offsets of people seen from behind crossed their shoulders (ring6 seed 7)."""
    T = 4
    P = skeleton(0.0, T)
    camera = CameraPlacement("cam", look_at([0.0, -2.5, 1.0], [0.0, 0.0, 1.0]))  # the person's side
    noise = dataclasses.replace(TrackerNoise.none(), arm_bias=dataclasses.replace(ARM, yaw_scaled=yaw_scaled),
                                yaw_multiplier=((0.0, 1.0), (180.0, 3.0)))
    rng = np.random.default_rng(0)
    stream, truth = track(P, np.zeros(T), np.arange(T) / 30.0, camera, TOPO, noise,
                          sample_model_bias(TOPO, noise, rng=rng), rng=rng)
    arms = _arm_index("left") + _arm_index("right")
    seen = apply(camera.T_world_cam, stream.positions)[:, arms] - P[:, arms]
    expected = arm_offsets(P, TOPO, np.asarray(ARM.mean_m))[:, arms]
    k = np.linalg.norm(seen) / np.linalg.norm(expected)
    assert k == pytest.approx(2.0, abs=0.1) if yaw_scaled else k == pytest.approx(1.0, abs=1e-9)
