"""Device swap: a short simulated two-camera session swapped from the Azure Kinect to the Femto Bolt
profile end to end (``mocap-bench device-swap``), the paired table, and the refusals."""

from __future__ import annotations

import dataclasses
import json
from types import SimpleNamespace

import numpy as np
import pytest

from fusion.errors import BadInputError
from fusion.io.recording_files import save_recording
from scenarios.cli import main
from scenarios.config import load_scenario
from scenarios.runner import build_simulation
from scenarios.sensors.device_swap import (
    ANGLES,
    CALIBRATION_METRICS,
    JOINT_METRIC,
    Draw,
    check_swap,
    swap_rows,
)
from scenarios.sensors.sim_to_real import BAND
from sim.session import simulate_session


@pytest.fixture(scope="module")
def real(tmp_path_factory):
    """5 s of azure_2cam_45's hand lifts (two K4ABT cameras, skeletons only) as the real session, saved."""
    d = tmp_path_factory.mktemp("swap")
    sc = load_scenario("azure_2cam_45")
    sim = build_simulation(sc.replace(session=sc.session[1:2]))
    rec, _ = simulate_session(sim.humanoid, sim.motion, sim.rig, sim.sensors, seed=5, duration_s=5.0)
    save_recording(rec, d / "rec")
    return rec, d


def test_cli_device_swap(real, capsys) -> None:
    _, d = real
    out = d / "swap"
    assert main(["device-swap", str(d / "rec"), "--from", "azure_kinect", "--to", "orbbec_femto_bolt",
                 "--draws", "2", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "| metric | kind | real session | azure_kinect | orbbec_femto_bolt |" in printed
    doc = json.loads((out / "results.json").read_text())
    assert doc["from_profile"] == "azure_kinect" and doc["to_profile"] == "orbbec_femto_bolt"
    assert doc["seeds"] == [0, 1] and len(doc["draws"]) == 4
    metrics = [r["metric"] for r in doc["rows"]]
    for label in [*CALIBRATION_METRICS.values(), JOINT_METRIC, *ANGLES.values(), "median cross-camera residual [mm]"]:
        assert label in metrics
    for r in doc["rows"]:
        draws = {(x["profile"], x["seed"]): x["values"].get(r["metric"]) for x in doc["draws"]}
        a = np.array([draws[("azure_kinect", s)] for s in doc["seeds"]], dtype=float)
        b = np.array([draws[("orbbec_femto_bolt", s)] for s in doc["seeds"]], dtype=float)
        assert r["from"]["median"] == pytest.approx(np.median(a)) and r["to"]["median"] == pytest.approx(np.median(b))
        assert [r["to"]["low"], r["to"]["high"]] == pytest.approx(np.percentile(b, BAND))
        assert r["change"] == pytest.approx(np.median(b - a))
        assert (r["real"] is None) == (r["kind"] != "truth-free")
    by = {r["metric"]: r for r in doc["rows"]}
    # same tracker, same seeds: the body calibration stays within millimetres of the true poses
    assert 0 < by["calibration translation error [mm]"]["from"]["median"] < 50
    assert 0 < by[JOINT_METRIC]["to"]["median"] < 100
    assert (out / "replica.toml").is_file() and (out / "swap.png").read_bytes()[:4] == b"\x89PNG"
    report = (out / "report.md").read_text()
    assert report.startswith("# Device swap: rec, azure_kinect -> orbbec_femto_bolt") and "Command: `mocap-bench device-swap" in report


def test_swap_rows_pairs_by_seed() -> None:
    names = ("a", "b")
    draws = [Draw("a", s, {JOINT_METRIC: 10.0 + s}, None) for s in (0, 1, 2)]
    draws += [Draw("b", s, {JOINT_METRIC: 12.0 + 2 * s}, None) for s in (0, 1, 2)]
    iv = SimpleNamespace(value=1.0)
    stats = SimpleNamespace(residual_mm={}, beyond_5cm=iv, jitter_mm={g: iv for g in ("head", "spine", "wrist")},
                            bone_std_mm={b: iv for b in ("upper_arm", "forearm")}, confidence2={"all": iv})
    row = {r.metric: r for r in swap_rows(stats, draws, names)}[JOINT_METRIC]
    assert row.before[0] == 11.0 and row.after[0] == 14.0 and row.change == 3.0 and np.isnan(row.real)
    assert np.isnan({r.metric: r for r in swap_rows(stats, draws, names)}[CALIBRATION_METRICS["rotation_error_deg"]].change)


@pytest.mark.parametrize("args,message", [
    (["--to", "kinect_v2"], "reports kinect_v2 skeletons, the session k4abt"),
    (["--from", "azure_kinect", "--to", "azure_kinect"], "same sensor models"),
    (["--to", "orbbec_femto_bolt", "--draws", "0"], "--draws must be a whole number >= 1"),
    (["--to", "no_such_sensor"], "sensor profile 'no_such_sensor' not found"),
])
def test_cli_device_swap_refuses(real, capsys, args, message) -> None:
    _, d = real
    out = d / "refused"
    assert main(["device-swap", str(d / "rec"), *args, "--out", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_one_camera_session_refused(real) -> None:
    rec, _ = real
    one = dataclasses.replace(rec, cameras=rec.cameras[:1])
    with pytest.raises(BadInputError, match="two or more skeleton cameras"):
        check_swap(one, 1, "azure_kinect", "orbbec_femto_bolt")
