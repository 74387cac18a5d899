"""Joint-angle tables: CSV and OpenSim .mot round trips, NaN kept, bad input and bad files rejected."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fusion.errors import BadInputError, RecordingError
from fusion.io.angle_tables import (
    read_angles_csv,
    read_mot,
    write_angles_csv,
    write_mot,
)

NAMES = ("elbow_flexion_left", "ht_elevation_right")


@settings(max_examples=20, deadline=None)
@given(st.lists(st.tuples(st.floats(-400, 400) | st.just(np.nan), st.floats(-400, 400) | st.just(np.nan)),
                min_size=1, max_size=8))
def test_round_trips_keep_values_and_nan(tmp_path_factory, rows):
    tmp = tmp_path_factory.mktemp("angles")
    degrees = np.array(rows, dtype=float)
    times = np.arange(len(rows)) / 30.0
    t, names, d = read_angles_csv(write_angles_csv(times, NAMES, degrees, tmp / "angles.csv"))
    assert names == NAMES and np.array_equal(t, times) and np.array_equal(d, degrees, equal_nan=True)
    t, names, d = read_mot(write_mot(times, NAMES, degrees, tmp / "angles.mot"))
    assert names == NAMES and np.allclose(t, times, atol=1e-6) and np.allclose(d, degrees, atol=1e-6, equal_nan=True)


def test_mot_header_is_opensim_storage(tmp_path):
    write_mot(np.array([0.0, 0.5]), NAMES, np.zeros((2, 2)), tmp_path / "a.mot", title="trial")
    head = (tmp_path / "a.mot").read_text().splitlines()
    assert head[:7] == ["trial", "version=1", "nRows=2", "nColumns=3", "inDegrees=yes", "endheader",
                        "time\telbow_flexion_left\tht_elevation_right"]


def test_bad_input_and_bad_files(tmp_path):
    with pytest.raises(BadInputError, match="shape"):
        write_mot(np.arange(2.0), NAMES, np.zeros((3, 2)), tmp_path / "a.mot")
    with pytest.raises(BadInputError, match="infinite"):
        write_angles_csv(np.zeros(1), NAMES, np.array([[np.inf, 0.0]]), tmp_path / "a.csv")
    with pytest.raises(BadInputError, match="names"):
        write_angles_csv(np.zeros(1), ("a b", "c"), np.zeros((1, 2)), tmp_path / "a.csv")
    with pytest.raises(BadInputError, match="at least one frame"):
        write_mot(np.zeros(0), NAMES, np.zeros((0, 2)), tmp_path / "a.mot")
    (tmp_path / "x.csv").write_text("t,a\n1,2\n")
    with pytest.raises(RecordingError, match="header"):
        read_angles_csv(tmp_path / "x.csv")
    (tmp_path / "x.mot").write_text("x\nversion=1\n")
    with pytest.raises(RecordingError, match="endheader"):
        read_mot(tmp_path / "x.mot")
