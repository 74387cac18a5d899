"""Kinematic fusion: a known articulated skeleton seen by noisy cameras, weights, invariance, bad input."""

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fusion.errors import BadInputError
from fusion.merge.angles import vertex_angle_deg
from fusion.merge.kinematic import (
    JOINT_LIMITS,
    JointLimit,
    KinematicOptions,
    bone_lengths,
    fit_kinematic,
    limit_bones,
    measurement_targets,
)
from fusion.merge.methods import MergeMethod, merge
from fusion.merge.views import CameraViews
from fusion.topology import KINECT_V2, Landmark, TrackingState
from tests.strategies import seeds

TOPO = KINECT_V2


def true_skeleton(T: int, rng: np.random.Generator, *, elbow_bend_deg: float | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """(T, J, 3) joints of a chain with fixed, left-right symmetric bone lengths (B,) whose bones swing;
    with ``elbow_bend_deg`` the right forearm keeps that bend against the upper arm."""
    bones = TOPO.bones
    L = rng.uniform(0.1, 0.4, len(bones))
    key = {(int(p), int(c)): k for k, (p, c) in enumerate(bones)}
    L = np.array([L[min(k, key.get((int(TOPO.mirror[p]), int(TOPO.mirror[c])), k))] for k, (p, c) in enumerate(bones)])
    base = rng.normal(size=(len(bones), 3))
    base[:, 2] -= 1.5  # mostly hanging down
    swing = rng.normal(scale=0.3, size=(len(bones), 3))
    t = np.linspace(0.0, 1.0, T)[:, None, None]
    u = base[None] + swing[None] * np.sin(2 * np.pi * t)
    u /= np.linalg.norm(u, axis=-1, keepdims=True)
    if elbow_bend_deg is not None:
        upper = key[TOPO.index(Landmark.SHOULDER_RIGHT), TOPO.index(Landmark.ELBOW_RIGHT)]
        fore = key[TOPO.index(Landmark.ELBOW_RIGHT), TOPO.index(Landmark.WRIST_RIGHT)]
        side = np.cross(u[:, upper], [1.0, 0.0, 0.0])
        side /= np.linalg.norm(side, axis=-1, keepdims=True)
        b = np.radians(elbow_bend_deg)
        u[:, fore] = np.cos(b) * u[:, upper] + np.sin(b) * side
    P = np.zeros((T, TOPO.n_joints, 3))
    root = TOPO.parents.index(-1)
    P[:, root] = [0.0, 0.0, 1.0]
    depth = [0] * TOPO.n_joints
    for j in range(TOPO.n_joints):
        k = j
        while TOPO.parents[k] != -1:
            depth[j], k = depth[j] + 1, TOPO.parents[k]
    for k in sorted(range(len(bones)), key=lambda k: depth[bones[k][1]]):  # parents before children
        p, c = bones[k]
        P[:, c] = P[:, p] + L[k] * u[:, k]
    return P, L


def views_of(P: np.ndarray, noise_m: float, rng: np.random.Generator, *, back: tuple[bool, bool] = (False, False),
             offset: np.ndarray | None = None) -> CameraViews:
    T = P.shape[0]
    pos = np.stack([P + rng.normal(scale=noise_m, size=P.shape) for _ in range(2)])
    if offset is not None:
        pos[1] += offset
    states = np.full(pos.shape[:3], TrackingState.TRACKED, dtype=np.int8)
    centres = np.array([[2.0, 1.0, 1.0], [2.0, -1.0, 1.0]])
    return CameraViews(("a", "b"), TOPO, np.arange(T) / 30.0, pos, states, centres,
                       np.array([np.full(T, back[0]), np.full(T, back[1])]))


def _error(positions, P):
    return np.nanmean(np.linalg.norm(positions - P, axis=-1))


def test_fit_recovers_a_chain_better_than_the_merge_with_constant_bone_lengths():
    rng = np.random.default_rng(5)
    P, L = true_skeleton(90, rng)
    views = views_of(P, 0.02, rng)
    fit = fit_kinematic(views)
    merged = merge(views, MergeMethod.AVG_FRONTAL)
    assert fit.merged.positions.shape == P.shape and fit.bone_lengths.shape == L.shape
    assert _error(fit.merged.positions, P) < 0.8 * _error(merged.positions, P)
    lengths = np.linalg.norm(fit.merged.positions[:, TOPO.bones[:, 1]] - fit.merged.positions[:, TOPO.bones[:, 0]], axis=-1)
    assert np.allclose(lengths, fit.bone_lengths[None], atol=1e-9)
    assert fit.residual_mm.shape == (90,) and np.all(np.isfinite(fit.residual_mm))


def test_noise_free_views_are_fitted_exactly():
    rng = np.random.default_rng(2)
    P, L = true_skeleton(20, rng)
    fit = fit_kinematic(views_of(P, 0.0, rng), KinematicOptions(temporal_weight=0.0, limits=()))
    assert np.allclose(fit.merged.positions, P, atol=1e-6) and fit.converged.all()
    # left and right instances of a bone share one length: compare with the averaged truth
    assert np.allclose(fit.bone_lengths, bone_lengths(P, np.ones(P.shape[:2], bool), TOPO), atol=1e-9)


def _elbow_bend_deg(P):
    s, e, w = (P[:, TOPO.index(lm)] for lm in (Landmark.SHOULDER_RIGHT, Landmark.ELBOW_RIGHT, Landmark.WRIST_RIGHT))
    return 180.0 - vertex_angle_deg(s, e, w)


@pytest.mark.parametrize("bend_deg", [120.0, 175.0])
def test_the_elbow_limit_bounds_the_fit_and_nothing_within_it(bend_deg):
    rng = np.random.default_rng(4)
    P, _ = true_skeleton(30, rng, elbow_bend_deg=bend_deg)
    views = views_of(P, 0.0, rng)
    elbow = tuple(lim for lim in JOINT_LIMITS if lim.joint is Landmark.ELBOW_RIGHT)  # the chain's other bends are random
    free = fit_kinematic(views, KinematicOptions(temporal_weight=0.0, limits=()))
    limited = fit_kinematic(views, KinematicOptions(temporal_weight=0.0, limits=elbow))
    assert np.allclose(_elbow_bend_deg(free.merged.positions), bend_deg, atol=1e-3)
    bound = elbow[0].max_bend_deg
    got = _elbow_bend_deg(limited.merged.positions)
    if bend_deg < bound:
        assert np.allclose(limited.merged.positions, P, atol=1e-6) and np.all(limited.at_limit == 0)
    else:
        assert np.all(got < bound + 1e-6) and np.all(got > bound - 1.0)
        assert np.all(limited.at_limit == 1) and np.all(free.at_limit == 0)


def test_limit_bones_skip_what_the_topology_lacks():
    b_in, b_out, bound = limit_bones(TOPO, JOINT_LIMITS)
    assert len(b_in) == len(JOINT_LIMITS)  # Kinect v2 has every bone pair
    assert np.all(TOPO.bones[b_in, 1] == TOPO.bones[b_out, 0])
    none = (JointLimit(Landmark.SHOULDER_LEFT, Landmark.HIP_LEFT, Landmark.KNEE_LEFT, 90.0),)
    assert limit_bones(TOPO, none)[0].size == 0
    with pytest.raises(BadInputError, match="max_bend_deg"):
        JointLimit(Landmark.SHOULDER_LEFT, Landmark.ELBOW_LEFT, Landmark.WRIST_LEFT, 180.0)


def test_measurements_from_a_back_facing_skeleton_weigh_less():
    rng = np.random.default_rng(1)
    P, _ = true_skeleton(3, rng)
    offset = np.array([0.1, 0.0, 0.0])
    options = KinematicOptions()
    W, m = measurement_targets(views_of(P, 0.0, rng, offset=offset), options)
    Wb, mb = measurement_targets(views_of(P, 0.0, rng, offset=offset, back=(False, True)), options)
    head = TOPO.index(Landmark.HEAD)
    assert np.all(np.abs(mb[:, head, 0] - P[:, head, 0]) < np.abs(m[:, head, 0] - P[:, head, 0]))
    assert np.all(Wb < W)


def test_unmeasured_joints_stay_nan():
    rng = np.random.default_rng(3)
    P, _ = true_skeleton(10, rng)
    views = views_of(P, 0.01, rng)
    pos, st_ = views.positions.copy(), views.states.copy()
    hand = TOPO.index(Landmark.HAND_LEFT)
    pos[:, 4:6, hand] = np.nan
    st_[:, 4:6, hand] = TrackingState.NOT_TRACKED
    fit = fit_kinematic(dataclasses.replace(views, positions=pos, states=st_))
    assert np.isnan(fit.merged.positions[4:6, hand]).all()
    assert np.isfinite(fit.merged.positions[:4, hand]).all()


@settings(max_examples=5, deadline=None)
@given(seeds, st.floats(-3.0, 3.0), st.floats(-3.0, 3.0))
def test_fit_moves_with_a_translation_of_the_measurements(seed, dx, dy):
    rng = np.random.default_rng(seed)
    P, _ = true_skeleton(12, rng)
    views = views_of(P, 0.01, rng)
    shift = np.array([dx, dy, 0.0])
    moved = dataclasses.replace(views, positions=views.positions + shift, centres=views.centres + shift)
    a, b = fit_kinematic(views), fit_kinematic(moved)
    assert np.allclose(a.merged.positions + shift, b.merged.positions, atol=1e-6)


def test_bad_input_is_rejected():
    with pytest.raises(BadInputError, match="CameraViews"):
        fit_kinematic(np.zeros((2, 3, 25, 3)))
    with pytest.raises(BadInputError, match="inferred_weight"):
        KinematicOptions(inferred_weight=0.0)
    with pytest.raises(BadInputError, match="at least 1"):
        KinematicOptions(iterations=0)
    rng = np.random.default_rng(0)
    P, _ = true_skeleton(4, rng)
    P[:, TOPO.index(Landmark.FOOT_LEFT)] = np.nan
    P[:, TOPO.index(Landmark.FOOT_RIGHT)] = np.nan  # one foot alone would take the other's length
    with pytest.raises(BadInputError, match="never measured"):
        bone_lengths(P, np.ones(P.shape[:2], bool), TOPO)


def test_a_bone_never_measured_takes_its_mirrors_length_and_without_either_is_refused():
    rng = np.random.default_rng(5)
    T, J = 20, KINECT_V2.n_joints
    rest = np.array([KINECT_V2.joints.index(n) for n in KINECT_V2.joints], dtype=float)[:, None] * [0.01, 0.02, 0.03]
    positions = rest[None] + rng.normal(0, 1e-4, (T, J, 3))
    reliable = np.ones((T, J), dtype=bool)
    full = bone_lengths(positions, reliable, KINECT_V2)
    hand = KINECT_V2.joints.index("HandLeft")
    positions[:, hand] = np.nan  # the left hand never reported
    missing = bone_lengths(positions, reliable, KINECT_V2)
    bones = KINECT_V2.bones
    into_hand = int(np.flatnonzero(bones[:, 1] == hand)[0])
    twin = int(np.flatnonzero(bones[:, 1] == KINECT_V2.mirror[hand])[0])
    assert missing[into_hand] == missing[twin] == pytest.approx(np.median(np.linalg.norm(
        positions[:, bones[twin, 1]] - positions[:, bones[twin, 0]], axis=-1)))
    assert np.all(np.isfinite(missing)) and missing[into_hand] != full[into_hand]
    positions[:, KINECT_V2.mirror[hand]] = np.nan  # and the right one
    with pytest.raises(BadInputError, match="HandLeft.*never measured.*--fit merge"):
        bone_lengths(positions, reliable, KINECT_V2)
