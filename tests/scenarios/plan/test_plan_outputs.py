"""The planner's user-facing outputs on a tiny room: own layouts (--evaluate), install sheets,
bootstrap intervals, the degenerate-layout rule, the no-valid-layout error and the overlap warning."""

import tomllib

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fusion.errors import BadInputError, BenchError
from scenarios.cli import main
from scenarios.plan.evaluate_rigs import layout_from_rig, layouts_from_rigs
from scenarios.plan.install_sheet import (
    camera_installs,
    install_markdown,
    mount_name,
    pan_tilt_roll_deg,
)
from scenarios.plan.room import room_from_dict
from scenarios.plan.rules import (
    MIN_SEPARATION_M,
    MIN_VIEW_ANGLE_DEG,
    bootstrap_interval,
    degenerate_reason,
    overlap_warning,
)
from scenarios.plan.search import (
    LayoutResult,
    NoValidLayoutError,
    degenerate,
    plan_layouts,
)
from scenarios.sweep import SweepOptions
from sim.rig import look_at
from tests.scenarios.plan.test_plan import TINY

SERIAL = SweepOptions(workers=0, progress=False)


def rig_file(path, cameras):
    """A hand-written rig file: (position, target) pairs in the world frame (patient at the origin, facing +x)."""
    lines = ['[scenario]', 'name = "own"']
    for k, (p, t) in enumerate(cameras):
        lines += ["[[rig.camera]]", f'name = "cam{k + 1}"', f"position_m = {list(p)}", f"target_m = {list(t)}"]
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def room():
    return room_from_dict(tomllib.loads(TINY))


def test_rig_file_becomes_a_room_frame_layout(room, tmp_path):
    # TINY: patient at (2.5, 2.5) facing +y, so world +x is room +y and world +y is room -x
    path = rig_file(tmp_path / "pair.toml", [([2.0, 0.0, 1.0], [0, 0, 0.9]), ([1.0, 1.7, 1.0], [0, 0, 1.1])])
    name, layout = layout_from_rig(room, path)
    assert name == "pair"
    np.testing.assert_allclose(layout, [(2.5, 4.5, 1.0, 0.9), (0.8, 3.5, 1.0, 1.1)], atol=1e-9)
    assert [n for n, _ in layouts_from_rigs(room, [path, path])] == ["pair", "pair (2)"]
    with pytest.raises(BadInputError, match="off the patient's axis"):
        layout_from_rig(room, rig_file(tmp_path / "off.toml", [([2, 0, 1], [0.5, 0, 1]), ([1, 1.7, 1], [0, 0, 1])]))
    with pytest.raises(BadInputError, match="at least two"):
        layout_from_rig(room, rig_file(tmp_path / "one.toml", [([2, 0, 1], [0, 0, 1])]))
    with pytest.raises(BenchError, match="outside"):
        layout_from_rig(room, rig_file(tmp_path / "out.toml", [([9, 0, 1], [0, 0, 1]), ([1, 1.7, 1], [0, 0, 1])]))


def test_cli_plan_evaluates_own_layouts_beside_the_best(room, tmp_path, capsys):
    tiny = tmp_path / "tiny.toml"
    tiny.write_text(TINY)
    pair = rig_file(tmp_path / "front_left.toml", [([2.0, 0.0, 1.0], [0, 0, 1.0]), ([1.0, 1.7, 1.0], [0, 0, 1.0])])
    out = tmp_path / "plan"
    assert main(["plan", str(tiny), "--out", str(out), "--trials", "1", "--final-seeds", "2", "--workers", "0",
                 "--evaluate", str(pair), "--no-ablation", "--sensor", "kinect_v2", "azure_kinect"]) == 0
    report = (out / "report.md").read_text()
    assert "front_left" in report and "best 2 cameras" in report and "Sensor: **kinect_v2**" in report
    others = report.split("## Other sensors")[1]
    assert "front_left (azure_kinect)" in others and "best 2 cameras" in others
    assert "further proposals were refused before simulation" in report
    sheet = (out / "install.md").read_text()
    assert "front_left" in sheet and "humerothoracic elevation" in sheet and "elbow position [mm]" in sheet
    assert {"install_1.png", "install_2.png", "install_1.pdf"} <= {p.name for p in out.iterdir()}
    # the same layout twice with --trials 0: nothing separates them, the warning goes to stderr too
    capsys.readouterr()
    assert main(["plan", str(tiny), "--out", str(tmp_path / "own"), "--trials", "0", "--final-seeds", "2",
                 "--workers", "0", "--evaluate", str(pair), str(pair), "--no-ablation"]) == 0
    captured = capsys.readouterr()
    assert "cannot separate the top layouts" in captured.err
    assert "cannot separate" in (tmp_path / "own" / "report.md").read_text()
    assert not (tmp_path / "own" / "rig_best.toml").exists()  # no search, no recommendation of its own


def test_cli_plan_with_sensor_and_ablation(room, tmp_path):
    tiny = tmp_path / "tiny.toml"
    tiny.write_text(TINY)
    pair = rig_file(tmp_path / "pair.toml", [([2.0, 0.0, 1.0], [0, 0, 1.0]), ([1.0, 1.7, 1.0], [0, 0, 1.0])])
    out = tmp_path / "plan"
    assert main(["plan", str(tiny), "--out", str(out), "--trials", "0", "--final-seeds", "1", "--workers", "0",
                 "--evaluate", str(pair), "--sensor", "kinect_v2"]) == 0
    report = (out / "report.md").read_text()
    assert "What dominates the expected error" in report and "tracker noise off" in report
    assert "sensor azure_kinect" in report  # the other sensor of the ablation


def test_no_trials_and_no_layouts_is_refused(room):
    with pytest.raises(BadInputError, match="--evaluate"):
        plan_layouts(room.with_search(trials=0), sweep=SERIAL)


def test_install_sheet_angles_match_the_closed_form(room):
    # TINY: patient at (2.5, 2.5) facing +y; a camera 2 m to its right (+x), 1.0 m higher than the aim point
    x, y, z, aim = 4.5, 2.5, 2.0, 1.0
    layout = LayoutResult("one", ((x, y, z, aim), (2.5, 4.5, 1.0, 1.0)), (), ())
    cam = camera_installs(room, layout)[0]
    assert cam.pan_deg == pytest.approx(180.0)  # looks towards -x
    assert cam.tilt_deg == pytest.approx(-np.degrees(np.arctan2(z - aim, x - 2.5)))
    assert cam.roll_deg == pytest.approx(0.0, abs=1e-9)
    assert cam.distance_m == pytest.approx(2.0) and cam.height_m == z
    assert cam.bearing_deg == pytest.approx(-90.0)  # on the patient's right
    front = camera_installs(room, layout)[1]
    assert front.bearing_deg == pytest.approx(0.0) and front.pan_deg == pytest.approx(-90.0)
    assert front.mount == "points" and mount_name(room, np.array([0.05, 1.0, 2.0])) == "wall (own place)"
    # level at 1.0 m and 2 m away, the 60 deg image cannot hold the raised hand (1.3 x 1.75 m): atan(1.275 / 2) > 30 deg
    assert "raised hand" in front.sees and "feet" not in front.sees.split(";")[-1]


@given(st.floats(-170, 170), st.floats(-60, 60), st.floats(-80, 80))
def test_pan_tilt_roll_recovers_a_rolled_camera(pan, tilt, roll):
    p, a, r = np.radians([pan, tilt, roll])
    forward = np.array([np.cos(a) * np.cos(p), np.cos(a) * np.sin(p), np.sin(a)])
    level_up = np.array([0.0, 0.0, 1.0]) - forward[2] * forward
    level_up /= np.linalg.norm(level_up)
    left = np.cross(level_up, forward)
    up = np.cos(r) * level_up + np.sin(r) * left  # image top turned towards the sensor's left
    T = look_at(np.zeros(3), forward, up)
    np.testing.assert_allclose(pan_tilt_roll_deg(T[:3, :3]), [pan, tilt, roll], atol=1e-6)


def test_install_markdown_lists_every_camera(room):
    layout = LayoutResult("pair", ((4.5, 2.5, 2.0, 1.0), (2.5, 4.5, 1.0, 1.0)), (), (), "kinect_v2")
    lines = install_markdown(room, layout, "install_1.png")
    rows = [line for line in lines if line.startswith("| 1 |") or line.startswith("| 2 |")]
    assert len(rows) == 2 and "| 180 | -27 | 0 | 2.00 | -90 |" in rows[0]


@given(st.lists(st.floats(0, 1e4), min_size=1, max_size=8), st.integers(0, 2**32 - 1))
def test_bootstrap_interval_stays_within_the_data(values, seed):
    mean, lo, hi = bootstrap_interval(values, rng=np.random.default_rng(seed))
    assert min(values) - 1e-9 <= lo <= mean + 1e-9 and mean - 1e-9 <= hi <= max(values) + 1e-9
    assert lo >= 0


def test_layout_interval_is_never_negative_where_a_t_interval_was():
    # two seeds, 20 and 90 mm: the t-interval of the old report ran to [-201, 311]
    sessions = tuple({"seed": s, "error": None, "calibration_translation_mm": v} for s, v in ((1, 20.0), (2, 90.0)))
    r = LayoutResult("x", ((0, 0, 1, 1), (1, 1, 1, 1)), sessions, (20.0, 90.0))
    mean, lo, hi = r.interval("calibration_translation_mm")
    assert mean == 55.0 and 20.0 <= lo <= hi <= 90.0
    assert r.interval("calibration_translation_mm") == (mean, lo, hi)  # seeded by the sessions' seeds
    with pytest.raises(BadInputError, match="level"):
        bootstrap_interval([1.0], rng=np.random.default_rng(0), level=1.5)


def test_degenerate_rule():
    centre = np.array([0.0, 0.0, 1.0])
    assert degenerate_reason(centre, np.array([[2.0, 0.0, 1.0], [0.0, 2.0, 1.0]])) is None
    close = degenerate_reason(centre, np.array([[2.0, 0.0, 1.0], [2.0, MIN_SEPARATION_M - 0.05, 1.0]]))
    assert close is not None and "m apart" in close
    # 2 m and 3.5 m away, 10 deg apart: far enough from each other, but in line from the patient
    a, b = np.radians(0.0), np.radians(MIN_VIEW_ANGLE_DEG / 2)
    inline = degenerate_reason(centre, np.array([[2 * np.cos(a), 2 * np.sin(a), 1.0],
                                                 [3.5 * np.cos(b), 3.5 * np.sin(b), 1.0]]))
    assert inline is not None and "as seen from the patient" in inline
    with pytest.raises(BadInputError):
        degenerate_reason(centre, np.zeros((2, 2)))


def test_search_refuses_degenerate_layouts_and_says_what_to_do(room, tmp_path, capsys):
    doc = tomllib.loads(TINY)
    # three places: 0.4 m apart, or in line as seen from the patient
    doc["mount"] = [{"kind": "points", "points_m": [[2.5, 4.5, 1.0], [2.9, 4.5, 1.0], [2.5, 4.9, 1.2]]}]
    cramped = room_from_dict(doc)
    assert degenerate(cramped, ((2.5, 4.5, 1.0, 1.0), (2.9, 4.5, 1.0, 1.0))) is not None
    with pytest.raises(NoValidLayoutError, match="raise the budget"):
        plan_layouts(cramped, sweep=SERIAL)
    path = tmp_path / "cramped.toml"
    path.write_text(TINY.replace("points_m = [[2.5, 4.5, 1.0], [4.2, 3.5, 1.0], [0.8, 3.5, 1.0]]",
                                 "points_m = [[2.5, 4.5, 1.0], [2.9, 4.5, 1.0], [2.5, 4.9, 1.2]]"))
    assert main(["plan", str(path), "--out", str(tmp_path / "p"), "--workers", "0"]) == 2
    assert "no valid layout" in capsys.readouterr().err


def test_overlap_warning():
    assert overlap_warning(["a"], [(1.0, 0.5, 1.5)]) is None
    assert overlap_warning(["a", "b"], [(1.0, 0.5, 1.5), (3.0, 2.0, 4.0)]) is None
    warning = overlap_warning(["a", "b", "c"], [(3.0, 2.0, 4.0), (1.0, 0.5, 2.5), (9.0, 8.0, 10.0)])
    assert warning is not None and warning.index("b scores") < warning.index("and a") and "--final-seeds" in warning
    assert overlap_warning(["a", "b"], [(np.nan,) * 3, (1.0, 0.5, 1.5)]) is None


def test_the_example_east_wall_pair_lies_on_the_east_wall():
    from scenarios.plan.room import ROOM_DIR, load_room

    exam = load_room("exam_room")
    name, layout = layout_from_rig(exam, ROOM_DIR / "layouts" / "exam_room_east_wall_pair.toml")
    assert name == "exam_room_east_wall_pair" and degenerate(exam, layout) is None
    np.testing.assert_allclose(layout, [(4.95, 1.0, 2.1, 1.0), (4.95, 3.0, 2.1, 1.0)], atol=1e-9)
    layout_result = LayoutResult(name, layout, (), ())
    assert [c.mount for c in camera_installs(exam, layout_result)] == ["wall: east wall"] * 2


def test_a_seed_failing_for_every_layout_is_named():
    from scenarios.plan.search import seed_warnings

    def result(name, errors):
        sessions = tuple({"seed": s, "error": e} for s, e in zip((11, 22), errors))
        return LayoutResult(name, ((0, 0, 1, 1), (1, 1, 1, 1)), sessions, (1.0, 1.0))

    fails = "CalibrationError: no pair\n  no candidates in body region(s) LOWER"
    warnings = seed_warnings([result("a", (None, fails)), result("b", (None, fails))])
    assert len(warnings) == 1 and "seed 22" in warnings[0] and "LOWER" in warnings[0]
    assert seed_warnings([result("a", (None, fails)), result("b", (None, None))]) == []
    assert seed_warnings([result("a", (None, fails))]) == []
