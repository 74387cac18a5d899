"""Sensor fit and sim-to-real: recover known noise from a simulated recording, compare, verdicts, CLI."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest

from fusion.errors import BadInputError
from fusion.io.formats.csv_layout import KIMORE
from fusion.io.recording_files import save_recording
from fusion.merge.sensor_stats import sensor_stats
from scenarios.cli import main
from scenarios.config import load_scenario
from scenarios.runner import build_simulation
from scenarios.sensors.fit import fit_profile, measure
from scenarios.sensors.sim_to_real import compare_stats, sim_to_real
from sim.sensor_profile import load_profile
from sim.session import simulate_session
from sim.tracker_noise import JointGroup, TrackerNoise

SAMPLES = Path(__file__).resolve().parents[3] / ".." / "shared" / "samples"


def _white_only(white_m: float) -> TrackerNoise:
    quiet = TrackerNoise.none()
    groups = {g: dataclasses.replace(n, jitter_m=white_m) for g, n in quiet.groups.items()}
    return dataclasses.replace(quiet, groups=groups)


def _simulated(tracker: TrackerNoise, duration: float = 12.0):
    sc = load_scenario("kimore_frontal").replace(duration_s=duration)
    sim = build_simulation(sc)
    sensors = dataclasses.replace(sim.sensors, tracker=tracker)
    rec, _ = simulate_session(sim.humanoid, sim.motion, sim.rig, sensors, seed=sim.session_seed, duration_s=duration)
    return rec


def test_fit_recovers_white_jitter() -> None:
    rec = _simulated(_white_only(0.003))
    stats = {"a": measure(rec, n_boot=5, rng=np.random.default_rng(0))}
    fit = fit_profile({"a": rec}, stats, load_profile("kinect_v2"), name="fitted")
    # white noise only: the lag-1 autocorrelation is -2/3, so the white share is 1 and the white jitter
    # comes back; the torso barely moves in this scenario
    assert fit.white_m[JointGroup.TORSO] == pytest.approx(0.003, rel=0.15)
    assert fit.wobble_m[JointGroup.TORSO] < 0.001
    assert fit.profile.name == "fitted" and all(n.bone_rigidity == 0.0 for n in fit.profile.tracker.groups.values())
    assert "fitted from a" in fit.profile.provenance["tracker.groups.torso.jitter_m"]
    assert fit.profile.tracker.body_scale_sd == 0.0 and "no body scale" in fit.profile.provenance["tracker.body_scale_sd"]


def test_fit_finds_the_body_scale_of_a_template_tracker() -> None:
    template = dataclasses.replace(_white_only(0.003), body_scale_sd=0.04, body_scale_tau_s=0.5)
    rec = _simulated(template, duration=20.0)
    fit = fit_profile({"a": rec}, {"a": measure(rec, n_boot=0, rng=np.random.default_rng(0))}, load_profile("kinect_v2"),
                      name="fitted")
    tracker = fit.profile.tracker
    assert tracker.body_scale_sd == pytest.approx(0.04, rel=0.25)
    assert 0.25 < tracker.body_scale_tau_s < 1.0  # 40 time constants: the 1/e lag is known to about +-50 %
    assert tracker.body_scale_shared == 0.0  # one camera: nothing to share
    assert "a common scale explains" in fit.profile.provenance["tracker.body_scale_sd"]
    assert any("body scale" in n for n in fit.notes)


def test_fit_rejects_other_topology() -> None:
    rec = _simulated(_white_only(0.003), duration=4.0)
    stats = {"a": measure(rec, n_boot=0, rng=np.random.default_rng(0))}
    with pytest.raises(BadInputError, match="base profile azure_kinect"):
        fit_profile({"a": rec}, stats, load_profile("azure_kinect"), name="x")
    with pytest.raises(BadInputError, match="every recording"):
        fit_profile({"a": rec}, {}, load_profile("kinect_v2"), name="x")


def test_compare_identical_and_scaled() -> None:
    a = sensor_stats(_simulated(_white_only(0.002), 6.0), n_boot=0, rng=np.random.default_rng(0))
    b = sensor_stats(_simulated(_white_only(0.004), 6.0), n_boot=0, rng=np.random.default_rng(0))
    same = compare_stats(a, a)
    assert all(r.passed for r in same) and all(r.ratio == pytest.approx(1.0) for r in same if not r.by_points)
    doubled = {r.statistic: r for r in compare_stats(a, b)}
    assert doubled["head jitter [mm]"].ratio == pytest.approx(2.0, rel=0.15)
    assert doubled["head jitter [mm]"].passed is False
    assert doubled["share of joints at confidence 2"].passed is True
    with pytest.raises(BadInputError, match="tolerances"):
        compare_stats(a, b, tolerance=0.0)


def test_sim_to_real_checks_topology() -> None:
    rec = _simulated(_white_only(0.002), 4.0)
    sc = load_scenario("azure_2cam_45").replace(duration_s=4.0)
    with pytest.raises(BadInputError, match="set subject.topology"):
        sim_to_real(rec, sc, n_boot=0, rng=np.random.default_rng(0))
    result = sim_to_real(rec, load_scenario("kimore_frontal").replace(duration_s=4.0), n_boot=0,
                         rng=np.random.default_rng(0))
    assert len(result.rows) == 6 and result.scenario.name == "kimore_frontal"


def test_cli_sensor_fit_and_sim_to_real(tmp_path: Path, capsys) -> None:
    rec = _simulated(_white_only(0.002), 6.0)
    save_recording(rec, tmp_path / "rec")
    assert main(["sensor-fit", str(tmp_path / "rec"), "--out", str(tmp_path / "p.toml"), "--report",
                 str(tmp_path / "fit"), "--bootstrap", "5"]) == 0
    assert load_profile(tmp_path / "p.toml").topology.name == "kinect_v2"
    assert (tmp_path / "fit" / "fit.png").stat().st_size > 0
    assert main(["sim-to-real", str(tmp_path / "rec"), "--scenario", "kimore_frontal", "--profile",
                 str(tmp_path / "p.toml"), "--out", str(tmp_path / "s2r"), "--bootstrap", "5"]) == 0
    assert "head jitter" in (tmp_path / "s2r" / "sim_to_real.md").read_text()
    # a second run into the same outputs stops before any work and keeps them
    kept = {p: p.read_bytes() for p in [tmp_path / "p.toml", *(tmp_path / "fit").iterdir(), *(tmp_path / "s2r").iterdir()]}
    capsys.readouterr()
    assert main(["sensor-fit", str(tmp_path / "rec"), "--out", str(tmp_path / "p.toml"), "--bootstrap", "5"]) == 2
    assert f"{tmp_path / 'p.toml'} already exists; choose another path or pass --overwrite" in capsys.readouterr().err
    assert main(["sensor-fit", str(tmp_path / "rec"), "--out", str(tmp_path / "p2.toml"), "--report",
                 str(tmp_path / "fit"), "--bootstrap", "5"]) == 2
    assert (f"{tmp_path / 'fit'} already exists and is not empty; choose another path or pass --overwrite"
            in capsys.readouterr().err)
    assert not (tmp_path / "p2.toml").exists()
    assert main(["sim-to-real", str(tmp_path / "rec"), "--scenario", "kimore_frontal", "--out", str(tmp_path / "s2r"),
                 "--bootstrap", "5"]) == 2
    assert (f"{tmp_path / 's2r'} already exists and is not empty; choose another path or pass --overwrite"
            in capsys.readouterr().err)
    assert {p: p.read_bytes() for p in kept} == kept
    assert main(["sensor-fit", str(tmp_path / "rec"), "--out", str(tmp_path / "p.toml"), "--report",
                 str(tmp_path / "fit"), "--bootstrap", "0", "--overwrite"]) == 0
    assert main(["sim-to-real", str(tmp_path / "rec"), "--scenario", "kimore_frontal", "--profile",
                 str(tmp_path / "p.toml"), "--out", str(tmp_path / "s2r"), "--bootstrap", "0", "--overwrite"]) == 0
    assert main(["sensor-fit", str(tmp_path / "rec"), "--out", str(tmp_path / "q.toml"), "--calib", "a", "b"]) == 2
    assert "one --calib per recording" in capsys.readouterr().err


@pytest.mark.skipif(not (SAMPLES / "kimore").is_dir(), reason="real samples absent")
def test_real_kimore_statistics() -> None:
    from fusion.io.formats.csv_layout import read_csv_layout

    rec = read_csv_layout(SAMPLES / "kimore" / "JointPositionExercise1.csv", KIMORE)
    st = measure(rec, n_boot=10, rng=np.random.default_rng(0))
    # the real tracker's statistics: head jitter about 1 mm, arm bone spread 12-22 mm
    assert 0.2 < st.jitter_mm["head"].value < 3.0
    assert 8.0 < st.bone_std_mm["upper_arm"].value < 30.0


def test_sim_to_real_calibrates_from_the_body_without_calib(tmp_path, capsys):
    from fusion.io.calibration_file import load_calibration
    from scenarios.cli import main

    run, out = tmp_path / "run", tmp_path / "r"
    assert main(["simulate", "fma_2cam", "--duration", "20", "--out", str(run)]) == 0
    assert main(["sim-to-real", str(run), "--out", str(out), "--bootstrap", "5"]) == 0
    assert "calibration.toml" in capsys.readouterr().out
    assert set(load_calibration(out / "calibration.toml").T_world_cam) == {"cam1", "cam2"}
    assert (out / "replica.toml").is_file() and (out / "sim_to_real.md").is_file()
    cosines = re.search(r"\| limb cosine of the steady residuals \| (\S+) \| (\S+) \|", (out / "sim_to_real.md").read_text())
    assert cosines and all(-1 <= float(v) <= 1 for v in cosines.groups())  # two cameras: real and simulated
    tails = re.search(r"\| elbows and wrists beyond 8 cm, Tracked in both \[%\] \| (\S+) \| (\S+) \|",
                      (out / "sim_to_real.md").read_text())
    assert tails and all(0 <= float(v) <= 100 for v in tails.groups())


def test_recordings_too_short_for_statistics_are_refused_before_anything_is_written(tmp_path: Path, capsys) -> None:
    rec = _simulated(_white_only(0.003), duration=1.0)
    with pytest.raises(BadInputError, match="need at least 2 s"):
        measure(rec, n_boot=0, rng=np.random.default_rng(0))
    save_recording(rec, tmp_path / "short")
    assert main(["sim-to-real", str(tmp_path / "short"), "--out", str(tmp_path / "s2r")]) == 2
    assert "need at least 2 s" in capsys.readouterr().err and not (tmp_path / "s2r").exists()
