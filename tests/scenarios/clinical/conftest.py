"""Fixtures shared by the clinical tests."""

import pytest

from scenarios.clinical.cohort import generate_cohort
from scenarios.sweep import SweepOptions
from tests.scenarios.clinical.test_cohort import tiny_config


@pytest.fixture(scope="session")
def tiny_cohort(tmp_path_factory):
    """The tiny cohort generated on two workers, once per test process for the cohort and the analysis
    tests (which only read it)."""
    out = tmp_path_factory.mktemp("cohort") / "tiny"
    return generate_cohort(tiny_config(), out, sweep=SweepOptions(workers=2, progress=False))
