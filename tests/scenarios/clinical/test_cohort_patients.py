"""Cohorts drawn from the literature-based patient model."""

import dataclasses
import json
import tomllib

import numpy as np
import pytest

from fusion.errors import ScenarioError
from scenarios.clinical.cohort import generate_cohort
from scenarios.clinical.cohort_file import cohort_from_dict, load_cohort
from scenarios.sweep import SweepOptions
from sim.patients import ModelPart, PatientModel, SeverityDistribution
from tests.scenarios.clinical.test_cohort import TINY, tiny_config


def test_patients_table_is_parsed_and_checked():
    c = cohort_from_dict(tomllib.loads(TINY + '\n[patients]\nmodel = "literature"\nseverity = "postacute"\n'))
    assert c.patients.model is PatientModel.LITERATURE and c.patients.severity is SeverityDistribution.POSTACUTE
    assert tiny_config().patients.model is PatientModel.RANGES  # the default keeps the group ranges
    with pytest.raises(ScenarioError, match="patients.model"):
        cohort_from_dict(tomllib.loads(TINY + '\n[patients]\nmodel = "made_up"\n'))
    with pytest.raises(ScenarioError, match="unknown key"):
        cohort_from_dict(tomllib.loads(TINY + '\n[patients]\nseverty = "uniform"\n'))
    c = cohort_from_dict(tomllib.loads(TINY + '\n[patients]\nmodel = "literature"\nablate = ["trunk", "timing"]\n'))
    assert c.patients.ablate == [ModelPart.TRUNK, ModelPart.TIMING]
    for bad in ('ablate = ["trunk"]', 'model = "literature"\nablate = ["trunk", "trunk"]',
                'model = "literature"\nablate = ["legs"]'):
        with pytest.raises(ScenarioError, match="ablate"):
            cohort_from_dict(tomllib.loads(TINY + f"\n[patients]\n{bad}\n"))


def test_builtin_literature_cohorts():
    paper, quick = load_cohort("cohort_literature"), load_cohort("cohort_literature_quick")
    assert (paper.groups.healthy, paper.groups.mild, paper.groups.moderate_severe) == (10, 6, 6)
    assert paper.patients.model is quick.patients.model is PatientModel.LITERATURE
    assert quick.groups.total == 8 and quick.processing.refine.value == "none"
    large = load_cohort("cohort_literature_200")
    assert large.groups.total == 200 and large.patients.model is PatientModel.LITERATURE


def test_generated_manifest_has_the_severity_and_the_initiation_pause(tmp_path):
    cohort = tiny_config(healthy=1, mild=1, moderate_severe=0)
    cohort = dataclasses.replace(
        cohort, patients=dataclasses.replace(cohort.patients, model=PatientModel.LITERATURE),
        protocol=dataclasses.replace(cohort.protocol, movements=["hand_lift"]))
    manifest = generate_cohort(cohort, tmp_path / "c", sweep=SweepOptions(workers=0, progress=False)).manifest
    by_group = {s["group"]: s for s in manifest["subjects"]}
    assert by_group["healthy"]["fma_ue"] is None
    patient = by_group["mild"]
    assert 50 <= patient["fma_ue"] <= 66
    assert 14 - patient["item_scores"][patient["affected_side"]]["total"] <= 66 - patient["fma_ue"]
    delay = patient["truth"]["profile"]["initiation_delay"]
    doc = json.loads((tmp_path / "c" / "subjects" / patient["id"] / "run" / "scenario.json").read_text())
    lifts = [s for s in doc["scenario"]["session"] if s["kind"] == "hand_lift"]
    assert lifts and np.isclose(lifts[0]["rest_s"], cohort.protocol.rest_s + delay)
