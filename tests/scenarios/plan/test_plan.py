"""The planner end to end on a tiny room: objectives, search, report files, rig files, the command."""

import json
import tomllib

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fusion.errors import BadInputError
from scenarios.cli import main
from scenarios.config import scenario_from_dict
from scenarios.plan.objectives import FAILURE_PENALTY, OBJECTIVES, rig_config, score
from scenarios.plan.plan_report import pareto_front, rig_toml, write_plan
from scenarios.plan.room import room_from_dict
from scenarios.plan.search import plan_layouts, reference_layout
from scenarios.runner import build_simulation
from scenarios.sweep import SweepOptions

TINY = """
[room]
name = "tiny"
outline_m = [[0.0, 0.0], [5.0, 0.0], [5.0, 5.0], [0.0, 5.0]]
seed = 2
[subject]
position_m = [2.5, 2.5]
facing_deg = 90.0
[[mount]]
kind = "points"
height_m = [1.0, 1.0]
points_m = [[2.5, 4.5, 1.0], [4.2, 3.5, 1.0], [0.8, 3.5, 1.0]]
[cameras]
min = 2
max = 2
[sensors]
depth_rate_hz = 0.0
population = "typical"
[search]
trials = 3
seeds = 1
final_seeds = 2
screen_poses = 3
min_visible = 0.0
aim_height_m = [0.9, 1.1]
[[reference]]
name = "front pair"
angles_deg = [30.0, -30.0]
[[protocol.segment]]
kind = "idle"
duration_s = 1.0
[[protocol.segment]]
kind = "calibration_turn"
duration_s = 8.0
[[protocol.segment]]
kind = "hand_lift"
side = "right"
repetitions = 1
"""


@pytest.fixture(scope="module")
def room():
    return room_from_dict(tomllib.loads(TINY))


@pytest.fixture(scope="module")
def planned(room):
    return plan_layouts(room, sweep=SweepOptions(workers=0, progress=False))


def test_reference_layout_stands_on_its_ring(room):
    layout = reference_layout(room, room.references[0])
    p = np.array([c[:3] for c in layout])
    np.testing.assert_allclose(np.hypot(p[:, 0] - 2.5, p[:, 1] - 2.5), 2.0)
    # facing +y: +30 deg from the front is towards -x in the room
    assert p[0, 0] < 2.5 < p[1, 0] and np.all(p[:, 1] > 2.5) and np.all(p[:, 2] == 1.0)


def test_rig_config_puts_the_cameras_in_the_world_frame(room):
    rig = rig_config(room, ((2.5, 4.5, 1.0, 0.9), (4.2, 3.5, 1.2, 1.1)))
    np.testing.assert_allclose(rig.camera[0].position_m, [2.0, 0.0, 1.0], atol=1e-12)  # straight ahead
    assert rig.camera[1].target_m == [0.0, 0.0, 1.1]
    sim = build_simulation(room.scenario("x", 0).replace(rig=rig))
    np.testing.assert_allclose(sim.rig.cameras[0].position, [2.0, 0.0, 1.0], atol=1e-12)


def test_plan_ranks_layouts_and_evaluates_finals_and_references(room, planned):
    assert 1 <= len(planned.trials) <= 3  # three places, two cameras: at most three distinct layouts
    scores = [r.score for r in planned.ranked]
    assert scores == sorted(scores)
    (final,) = planned.finals
    assert final.layout == planned.ranked[0].layout and len(final.sessions) == 2
    assert [s["seed"] for s in final.sessions] != [s["seed"] for s in planned.trials[0].sessions][:2]
    (ref,) = planned.references
    assert ref.name == "front pair" and len(ref.sessions) == 2
    for r in (*planned.trials, final, ref):
        for s, value in zip(r.sessions, r.scores):
            assert set(OBJECTIVES) <= set(s) and value == score(room, s)
            if s["error"] is None:
                assert 0 < s["joint_error_mm"] < 500 and 0 <= s["back_pose_pct"] <= 100
    mean, lo, hi = final.interval("joint_error_mm")
    assert lo <= mean <= hi


def test_score_weights_and_failures(room):
    session = {k: 1.0 for k in OBJECTIVES} | {"error": None, "arm_occluded_pct": float("nan")}
    w = room.objective
    expected = sum(getattr(w, k) for k in OBJECTIVES if k != "arm_occluded_pct")
    assert score(room, session) == pytest.approx(expected)
    assert score(room, session | {"error": "CalibrationError: no pair"}) == FAILURE_PENALTY


def test_plan_refuses_bad_input(room):
    with pytest.raises(BadInputError, match="Room"):
        plan_layouts("tiny")
    doc = tomllib.loads(TINY)
    doc["obstacle"] = [{"name": "partition", "min_m": [0.0, 3.2, 0.0], "max_m": [5.0, 3.3, 2.7]}]
    hidden = room_from_dict(doc).with_search(min_visible=0.1)
    with pytest.raises(BadInputError, match="min_visible"):
        plan_layouts(hidden, sweep=SweepOptions(workers=0, progress=False))


def test_written_plan_and_rig_file_simulate(planned, tmp_path):
    names = write_plan(planned, tmp_path / "p")
    assert {"plan.json", "report.md", "pareto.png", "top_views.png", "rig_best.toml", "rig_2cam.toml"} <= set(names)
    doc = json.loads((tmp_path / "p" / "plan.json").read_text())
    assert len(doc["trials"]) == len(planned.trials) and doc["references"][0]["name"] == "front pair"
    report = (tmp_path / "p" / "report.md").read_text()
    assert "front pair" in report and "best 2 cameras" in report
    scenario = scenario_from_dict(tomllib.loads((tmp_path / "p" / "rig_best.toml").read_text()))
    assert len(scenario.rig.camera) == 2 and scenario.session == planned.room.protocol
    assert rig_toml(planned, planned.finals[0]).startswith("# Planned")


def test_cli_plan(tmp_path, capsys):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    out = tmp_path / "plan"
    assert main(["plan", str(path), "--out", str(out), "--trials", "1", "--final-seeds", "1", "--workers", "0"]) == 0
    assert "Camera plan: tiny" in capsys.readouterr().out
    assert main(["simulate", str(out / "rig_best.toml"), "--out", str(tmp_path / "run"), "--duration", "3"]) == 0
    assert main(["plan", str(path), "--out", str(out), "--workers", "0"]) == 2  # exists, no --overwrite


@given(st.lists(st.tuples(st.floats(0, 10), st.floats(0, 10)), min_size=1, max_size=12))
def test_pareto_front_against_brute_force(points):
    p = np.array(points)
    front = pareto_front(p)
    for i in range(len(p)):
        dominated = any(np.all(p[j] <= p[i]) and np.any(p[j] < p[i]) for j in range(len(p)))
        assert front[i] == (not dominated)
