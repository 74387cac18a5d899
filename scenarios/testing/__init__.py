"""Testing other people's algorithms with the bench (``scenarios.testing``): hypothesis strategies
for rigs, subjects, motions, sensor conditions and seeds (:mod:`~scenarios.testing.strategies`),
property checks that name the failing case and a command reproducing it
(:mod:`~scenarios.testing.properties`), and a pytest plugin with simulated-session fixtures cached per
test session (:mod:`~scenarios.testing.pytest_plugin`, registered as the ``pytest11`` entry point
``mocap_bench``).

Imports only the public API (:mod:`scenarios.api`) and the core; ``hypothesis`` and ``pytest`` are needed
by the strategies and the plugin only (the ``testing`` extra).
"""
