"""Small numeric helpers against numpy's own."""

import warnings

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from fusion.arrays import nanmedian


@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 9), cols=st.integers(1, 6), missing=st.floats(0, 1),
       axis=st.sampled_from([0, 1]))
def test_nanmedian_is_numpys_bit_for_bit(seed, n, cols, missing, axis):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, cols)) if axis == 0 else rng.normal(size=(cols, n))
    x[rng.random(x.shape) < missing] = np.nan
    got = nanmedian(x, axis=axis)
    assert got.shape == (cols,)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        expected = np.nanmedian(x, axis=axis) if n else np.full(cols, np.nan)
    assert np.array_equal(got, expected, equal_nan=True)
