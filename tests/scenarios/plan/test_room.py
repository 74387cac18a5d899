"""Room files of the planner: built-ins load, bad files are refused with a clear message, frames."""

import tomllib

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fusion.errors import ScenarioError
from fusion.transforms import apply
from scenarios.plan.room import ROOM_DIR, MountKind, load_room, room_from_dict

SMALL = """
[room]
name = "small"
outline_m = [[0.0, 0.0], [4.0, 0.0], [4.0, 3.0], [0.0, 3.0]]
[subject]
position_m = [1.5, 1.5]
facing_deg = 90.0
[[mount]]
kind = "wall"
from_m = [0.1, 2.9]
to_m = [3.9, 2.9]
height_m = [1.8, 2.2]
[[obstacle]]
name = "cupboard"
min_m = [3.0, 0.0, 0.0]
max_m = [4.0, 0.6, 2.0]
[[protocol.segment]]
kind = "idle"
duration_s = 1.0
"""


def small(**edits):
    doc = tomllib.loads(SMALL)
    for table, values in edits.items():
        doc[table] = values if not isinstance(doc.get(table), dict) else {**doc[table], **values}
    return room_from_dict(doc)


def test_builtin_rooms_load():
    names = sorted(p.stem for p in ROOM_DIR.glob("*.toml"))
    assert {"exam_room", "ring6_room"} <= set(names)
    exam = load_room("exam_room")
    assert exam.cameras.min == 2 and exam.cameras.max == 4
    assert {m.kind for m in exam.mounts} == {MountKind.WALL, MountKind.TRIPOD}
    assert [o.name for o in exam.obstacles] == ["bed"] and exam.references[0].angles_deg == [45.0, -45.0]
    assert load_room(ROOM_DIR / "exam_room.toml") == exam


def test_subject_is_the_world_origin_facing_plus_x():
    room = small()
    T = room.T_world_room
    np.testing.assert_allclose(apply(T, np.array([[1.5, 1.5, 0.0], [1.5, 2.5, 1.0]])),
                               [[0, 0, 0], [1, 0, 1]], atol=1e-12)


@given(st.floats(-180, 180), st.floats(0.5, 3.5), st.floats(0.5, 2.5))
def test_room_to_world_keeps_distances_to_the_subject(facing, x, y):
    room = small(subject={"position_m": [1.5, 1.5], "facing_deg": facing})
    p = apply(room.T_world_room, np.array([[x, y, 1.0]]))[0]
    assert np.hypot(p[0], p[1]) == pytest.approx(np.hypot(x - 1.5, y - 1.5), abs=1e-9)
    assert p[2] == pytest.approx(1.0)


@pytest.mark.parametrize("edits, message", [
    ({"room": {"name": "x", "outline_m": [[0.0, 0.0], [1.0, 0.0]]}}, "at least three"),
    ({"subject": {"position_m": [9.0, 9.0]}}, "outside room.outline_m"),
    ({"cameras": {"min": 1, "max": 2}}, "2 <= min <= max"),
    ({"mount": [{"kind": "wall", "from_m": [0.0, 0.0], "height_m": [1.0, 2.0]}]}, "needs from_m, to_m"),
    ({"mount": [{"kind": "tripod", "min_m": [0.0, 0.0], "max_m": [1.0, 1.0], "height_m": [2.0, 1.0]}]}, "height_m"),
    ({"mount": [{"kind": "crane"}]}, "not one of"),
    ({"objective": {"joint_error_mm": -1.0}}, "weight"),
    ({"search": {"min_visible": 1.5}}, "min_visible"),
    ({"reference": [{"name": "one", "angles_deg": [0.0]}]}, "two angles"),
    ({"protocol": {"segment": [{"kind": "salute", "side": "up"}]}}, "side"),
    ({"garden": {}}, "unknown table"),
    ({"room": {"name": "x", "outline_m": [[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]], "colour": "red"}}, "unknown key"),
])
def test_bad_rooms_are_refused(edits, message):
    with pytest.raises(ScenarioError, match=message):
        small(**edits)


def test_missing_tables_and_files():
    doc = tomllib.loads(SMALL)
    del doc["mount"]
    with pytest.raises(ScenarioError, match="mount"):
        room_from_dict(doc)
    with pytest.raises(ScenarioError, match="exam_room"):
        load_room("no_such_room")


def test_search_overrides_are_checked():
    room = small()
    assert room.with_search(trials=3).search.trials == 3
    with pytest.raises(ScenarioError, match="trials"):
        room.with_search(trials=-1)


@pytest.mark.parametrize(("point", "message"), [
    ([1.0, 2.5, 0.0], "not between the floor and the ceiling"),
    ([1.0, 2.5, 3.5], "not between the floor and the ceiling"),
    ([5.0, 1.0, 2.0], "outside room.outline_m"),
    ([3.5, 0.3, 1.5], "inside obstacle cupboard"),
    ([0.5, 0.5, 2.0], "in forbidden zone door"),
])
def test_impossible_camera_points_are_refused_before_any_simulation(point, message):
    doc = tomllib.loads(SMALL)
    doc["forbidden"] = [{"name": "door", "min_m": [0.0, 0.0], "max_m": [1.0, 1.0]}]
    doc["mount"].append({"kind": "points", "points_m": [point], "height_m": [1.0, 2.0]})
    with pytest.raises(ScenarioError, match=message):
        room_from_dict(doc)
    doc["mount"][-1]["points_m"] = [[2.0, 2.5, 2.0]]  # a free place is accepted
    room_from_dict(doc)
