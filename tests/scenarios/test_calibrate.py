"""End-to-end calibration on short simulated sessions, its file format, and its failure modes."""

import dataclasses
import tomllib

import numpy as np
import pytest

from fusion.calibrate.icp_result import IcpResult
from fusion.calibrate.options import (
    CalibrationOptions,
    JointWeighting,
    Refinement,
    RigMethod,
    SkeletonFit,
)
from fusion.calibrate.pair import body_speed, calibrate_pair, icp_instants
from fusion.calibrate.pipeline import calibrate_rig
from fusion.calibrate.results import calibration_from_rig, relative_poses
from fusion.depth import DepthStream
from fusion.errors import (
    BadInputError,
    CalibrationError,
    RecordingError,
    StaticPersonError,
)
from fusion.io.calibration_file import load_calibration, save_calibration
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.transforms import compose, from_rotvec, transform_difference
from scenarios.cli import main
from scenarios.config import scenario_from_dict
from scenarios.runner import simulate, simulate_to_disk


def _scenario(angles, segments, duration=None, depth_rate=1.0):
    doc = {
        "scenario": {"name": "t", "seed": 3} | ({"duration_s": duration} if duration else {}),
        "rig": {"angles_deg": angles, "radius_m": 2.0, "target_height_m": 0.9},
        "sensors": {"depth_rate_hz": depth_rate},
        "session": {"segment": segments},
    }
    return scenario_from_dict(doc)


TURN = [{"kind": "idle", "duration_s": 1.0}, {"kind": "calibration_turn", "duration_s": 16.0},
        {"kind": "hand_lift", "side": "right", "repetitions": 2}]


@pytest.fixture(scope="module")
def two_cameras():
    return simulate(_scenario([45.0, -45.0], TURN), progress=False)


@pytest.fixture(scope="module")
def calibrated(two_cameras):
    rec, _ = two_cameras
    return calibrate_rig(rec, CalibrationOptions(refine=Refinement.ICP), rng=np.random.default_rng(0))


def _errors(calib, truth):
    true_rel = relative_poses(truth.T_world_cam(), calib.reference)
    return {n: transform_difference(calib.T_ref_cam[n], true_rel[n]) for n in calib.T_ref_cam}


def test_two_camera_calibration_is_close_to_truth(calibrated, two_cameras):
    _, truth = two_cameras
    pair = calibrated.pairs[0]
    assert pair.refined, pair.icp_note
    angle, dist = _errors(calibrated, truth)["cam2"]
    assert angle < 1.0 and dist < 0.025
    skel_angle, skel_dist = transform_difference(pair.T_a_b_skeleton, relative_poses(truth.T_world_cam(), "cam1")["cam2"])
    assert skel_angle < 3.0 and skel_dist < 0.12
    assert 0.5 < pair.ransac.support <= 1.0
    assert pair.rotation_std_deg > 0 and pair.translation_std_mm > 0
    # the world frame: floor at z = 0 (camera heights right), cameras at the right distance from the subject
    for name, T in calibrated.T_world_cam.items():
        T_true = truth.camera(name).T_world_cam
        assert abs(T[2, 3] - T_true[2, 3]) < 0.05
        assert abs(np.linalg.norm(T[:2, 3]) - np.linalg.norm(T_true[:2, 3])) < 0.1


def test_clock_offset_is_recovered(calibrated, two_cameras):
    _, truth = two_cameras
    true_offset = truth.camera("cam2").clock_offset_s - truth.camera("cam1").clock_offset_s
    # a quarter frame: with the Kinect v2 profile refined on replicas of real recordings (errors that grow
    # with the joints' speed, so the noise follows the motion the estimate correlates) this simulated session's
    # estimate is 6.2 ms off; with the profile fitted from the statistics alone 3.4 ms, with the former
    # white-noise defaults < 3 ms
    assert abs(calibrated.clock_offset_s["cam2"] - true_offset) < 0.0083


def test_skeleton_only_and_chain_variants(two_cameras):
    rec, truth = two_cameras
    calib = calibrate_rig(rec, CalibrationOptions(refine=Refinement.NONE, rig=RigMethod.CHAIN),
                          rng=np.random.default_rng(1))
    assert calib.pairs[0].icp is None and calib.solution is None
    angle, dist = _errors(calib, truth)["cam2"]
    assert angle < 3.0 and dist < 0.12


def test_plain_skeleton_fit_refits_once_on_every_frame(two_cameras):
    rec, truth = two_cameras
    options = CalibrationOptions(refine=Refinement.NONE, skeleton_fit=SkeletonFit.PLAIN, estimate_clock=False)
    calib = calibrate_rig(rec, options, rng=np.random.default_rng(1))
    robust = calibrate_rig(rec, CalibrationOptions(refine=Refinement.NONE, estimate_clock=False),
                           rng=np.random.default_rng(1))
    assert calib.pairs[0].ransac.n_refits == 1 and robust.pairs[0].ransac.n_refits > 1
    assert calib.pairs[0].ransac.candidates.shape[0] > robust.pairs[0].ransac.candidates.shape[0]
    angle, dist = _errors(calib, truth)["cam2"]
    assert angle < 3.0 and dist < 0.12


def test_uniform_joint_weighting_keeps_the_robust_refits(two_cameras):
    rec, truth = two_cameras
    options = CalibrationOptions(refine=Refinement.NONE, estimate_clock=False, joint_weighting=JointWeighting.RESIDUAL)
    residual = calibrate_rig(rec, options, rng=np.random.default_rng(1)).pairs[0]
    calib = calibrate_rig(rec, CalibrationOptions(refine=Refinement.NONE, estimate_clock=False),
                          rng=np.random.default_rng(1))
    uniform = calib.pairs[0]
    assert uniform.ransac.n_refits > 1
    np.testing.assert_array_equal(uniform.ransac.candidates, residual.ransac.candidates)
    assert not np.allclose(uniform.T_a_b_skeleton, residual.T_a_b_skeleton)
    angle, dist = _errors(calib, truth)["cam2"]
    assert angle < 3.0 and dist < 0.12
    with pytest.raises(BadInputError, match="joint_weighting"):
        CalibrationOptions(joint_weighting="uniform")


def test_calibration_file_roundtrip(calibrated, tmp_path):
    cal = calibration_from_rig(calibrated)
    save_calibration(cal, tmp_path / "c.toml")
    back = load_calibration(tmp_path / "c.toml")
    assert back.camera_names == cal.camera_names and back.reference == "cam1"
    for n in cal.camera_names:
        np.testing.assert_array_equal(back.pose(n), cal.pose(n))
        assert back.intrinsics[n] == cal.intrinsics[n]
    doc = tomllib.loads((tmp_path / "c.toml").read_text())
    assert len(doc["camera"][0]["T_world_cam"]) == 4 and doc["pair"][0]["icp"] == "accepted"
    (tmp_path / "bad.toml").write_text("format = 'mocap-bench-calibration'\nversion = 1\n[[camera]]\nname='x'\n")
    with pytest.raises(RecordingError, match="inconsistent"):
        load_calibration(tmp_path / "bad.toml")
    with pytest.raises(RecordingError, match="does not exist"):
        load_calibration(tmp_path / "none.toml")


def test_static_person_is_refused():
    rec, _ = simulate(_scenario([45.0, -45.0], [{"kind": "idle", "duration_s": 6.0}], depth_rate=0.0), progress=False)
    with pytest.raises(StaticPersonError, match="static in camera cam1"):
        calibrate_rig(rec, CalibrationOptions(refine=Refinement.NONE), rng=np.random.default_rng(0))


def test_only_back_views_are_refused():
    segments = [{"kind": "hand_lift", "side": "right", "repetitions": 3}]
    rec, truth = simulate(_scenario([150.0, -150.0], segments, depth_rate=0.0), progress=False)
    assert all(c.flipped.mean() > 0.9 for c in truth.cameras)
    with pytest.raises(CalibrationError, match="behind"):
        calibrate_rig(rec, CalibrationOptions(refine=Refinement.NONE), rng=np.random.default_rng(0))


def test_camera_that_never_sees_the_person_is_named(two_cameras):
    rec, _ = two_cameras
    sk = rec.camera("cam2").skeleton
    blind = SkeletonStream(sk.topology, sk.timestamps, np.full(sk.positions.shape, np.nan),
                           np.zeros(sk.states.shape, np.int8))
    cams = (rec.camera("cam1"), CameraRecording("cam2", rec.camera("cam2").intrinsics, blind))
    with pytest.raises(CalibrationError, match="cam2 never tracks the person"):
        calibrate_rig(Recording(cams), rng=np.random.default_rng(0))


def test_no_overlap_in_time(two_cameras):
    rec, _ = two_cameras
    sk = rec.camera("cam2").skeleton
    later = SkeletonStream(sk.topology, sk.timestamps + 1000.0, sk.positions, sk.states)
    cams = (rec.camera("cam1"), CameraRecording("cam2", rec.camera("cam2").intrinsics, later))
    with pytest.raises(CalibrationError, match="no simultaneous frames|overlap"):
        calibrate_rig(Recording(cams), CalibrationOptions(refine=Refinement.NONE, estimate_clock=False),
                      rng=np.random.default_rng(0))


def test_too_few_shared_joints(two_cameras):
    rec, _ = two_cameras
    sk = rec.camera("cam2").skeleton
    short = sk.subset(slice(0, 6))
    cams = (rec.camera("cam1"), CameraRecording("cam2", rec.camera("cam2").intrinsics, short))
    with pytest.raises(CalibrationError, match=r"only \d+ joint measurements"):
        calibrate_rig(Recording(cams), CalibrationOptions(refine=Refinement.NONE, estimate_clock=False),
                      rng=np.random.default_rng(0))


def test_single_camera_is_refused(two_cameras):
    rec, _ = two_cameras
    with pytest.raises(CalibrationError, match="at least two cameras"):
        calibrate_rig(Recording((rec.camera("cam1"),)), rng=np.random.default_rng(0))


def test_cli_calibrate_and_evaluate(tmp_path, capsys):
    run = simulate_to_disk(_scenario([45.0, -45.0], TURN, depth_rate=0.5), tmp_path / "run", progress=False)
    assert main(["calibrate", str(run), "--out", str(tmp_path / "c.toml"), "--refine", "none", "--rig", "chain"]) == 0
    assert main(["evaluate", str(run), "--calib", str(tmp_path / "c.toml"), "--out", str(tmp_path / "ev")]) == 0
    import json

    result = json.loads((tmp_path / "ev" / "result.json").read_text())
    assert set(result["cameras"]) == {"cam1", "cam2"}
    assert result["cameras"]["cam1"]["rotation_error_deg"] < 1e-6
    residual = tmp_path / "residual.toml"
    assert main(["calibrate", str(run), "--out", str(residual), "--refine", "none", "--rig", "chain",
                 "--joint-weighting", "residual"]) == 0
    assert residual.read_text() != (tmp_path / "c.toml").read_text()
    assert result["cameras"]["cam2"]["rotation_error_deg"] < 3.0
    within = result["truth_free"]["within_5cm_pct"]
    assert 0.0 < within["all"] <= 100.0 and 0.0 < within["confidence2"] <= 100.0
    assert (tmp_path / "ev" / "report.md").read_text().startswith("# Calibration evaluation")
    assert main(["calibrate", str(tmp_path / "nothing"), "--out", str(tmp_path / "x.toml")]) == 2
    assert "not a recording directory" in capsys.readouterr().err


def test_azure_kinect_topology_end_to_end():
    doc = {"scenario": {"name": "t", "seed": 2}, "subject": {"topology": "k4abt"},
           "rig": {"angles_deg": [45.0, -45.0], "radius_m": 2.0}, "sensors": {"depth_rate_hz": 0.0},
           "session": {"segment": TURN}}
    rec, truth = simulate(scenario_from_dict(doc), progress=False)
    from fusion.camera import AxisConvention

    assert rec.topology.n_joints == 32 and rec.cameras[0].intrinsics.axes is AxisConvention.OPENCV
    calib = calibrate_rig(rec, CalibrationOptions(refine=Refinement.NONE), rng=np.random.default_rng(0))
    angle, dist = _errors(calib, truth)["cam2"]
    assert angle < 3.0 and dist < 0.12


def test_session_spread_known_values():
    from fusion.errors import BadInputError
    from fusion.transforms import make_transform
    from scenarios.evaluate import session_spread, session_to_session_rmse_mm

    p_ref = np.array([[0.0, 0.0, 2.0], [0.5, 0.2, 2.5], [-0.3, 0.8, 3.0]])
    base = make_transform(np.eye(3), [1.0, 0.0, 0.0])
    sessions = [{"cam1": np.eye(4), "cam2": make_transform(np.eye(3), [1.0 + dx, 0.0, 0.0])} for dx in (0.01, 0.0, -0.01)]
    spread = session_spread(sessions, p_ref)
    assert spread.cameras == ("cam2",)
    np.testing.assert_allclose(spread.per_session_mm, [10.0, 0.0, 10.0], atol=1e-9)
    assert spread.spread_mm == pytest.approx(10.0 * np.sqrt(2 / 3))
    assert spread.pairwise_rmse_mm[0, 2] == pytest.approx(20.0)
    # session_to_session_rmse_mm also averages the reference camera's zero distances in
    assert spread.pairwise_rmse_mm[0, 1] == pytest.approx(
        np.sqrt(2) * session_to_session_rmse_mm(sessions[0], sessions[1], p_ref))
    assert spread.pairwise().median == pytest.approx(10.0)
    same = session_spread([{"cam1": np.eye(4), "cam2": base}] * 4, p_ref)
    assert same.spread_mm == pytest.approx(0.0, abs=1e-9) and same.pairwise().max == pytest.approx(0.0, abs=1e-9)
    with pytest.raises(BadInputError):
        session_spread(sessions[:1], p_ref)
    with pytest.raises(BadInputError):
        session_spread([{"cam1": np.eye(4)}, {"cam1": np.eye(4)}], p_ref)
    with pytest.raises(BadInputError):
        session_spread(sessions, np.zeros((0, 3)))
    assert spread.interval_mm is None  # three sessions: too few for an interval
    same5 = session_spread([{"cam1": np.eye(4), "cam2": base}] * 5, p_ref)
    assert same5.interval_mm == pytest.approx((0.0, 0.0), abs=1e-9)


def test_session_spread_interval_is_the_bootstrap_of_the_spread():
    """The interval's shortcut (one Gram matrix for every resample) gives what resampling the
    sessions and recomputing the spread gives, corrected for the mean square's (S - 1) / S bias; and,
    relative to the spread, it narrows as sessions of the same rig accumulate."""
    from fusion.transforms import make_transform
    from scenarios.evaluate import SPREAD_BOOTSTRAP, session_spread

    rng = np.random.default_rng(3)
    p_ref = rng.uniform([-0.5, -0.5, 2.0], [0.5, 1.0, 3.5], (40, 3))

    def sessions(n):
        out = []
        for _ in range(n):
            axis = rng.normal(size=3)
            angle = np.radians(rng.normal(0.0, 0.3))
            K = np.cross(np.eye(3), axis / np.linalg.norm(axis))
            R = np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K
            out.append({"cam1": np.eye(4), "cam2": make_transform(R, [1.0, 0.0, 0.0] + rng.normal(0.0, 0.004, 3))})
        return out

    few = sessions(8)
    spread = session_spread(few, p_ref)
    low, high = spread.interval_mm
    assert 0 < low < spread.spread_mm < high
    draws = np.random.default_rng(0).multinomial(8, np.full(8, 1 / 8), size=SPREAD_BOOTSTRAP)
    direct = [session_spread([s for s, k in zip(few, w) for _ in range(k)], p_ref).spread_mm * np.sqrt(8 / 7)
              if np.count_nonzero(w) > 1 else 0.0 for w in draws]
    np.testing.assert_allclose([low, high], np.percentile(direct, [2.5, 97.5]), rtol=1e-9)
    more = session_spread(few + sessions(56), p_ref)
    assert more.interval_mm[0] < more.spread_mm < more.interval_mm[1]
    assert np.diff(more.interval_mm)[0] / more.spread_mm < 0.8 * (high - low) / spread.spread_mm


def test_cli_calibrates_one_rig_from_two_sessions_and_compares_them(tmp_path, capsys):
    """Two sessions of one rig (seeds 3 and 4, skeletons only): pooled calibration near the truth,
    per-session calibrations compared by `evaluate --compare` with several calibrations."""
    runs = []
    for seed in (3, 4):
        scenario = _scenario([45.0, -45.0], TURN, depth_rate=0.0).replace(seed=seed)
        runs.append(simulate_to_disk(scenario, tmp_path / f"run{seed}", progress=False))
    common = ["--refine", "none", "--rig", "chain"]
    assert main(["calibrate", *map(str, runs), "--out", str(tmp_path / "pooled.toml"), *common]) == 0
    assert "2 sessions pooled" in capsys.readouterr().out
    for k, run in enumerate(runs):
        assert main(["calibrate", str(run), "--out", str(tmp_path / f"c{k}.toml"), *common]) == 0
    from scenarios.runner import load_truth_if_any

    truth = load_truth_if_any(runs[0])
    pooled = load_calibration(tmp_path / "pooled.toml")
    true_rel = relative_poses(truth.T_world_cam(), "cam1")["cam2"]
    angle, dist = transform_difference(relative_poses(pooled.T_world_cam, "cam1")["cam2"], true_rel)
    assert angle < 3.0 and dist < 0.12
    assert main(["evaluate", str(runs[0]), "--calib", str(tmp_path / "c0.toml"), "--out", str(tmp_path / "ev"),
                 "--compare", str(tmp_path / "c1.toml"), str(tmp_path / "pooled.toml")]) == 0
    import json

    result = json.loads((tmp_path / "ev" / "result.json").read_text())
    spread = result["truth_free"]["session_spread"]
    assert spread["sessions"] == 3 and spread["cameras"] == ["cam2"]
    assert 0 < spread["spread_mm"] < 200 and len(spread["per_session_mm"]) == 3
    assert spread["spread_interval_mm"] is None  # three calibrations: too few for an interval
    assert "interval over the sessions" not in (tmp_path / "ev" / "report.md").read_text()


def test_icp_instants_survive_a_clock_offset_a_frame_off(two_cameras):
    """Depth frame pairs are chosen by how far the body moves between them, not by a fixed time
    tolerance: with the clock offset wrong by 40 ms (more than a frame) the still instants remain."""
    rec, truth = two_cameras
    cam1, cam2 = rec.camera("cam1"), rec.camera("cam2")
    true_offset = truth.camera("cam2").clock_offset_s - truth.camera("cam1").clock_offset_s
    options = CalibrationOptions()
    for offset in (true_offset, true_offset + 0.04):
        chosen = icp_instants(cam1, cam2, offset, options)
        assert options.icp_min_instants <= chosen.shape[0] <= options.icp_instants
        t_a = cam1.depth.timestamps[chosen[:, 0]]
        dt = np.abs(t_a - (cam2.depth.timestamps[chosen[:, 1]] - offset))
        assert np.all(body_speed(cam1.skeleton, t_a) * dt <= options.icp_max_shift_m)
    first = icp_instants(cam1, cam2, true_offset, options)
    interleaved = icp_instants(cam1, cam2, true_offset, options, phase=0.5)
    assert interleaved.shape[0] >= options.icp_min_instants
    assert first[0, 0] < interleaved[0, 0] and interleaved[-1, 0] < first[-1, 0]
    strict = CalibrationOptions(icp_max_shift_m=1e-6)
    assert icp_instants(cam1, cam2, true_offset + 0.04, strict).shape == (0, 2)


def test_icp_is_not_run_on_too_few_instants(two_cameras):
    rec, _ = two_cameras
    cam1, cam2 = rec.camera("cam1"), rec.camera("cam2")
    one = CameraRecording("cam2", cam2.intrinsics, cam2.skeleton,
                          DepthStream(cam2.depth.timestamps[5:6], cam2.depth.depth_mm[5:6], cam2.depth.labels[5:6]))
    pair = calibrate_pair(cam1, one, CalibrationOptions(), rng=np.random.default_rng(0))
    assert pair.icp is None and not pair.refined
    assert "ICP not run" in pair.icp_note and "needs 3" in pair.icp_note
    with pytest.raises(BadInputError, match="icp_min_instants"):
        CalibrationOptions(icp_instants=2, icp_min_instants=3)


def _icp_solution(T_start: np.ndarray, T_found: np.ndarray, fitness: float = 0.4) -> IcpResult:
    return IcpResult(T_a_b=T_found, T_a_b_icp=T_found, T_a_b_init=T_start, accepted=True, reason="accepted",
                     fitness=fitness, inlier_rmse_m=0.005, initial_fitness=0.3, initial_inlier_rmse_m=0.006,
                     converged=True, constraint_ratio=0.1, opposite_fraction=0.0, rotation_change_deg=0.0,
                     translation_change_m=0.0, n_points_a=1000, n_points_b=1000)


def test_two_camera_icp_not_confirmed_on_other_instants_is_replaced(two_cameras, monkeypatch):
    """A two-camera rig whose ICP lands in a wrong minimum of its instants, far from the skeleton start:
    ICP on the interleaved instant sets agrees elsewhere, and that solution is kept."""
    import fusion.calibrate.pair as pair_module

    rec, truth = two_cameras
    T_true = relative_poses(truth.T_world_cam(), "cam1")["cam2"]
    phases = []

    def icp(cam_a, cam_b, T_a_b, offset_s, options, rng, phase=0.0):
        phases.append(phase)
        wrong = compose(from_rotvec(np.radians([0.0, 3.0, 0.0]), [0.09, 0.0, 0.0]), T_a_b)
        return _icp_solution(T_a_b, wrong if phase == 0.0 else T_true), None

    monkeypatch.setattr(pair_module, "_icp_pair", icp)
    calib = calibrate_rig(rec, CalibrationOptions(), rng=np.random.default_rng(0))
    assert phases == [0.0, *pair_module.CROSS_CHECK_PHASES]
    angle, dist = _errors(calib, truth)["cam2"]
    assert angle < 1e-6 and dist < 1e-9
    assert "first ICP not confirmed" in calib.pairs[0].icp_note and calib.pairs[0].refined


@pytest.mark.parametrize("angle_deg, shift_m, checked", [(0.3, 0.005, False), (3.0, 0.09, True)])
def test_two_camera_icp_kept_near_the_start_or_when_the_next_instants_confirm_it(two_cameras, monkeypatch,
                                                                                angle_deg, shift_m, checked):
    """An ICP near the skeleton start is not cross-checked; one far from it that the next instant set
    reproduces is kept after one extra run."""
    import fusion.calibrate.pair as pair_module

    rec, _ = two_cameras
    phases = []

    def icp(cam_a, cam_b, T_a_b, offset_s, options, rng, phase=0.0):
        phases.append(phase)
        moved = compose(from_rotvec(np.radians([0.0, angle_deg, 0.0]), [shift_m, 0.0, 0.0]), T_a_b)
        return _icp_solution(T_a_b, moved), None

    monkeypatch.setattr(pair_module, "_icp_pair", icp)
    calib = calibrate_rig(rec, CalibrationOptions(), rng=np.random.default_rng(0))
    if checked:
        assert phases == [0.0, pair_module.CROSS_CHECK_PHASES[0]]
        assert "confirmed on other instants" in calib.pairs[0].icp_note
    else:
        assert phases == [0.0] and calib.pairs[0].icp_note is None


def test_calibration_file_says_icp_only_when_a_pair_was_refined(two_cameras, calibrated):
    rec, _ = two_cameras
    assert calibration_from_rig(calibrated).info["refine"] == "icp"  # with depth: refined
    skeletons = Recording(tuple(CameraRecording(c.name, c.intrinsics, c.skeleton, None) for c in rec.cameras),
                          rec.metadata)
    info = calibration_from_rig(calibrate_rig(skeletons, CalibrationOptions(refine=Refinement.ICP),
                                              rng=np.random.default_rng(0))).info
    assert info["refine"] == "none" and any("no pair was refined" in n for n in info["notes"])


@pytest.mark.parametrize("shift_s", [0.7, -1.6])
def test_a_clock_offset_beyond_the_first_search_is_found_by_the_wider_one(two_cameras, shift_s):
    rec, truth = two_cameras
    cam2 = rec.camera("cam2")
    late = dataclasses.replace(cam2, skeleton=dataclasses.replace(cam2.skeleton,
                                                                  timestamps=cam2.skeleton.timestamps + shift_s))
    shifted = Recording(tuple(late if c.name == "cam2" else c for c in rec.cameras), rec.metadata)
    calib = calibrate_rig(shifted, CalibrationOptions(refine=Refinement.NONE), rng=np.random.default_rng(1))
    true_offset = truth.camera("cam2").clock_offset_s - truth.camera("cam1").clock_offset_s + shift_s
    assert abs(calib.clock_offset_s["cam2"] - true_offset) < 0.02
    assert any("beyond +-0.2 s" in n for n in calib.notes)
