"""Hypothesis profiles: ``ci`` (default, derandomised, fast) and ``nightly`` (many examples).

Select with ``HYPOTHESIS_PROFILE=nightly``.
"""

import os

from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci", max_examples=40, derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow]
)
settings.register_profile("nightly", max_examples=2000, deadline=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))
