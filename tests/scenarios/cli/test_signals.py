"""SIGTERM ends a command like Ctrl-C: exit status 143, a short message, no temporary folder left."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from scenarios.cli import Terminated, sigterm_raises

ROOT = Path(__file__).resolve().parents[3]


def test_sigterm_raises_in_the_block_and_restores_the_previous_handler():
    def previous(signum, frame):
        pass

    saved = signal.signal(signal.SIGTERM, previous)
    try:
        with pytest.raises(Terminated), sigterm_raises():
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5)  # the handler runs before this returns
        assert signal.getsignal(signal.SIGTERM) is previous
    finally:
        signal.signal(signal.SIGTERM, saved)


def test_sigterm_handler_is_left_alone_outside_the_main_thread():
    before, errors = signal.getsignal(signal.SIGTERM), []

    def run():
        try:
            with sigterm_raises():
                pass
        except Exception as exc:  # noqa: BLE001 - reported below
            errors.append(exc)

    thread = threading.Thread(target=run)
    thread.start()
    thread.join()
    assert errors == [] and signal.getsignal(signal.SIGTERM) is before


def test_sigterm_during_simulate_removes_the_temporary_folder(tmp_path):
    out = tmp_path / "run"
    env = {**os.environ, "TQDM_DISABLE": "1"}
    proc = subprocess.Popen(  # about 20 s of work: SIGTERM arrives long before it ends
        [sys.executable, "-m", "scenarios.cli", "-q", "simulate", "single", "--duration", "600", "--out", str(out)],
        cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + 30
        while not any(p.name.startswith(".") for p in tmp_path.iterdir()):
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "no temporary folder appeared in 30 s"
            time.sleep(0.05)
        time.sleep(0.3)  # into the simulation
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 143, err
    assert "interrupted" in err and "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


_HALF_BUILT = """
import argparse, sys
from scenarios import cli

class HalfBuilt:  # like an llvmlite object whose constructor an interruption cut short
    def __init__(self):
        raise {exc}
    def __del__(self):
        self.handle.close()

def build_parser():
    parser = argparse.ArgumentParser()
    parser.set_defaults(func=lambda args: HalfBuilt(), command="x", verbose=0, quiet=True)
    return parser

cli.build_parser = build_parser
sys.exit(cli.main([]))
"""


@pytest.mark.parametrize("exc, status", [("KeyboardInterrupt", 130), ("cli.Terminated", 143)])
def test_an_interrupted_constructor_does_not_print_a_traceback(exc, status):
    proc = subprocess.run([sys.executable, "-c", _HALF_BUILT.format(exc=exc)], cwd=ROOT,
                          capture_output=True, text=True, timeout=60)
    assert proc.returncode == status, proc.stderr
    assert "interrupted" in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
