"""The two-pass distance test of the ICP point selection: the same answer as querying every point."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial import cKDTree

from fusion.calibrate.icp_points import within_distance
from fusion.errors import BadInputError


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**31 - 1), st.integers(0, 3000), st.integers(1, 400), st.floats(0.01, 1.0))
def test_within_distance_is_the_per_point_query(seed, n_points, n_tree, radius):
    rng = np.random.default_rng(seed)
    floor = rng.uniform(-2.0, 2.0, (n_points, 3)) * [1.0, 0.02, 1.0] + [0.0, -0.9, 2.5]  # a slab, as a floor
    feet = rng.normal([0.0, -0.85, 2.5], 0.15, (n_tree, 3))
    tree = cKDTree(feet)
    expected = tree.query(floor, distance_upper_bound=radius)[0] < radius
    np.testing.assert_array_equal(within_distance(floor, tree, radius), expected)


def test_points_on_the_radius_are_outside_and_just_inside_are_in():
    tree = cKDTree(np.zeros((1, 3)))
    r = 0.6
    points = np.array([[r, 0.0, 0.0], [0.0, 0.0, r - 1e-9], [0.0, r + 1e-9, 0.0], [0.3, 0.3, 0.0]])
    np.testing.assert_array_equal(within_distance(points, tree, r), [False, True, False, True])
    assert within_distance(np.zeros((0, 3)), tree, r).shape == (0,)
    with pytest.raises(BadInputError, match="finite"):
        within_distance(np.array([[np.nan, 0.0, 0.0]]), tree, r)
