"""The angle study: rows per seed and fusion, summary, Markdown, and the static-bias switch."""

import pytest

from fusion.errors import BadInputError
from scenarios.angle_study import TrackerBias, angle_study, angle_study_markdown
from scenarios.config import load_scenario


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
