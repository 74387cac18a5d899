"""The public API: scenarios in code, sessions in memory, calibration, fusion, scorers and
bring-your-own algorithms."""

from __future__ import annotations

import numpy as np
import pytest

from fusion.errors import BadInputError
from scenarios import api


@pytest.fixture(scope="module")
def session():
    return api.simulate(api.scenario("fma_2cam", seed=2, duration_s=12))


def test_simulate_is_in_memory_and_reproducible(session, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    again = api.simulate(api.scenario("fma_2cam", seed=2, duration_s=12))
    assert not list(tmp_path.iterdir())
    for a, b in zip(session.recording.cameras, again.recording.cameras):
        np.testing.assert_array_equal(a.skeleton.positions, b.skeleton.positions)
        assert a.depth is None or a.depth.n_frames == 0
    assert session.scenario.seed == 2 and session.recording.camera_names == ("cam1", "cam2")


def test_scenario_changes_and_depth_switch():
    s = api.scenario("ring6", seed=4, duration_s=5, depth=True, rig=api.RigConfig(n_cameras=3))
    assert (s.seed, s.duration_s, s.rig.n_cameras) == (4, 5, 3) and s.sensors.depth_rate_hz > 0
    assert api.scenario("ring6").sensors.depth_rate_hz == 0


def test_true_calibration_scores_zero(session):
    calibration = api.true_calibration(session.recording, session.truth)
    scores = api.score_calibration(calibration, session.truth)
    assert max(c.rotation_error_deg for c in scores.cameras) < 1e-6
    assert max(c.translation_error_mm for c in scores.cameras) < 1e-6
    true = session.truth.camera(calibration.reference).joints_world
    s = api.score_skeleton(true, calibration, session.truth, session.recording.topology)
    assert s.joint_error_mm.max < 1e-9 and s.raised_error_deg["elbow_flexion"].max < 1e-6


def test_the_projects_calibration_and_fusion(session):
    run = api.calibrate(session.recording, seed=2)
    assert run.calibration.camera_names == ("cam1", "cam2") and run.rig.pairs
    scores = api.score_calibration(run.calibration, session.truth).summary()
    assert scores["rotation_error_deg"]["max"] < 5.0
    fused = api.fuse(session.recording, run.calibration)
    assert fused.positions.shape == session.truth.camera(run.calibration.reference).joints_world.shape
    s = api.score_skeleton(fused.positions, run.calibration, session.truth, session.recording.topology)
    assert 5.0 < s.joint_error_mm.median < 300.0


def test_bring_your_own_calibration_and_fusion(session, tmp_path):
    module = tmp_path / "mine.py"
    module.write_text(
        "import numpy as np\n"
        "def poses(recording, *, rng):\n"
        "    return {c.name: np.eye(4) for c in recording.cameras}\n"
        "def first_camera(recording, calibration):\n"
        "    return recording.cameras[0].skeleton.positions\n"
        "def wrong(recording, *, rng):\n"
        "    return 3\n")
    poses = api.load_algorithm(f"{module}:poses")
    calibration = api.run_calibration_algorithm(poses, session.recording, rng=np.random.default_rng(0))
    assert calibration.reference == "cam1" and calibration.clock_offset_s == {"cam1": 0.0, "cam2": 0.0}
    ref = session.recording.cameras[0].skeleton
    out = api.run_fusion_algorithm(api.load_algorithm(f"{module}:first_camera"), session.recording, calibration)
    assert out.shape == ref.positions.shape
    only2 = api.run_fusion_algorithm(api.load_algorithm(f"{module}:first_camera"), session.recording, calibration,
                                     cameras=["cam2"])
    np.testing.assert_array_equal(only2, session.recording.camera("cam2").skeleton.positions)
    with pytest.raises(BadInputError, match="returned int"):
        api.run_calibration_algorithm(api.load_algorithm(f"{module}:wrong"), session.recording,
                                      rng=np.random.default_rng(0))
    with pytest.raises(BadInputError, match=r"returned an array of shape \(3,\)"):
        api.run_fusion_algorithm(lambda r, c: np.zeros(3), session.recording, calibration)
    with pytest.raises(BadInputError, match=r"no pose for camera\(s\) \['cam2'\]"):
        api.calibration_from_poses(session.recording, {"cam1": np.eye(4)})


@pytest.mark.parametrize("spec, message", [
    ("no_colon", "give MODULE:FUNCTION"),
    ("package_that_is_not_there.module:fn", "cannot import package_that_is_not_there.module"),
    ("numpy:not_a_function_here", "numpy has no function not_a_function_here"),
    ("missing/file.py:fn", "no file missing/file.py"),
])
def test_load_algorithm_errors(spec, message):
    with pytest.raises(BadInputError, match=message):
        api.load_algorithm(spec)


def test_load_algorithm_by_module_name():
    assert api.load_algorithm("numpy.linalg:norm") is np.linalg.norm
