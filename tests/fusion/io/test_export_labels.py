"""Data set labels inside exported files: C3D parameters, TRC header extras, CSV leading columns."""

from __future__ import annotations

import csv

import ezc3d
import numpy as np
import pytest

from fusion.errors import BadInputError
from fusion.io.export import export_c3d, export_csv, export_trc
from fusion.io.formats.labels import LABEL_GROUP, check_labels
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, TrackingState

LABELS = {"participant_id": "sub-03", "group": "mild", "affected_side": "left", "fma_ue": "n/a",
          "salute_left_score": "1", "height_m": "1.7712"}


def _stream(n: int = 6) -> SkeletonStream:
    rng = np.random.default_rng(3)
    pos = rng.uniform(-0.5, 1.5, size=(n, KINECT_V2.n_joints, 3))
    states = np.full((n, KINECT_V2.n_joints), TrackingState.TRACKED, dtype=np.int8)
    return SkeletonStream(KINECT_V2, np.arange(n) / 30.0, pos, states)


def test_c3d_labels_are_parameters_of_their_group(tmp_path):
    export_c3d(_stream(), tmp_path / "a.c3d", labels=LABELS)
    c3d = ezc3d.c3d(str(tmp_path / "a.c3d"))
    got = {k: v["value"] for k, v in c3d["parameters"][LABEL_GROUP].items() if k != "__METADATA__"}
    assert got == {k: [v] for k, v in LABELS.items()}
    assert c3d["data"]["points"].shape[1:] == (KINECT_V2.n_joints, 6)


def test_trc_labels_follow_the_file_name(tmp_path):
    export_trc(_stream(), tmp_path / "a.trc", labels=LABELS)
    lines = (tmp_path / "a.trc").read_text().split("\n")
    first = lines[0].split("\t")
    assert first[:4] == ["PathFileType", "4", "(X/Y/Z)", "a.trc"]
    assert dict(f.split("=", 1) for f in first[4:]) == LABELS
    assert lines[1].split("\t") == ["DataRate", "CameraRate", "NumFrames", "NumMarkers", "Units", "OrigDataRate",
                                     "OrigDataStartFrame", "OrigNumFrames"]
    assert lines[3].startswith("Frame#\tTime\tSpineBase")


def test_opensim_reads_a_labelled_trc(tmp_path):
    osim = pytest.importorskip("opensim")
    export_trc(_stream(), tmp_path / "a.trc", labels=LABELS)
    table = osim.TimeSeriesTableVec3(str(tmp_path / "a.trc"))
    assert (table.getNumRows(), table.getNumColumns()) == (6, KINECT_V2.n_joints)


def test_csv_labels_lead_every_row(tmp_path):
    stream = _stream()
    export_csv(stream, tmp_path / "a.csv", labels=LABELS)
    with open(tmp_path / "a.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 6 and list(rows[0])[: len(LABELS) + 1] == [*LABELS, "time_s"]
    assert all({k: r[k] for k in LABELS} == LABELS for r in rows)
    assert float(rows[2]["SpineBase_z_m"]) == stream.positions[2, 0, 2]


def test_no_labels_writes_the_plain_files(tmp_path):
    export_csv(_stream(), tmp_path / "a.csv")
    assert (tmp_path / "a.csv").read_text().startswith("time_s,")
    assert check_labels(None) == {}


@pytest.mark.parametrize(("labels", "message"), [
    ({"Group": "mild"}, "lower-case identifier"),
    ({"group id": "mild"}, "lower-case identifier"),
    ({"a" * 61: "x"}, "at most 60"),
    ({"group": "mild, left"}, "without tabs, newlines, commas or quotes"),
    ({"group": "a\tb"}, "without tabs"),
    ({"group": 2}, "must be text"),
])
def test_bad_labels_are_refused_before_writing(tmp_path, labels, message):
    for write, name in ((export_c3d, "a.c3d"), (export_trc, "a.trc"), (export_csv, "a.csv")):
        with pytest.raises(BadInputError, match=message):
            write(_stream(), tmp_path / name, labels=labels)
        assert not (tmp_path / name).exists()
