import numpy as np
import pytest
from hypothesis import given
from scipy.spatial.transform import Rotation

from fusion.errors import BadInputError
from fusion.transforms import (
    apply,
    compose,
    from_rotvec,
    invert,
    make_transform,
    rotation_angle,
    to_rotvec,
    transform_difference,
    validate_transform,
)
from tests.strategies import point_sets, transforms


@given(transforms())
def test_invert_composes_to_identity(T_a_b):
    np.testing.assert_allclose(compose(T_a_b, invert(T_a_b)), np.eye(4), atol=1e-12)
    np.testing.assert_allclose(compose(invert(T_a_b), T_a_b), np.eye(4), atol=1e-12)


@given(transforms(), transforms(), point_sets())
def test_compose_matches_sequential_apply(T_a_b, T_b_c, p_c):
    np.testing.assert_allclose(apply(compose(T_a_b, T_b_c), p_c), apply(T_a_b, apply(T_b_c, p_c)), atol=1e-12)


@given(transforms(), transforms(), transforms())
def test_compose_is_associative(T1, T2, T3):
    np.testing.assert_allclose(compose(compose(T1, T2), T3), compose(T1, compose(T2, T3)), atol=1e-12)


@given(transforms(), point_sets())
def test_apply_preserves_distances_and_inverts(T_a_b, p_b):
    p_a = apply(T_a_b, p_b)
    d_b = np.linalg.norm(p_b[:, None] - p_b[None], axis=-1)
    d_a = np.linalg.norm(p_a[:, None] - p_a[None], axis=-1)
    np.testing.assert_allclose(d_a, d_b, atol=1e-9)
    np.testing.assert_allclose(apply(invert(T_a_b), p_a), p_b, atol=1e-9)


@given(transforms())
def test_validate_accepts_rigid_and_rotvec_roundtrip(T):
    validate_transform(T)
    rv, t = to_rotvec(T)
    np.testing.assert_allclose(from_rotvec(rv, t), T, atol=1e-9)


@given(transforms())
def test_difference_to_itself_is_zero(T):
    angle, dist = transform_difference(T, T)
    assert angle < 1e-5 and dist < 1e-12


def test_difference_known_values():
    R = Rotation.from_euler("z", 3.0, degrees=True).as_matrix()
    angle, dist = transform_difference(make_transform(R, [0.0, 0.004, 0.003]), np.eye(4))
    assert angle == pytest.approx(3.0) and dist == pytest.approx(0.005)
    assert rotation_angle(R) == pytest.approx(np.radians(3.0))


def test_apply_keeps_nan_and_broadcasts():
    T = make_transform(np.eye(3), [1.0, 2.0, 3.0])
    p = np.array([[[0.0, 0.0, 0.0], [np.nan, np.nan, np.nan]]])
    out = apply(T, p)
    assert out.shape == (1, 2, 3)
    np.testing.assert_array_equal(out[0, 0], [1, 2, 3])
    assert np.isnan(out[0, 1]).all()


@pytest.mark.parametrize(
    "bad, msg",
    [
        (np.eye(3), "shape"),
        (np.full((4, 4), np.nan), "NaN"),
        (np.diag([1.0, 1.0, -1.0, 1.0]), "reflection"),
        (np.diag([2.0, 1.0, 1.0, 1.0]), "orthonormal"),
        (np.vstack([np.eye(4)[:3], [1, 0, 0, 1]]), "last row"),
    ],
)
def test_validate_rejects_bad_transforms(bad, msg):
    with pytest.raises(BadInputError, match=msg):
        validate_transform(bad)


def test_bad_shapes_raise():
    with pytest.raises(BadInputError):
        apply(np.eye(4), np.zeros((3, 2)))
    with pytest.raises(BadInputError):
        make_transform(np.eye(3), np.zeros(2))
    with pytest.raises(BadInputError):
        compose()
