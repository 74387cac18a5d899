"""Benchmark scenarios load, and the results table renders (no timing is asserted here)."""

import pytest

from fusion.errors import ScenarioError
from scenarios.bench import real_samples
from scenarios.bench.benchmarks import (
    BenchKind,
    BenchmarkConfig,
    BenchResult,
    Goal,
    load_benchmarks,
    result_row,
    results_table,
    run_benchmarks,
)


def test_every_benchmark_file_is_valid():
    configs = load_benchmarks()
    names = {c.name for c in configs}
    assert {"depth_frame", "skeleton_ring6", "session_2cam", "calibrate_2cam_icp", "calibrate_ring6", "merge_ring6",
            "cohort_paper"} <= names
    assert all(c.target > 0 for c in configs)


def test_results_table_marks_missed_targets():
    cfg = BenchmarkConfig(name="x", kind=BenchKind.DEPTH_RENDER, scenario="single", target=20.0, goal=Goal.AT_MOST,
                          unit="ms", description="d")
    ok, missed = BenchResult(cfg, 10.0, (10.0,)), BenchResult(cfg, 30.0, (30.0,))
    assert ok.passed and not missed.passed
    table = results_table([result_row(ok), result_row(missed)])
    assert "| x | d | 10 ms | <= 20 ms | yes |" in table and "| NO |" in table


def test_unknown_benchmark_is_named(tmp_path):
    with pytest.raises(ScenarioError, match="depth_frame"):
        run_benchmarks(tmp_path / "B.md", only=["nope"])


def test_depth_memory_measures_a_run_streamed_to_disk():
    from scenarios.bench.memory import measure_in_subprocess

    m = measure_in_subprocess("single", 1.0, 30.0)
    assert 25 <= m["depth_frames"] <= 30  # one camera, 1 s at 30 Hz (the clock's phase may drop a frame)
    assert 0 < m["recording_mb"] < 30 * 0.7  # compressed below the raw 0.65 MB per frame
    assert m["peak_rss_mb"] > 50 and m["wall_s"] > 0
    assert {c.name for c in load_benchmarks() if c.kind is BenchKind.DEPTH_MEMORY} == {"depth_recording_ring6"}


@pytest.mark.skipif(not (real_samples.SAMPLES_DIR.parent / "ui_prmd").is_dir()
                    or not (real_samples.SAMPLES_DIR.parent / "kimore").is_dir(), reason="UI-PRMD or KIMORE samples not present")
def test_the_kinect_v2_benchmark_reads_seven_peoples_recordings():
    recordings, persons = real_samples.kinect_v2_recordings()
    assert len(recordings) == 24 and sorted(set(persons.values())) == ["P1", "P2", "s01", "s02", "s03", "s04", "s05"]
    joined = recordings["s03_m09"]
    assert [e["episode"] for e in joined.metadata["episodes"]] == list(range(1, 11))
    assert {r.topology.full_set.name for r in recordings.values()} == {"kinect_v2"}


def test_the_limb_axes_benchmark_times_a_session_with_depth():
    from scenarios.bench.fusion_runs import limb_axes_rate

    cfg = BenchmarkConfig(name="x", kind=BenchKind.LIMB_AXES, scenario="fma_2cam", target=10.0, goal=Goal.AT_LEAST,
                          unit="instants/s", duration_s=1.5, depth_rate_hz=4.0, repeats=1)
    samples = limb_axes_rate(cfg)
    assert len(samples) == 1 and samples[0] > 0
    assert "limb_axes_2cam" in {c.name for c in load_benchmarks() if c.kind is BenchKind.LIMB_AXES}
