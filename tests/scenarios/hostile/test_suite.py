"""The hostile suite: its classification of outcomes, and its quick subset run through every command."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from fusion.errors import BadInputError
from scenarios.cli import main
from scenarios.hostile.command_cases import all_cases
from scenarios.hostile.reader_cases import build_base
from scenarios.hostile.suite import (
    GOOD,
    Case,
    Expect,
    Outcome,
    counts,
    report_markdown,
    run_case,
    run_suite,
)


def _case(build, expect=Expect.ERROR) -> Case:
    return Case("t", "test", build, expect)


def test_outcomes_are_classified(tmp_path):
    version = lambda d: (["--version"], None)  # noqa: E731 - exits 0
    bad_arg = lambda d: (["simulate"], None)  # noqa: E731 - argparse usage error, exit 2
    refused = lambda d: (["export", str(d / "missing"), "--format", "csv", "--out", str(d / "x")], None)  # noqa: E731

    def crash(d: Path):
        raise ValueError("boom")

    def slow(d: Path):
        time.sleep(5)

    def wrong(d: Path):
        return ["--version"], lambda dd: "the output is wrong"

    expected = [(version, Expect.ERROR, Outcome.SILENT_WRONG), (version, Expect.RESULT, Outcome.CORRECT),
                (wrong, Expect.RESULT, Outcome.SILENT_WRONG), (wrong, Expect.EITHER, Outcome.SILENT_WRONG),
                (bad_arg, Expect.ERROR, Outcome.CLEAR_ERROR), (refused, Expect.ERROR, Outcome.CLEAR_ERROR),
                (refused, Expect.RESULT, Outcome.WRONG_REFUSAL), (refused, Expect.EITHER, Outcome.CLEAR_ERROR),
                (crash, Expect.ERROR, Outcome.TRACEBACK), (slow, Expect.ERROR, Outcome.HANG)]
    for i, (build, expect, outcome) in enumerate(expected):
        result = run_case(_case(build, expect), tmp_path / str(i), main, timeout_s=0.5)
        assert result.outcome is outcome, (i, result)
    assert "ValueError: boom" in run_case(_case(crash), tmp_path / "c", main, timeout_s=5).message


def test_bad_suite_arguments(tmp_path):
    with pytest.raises(BadInputError, match="no hostile cases"):
        run_suite([], tmp_path, main)
    with pytest.raises(BadInputError, match="timeout_s"):
        run_suite([_case(lambda d: (["--version"], None))], tmp_path, main, timeout_s=float("nan"))


@pytest.fixture(scope="module")
def quick_results(tmp_path_factory):
    work = tmp_path_factory.mktemp("hostile")
    base = build_base(work / "base", seed=1)
    cases = [c for c in all_cases(base, mutants=6, rng=np.random.default_rng(1)) if c.quick]
    return run_suite(cases, work / "cases", main, timeout_s=60.0)


def test_quick_suite_has_no_traceback_hang_or_silent_wrong_result(quick_results):
    c = counts(quick_results)
    bad = [(r.case.group, r.case.name, r.outcome.value, r.message) for r in quick_results if r.outcome not in GOOD]
    assert not bad, bad
    assert c["traceback"] == c["hang"] == c["silent wrong result"] == c["refused a good input"] == 0
    assert sum(c.values()) == len(quick_results) > 60
    groups = {r.case.group for r in quick_results}
    assert {"import csv", "import ntu", "import k4abt-json", "recording", "calibration", "simulate", "layout",
            "cohort", "fma", "export"} <= groups


@pytest.mark.parametrize("name, words", [
    ("csv in millimetres read as metres", "look like millimetres"),
    ("csv timestamps in microseconds", "look like microseconds"),
    ("csv epoch offset on one camera", "do not share a time base"),
    ("k4abt-json in metres", "metres read as millimetres"),
    ("ntu in millimetres", "look like millimetres"),
    ("float tracking states (1.7)", "whole numbers"),
    ("truncated depth file", "depth.h5 is truncated or altered"),
    ("damaged depth frame", "frame 0 of depth_mm cannot be read"),
    ("fuse: calibration lacks a camera", "lacks recording camera(s) cam2"),
    ("evaluate: calibration names an extra camera", "names camera(s) cam3"),
    ("fuse: a camera with one frame", "has 1 frame(s)"),
    ("300 cameras", "at most 24"),
    ("ring radius 50 m", "outside the sensor's depth range"),
    ("cameras below the floor", "below the floor"),
    ("2 angles with n_cameras = 3", "lists 2 angles"),
    ("--duration 1e9", "GiB in memory"),
    ("layout on a two-camera scenario", "at least three ring cameras"),
    ("cohort with 100,000,000 subjects", "at most 500"),
    ("fma on a truncated manifest", "not valid JSON"),
    ("calibrate: --out an existing directory", "is a directory"),
    ("export onto an existing file", "--overwrite"),
])
def test_each_refusal_says_what_was_wrong(quick_results, name, words):
    (result,) = [r for r in quick_results if r.case.name == name]
    assert result.outcome is Outcome.CLEAR_ERROR and words in result.message


def test_report_lists_counts_and_cases(quick_results):
    text = report_markdown(quick_results)
    assert f"{len(quick_results)} cases." in text and "| traceback | 0 |" in text
    assert "csv person re-acquired under a new body id" in text
