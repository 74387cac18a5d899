"""``mocap-bench sensor-check``: files, every check passing on the default seed, determinism, errors."""

import contextlib
import dataclasses
import io
import json

import numpy as np
import pytest

from fusion.errors import BadInputError
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, TrackingState
from scenarios.cli import main
from scenarios.sensors.check.check_report import (
    REPORT_NAME,
    RESULT_NAME,
    SECTION_TITLES,
    run_sensor_check,
)
from scenarios.sensors.check.check_results import Check
from scenarios.sensors.check.clocks import check_clocks
from scenarios.sensors.check.tracker_checks import (
    bone_spread_range,
    check_back_facing,
    swapped_frames,
)
from sim.anthropometry import Anthropometry
from sim.camera_clock import ClockModel
from sim.humanoid_model import build_humanoid
from sim.tracker_noise import JointGroup, TrackerNoise

FIGURES = ["projection.png", "depth_noise.png", "bone_lengths.png"]


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """The command run once with the default seed: (output directory, exit status, stdout)."""
    out = tmp_path_factory.mktemp("sensor") / "check"
    with contextlib.redirect_stdout(io.StringIO()) as stdout:
        status = main(["sensor-check", "--out", str(out)])
    return out, status, stdout.getvalue()


def test_every_check_passes_on_the_default_seed(report):
    out, status, _ = report
    doc = json.loads((out / RESULT_NAME).read_text())
    failed = [(s["key"], c["case"], c["quantity"], c["measured"]) for s in doc["sections"] for c in s["checks"]
              if not c["passed"]]
    assert not failed
    assert status == 0 and doc["passed"] and doc["seed"] == 0
    assert [s["key"] for s in doc["sections"]] == list(SECTION_TITLES)
    for section in doc["sections"]:
        assert section["checks"]
        for c in section["checks"]:
            assert c["low"] <= c["measured"] <= c["high"]
            assert c["expected"] is None or c["low"] <= c["expected"] <= c["high"]


def test_files_report_and_figures(report):
    out, _, _ = report
    assert sorted(p.name for p in out.iterdir()) == sorted([REPORT_NAME, RESULT_NAME] + FIGURES)
    assert not [p for p in out.parent.iterdir() if p.name.startswith(".")]  # no temporary directory left
    md = (out / REPORT_NAME).read_text()
    for k, title in enumerate(SECTION_TITLES.values(), start=1):
        assert f"## {k}. {title}" in md
    for name in FIGURES:
        assert f"]({name})" in md
        assert (out / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "FAIL" not in md and "| case | quantity | measured |" in md
    n = sum(len(s["checks"]) for s in json.loads((out / RESULT_NAME).read_text())["sections"])
    assert f"**{n} of {n} checks pass.**" in md


def test_cli_prints_progress_and_the_table(report):
    out, _, stdout = report
    for k, title in enumerate(SECTION_TITLES.values(), start=1):
        assert f"[{k}/{len(SECTION_TITLES)}] {title}" in stdout
    assert "checks pass" in stdout and "wall 2.5 m, 75 deg" in stdout and "ElbowRight-WristRight" in stdout
    assert f"report: {out / REPORT_NAME}" in stdout


def test_same_seed_same_numbers(report):
    out, _, _ = report
    again = json.loads(json.dumps(run_sensor_check(0).to_dict()))
    assert again == json.loads((out / RESULT_NAME).read_text())


def test_clock_section_is_seeded_and_follows_the_model():
    a = check_clocks(rng=np.random.default_rng(3))
    b = check_clocks(rng=np.random.default_rng(3))
    c = check_clocks(rng=np.random.default_rng(4))
    assert [x.measured for x in a.checks] == [x.measured for x in b.checks]
    assert [x.measured for x in a.checks] != [x.measured for x in c.checks]
    other = ClockModel(rate_hz=15.0, drop_probability=0.05, jitter_sigma_s=0.002)
    section = check_clocks(rng=np.random.default_rng(3), model=other)
    assert section.passed
    drops = next(x for x in section.checks if x.quantity == "dropped frames")
    assert drops.expected == 0.05 and drops.measured == pytest.approx(0.05, abs=0.005)


def test_a_broken_sensor_model_fails_its_check():
    no_flip = dataclasses.replace(TrackerNoise(), flip_enabled=False)
    section = check_back_facing(build_humanoid(Anthropometry()), rng=np.random.default_rng(0), noise=no_flip)
    facing, away = section.checks
    assert facing.passed and not away.passed and away.measured == 0.0


def test_existing_non_empty_output_exits_2(tmp_path, capsys):
    out = tmp_path / "taken"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    assert main(["sensor-check", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "sensor-check: error:" in err and "not empty" in err and str(out) in err
    assert [p.name for p in out.iterdir()] == ["keep.txt"] and (out / "keep.txt").read_text() == "mine"


def test_negative_seed_exits_2(tmp_path, capsys):
    assert main(["sensor-check", "--out", str(tmp_path / "x"), "--seed", "-1"]) == 2
    assert "seed" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_check_interval_and_json():
    c = Check("case", "q", "mm", 1.0, 1.2, 0.9, 1.5, "+-0.3 mm", {"n": 3})
    assert c.passed and c.to_dict()["extra"] == {"n": 3.0} and c.to_dict()["passed"] is True
    nan = dataclasses.replace(c, measured=float("nan"))
    assert not nan.passed and nan.to_dict()["measured"] is None
    assert not dataclasses.replace(c, measured=1.6).passed
    with pytest.raises(BadInputError):
        Check("case", "q", "mm", 1.0, None, 2.0, 1.0, "empty")
    with pytest.raises(BadInputError):
        run_sensor_check(-1)


def test_swapped_frames():
    rng = np.random.default_rng(0)
    joints = rng.normal(size=(5, KINECT_V2.n_joints, 3)) + [0.0, 0.0, 2.5]
    states = np.full((5, KINECT_V2.n_joints), TrackingState.TRACKED)
    same = SkeletonStream(KINECT_V2, np.arange(5.0), joints, states)
    mirrored = SkeletonStream(KINECT_V2, np.arange(5.0), joints[:, KINECT_V2.mirror], states)
    assert not swapped_frames(same, joints).any()
    assert swapped_frames(mirrored, joints).all()


def test_bone_spread_range():
    still = np.zeros((3, 3))
    low, high = bone_spread_range((JointGroup.LIMB, JointGroup.HAND), still, 1.0)
    assert low == pytest.approx(np.hypot(0.002, 0.005))
    # no bias term for a bone that does not turn: jitter at the high end and 5 % outliers
    limb, hand = TrackerNoise().groups[JointGroup.LIMB].outlier_m, TrackerNoise().groups[JointGroup.HAND].outlier_m
    second = sum((lo * lo + lo * hi + hi * hi) / 3 for lo, hi in (limb, hand))
    assert high == pytest.approx(np.sqrt(0.015**2 + 0.015**2 + 0.05 * second / 3))
    turning = np.diag([0.3, 0.1, 0.0])
    _, high_turning = bone_spread_range((JointGroup.LIMB, JointGroup.HAND), turning, 1.0)
    assert high_turning**2 == pytest.approx(high**2 + 0.3 * (0.06 + 0.08) ** 2)
    assert bone_spread_range((JointGroup.LIMB, JointGroup.HAND), turning, 1.5)[1] > high_turning
