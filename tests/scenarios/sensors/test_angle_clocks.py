"""The Kinect's clock against the optical one, per subject and movement (scenarios.sensors.angle_clocks)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from scenarios.sensors import angle_clocks
from scenarios.sensors.angle_clocks import (
    CLOCK_EPISODES,
    MIN_RANGE_DEG,
    ClockRatios,
    clock_ratios,
)
from scenarios.sensors.angle_validate import Episode, find_episodes

SAMPLES = Path(__file__).resolve().parents[3].parent / "shared" / "samples" / "ui_prmd"


def _episode(subject: str, movement: str, number: int) -> Episode:
    return Episode(movement, subject, number, Path(f"{movement}_{subject}_e{number:02d}.txt"), Path("vicon.txt"))


def test_one_ratio_per_subject_and_movement_and_a_flat_movement_borrows(monkeypatch):
    found = {  # (subject, movement, number) -> (ratio, elevation range [deg])
        ("s01", "m07", 1): (1.6, 130.0), ("s01", "m07", 2): (1.55, 131.0), ("s01", "m07", 3): (1.65, 129.0),
        ("s01", "m07", 4): (0.6, 130.0),  # beyond the first CLOCK_EPISODES: not looked at
        ("s01", "m10", 1): (0.9, 90.0), ("s01", "m10", 2): (np.nan, 90.0), ("s01", "m10", 3): (0.925, 91.0),
        ("s01", "m09", 1): (1.6, 15.0), ("s01", "m09", 2): (0.6, 20.0),  # too flat to fix a ratio
        ("s02", "m09", 1): (1.5, 12.0),  # nothing of s02 fixes one
    }
    monkeypatch.setattr(angle_clocks, "episode_ratio", lambda e: found[(e.subject, e.movement, e.number)])
    assert CLOCK_EPISODES == 3 and MIN_RANGE_DEG > 20.0
    ratios = clock_ratios([_episode(*key) for key in found], jobs=1)
    assert ratios.subjects == ["s01", "s02"]
    assert ratios.ratios["s01"]["m07"] == pytest.approx(1.6)
    assert ratios.ratios["s01"]["m10"] == pytest.approx(0.9125)
    assert ratios.ratios["s01"]["m09"] == pytest.approx(np.median([1.6, 0.9125]))
    assert ratios.ratios["s02"] == {"m09": 1.0}
    assert ratios.borrowed == {("s01", "m09"), ("s02", "m09")}
    assert ratios.of(_episode("s01", "m07", 7)) == pytest.approx(1.6)
    assert ratios.of(_episode("s03", "m07", 1)) == 1.0
    assert ratios.as_dict()["s01"] == {"m07": pytest.approx(1.6), "m09": pytest.approx(1.25625),
                                       "m10": pytest.approx(0.9125)}
    assert ratios.text().splitlines() == ["s01: m07 1.600 (at the search's end), m09 1.256 (borrowed), m10 0.913",
                                          "s02: m09 1.000 (borrowed)"]


def test_an_empty_ratio_set_is_one_everywhere():
    assert ClockRatios({}).of(_episode("s01", "m07", 1)) == 1.0


@pytest.mark.skipif(not SAMPLES.is_dir(), reason="UI-PRMD samples not present")
def test_s01s_kinect_runs_at_two_rates():
    """s01's abduction fits the optical clock stretched by about 1.6, its scaption shrunk by about 0.9;
    its rotation's arm hardly rises, so it borrows."""
    ratios = clock_ratios(find_episodes(SAMPLES, ["s01"], ["m07", "m09", "m10"], limit=CLOCK_EPISODES), jobs=1)
    assert ratios.ratios["s01"]["m07"] >= 1.45
    assert 0.8 <= ratios.ratios["s01"]["m10"] <= 1.0
    assert ratios.borrowed == {("s01", "m09")}
