"""The angle study: rows per seed and fusion, summary, Markdown, and the static-bias switch."""

import numpy as np
import pytest

from fusion.errors import BadInputError
from scenarios.config import load_scenario
from scenarios.studies.angle_study import angle_study, angle_study_markdown
from sim.tracker_bias import TrackerBias, tracker_with
from sim.tracker_noise import JointGroup, TrackerNoise


def test_study_without_static_bias_favours_the_kinematic_fit():
    scenario = load_scenario("fma_2cam").replace(duration_s=6.0)
    result = angle_study(scenario, [3], bias=TrackerBias.OFF)
    assert [(r["seed"], r["fusion"]) for r in result["rows"]] == [(3, "avg_frontal"), (3, "kinematic")]
    summary = result["summary"]
    assert summary["all kinematic"]["joint_error_mm"] < summary["all avg_frontal"]["joint_error_mm"] < 60.0
    assert summary["all avg_frontal"]["joint_error_reduction_pct"]["mean"] == 0.0
    assert "| all kinematic |" in angle_study_markdown(result)


def test_study_needs_a_seed():
    with pytest.raises(BadInputError, match="seed"):
        angle_study(load_scenario("fma_2cam"), [])


def test_tracker_bias_parts_keep_the_total_size_of_the_rest():
    noise = TrackerNoise()
    f = noise.model_fraction
    limb = noise.groups[JointGroup.LIMB].bias_m
    assert tracker_with(noise, TrackerBias.ON) is noise
    off = tracker_with(noise, TrackerBias.OFF)
    assert all(g.bias_m == (0.0, 0.0) for g in off.groups.values()) and off.hip_up_m == off.hip_out_m == 0.0
    model_off = tracker_with(noise, TrackerBias.MODEL_OFF)  # what is left is the view part at its size
    assert model_off.model_fraction == 0.0 and model_off.hip_up_m == 0.0
    assert model_off.groups[JointGroup.LIMB].bias_m == pytest.approx(np.sqrt(1 - f) * np.array(limb))
    view_off = tracker_with(noise, TrackerBias.VIEW_OFF)  # the model part at its size
    assert view_off.model_fraction == 1.0 and view_off.hip_up_m == noise.hip_up_m
    assert view_off.groups[JointGroup.LIMB].bias_m == pytest.approx(np.sqrt(f) * np.array(limb))
    arms = tracker_with(noise, TrackerBias.ARMS_OFF)
    assert arms.groups[JointGroup.HAND].bias_m == (0.0, 0.0) and arms.groups[JointGroup.TORSO] == noise.groups[JointGroup.TORSO]


def test_study_with_limb_axes_scores_both_fusions_on_corrected_views():
    scenario = load_scenario("fma_2cam").replace(duration_s=4.0)
    result = angle_study(scenario, [2], limb_axes=True)
    assert [r["fusion"] for r in result["rows"]] == ["avg_frontal", "kinematic", "avg_frontal+axes", "kinematic+axes"]
    summary = result["summary"]
    assert summary["all avg_frontal+axes"]["joint_error_mm"] < summary["all avg_frontal"]["joint_error_mm"]
    assert result["limb_axes"] and "Rows `+axes`" in angle_study_markdown(result)
