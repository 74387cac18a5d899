"""Hypothesis strategies shared by the tests.

Rotations are built from raw floats drawn by hypothesis (never from numpy's global RNG), in three
regimes: uniform, near identity and near 180 degrees.
"""

from __future__ import annotations

import numpy as np
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from fusion.transforms import make_transform

finite = st.floats(min_value=-1.0, max_value=1.0, allow_nan=False, allow_infinity=False)


@st.composite
def unit_vectors(draw) -> np.ndarray:
    """Unit 3-vectors, uniform enough over the sphere."""
    v = np.array([draw(finite), draw(finite), draw(finite)])
    n = np.linalg.norm(v)
    return np.array([0.0, 0.0, 1.0]) if n < 1e-3 else v / n


@st.composite
def rotations(draw) -> np.ndarray:
    """(3, 3) proper rotations: uniform, near identity or near 180 degrees."""
    axis = draw(unit_vectors())
    regime = draw(st.sampled_from(["uniform", "identity", "half_turn"]))
    if regime == "uniform":
        angle = draw(st.floats(min_value=0.0, max_value=np.pi))
    elif regime == "identity":
        angle = draw(st.floats(min_value=0.0, max_value=1e-6))
    else:
        angle = np.pi - draw(st.floats(min_value=0.0, max_value=1e-6))
    return Rotation.from_rotvec(axis * angle).as_matrix()


@st.composite
def transforms(draw, max_translation: float = 5.0) -> np.ndarray:
    """(4, 4) rigid transforms with translations up to ``max_translation`` metres."""
    t = np.array([draw(finite), draw(finite), draw(finite)]) * max_translation
    return make_transform(draw(rotations()), t)


@st.composite
def point_sets(draw, min_points: int = 1, max_points: int = 30, scale: float = 3.0) -> np.ndarray:
    """(N, 3) point sets from a hypothesis-drawn seed."""
    n = draw(st.integers(min_value=min_points, max_value=max_points))
    rng = np.random.default_rng(draw(st.integers(min_value=0, max_value=2**32 - 1)))
    return rng.uniform(-scale, scale, size=(n, 3))


seeds = st.integers(min_value=0, max_value=2**32 - 1)
