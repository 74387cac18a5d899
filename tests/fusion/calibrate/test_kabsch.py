import numpy as np
import pytest
from hypothesis import assume, given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fusion.calibrate.kabsch import kabsch, kabsch_batch
from fusion.errors import BadInputError
from fusion.transforms import (
    apply,
    compose,
    invert,
    make_transform,
    transform_difference,
    validate_transform,
)
from tests.strategies import point_sets, seeds, transforms


def _spread_ratio(p: np.ndarray) -> float:
    s = np.linalg.svd(p - p.mean(axis=0), compute_uv=False)
    return s[1] / s[0]


def test_identity_smoke():
    p = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    T = kabsch(p, p)
    assert T.shape == (4, 4)
    np.testing.assert_allclose(T, np.eye(4), atol=1e-12)


@given(transforms(), point_sets(min_points=3))
def test_recovers_any_rigid_transform_exactly(T_a_b, p_b):
    assume(_spread_ratio(p_b) > 1e-3)
    T = kabsch(p_b, apply(T_a_b, p_b))
    validate_transform(T)
    angle, dist = transform_difference(T, T_a_b)
    assert angle < 1e-6 and dist < 1e-8


@given(transforms(), seeds)
def test_matches_scipy_align_vectors_on_noisy_weighted_data(T_a_b, seed):
    rng = np.random.default_rng(seed)
    p_b = rng.uniform(-2, 2, size=(12, 3))
    p_a = apply(T_a_b, p_b) + rng.normal(0, 0.05, size=p_b.shape)
    w = rng.uniform(0.1, 2.0, size=12)
    T = kabsch(p_b, p_a, w)
    c_a, c_b = np.average(p_a, axis=0, weights=w), np.average(p_b, axis=0, weights=w)
    R_oracle, _ = Rotation.align_vectors(p_a - c_a, p_b - c_b, weights=w)
    T_oracle = make_transform(R_oracle.as_matrix(), c_a - R_oracle.apply(c_b))
    angle, dist = transform_difference(T, T_oracle)
    assert angle < 1e-6 and dist < 1e-6


def test_returns_proper_rotation_when_best_orthogonal_fit_is_a_reflection():
    rng = np.random.default_rng(3)
    p_b = rng.normal(size=(10, 3))
    p_a = p_b * [1.0, 1.0, -1.0]
    T = kabsch(p_b, p_a)
    assert np.linalg.det(T[:3, :3]) == pytest.approx(1.0)
    validate_transform(T)


@given(st.lists(transforms(), min_size=1, max_size=6), seeds)
def test_batch_matches_unbatched(Ts, seed):
    rng = np.random.default_rng(seed)
    p_b = rng.uniform(-1, 1, size=(len(Ts), 5, 3))
    p_a = np.stack([apply(T, p) for T, p in zip(Ts, p_b)]) + rng.normal(0, 0.01, p_b.shape)
    T_batch, ok = kabsch_batch(p_b, p_a)
    assert T_batch.shape == (len(Ts), 4, 4) and ok.shape == (len(Ts),) and ok.all()
    for k in range(len(Ts)):
        np.testing.assert_allclose(T_batch[k], kabsch(p_b[k], p_a[k]), atol=1e-12)
    np.testing.assert_allclose(kabsch(p_b, p_a), T_batch, atol=0)


def test_batch_over_two_leading_axes():
    rng = np.random.default_rng(0)
    p_b = rng.normal(size=(2, 3, 4, 3))
    T, ok = kabsch_batch(p_b, p_b + 1.0)
    assert T.shape == (2, 3, 4, 4) and ok.shape == (2, 3) and ok.all()
    np.testing.assert_allclose(T[..., :3, 3], np.ones((2, 3, 3)), atol=1e-12)


def test_batch_flags_degenerate_items_and_returns_identity_there():
    rng = np.random.default_rng(1)
    good = rng.normal(size=(3, 3))
    collinear = np.outer([0.0, 1.0, 2.0], [1.0, 2.0, 3.0])
    coincident = np.ones((3, 3))
    with_nan = good.copy()
    with_nan[1] = np.nan
    p_b = np.stack([good, collinear, coincident, with_nan])
    T, ok = kabsch_batch(p_b, p_b + 0.5)
    assert ok.tolist() == [True, False, False, False]
    np.testing.assert_allclose(T[1:], np.broadcast_to(np.eye(4), (3, 4, 4)))


def test_zero_weight_points_are_ignored_even_if_nan():
    rng = np.random.default_rng(2)
    T_a_b = make_transform(Rotation.from_rotvec([0.3, -0.2, 1.0]).as_matrix(), [1.0, 2.0, 3.0])
    p_b = rng.normal(size=(6, 3))
    p_a = apply(T_a_b, p_b)
    p_a[4] += 10.0
    p_b[5] = np.nan
    w = np.array([1.0, 1.0, 1.0, 1.0, 0.0, 0.0])
    np.testing.assert_allclose(kabsch(p_b, p_a, w), T_a_b, atol=1e-12)
    np.testing.assert_allclose(kabsch(p_b[:4], p_a[:4]), T_a_b, atol=1e-12)


def test_inverse_fit_is_the_inverse():
    rng = np.random.default_rng(4)
    p_b = rng.normal(size=(8, 3))
    p_a = p_b @ Rotation.from_rotvec([0.0, 0.5, 0.1]).as_matrix().T + rng.normal(0, 0.1, size=(8, 3))
    np.testing.assert_allclose(compose(kabsch(p_b, p_a), kabsch(p_a, p_b)), np.eye(4), atol=1e-12)
    np.testing.assert_allclose(kabsch(p_a, p_b), invert(kabsch(p_b, p_a)), atol=1e-12)


@pytest.mark.parametrize(
    "p_b, p_a, weights",
    [
        (np.zeros((4, 2)), np.zeros((4, 2)), None),
        (np.zeros((4, 3)), np.zeros((5, 3)), None),
        (np.zeros(3), np.zeros(3), None),
        (np.eye(3), np.eye(3), np.ones(4)),
        (np.eye(3), np.eye(3), -np.ones(3)),
        (np.eye(3), np.eye(3), np.array([1.0, np.nan, 1.0])),
    ],
)
def test_bad_arguments_raise(p_b, p_a, weights):
    with pytest.raises(BadInputError):
        kabsch(p_b, p_a, weights)
    with pytest.raises(BadInputError):
        kabsch_batch(p_b, p_a, weights)


@pytest.mark.parametrize(
    "p_b",
    [
        np.eye(3)[:2],
        np.outer(np.arange(5.0), [0.2, 0.3, 0.4]) + 1.0,
        np.array([[0.0, 0, 0], [1, 1, 1], [np.nan, 0, 0]]),
    ],
    ids=["two_points", "collinear", "nan"],
)
def test_degenerate_unbatched_raises(p_b):
    with pytest.raises(BadInputError, match="degenerate"):
        kabsch(p_b, p_b + 1.0)
