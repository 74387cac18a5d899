"""A pylsl inlet for the LSL outlet tests: open it by name, pull every sample, check samples against
fused skeletons."""

import time
import xml.etree.ElementTree as ET

import numpy as np


def open_inlet(pylsl, name, timeout_s=10.0):
    """An inlet of the stream called ``name``, its connection open, and its full description (parsed)."""
    found = pylsl.resolve_byprop("name", name, 1, timeout_s)
    assert len(found) == 1, f"LSL stream {name!r} not found in {timeout_s} s"
    inlet = pylsl.StreamInlet(found[0])
    inlet.open_stream(timeout_s)
    return inlet, ET.fromstring(inlet.info(timeout_s).as_xml())


def pull_all(inlet, n=None, timeout_s=20.0, idle_s=2.0):
    """``(samples (T, C), stamps (T,))`` once ``n`` samples arrived (without ``n``: ``idle_s`` [s]
    without one after the first), or after ``timeout_s`` [s]."""
    samples, stamps = [], []
    deadline, last = time.perf_counter() + timeout_s, np.inf
    while (len(stamps) < n if n else time.perf_counter() - last < idle_s) and time.perf_counter() < deadline:
        chunk, times = inlet.pull_chunk(timeout=0.2)
        if times:
            samples += chunk
            stamps += times
            last = time.perf_counter()
    return np.array(samples, dtype=np.float64), np.array(stamps)


def check_samples(samples, positions, states):
    """LSL samples (T, 4 J) against fused (T, J, 3) positions [m] and (T, J) states: NaN where
    absent, float32 rounding (<= 1 um at a few metres) elsewhere, confidence = state / 2."""
    got = samples.reshape(len(samples), -1, 4)
    assert got.shape[:2] == states.shape
    assert np.array_equal(np.isnan(got[..., :3]), np.isnan(positions))
    assert np.nanmax(np.abs(got[..., :3] - positions)) <= 1e-6
    assert np.array_equal(got[..., 3], states / 2.0)
