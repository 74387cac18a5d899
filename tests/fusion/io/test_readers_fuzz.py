"""Fuzzing the skeleton-file readers: damaged files give a RecordingError or a consistent recording."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fusion.camera import AxisConvention
from fusion.errors import RecordingError
from fusion.io.formats import (
    read_csv_skeleton,
    read_k4abt_json,
    read_ntu,
    write_csv_skeleton,
    write_k4abt_json,
)
from fusion.recording import Recording
from fusion.topology import K4ABT, KINECT_V2
from tests.fusion.io.test_readers import make_recording, write_ntu_fixture

fuzz = settings(max_examples=50, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])

NON_FINITE = st.sampled_from(["nan", "NaN", "inf", "-inf", "Infinity", "1e999", "-1E400"])
_NUMBER = re.compile(rb"(?<![\w.])-?\d+(\.\d+)?([eE][+-]?\d+)?(?![\w.])")


def _ntu(tmp: Path) -> Path:
    path = tmp / "S001C001P001R001A001.skeleton"
    write_ntu_fixture(path)
    return path


def _k4a(tmp: Path) -> Path:
    rec = make_recording(K4ABT, n_cams=1, n_frames=3, axes=AxisConvention.OPENCV)
    return write_k4abt_json(rec, tmp)[0]


def _csv(tmp: Path) -> Path:
    return write_csv_skeleton(make_recording(KINECT_V2, n_cams=1, n_frames=3), tmp)[0]


FORMATS: dict[str, tuple[Callable[[Path], Path], Callable[[Path], Recording]]] = {
    "ntu": (_ntu, read_ntu),
    "k4abt_json": (_k4a, read_k4abt_json),
    "csv": (_csv, read_csv_skeleton),
}


@pytest.fixture(params=sorted(FORMATS))
def valid_file(request, tmp_path):
    """(path of a valid file, its original bytes, its reader, the recording it holds)."""
    make, read = FORMATS[request.param]
    path = make(tmp_path)
    return path, path.read_bytes(), read, read(path)


def _read_or_error(read, path: Path, data: bytes) -> Recording | None:
    path.write_bytes(data)
    try:
        return read(path)
    except RecordingError as exc:
        assert path.name in str(exc)
        return None


@fuzz
@given(data=st.binary(max_size=300))
def test_random_bytes(valid_file, data):
    path, _, read, _ = valid_file
    _read_or_error(read, path, data)


@fuzz
@given(fraction=st.floats(0, 1, exclude_max=True))
def test_truncation_gives_error_or_a_consistent_prefix(valid_file, fraction):
    path, original, read, full = valid_file
    rec = _read_or_error(read, path, original[: int(fraction * len(original))])
    if rec is not None:  # only a cut at a row end of a CSV, or in trailing whitespace, leaves a valid file
        s, ref = rec.cameras[0].skeleton, full.cameras[0].skeleton
        n = s.n_frames
        assert 0 < n <= ref.n_frames and s.topology == ref.topology
        assert s.subset(slice(0, n - 1)).equals(ref.subset(slice(0, n - 1)))
        np.testing.assert_array_equal(s.timestamps, ref.timestamps[:n])


@fuzz
@given(choice=st.integers(0, 10**6))
def test_deleting_a_number_is_an_error(valid_file, choice):
    path, original, read, _ = valid_file
    numbers = list(_NUMBER.finditer(original))
    m = numbers[choice % len(numbers)]
    damaged = original[: m.start()] + original[m.end():]
    if path.suffix == ".skeleton":  # a token stream: drop the token with its separator
        damaged = original[: m.start()] + original[m.end() + 1:]
    assert _read_or_error(read, path, damaged) is None


@fuzz
@given(choice=st.integers(0, 10**6), text=NON_FINITE)
def test_non_finite_text_is_an_error(valid_file, choice, text):
    path, original, read, _ = valid_file
    numbers = list(_NUMBER.finditer(original))
    m = numbers[choice % len(numbers)]
    assert _read_or_error(read, path, original[: m.start()] + text.encode() + original[m.end():]) is None
