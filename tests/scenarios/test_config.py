import dataclasses
import tomllib

import numpy as np
import pytest

from fusion.errors import ScenarioError
from scenarios.config import (
    SCENARIO_DIR,
    PopulationDraw,
    SegmentKind,
    check_memory,
    check_scenario,
    estimate_recording_bytes,
    load_scenario,
    scenario_from_dict,
    session_seconds,
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
        ("[sensors]\npopulation = 'random'\n", "sensors.population: 'random' is not one of \\['draw', 'typical'\\]"),
        ("[sensors]\nperson_seed = 1.5\n", "sensors.person_seed: expected int"),
        ("[sensors]\nperson_seed = true\n", "sensors.person_seed: expected int"),
    ],
)
def test_bad_keys_and_values_are_named(extra, message):
    with pytest.raises(ScenarioError, match=message):
        scenario_from_dict(tomllib.loads(MINIMAL + extra))


def test_population_keys():
    s = scenario_from_dict(tomllib.loads(MINIMAL))
    assert s.sensors.population is PopulationDraw.DRAW and s.sensors.person_seed is None
    s = scenario_from_dict(tomllib.loads(MINIMAL + "[sensors]\npopulation = 'typical'\nperson_seed = 7\n"))
    assert s.sensors.population is PopulationDraw.TYPICAL and s.sensors.person_seed == 7
    s = scenario_from_dict(tomllib.loads(MINIMAL + "[sensors]\npopulation = 'draw'\n"))
    assert s.sensors.population is PopulationDraw.DRAW


def test_negative_person_seed_is_refused():
    with pytest.raises(ScenarioError, match="sensors.person_seed must be a non-negative integer, got -1"):
        scenario_from_dict(tomllib.loads(MINIMAL + "[sensors]\nperson_seed = -1\n"))
    assert scenario_from_dict(tomllib.loads(MINIMAL + "[sensors]\nperson_seed = 0\n")).sensors.person_seed == 0


def test_cohort_file_refuses_a_person_seed(tmp_path):
    from scenarios.clinical.cohort_file import cohort_from_dict, load_cohort
    from tests.scenarios.clinical.test_cohort import TINY

    with pytest.raises(ScenarioError, match="sensors.person_seed would make every subject the same person"):
        cohort_from_dict(tomllib.loads(TINY + "\n[sensors]\nperson_seed = 3\n"))
    path = tmp_path / "c.toml"
    path.write_text(TINY + "\n[sensors]\nperson_seed = 0\n")
    with pytest.raises(ScenarioError, match="person_seed"):
        load_cohort(path)
    # the population draw itself stays a cohort's choice
    typical = cohort_from_dict(tomllib.loads(TINY + "\n[sensors]\npopulation = 'typical'\n"))
    assert typical.sensors.population is PopulationDraw.TYPICAL and typical.sensors.person_seed is None


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


def test_an_explicit_camera_may_keep_its_roll():
    from scenarios.runner import build_simulation

    cam = "[[rig.camera]]\nname = 'c'\nposition_m = [2.0, 0.0, 1.2]\ntarget_m = [0.0, 0.0, 1.0]\n"
    level = build_simulation(scenario_from_dict(tomllib.loads(MINIMAL + cam))).rig.cameras[0].T_world_cam
    assert level[2, 0] == pytest.approx(0.0, abs=1e-12)  # without up_m: levelled
    rolled = build_simulation(scenario_from_dict(tomllib.loads(MINIMAL + cam + "up_m = [0.0, 0.5, 1.0]\n")))
    T = rolled.rig.cameras[0].T_world_cam
    np.testing.assert_allclose(T[:3, 2], level[:3, 2], atol=1e-12)
    assert np.degrees(np.arccos(T[:3, 1] @ level[:3, 1])) == pytest.approx(26.6, abs=0.1)  # atan(0.5)
    with pytest.raises(ScenarioError, match="up_m .* along the view"):
        scenario_from_dict(tomllib.loads(MINIMAL + cam + "up_m = [-1.0, 0.0, -0.1]\n"))


@pytest.mark.parametrize(
    "top, rig, message",
    [
        ("duration_s = nan", "", "duration_s: expected a finite number"),
        ("duration_s = 1e9", "", "GiB in memory"),
        ("duration_s = -2.0", "", "positive number of seconds"),
        ("", "n_cameras = 300", "the rig places 300 cameras; at most 24"),
        ("", "radius_m = 50.0", "cam1 is 50.00 m from the subject, outside the sensor's depth range 0.5-4.5 m"),
        ("", "radius_m = 0.2\nheight_m = 1.0", "outside the sensor's depth range"),
        ("", "radius_m = inf", "expected a finite number"),
        ("", "height_m = -0.5", "cam1 is at height -0.5 m, at or below the floor"),
        ("", "n_cameras = 3\nangles_deg = [0.0, 90.0]", "n_cameras = 3 but rig.angles_deg lists 2 angles"),
        ("", "angles_deg = []", "angles_deg is empty"),
        ("", "subset = [1, 9]", "must name distinct cameras among 1..2"),
    ],
)
def test_values_a_simulation_cannot_honour_are_refused(top, rig, message):
    doc = MINIMAL.replace('name = "t"', f'name = "t"\n{top}') + f"[rig]\n{rig}\n"
    with pytest.raises(ScenarioError, match=message):
        scenario_from_dict(tomllib.loads(doc))


def test_azure_range_and_explicit_cameras_below_the_floor():
    doc = MINIMAL + "[subject]\ntopology = 'k4abt'\n[rig]\nradius_m = 4.0\n"  # 4 m > 3.86 m of the Azure NFOV mode
    with pytest.raises(ScenarioError, match="0.5-3.86 m"):
        scenario_from_dict(tomllib.loads(doc))
    doc = MINIMAL + "[[rig.camera]]\nname = 'low'\nposition_m = [2.0, 0.0, -0.1]\ntarget_m = [0.0, 0.0, 1.0]\n"
    with pytest.raises(ScenarioError, match="camera low is at height -0.1 m"):
        scenario_from_dict(tomllib.loads(doc))


def test_replace_checks_again():
    s = load_scenario("fma_2cam")
    assert s.replace(duration_s=5.0).duration_s == 5.0
    for bad in (float("nan"), float("inf"), 0.0, 1e9):
        with pytest.raises(ScenarioError):
            s.replace(duration_s=bad)


def test_memory_estimate_against_the_arrays_it_counts():
    """The estimate for one camera, 10 s, depth at 1 Hz: 300 skeleton frames and 10 depth frames."""
    doc = MINIMAL.replace("duration_s = 1.0", "duration_s = 10.0") + "[rig]\nn_cameras = 1\n"
    s = scenario_from_dict(tomllib.loads(doc))
    assert session_seconds(s) == 10.0
    per_frame = 25 * (3 * 8 + 1) + 8 + 25 * 3 * 8 + 25 + 4 * 8  # positions, states, time; truth joints, flags
    assert estimate_recording_bytes(s, depth_in_memory=True) == 300 * per_frame + 10 * 512 * 424 * 3
    assert estimate_recording_bytes(s, depth_in_memory=False) == 300 * per_frame
    long = s.replace(duration_s=20.0)
    assert estimate_recording_bytes(long, depth_in_memory=True) == 2 * estimate_recording_bytes(s, depth_in_memory=True)


def test_depth_streamed_to_disk_does_not_count_against_memory():
    """Six cameras, 60 s, depth at 30 Hz: 4.7 GB of frames in memory are refused, streamed to disk accepted."""
    ring = load_scenario("ring6").replace(duration_s=60.0)
    ring = dataclasses.replace(ring, sensors=dataclasses.replace(ring.sensors, depth_rate_hz=30.0))
    check_scenario(ring)
    check_memory(ring, depth_in_memory=False)
    with pytest.raises(ScenarioError, match="simulate it to disk"):
        check_memory(ring, depth_in_memory=True)


def test_a_lab_name_is_checked():
    s = scenario_from_dict(tomllib.loads(MINIMAL + "[sensors]\nlab = 'ui_prmd'\n"))
    assert s.sensors.lab == "ui_prmd"
    for bad in ("''", "'a.b'"):
        with pytest.raises(ScenarioError, match="sensors.lab must be a non-empty string without"):
            scenario_from_dict(tomllib.loads(MINIMAL + f"[sensors]\nlab = {bad}\n"))
