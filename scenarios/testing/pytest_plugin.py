"""pytest plugin ``mocap_bench`` (entry point ``pytest11``): fixtures with simulated sessions, each
simulated once per test session and shared by every test that asks for it.

Fixtures
--------
mocap_simulate
    ``simulate(scenario) -> Session``: :func:`scenarios.api.simulate` with a cache keyed by the
    scenario's full content (rig, subject, motion, sensor, seed), so tests that build the same scenario
    share one simulation.
mocap_session
    The default two-camera session: ``fma_2cam``, seed 1, 30 s, skeletons only. Override the scenario
    with the ``--mocap-scenario`` option (a built-in name or a scenario TOML).

Sessions are read-only by convention: a test that changes one's arrays changes them for every test.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest

DEFAULT_SCENARIO = "fma_2cam"
DEFAULT_SECONDS = 30.0


def pytest_addoption(parser: pytest.Parser) -> None:
    """``--mocap-scenario NAME_OR_PATH`` and ``--mocap-seconds S``: the scenario of ``mocap_session``."""
    group = parser.getgroup("mocap-bench")
    group.addoption("--mocap-scenario", default=DEFAULT_SCENARIO,
                    help=f"scenario of the mocap_session fixture (default {DEFAULT_SCENARIO})")
    group.addoption("--mocap-seconds", type=float, default=DEFAULT_SECONDS,
                    help=f"length of the mocap_session fixture's session [s] (default {DEFAULT_SECONDS:g})")


@pytest.fixture(scope="session")
def mocap_simulate() -> Callable[[Any], Any]:
    """A cached :func:`scenarios.api.simulate` (see the module docstring)."""
    from scenarios.api import scenario_toml, simulate

    cache: dict[str, Any] = {}

    def run(scenario: Any) -> Any:
        key = scenario_toml(scenario)
        if key not in cache:
            cache[key] = simulate(scenario)
        return cache[key]

    return run


@pytest.fixture(scope="session")
def mocap_session(request: pytest.FixtureRequest, mocap_simulate: Callable[[Any], Any]) -> Any:
    """The session of ``--mocap-scenario`` (default ``fma_2cam``), skeletons only: a
    :class:`scenarios.api.Session` with ``recording`` and ``truth``."""
    from scenarios.api import scenario

    name = request.config.getoption("--mocap-scenario")
    return mocap_simulate(scenario(name, duration_s=request.config.getoption("--mocap-seconds")))
