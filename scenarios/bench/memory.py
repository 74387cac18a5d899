"""Peak memory of a simulation to disk, measured in a fresh process.

``python -m scenarios.bench.memory SCENARIO DURATION_S DEPTH_RATE_HZ OUT_DIR`` simulates the scenario
into ``OUT_DIR`` (depth streamed to its files) and prints one JSON line: ``peak_rss_mb`` (MiB, the process's
maximum resident set size, ``getrusage``), ``wall_s``, ``depth_frames`` and ``recording_mb`` (on disk).
"""

from __future__ import annotations

import dataclasses
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from fusion.errors import ScenarioError


def measure(scenario_name: str, duration_s: float, depth_rate_hz: float, out_dir: Path) -> dict[str, float]:
    """Simulate to ``out_dir`` and return peak RSS [MiB], wall time [s], depth frames and size on disk [MB]."""
    from fusion.io.recording_files import load_recording
    from scenarios.config import load_scenario
    from scenarios.runner import simulate_to_disk

    scenario = load_scenario(scenario_name).replace(duration_s=duration_s)
    scenario = dataclasses.replace(scenario, sensors=dataclasses.replace(scenario.sensors, depth_rate_hz=depth_rate_hz))
    t0 = time.perf_counter()
    simulate_to_disk(scenario, out_dir, progress=False)
    wall = time.perf_counter() - t0
    recording = load_recording(out_dir / "recording")
    return {
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,  # Linux: kilobytes
        "wall_s": wall,
        "depth_frames": sum(c.depth.n_frames for c in recording.cameras if c.depth is not None),
        "recording_mb": sum(p.stat().st_size for p in (out_dir / "recording").rglob("*") if p.is_file()) / 1e6,
    }


def measure_in_subprocess(scenario_name: str, duration_s: float, depth_rate_hz: float) -> dict[str, float]:
    """:func:`measure` in a fresh Python process (so the peak is this run's alone), into a temporary directory."""
    root = Path(__file__).resolve().parents[2]
    env = os.environ | {"PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}
    with tempfile.TemporaryDirectory() as tmp:
        args = [sys.executable, "-m", "scenarios.bench.memory", scenario_name, str(duration_s), str(depth_rate_hz),
                str(Path(tmp) / "run")]
        done = subprocess.run(args, capture_output=True, text=True, env=env)
    if done.returncode != 0:
        raise ScenarioError(f"the measuring process failed:\n{done.stderr[-2000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


if __name__ == "__main__":
    name, duration, rate, out = sys.argv[1:5]
    print(json.dumps(measure(name, float(duration), float(rate), Path(out))), flush=True)
