"""A test suite written as a user would: in a folder of its own, importing only the documented API,
using the plugin's fixtures; run by pytest in a fresh process."""

from __future__ import annotations

import subprocess
import sys
import textwrap


def test_a_users_suite_runs_with_the_plugin(tmp_path):
    (tmp_path / "test_mine.py").write_text(textwrap.dedent('''
        import numpy as np
        from hypothesis import given, settings

        from scenarios import api
        from scenarios.testing import properties, strategies as mb


        def test_fixture_session(mocap_session, mocap_simulate):
            assert mocap_session.recording.camera_names == ("cam1", "cam2")
            assert mocap_simulate(mocap_session.scenario) is mocap_session  # cached per test session


        @settings(max_examples=3, deadline=None, derandomize=True)
        @given(mb.scenarios(rig=mb.ring_rigs(2, 2, arc_deg=(60.0, 90.0)), motion=mb.motions(turn_s=(8.0, 9.0), max_items=0)))
        def test_true_poses_pass(scenario):
            session = api.simulate(scenario)
            calibration = api.true_calibration(session.recording, session.truth)
            properties.check_calibration(calibration, session, max_rotation_deg=1e-6, max_translation_mm=1e-6)
    '''))
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:randomly",
                           "--mocap-seconds", "8", "test_mine.py"], cwd=tmp_path, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "2 passed" in done.stdout
