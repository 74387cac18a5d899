"""Hypothesis profiles: ``ci`` (default, derandomised, fast) and ``nightly`` (many examples), selected with
``HYPOTHESIS_PROFILE=nightly``; the ``small_forests`` fixtures."""

import contextlib
import os

import pytest
from hypothesis import HealthCheck, settings

import fma.classify

settings.register_profile(
    "ci", max_examples=40, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile("nightly", max_examples=2000, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

SMALL_FOREST = 10


@contextlib.contextmanager
def _small_forests():
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(fma.classify, "N_TREES", SMALL_FOREST)  # the classifiers' and the severity regressor's
        yield


@pytest.fixture
def small_forests():
    """Random forests of :data:`SMALL_FOREST` trees instead of ``fma.classify.N_TREES`` during a test: the
    same code on the tests' small cohorts, several times faster (a forest's cost is mostly per tree there)."""
    with _small_forests():
        yield


@pytest.fixture(scope="module")
def small_forests_module():
    """:func:`small_forests` for a whole module (its module-scoped analyses included)."""
    with _small_forests():
        yield
