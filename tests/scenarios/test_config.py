import tomllib

import pytest

from fusion.errors import ScenarioError
from scenarios.config import (
    SCENARIO_DIR,
    SegmentKind,
    load_scenario,
    scenario_from_dict,
)

MINIMAL = """
[scenario]
name = "t"
[[session.segment]]
kind = "idle"
duration_s = 1.0
"""


@pytest.mark.parametrize("name", ["fma_2cam", "ring6", "single"])
def test_builtin_scenarios_load(name):
    s = load_scenario(name)
    assert s.name == name and s.session


def test_paper_two_camera_layout():
    s = load_scenario("fma_2cam")
    assert sorted(s.rig.angles_deg) == [-45.0, 45.0] and 1.5 <= s.rig.radius_m <= 2.0
    kinds = {(seg.kind, seg.side) for seg in s.session}
    for kind in (SegmentKind.SALUTE, SegmentKind.HAND_LIFT):
        assert {(kind, "left"), (kind, "right")} <= kinds


@pytest.mark.parametrize(
    "extra, message",
    [
        ("[rig]\nradius = 2.0\n", "unknown key 'radius' in \\[rig\\]"),
        ("[camera]\nx = 1\n", "unknown table \\[camera\\]"),
        ("[sensors]\ndepth_noise = 'loud'\n", "not one of"),
        ("[rig]\nn_cameras = 'two'\n", "expected int"),
    ],
)
def test_bad_keys_and_values_are_named(extra, message):
    with pytest.raises(ScenarioError, match=message):
        scenario_from_dict(tomllib.loads(MINIMAL + extra))


def test_segment_checks():
    doc = tomllib.loads(MINIMAL.replace('kind = "idle"\nduration_s = 1.0', 'kind = "salute"'))
    with pytest.raises(ScenarioError, match="side"):
        scenario_from_dict(doc)
    doc = tomllib.loads(MINIMAL.replace("duration_s = 1.0", "duration = 1.0"))
    with pytest.raises(ScenarioError, match="unknown key 'duration'"):
        scenario_from_dict(doc)


def test_unknown_scenario_lists_builtins(tmp_path):
    with pytest.raises(ScenarioError, match="fma_2cam"):
        load_scenario("nope")
    bad = tmp_path / "bad.toml"
    bad.write_text("[scenario\nname=")
    with pytest.raises(ScenarioError, match="not valid TOML"):
        load_scenario(bad)


def test_every_builtin_file_is_valid():
    for path in SCENARIO_DIR.glob("*.toml"):
        load_scenario(path)


def test_explicit_cameras_replace_the_ring():
    from scenarios.runner import build_simulation

    doc = tomllib.loads(MINIMAL + "[[rig.camera]]\nname = 'left'\nposition_m = [1.0, 2.0, 1.2]\ntarget_m = [0.0, 0.0, 1.0]\n"
                        "[[rig.camera]]\nname = 'right'\nposition_m = [1.0, -2.0, 1.2]\ntarget_m = [0.0, 0.0, 1.0]\n")
    sim = build_simulation(scenario_from_dict(doc))
    assert sim.rig.names == ("left", "right")
    assert sim.rig.cameras[0].position.tolist() == [1.0, 2.0, 1.2]
    bad = tomllib.loads(MINIMAL + "[[rig.camera]]\nname = 'x'\nposition_m = [1.0, 2.0]\ntarget_m = [0.0, 0.0, 1.0]\n")
    with pytest.raises(ScenarioError, match="three numbers"):
        scenario_from_dict(bad)
