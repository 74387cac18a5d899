import warnings

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fusion.calibrate.sync import interpolate_stream
from fusion.errors import BadInputError
from fusion.merge.methods import (
    MergedSkeleton,
    MergeMethod,
    MergeParams,
    Reliability,
    distance,
    frontality,
    merge,
    weights,
)
from fusion.merge.views import CameraViews, unflip_back_facing, views_from_streams
from fusion.skeleton import SkeletonStream
from fusion.topology import K4ABT, KINECT_V2, Landmark, TrackingState
from fusion.transforms import apply, invert
from tests.fusion.skeleton_fakes import REST_POSE
from tests.strategies import seeds, transforms

TOPO = KINECT_V2
J = TOPO.n_joints
AVERAGING = [m for m in MergeMethod if m not in (MergeMethod.FRONTALITY, MergeMethod.DISTANCE)]


def _ring(n: int, radius: float = 2.5, height: float = 1.3) -> np.ndarray:
    """(n, 3) camera centres on a ring around the origin, world +y up; camera 0 on +z."""
    a = 2 * np.pi * np.arange(n) / n
    return np.column_stack([radius * np.sin(a), np.full(n, height), radius * np.cos(a)])


def _body(yaw: float = 0.0) -> np.ndarray:
    """(J, 3) rest pose turned by ``yaw`` about +y; at yaw 0 the person faces +z."""
    return Rotation.from_rotvec([0.0, yaw, 0.0]).apply(REST_POSE)


def _views(per_camera: np.ndarray, centres: np.ndarray, states=None, back=None, names=None) -> CameraViews:
    """CameraViews from (C, T, J, 3) positions; Tracked wherever present unless states are given."""
    C, T = per_camera.shape[:2]
    present = ~np.isnan(per_camera).any(-1)
    states = np.where(present, TrackingState.TRACKED, 0).astype(np.int8) if states is None else states
    back = np.zeros((C, T), bool) if back is None else back
    names = tuple(f"cam{c}" for c in range(C)) if names is None else names
    return CameraViews(names, TOPO, np.arange(T) / 30, per_camera, states, centres, back)


def _random_views(rng: np.random.Generator, C: int, T: int = 4) -> CameraViews:
    """Noisy skeletons of a turning person with random states, gaps and back-facing cameras."""
    yaw = rng.uniform(-np.pi, np.pi, T)
    truth = np.stack([_body(y) for y in yaw])
    P = truth[None] + rng.normal(0, 0.03, (C, T, J, 3))
    states = rng.choice(np.array([0, 1, 2, 2, 2], np.int8), size=(C, T, J))
    P[states == 0] = np.nan
    back = rng.random((C, T)) < 0.3
    names = tuple(f"cam{k}" for k in rng.permutation(C))
    return _views(P, _ring(C) + rng.normal(0, 0.2, (C, 3)), states, back, names)


# ---------------------------------------------------------------- CameraViews


def test_camera_views_validates_shapes_and_states():
    P = np.zeros((2, 3, J, 3))
    ok = dict(names=("a", "b"), topology=TOPO, times=np.arange(3.0), positions=P,
              states=np.ones((2, 3, J), np.int8), centres=np.zeros((2, 3)), back_facing=np.zeros((2, 3), bool))
    CameraViews(**ok)
    bad = [
        dict(names=("a", "a")),
        dict(positions=np.zeros((2, 3, J - 1, 3))),
        dict(states=np.ones((2, 3, J))[..., None]),
        dict(centres=np.zeros((3, 3))),
        dict(back_facing=np.zeros((2, 3))),
        dict(times=np.array([0.0, 0.0, 1.0])),
        dict(states=np.full((2, 3, J), 7, np.int8)),
        dict(positions=np.where(np.arange(J)[:, None] == 0, np.nan, P)),  # NaN with a state
    ]
    for change in bad:
        with pytest.raises(BadInputError):
            CameraViews(**(ok | change))


def test_camera_views_discards_not_tracked_positions_and_is_read_only():
    states = np.ones((1, 2, J), np.int8)
    states[0, 0, 3] = 0
    v = CameraViews(("a",), TOPO, np.arange(2.0), np.ones((1, 2, J, 3)), states, np.zeros((1, 3)),
                    np.zeros((1, 2), bool))
    assert np.isnan(v.positions[0, 0, 3]).all() and np.isfinite(v.positions[0, 1, 3]).all()
    with pytest.raises(ValueError):
        v.positions[0, 0, 0, 0] = 1.0


def test_views_from_streams_resamples_maps_to_world_and_takes_nearest_flags():
    rng = np.random.default_rng(3)
    ts = np.arange(10) / 30
    T_world_cam = {"a": np.eye(4), "b": invert(np.array([[0, 0, 1, 0.5], [0, 1, 0, 0], [-1, 0, 0, 2], [0, 0, 0, 1.0]]))}
    streams = {n: SkeletonStream(TOPO, ts + (0.2 if n == "b" else 0.0), rng.normal(size=(10, J, 3)),
                                 np.full((10, J), 2, np.int8)) for n in "ab"}
    flags = np.arange(10) % 3 == 0
    times = np.arange(1, 8) / 30 + 0.004
    v = views_from_streams(streams, T_world_cam, times, {"a": 0.0, "b": 0.2}, {"b": flags})
    assert v.names == ("a", "b") and v.positions.shape == (2, 7, J, 3)
    expected_b = apply(T_world_cam["b"], interpolate_stream(streams["b"], times + 0.2, max_gap_s=0.05).positions)
    np.testing.assert_allclose(v.positions[1], expected_b, atol=1e-12)
    np.testing.assert_allclose(v.centres[1], T_world_cam["b"][:3, 3])
    np.testing.assert_array_equal(v.back_facing[0], False)
    np.testing.assert_array_equal(v.back_facing[1], flags[1:8])  # 4 ms after each frame: that frame
    with pytest.raises(BadInputError):
        views_from_streams(streams, {"a": np.eye(4)}, times, {"a": 0.0, "b": 0.2})
    with pytest.raises(BadInputError):
        views_from_streams(streams, T_world_cam, times, {"a": 0.0, "b": 0.2}, {"b": flags[:5]})
    with pytest.raises(BadInputError, match="overlap the reference camera's .* for 0% of the session"):
        views_from_streams(streams, T_world_cam, times, {"a": 0.0, "b": 1e12})


# ---------------------------------------------------------------- frontality and distance


@pytest.mark.parametrize("angle_deg", [0.0, 30.0, 75.0, 90.0, 140.0, 180.0])
def test_frontality_is_angle_between_chest_and_camera(angle_deg):
    """Torso facing +z (left shoulder at +x, spine along +y); camera at a known bearing, shoulder height."""
    p = np.full((J, 3), np.nan)
    for lm, xyz in [(Landmark.SHOULDER_LEFT, (0.2, 1.45, 0)), (Landmark.SHOULDER_RIGHT, (-0.2, 1.45, 0)),
                    (Landmark.SPINE_SHOULDER, (0, 1.47, 0)), (Landmark.SPINE_MID, (0, 1.2, 0))]:
        p[TOPO.index(lm)] = xyz
    a = np.radians(angle_deg)
    centre = np.array([[2 * np.sin(a), 1.45, 2 * np.cos(a)]])
    alpha = frontality(_views(p[None, None], centre))
    assert alpha.shape == (1, 1)
    assert alpha[0, 0] == pytest.approx(a, abs=1e-9)


def test_frontality_without_spine_uses_shoulder_depths_and_nan_without_shoulder():
    p = np.full((1, 2, J, 3), np.nan)
    p[0, :, TOPO.index(Landmark.SHOULDER_LEFT)] = (0.2, 1.45, 0.0)
    p[0, :, TOPO.index(Landmark.SHOULDER_RIGHT)] = (-0.2, 1.45, 0.0)
    p[0, 1, TOPO.index(Landmark.SHOULDER_RIGHT)] = np.nan
    a = np.radians(140)
    alpha = frontality(_views(p, np.array([[2 * np.sin(a), 1.45, 2 * np.cos(a)]])))
    assert alpha[0, 0] == pytest.approx(np.radians(40), abs=1e-9)  # front/back unknown: folded to [0, pi/2]
    assert np.isnan(alpha[0, 1])


def test_frontality_ignores_shoulders_below_min_state():
    P = _body()[None, None]
    states = np.full((1, 1, J), TrackingState.TRACKED, np.int8)
    states[0, 0, TOPO.index(Landmark.SHOULDER_LEFT)] = TrackingState.INFERRED
    v = _views(P, _ring(1), states)
    assert np.isfinite(frontality(v)[0, 0])
    assert np.isnan(frontality(v, min_state=TrackingState.TRACKED)[0, 0])


def test_back_facing_skeleton_looks_frontal_until_unflipped():
    """A camera behind the person reports a mirrored (front-facing) skeleton."""
    truth = _body(0.0)
    behind = np.array([[0.0, 1.45, -2.5]])
    reported = truth[TOPO.mirror][None, None]
    v = _views(reported, behind, back=np.ones((1, 1), bool))
    assert frontality(v)[0, 0] < np.radians(20)
    fixed = unflip_back_facing(v)
    assert frontality(fixed)[0, 0] > np.radians(160)
    np.testing.assert_allclose(fixed.positions[0, 0], truth)
    assert fixed.back_facing.all()


def test_distance_is_joint_to_camera_centre():
    P = np.zeros((1, 1, J, 3))
    P[0, 0, 1] = (3.0, 4.0, 0.0)
    P[0, 0, 2] = np.nan
    d = distance(_views(P, np.zeros((1, 3))))
    assert d[0, 0, 1] == pytest.approx(5.0) and d[0, 0, 0] == 0.0 and np.isnan(d[0, 0, 2])


# ---------------------------------------------------------------- weights


def test_weights_values_and_limits():
    params = MergeParams()
    assert weights(0.0, params.d0, MergeMethod.AVG_DIST_FRONTAL) == pytest.approx(1.0)
    assert weights(1.0, 9.0, MergeMethod.AVG_FRONTAL) == pytest.approx(np.exp(-1 / 1.1))
    assert weights(1.0, 2.5, MergeMethod.AVG_DISTANCE) == pytest.approx(np.exp(-4 / 2.0))
    assert weights(1.0, 2.5, MergeMethod.AVG_DIST_FRONTAL) == pytest.approx(np.exp(-1 / 1.1 - 2.0))
    flat = MergeParams(gamma_a=np.inf, gamma_d=np.inf)
    np.testing.assert_array_equal(weights(np.linspace(0, np.pi, 5), 3.0, MergeMethod.AVG_DIST_FRONTAL, flat), 1.0)
    np.testing.assert_array_equal(weights(2.0, np.ones((2, 3)), MergeMethod.AVERAGE).shape, (2, 3))
    with pytest.raises(BadInputError):
        weights(0.0, 1.0, MergeMethod.FRONTALITY)


@pytest.mark.parametrize("change", [dict(gamma_a=0.0), dict(gamma_d=-1.0), dict(d0=np.nan),
                                    dict(unknown_frontality_rad=4.0),
                                    dict(frontality_min_state=TrackingState.NOT_TRACKED)])
def test_merge_params_reject_bad_values(change):
    with pytest.raises(BadInputError):
        MergeParams(**change)


# ---------------------------------------------------------------- merge: properties


@given(seeds, st.integers(1, 5), st.data())
def test_merge_is_invariant_to_camera_order(seed, C, data):
    v = _random_views(np.random.default_rng(seed), C)
    order = data.draw(st.permutations(range(C)))
    w = v.subset([v.names[k] for k in order])
    for method in MergeMethod:
        a, b = merge(v, method), merge(w, method)
        np.testing.assert_array_equal(a.positions, b.positions)
        np.testing.assert_array_equal(a.reliability, b.reliability)
        np.testing.assert_array_equal(a.n_cameras, b.n_cameras)
        name_a = np.where(a.source_camera >= 0, np.array(v.names)[a.source_camera], "")
        name_b = np.where(b.source_camera >= 0, np.array(w.names)[b.source_camera], "")
        np.testing.assert_array_equal(name_a, name_b)


@given(seeds, st.integers(1, 4))
def test_unmeasured_joints_stay_nan_and_measured_ones_are_finite(seed, C):
    rng = np.random.default_rng(seed)
    v = _random_views(rng, C)
    absent = rng.integers(0, J, 3)
    absent = np.union1d(absent, TOPO.mirror[absent])  # a back-facing view fills a joint from its mirror
    P, S = v.positions.copy(), v.states.copy()
    P[:, :, absent], S[:, :, absent] = np.nan, 0
    v = _views(P, v.centres, S, v.back_facing, v.names)
    seen = (unflip_back_facing(v).states > 0).any(axis=0)
    for method in MergeMethod:
        m = merge(v, method)
        assert np.isnan(m.positions[:, absent]).all()
        np.testing.assert_array_equal(np.isfinite(m.positions).all(-1), seen)
        np.testing.assert_array_equal(m.reliability == Reliability.NONE, ~seen)
        np.testing.assert_array_equal(m.n_cameras == 0, ~seen)


def test_all_nan_input_gives_all_nan_without_warnings():
    v = _views(np.full((3, 5, J, 3), np.nan), _ring(3))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for method in MergeMethod:
            m = merge(v, method)
            assert np.isnan(m.positions).all() and (m.reliability == Reliability.NONE).all()
            assert (m.source_camera == -1).all() and (m.n_cameras == 0).all()
    assert merge(_views(np.zeros((2, 0, J, 3)), _ring(2)), MergeMethod.AVERAGE).positions.shape == (0, J, 3)


@given(seeds, st.integers(1, 5))
def test_infinite_gammas_turn_weighted_averages_into_the_average(seed, C):
    v = _random_views(np.random.default_rng(seed), C)
    flat = MergeParams(gamma_a=np.inf, gamma_d=np.inf)
    average = merge(v, MergeMethod.AVERAGE).positions
    np.testing.assert_allclose(merge(v, MergeMethod.AVG_FRONTAL, MergeParams(gamma_a=np.inf)).positions, average,
                               atol=1e-12)
    np.testing.assert_allclose(merge(v, MergeMethod.AVG_DISTANCE, MergeParams(gamma_d=np.inf)).positions, average,
                               atol=1e-12)
    np.testing.assert_allclose(merge(v, MergeMethod.AVG_DIST_FRONTAL, flat).positions, average, atol=1e-12)


@given(seeds, st.integers(1, 5))
def test_identical_measurements_come_out_unchanged(seed, C):
    rng = np.random.default_rng(seed)
    body = _body(rng.uniform(-np.pi, np.pi)) + rng.normal(0, 0.1, 3)
    v = _views(np.broadcast_to(body, (C, 2, J, 3)), _ring(C) + rng.normal(0, 0.3, (C, 3)))
    for method in MergeMethod:
        m = merge(v, method)
        np.testing.assert_allclose(m.positions, np.broadcast_to(body, (2, J, 3)), atol=1e-12)
        assert (m.reliability == Reliability.HIGH).all() and (m.n_cameras == C).all()


@given(seeds, st.integers(1, 5), st.booleans())
def test_selection_methods_return_one_of_the_candidates(seed, C, relabel):
    v = _random_views(np.random.default_rng(seed), C)
    source_views = unflip_back_facing(v) if relabel else v
    for method in (MergeMethod.FRONTALITY, MergeMethod.DISTANCE):
        m = merge(v, method, relabel_back_facing=relabel)
        t, j = np.nonzero(m.source_camera >= 0)
        c = m.source_camera[t, j]
        np.testing.assert_array_equal(m.positions[t, j], source_views.positions[c, t, j])
        np.testing.assert_array_equal(m.source_camera >= 0, m.reliability > Reliability.NONE)
    for method in AVERAGING:
        assert (merge(v, method).source_camera == -1).all()


@given(seeds, st.floats(-np.pi, np.pi))
def test_relabelling_a_flipped_skeleton_restores_left_and_right(seed, yaw):
    """A front camera lacks the left arm; the only other view is a back-facing (mirrored) skeleton."""
    rng = np.random.default_rng(seed)
    truth = _body(yaw)
    facing = Rotation.from_rotvec([0.0, yaw, 0.0]).apply([0.0, 0.0, 2.5]) + [0, 1.3, 0]
    front = truth + rng.normal(0, 0.005, truth.shape)
    left_arm = TOPO.indices(["ElbowLeft", "WristLeft", "HandLeft"])
    front[left_arm] = np.nan
    back = truth[TOPO.mirror] + rng.normal(0, 0.005, truth.shape)
    v = _views(np.stack([front, back])[:, None], np.stack([facing, np.array([0, 2.6, 0]) - facing]),
               back=np.array([[False], [True]]))
    for method in MergeMethod:
        fixed = merge(v, method)
        np.testing.assert_allclose(fixed.positions[0, left_arm], truth[left_arm], atol=0.03)
        assert (fixed.reliability[0, left_arm] == Reliability.BACK_POSE).all()
        others = np.setdiff1d(np.arange(J), left_arm)
        assert (fixed.reliability[0, others] == Reliability.HIGH).all()
        np.testing.assert_allclose(fixed.positions[0, others], front[others])  # front-facing wins
        as_reported = merge(v, method, relabel_back_facing=False)
        np.testing.assert_allclose(as_reported.positions[0, left_arm], truth[TOPO.mirror[left_arm]], atol=0.03)


# ---------------------------------------------------------------- merge: hand-made cases


def test_highest_confidence_wins_and_reliability_follows_table_2_rules():
    P = np.stack([np.full((1, J, 3), float(c)) for c in range(3)])
    states = np.zeros((3, 1, J), np.int8)
    back = np.array([[False], [False], [True]])
    states[:, 0, 0] = (2, 1, 2)  # tracked + inferred + back-facing tracked -> the tracked one
    states[:, 0, 1] = (1, 1, 2)  # inferred twice beat a back-facing tracked
    states[:, 0, 2] = (0, 0, 2)  # only back-facing
    states[:, 0, 3] = (0, 2, 0)
    states[:, 0, 4] = (3, 2, 0)  # K4ABT HIGH above TRACKED
    P[states == 0] = np.nan
    m = merge(_views(P, _ring(3), states, back), MergeMethod.AVERAGE, relabel_back_facing=False)
    np.testing.assert_array_equal(m.positions[0, :5, 0], [0.0, 0.5, 2.0, 1.0, 0.0])
    np.testing.assert_array_equal(m.reliability[0, :5], [Reliability.HIGH, Reliability.LOW, Reliability.BACK_POSE,
                                                         Reliability.HIGH, Reliability.HIGH])
    np.testing.assert_array_equal(m.n_cameras[0, :5], [1, 2, 1, 1, 1])
    assert (m.reliability[0, 5:] == Reliability.NONE).all()


def test_frontality_selects_the_camera_the_person_faces_and_distance_the_closest():
    truth = _body(0.3)
    centres = np.array([[2.0 * np.sin(0.3), 1.4, 2.0 * np.cos(0.3)], [-3.0, 1.4, 0.0], [0.0, 1.4, -0.8]])
    P = np.stack([truth + k * 0.01 for k in range(3)])[:, None]
    v = _views(P, centres)
    front = merge(v, MergeMethod.FRONTALITY)
    assert (front.source_camera == 0).all()
    np.testing.assert_array_equal(front.positions, P[0])
    near = merge(v, MergeMethod.DISTANCE)
    assert (near.source_camera == 2).all()


def test_weighted_average_matches_hand_computed_weights():
    P = np.stack([np.zeros((1, J, 3)), np.ones((1, J, 3))])
    P[:, :, TOPO.index(Landmark.SHOULDER_RIGHT)] = np.nan  # no frontality: unknown_frontality_rad
    centres = np.array([[0.0, 0.0, 0.5], [0.0, 0.0, -1.5]])
    params = MergeParams(unknown_frontality_rad=0.0)
    m = merge(_views(P, centres), MergeMethod.AVG_DISTANCE, params)
    w0 = np.exp(-(0.5 - 0.5) ** 2 / 2.0)
    w1 = np.exp(-(np.sqrt(2 + 2.5**2) - 0.5) ** 2 / 2.0)
    assert m.positions[0, 0, 0] == pytest.approx(w1 / (w0 + w1))
    assert m.positions[0, 3, 2] == pytest.approx(w1 / (w0 + w1))  # joint 3 also at (0|1, 0|1, 0|1)
    frontal = merge(_views(P, centres), MergeMethod.AVG_FRONTAL, params).positions
    np.testing.assert_allclose(np.delete(frontal, TOPO.index(Landmark.SHOULDER_RIGHT), axis=1), 0.5)


def test_merge_rejects_bad_arguments():
    v = _views(np.zeros((1, 1, J, 3)), _ring(1))
    with pytest.raises(BadInputError):
        merge(v, "average")
    with pytest.raises(BadInputError):
        merge(v.positions, MergeMethod.AVERAGE)


# ---------------------------------------------------------------- MergedSkeleton


def test_merged_skeleton_to_stream_maps_reliability_to_states():
    rel = np.array([[Reliability.NONE, Reliability.BACK_POSE, Reliability.LOW, Reliability.HIGH]], np.int8)
    P = np.where((rel == Reliability.NONE)[..., None], np.nan, np.ones((1, 4, 3)))
    topo = KINECT_V2
    m = MergedSkeleton(np.zeros(1), np.concatenate([P, np.ones((1, J - 4, 3))], 1),
                       np.concatenate([rel, np.full((1, J - 4), 3, np.int8)], 1), np.ones((1, J), int),
                       np.full((1, J), -1))
    s = m.to_stream(topo)
    np.testing.assert_array_equal(s.states[0, :4], [TrackingState.NOT_TRACKED, TrackingState.INFERRED,
                                                    TrackingState.INFERRED, TrackingState.TRACKED])
    np.testing.assert_array_equal(s.positions, m.positions)
    with pytest.raises(BadInputError):
        m.to_stream(K4ABT)


def test_merged_skeleton_requires_nan_exactly_where_reliability_is_none():
    with pytest.raises(BadInputError):
        MergedSkeleton(np.zeros(1), np.ones((1, 2, 3)), np.zeros((1, 2), np.int8), np.zeros((1, 2), int),
                       np.full((1, 2), -1))
    with pytest.raises(BadInputError):
        MergedSkeleton(np.zeros(1), np.ones((1, 2, 3)), np.full((1, 2), 3, np.int8), np.zeros((1, 2), int),
                       np.full((1, 2), -2))


@given(transforms())
def test_merge_commutes_with_a_rigid_change_of_world_frame(T_new_world):
    rng = np.random.default_rng(0)
    v = _random_views(rng, 3)
    moved = CameraViews(v.names, TOPO, v.times, apply(T_new_world, v.positions), v.states,
                        apply(T_new_world, v.centres), v.back_facing)
    for method in MergeMethod:
        np.testing.assert_allclose(merge(moved, method).positions, apply(T_new_world, merge(v, method).positions),
                                   atol=1e-9)
