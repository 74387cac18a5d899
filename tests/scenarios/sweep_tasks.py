"""Light sweep tasks: a Dask worker that unpickles them imports only this module and numpy."""

import time

import numpy as np


def draw(seed, k):
    """A task whose result depends on its seed only; later tasks finish first."""
    time.sleep(0.05 * (3 - k % 4))
    return k, np.random.default_rng(seed).normal(size=5).tolist()
