"""serve, stream and listen as commands on loopback: the listened stream is the offline ``fuse``
result with the same method and the causal One-Euro filter, frame for frame; so is the LSL stream
``serve --lsl`` publishes."""

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from fusion.io.recording_files import load_recording
from fusion.live.client import replay
from fusion.live.protocol import Endpoint
from scenarios.cli import main
from tests.fusion.live.lsl_inlet import check_samples, open_inlet, pull_all

ROOT = Path(__file__).resolve().parents[2]


def _start(args):
    return subprocess.Popen([sys.executable, "-m", "scenarios.cli", *args], cwd=ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)


def _wait_for_line(proc, prefix, timeout_s=60.0):
    start = time.perf_counter()
    while time.perf_counter() - start < timeout_s:
        line = proc.stdout.readline()
        if line.startswith(prefix):
            return line
        if proc.poll() is not None:
            break
    raise AssertionError(f"no line starting with {prefix!r}: {proc.stderr.read()[-2000:]}")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    out = tmp_path_factory.mktemp("live") / "run"
    assert main(["simulate", "fma_2cam", "--out", str(out), "--duration", "14", "--seed", "3"]) == 0
    assert main(["calibrate", str(out), "--out", str(out / "calib.toml"), "--refine", "none"]) == 0
    return out


def test_serve_stream_listen_gives_the_offline_fused_skeleton(run, tmp_path):
    address = f"127.0.0.1:{Endpoint.free_loopback().port}"
    served, listened, fused = tmp_path / "served", tmp_path / "listened", tmp_path / "fused"
    assert main(["fuse", str(run), "--calib", str(run / "calib.toml"), "--fit", "merge", "--method", "avg_frontal", "--filter", "one_euro",
                 "--out", str(fused)]) == 0
    server = _start(["serve", "--calib", str(run / "calib.toml"), "--listen", address, "--method", "avg_frontal",
                     "--filter", "one_euro", "--deadline-ms", "inf", "--silent-after", "inf", "--max-held", "100000",
                     "--exit-when-done",
                     "--out", str(served)])
    listener = _start(["listen", address, "--out", str(listened), "--timeout", "60"])
    try:
        _wait_for_line(server, "serving on")
        _wait_for_line(listener, "listening to")
        time.sleep(0.5)  # the subscription reaches the publisher
        assert main(["stream", str(run), "--to", address, "--speed", "0"]) == 0
        assert server.wait(timeout=120) == 0 and listener.wait(timeout=120) == 0
    finally:
        for proc in (server, listener):
            if proc.poll() is None:
                proc.terminate()
    offline = load_recording(fused / "recording").camera("fused").skeleton
    for out in (listened, served):
        live = load_recording(out / "recording").camera("fused").skeleton
        assert np.array_equal(live.timestamps, offline.timestamps)
        assert np.array_equal(np.isnan(live.positions), np.isnan(offline.positions))
        assert np.nanmax(np.abs(live.positions - offline.positions)) <= 1e-9
        assert np.array_equal(live.states, offline.states)
        status = json.loads((out / "status.json").read_text())
        assert all(c["forgotten"] == 0 for c in status["cameras"].values())


def test_bad_addresses_are_refused(run, tmp_path, capsys):
    assert main(["serve", "--listen", "0.0.0.0:5570", "--out", str(tmp_path / "x")]) == 2
    assert "token" in capsys.readouterr().err
    assert main(["stream", str(run), "--to", "nowhere"]) == 2
    assert main(["listen", "127.0.0.1:99999", "--out", str(tmp_path / "y")]) == 2
    capsys.readouterr()
    nobody = f"127.0.0.1:{Endpoint.free_loopback().port}"  # no server there: nothing is delivered, exit 2
    assert main(["stream", str(run), "--to", nobody, "--speed", "0"]) == 2
    assert "did not take" in capsys.readouterr().err
    for timeout in ("-1", "0", "inf", "nan"):  # a listener that would never stop
        assert main(["listen", "127.0.0.1:5571", "--timeout", timeout, "--out", str(tmp_path / "z")]) == 2
        assert "--timeout must be a positive number" in capsys.readouterr().err


def test_serve_publishes_the_served_frames_as_an_lsl_stream(run, tmp_path):
    pylsl = pytest.importorskip("pylsl")
    address, name = f"127.0.0.1:{Endpoint.free_loopback().port}", f"mocap-bench-cli-{os.getpid()}"
    served = tmp_path / "served"
    got = {}

    def inlet_and_cameras():  # the server runs in this (main) thread: it handles the signals
        inlet, got["info"] = open_inlet(pylsl, name, timeout_s=60.0)
        got["before"] = pylsl.local_clock()
        replay(load_recording(run / "recording"), Endpoint.parse(address), speed=0.0)
        got["samples"], got["stamps"] = pull_all(inlet, timeout_s=60.0)

    thread = threading.Thread(target=inlet_and_cameras)
    thread.start()
    code = main(["serve", "--calib", str(run / "calib.toml"), "--listen", address, "--deadline-ms", "inf",
                 "--silent-after", "inf", "--max-held", "100000", "--exit-when-done", "--quiet", "--out", str(served),
                 "--lsl", name, "--lsl-joints", "kinect_v2", "--lsl-rate", "30"])
    thread.join()
    assert code == 0
    fused = load_recording(served / "recording").camera("fused").skeleton
    assert len(got["stamps"]) == fused.n_frames
    check_samples(got["samples"], fused.positions, fused.states)
    assert np.ptp(got["stamps"] - fused.timestamps) <= 1e-6 and got["stamps"][0] >= got["before"]
    assert got["info"].findtext("desc/setup/world").startswith("floor z = 0, z up")
    assert json.loads((served / "status.json").read_text())["lsl"]["pushed"] == fused.n_frames


def test_lsl_options_need_a_stream_name(run, capsys):
    assert main(["serve", "--calib", str(run / "calib.toml"), "--lsl-rate", "30"]) == 2
    assert "--lsl NAME" in capsys.readouterr().err
    assert main(["serve", "--calib", str(run / "calib.toml"), "--lsl", "fused", "--lsl-rate", "0"]) == 2
    assert "nominal rate" in capsys.readouterr().err
