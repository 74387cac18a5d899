from dataclasses import fields
from pathlib import Path

import pytest

from fusion.errors import BadInputError
from scenarios.clinical.vocabulary import (
    ITEM_RULES,
    PARTICIPANT_COLUMNS,
    PROFILE_UNITS,
    SIDE_NAMES,
    Item,
    item_raw,
    item_score,
    vocabulary_markdown,
)
from sim.patient_motion import MovementProfile, Side

DOCS = Path(__file__).parents[3] / "docs"


@pytest.mark.parametrize(("raw", "score"), [(0, 0), (4, 0), (5, 1), (11, 1), (12, 2)])
def test_salute_rule(raw, score):
    assert item_score(Item.SALUTE, raw) == score


@pytest.mark.parametrize("raw", [0, 1, 2])
def test_hand_lift_score_is_its_raw_measure(raw):
    assert item_score(Item.HAND_LIFT, raw) == raw


@pytest.mark.parametrize(("item", "raw"), [(Item.SALUTE, 13), (Item.SALUTE, -1), (Item.HAND_LIFT, 3),
                                           (Item.SALUTE, 6.0), (Item.HAND_LIFT, True)])
def test_item_score_bad_input(item, raw):
    with pytest.raises(BadInputError, match=f"raw {item.value} measure must be an integer 0-{ITEM_RULES[item].raw_max}"):
        item_score(item, raw)


def test_raw_measures_from_manifest_scores():
    scores = {"shoulder_retraction": 2, "shoulder_elevation": 1, "shoulder_abduction": 2,
              "shoulder_external_rotation": 0, "elbow_flexion": 1, "forearm_supination": 2, "hand_lift": 1}
    assert item_raw(Item.SALUTE, scores) == 8 and item_raw(Item.HAND_LIFT, scores) == 1


def test_sides_are_words_and_units_cover_the_profile():
    assert set(SIDE_NAMES) == set(Side) and set(SIDE_NAMES.values()) == {"left", "right"}
    assert set(PROFILE_UNITS) == {f.name for f in fields(MovementProfile)}
    names = [c.name for c in PARTICIPANT_COLUMNS]
    assert len(names) == len(set(names)) and names[0] == "participant_id"


def test_the_docs_hold_the_vocabulary_of_the_code():
    assert vocabulary_markdown() in (DOCS / "reference" / "formats" / "datasets.md").read_text()
