"""CSV layout mapping: the two shipped layouts on fixture files, errors, body stitching, real samples."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fusion.camera import AxisConvention
from fusion.errors import BadInputError, RecordingError
from fusion.frames import LengthUnit
from fusion.io.formats.csv_layout import (
    AZURE_2CAM,
    KIMORE,
    CsvLayout,
    layout_from_dict,
    read_csv_layout,
    stitch_bodies,
)
from fusion.io.formats.csv_skeleton import ConfidenceScale
from fusion.topology import K4ABT, KINECT_V2

SAMPLES = Path(__file__).resolve().parents[3] / ".." / "shared" / "samples"


def _azure_file(path: Path, rows: list[tuple[int, int, np.ndarray, np.ndarray]]) -> Path:
    header = ["timestamp", "body_idx"] + [f"{j} ({f})" for j in K4ABT.joints for f in "cxyz"]
    lines = [";".join(header)]
    for t, body, conf, xyz in rows:
        cells = [str(t), str(body)] + [v for j in range(32) for v in (str(conf[j]), *(repr(float(x)) for x in xyz[j]))]
        lines.append(";".join(cells))
    path.write_text("\n".join(lines) + "\n")
    return path


def test_azure_layout_reads_mm_microseconds(tmp_path: Path) -> None:
    xyz = np.arange(96, dtype=float).reshape(32, 3) * 10.0
    conf = np.full(32, 2)
    conf[9] = 0
    path = _azure_file(tmp_path / "a.csv", [(1000, 1, conf, xyz), (34333, 1, conf, xyz + 1.0)])
    rec = read_csv_layout(path, AZURE_2CAM)
    s = rec.cameras[0].skeleton
    assert s.positions.shape == (2, 32, 3)
    np.testing.assert_allclose(s.timestamps, [0.001, 0.034333])
    np.testing.assert_allclose(s.positions[0, 0], [0.0, 0.01, 0.02])
    assert np.all(np.isnan(s.positions[:, 9])) and s.states[0, 9] == 0
    assert rec.cameras[0].intrinsics.axes is AxisConvention.OPENCV


def test_kimore_layout_blank_lines_trailing_comma(tmp_path: Path) -> None:
    row = ",".join(f"{0.1 * j},{-0.2},{2.5},{1 + j % 2}" for j in range(25)) + ","
    path = tmp_path / "k.csv"
    path.write_text("\n\n\n" + row + "\n" + row + "\n" + row + "\n")
    s = read_csv_layout(path, KIMORE).cameras[0].skeleton
    np.testing.assert_allclose(s.timestamps, [0, 1 / 30, 2 / 30])
    np.testing.assert_allclose(s.positions[1, 3], [0.3, -0.2, 2.5])
    assert s.states[0, 0] == 1 and s.states[0, 1] == 2


def test_reacquired_body_is_stitched(tmp_path: Path) -> None:
    xyz = 1000.0 + np.arange(96, dtype=float).reshape(32, 3) * 10.0  # a body-sized spread of joints, mm
    conf = np.full(32, 2)
    rows = [(0, 1, conf, xyz), (33333, 1, conf, xyz), (66666, 4, conf, xyz), (99999, 4, conf, xyz),
            (99999, 7, conf, xyz + 900.0)]
    rec = read_csv_layout(_azure_file(tmp_path / "a.csv", rows), AZURE_2CAM)
    s = rec.cameras[0].skeleton
    assert s.n_frames == 4 and not np.any(np.isnan(s.positions[:, 0]))
    np.testing.assert_allclose(s.positions[3, 0], [1.0, 1.01, 1.02])
    assert rec.metadata["body_ids"]["a"] == [1, 4]


@given(st.lists(st.integers(0, 3), min_size=1, max_size=30))
def test_stitch_keeps_one_row_per_frame(frames: list[int]) -> None:
    f = np.sort(np.array(frames))
    keep = stitch_bodies(np.arange(len(f)) % 2, f, np.zeros((len(f), 3)))
    assert keep.sum() == len(np.unique(f))
    assert len(np.unique(f[keep])) == keep.sum()


def test_missing_column_and_bad_cells(tmp_path: Path) -> None:
    p = tmp_path / "bad.csv"
    p.write_text("timestamp;body_idx;PELVIS (c)\n0;1;2\n")
    with pytest.raises(RecordingError, match="no column 'PELVIS \\(x\\)'"):
        read_csv_layout(p, AZURE_2CAM)
    row = ",".join("0,0,2,x" for _ in range(25))
    p.write_text(row + "\n")
    with pytest.raises(RecordingError, match="not a number"):
        read_csv_layout(p, KIMORE)
    p.write_text(",".join("0,0,2,5" for _ in range(25)) + "\n")
    with pytest.raises(RecordingError, match="confidences must be integers 0..2"):
        read_csv_layout(p, KIMORE)


def test_bad_layouts() -> None:
    with pytest.raises(BadInputError, match="exactly one of time_column"):
        CsvLayout(topology=KINECT_V2, rate_hz=30.0)
    with pytest.raises(BadInputError, match="separator"):
        CsvLayout(topology=KINECT_V2, separator=";;")
    with pytest.raises(BadInputError, match="unknown CSV layout key"):
        layout_from_dict({"topology": "k4abt", "sep": ";"})
    with pytest.raises(BadInputError, match="needs topology"):
        layout_from_dict({"separator": ";"})
    with pytest.raises(BadInputError, match="rate_hz must be a number, got '30'"):  # numbers written as strings
        layout_from_dict({"topology": "kinect_v2", "header": False, "rate_hz": "30"})
    with pytest.raises(BadInputError, match="header must be true or false"):
        layout_from_dict({"topology": "kinect_v2", "header": "no", "rate_hz": 30})


def test_layout_from_dict_matches_builtin() -> None:
    table = {"topology": "k4abt", "separator": ";", "time_column": "timestamp", "time_unit_s": 1e-6,
             "body_column": "body_idx", "joint_pattern": "{joint} ({field})", "unit": "mm", "axes": "opencv",
             "confidence": "state_0_3"}
    assert layout_from_dict(table) == AZURE_2CAM
    assert layout_from_dict({"topology": "kinect_v2", "header": False, "rate_hz": 30.0,
                             "field_order": ["x", "y", "z", "c"]}) == KIMORE
    assert KIMORE.unit is LengthUnit.M and AZURE_2CAM.confidence is ConfidenceScale.STATE_0_3


@pytest.mark.skipif(not (SAMPLES / "azure_2cam").is_dir(), reason="real samples absent")
def test_real_samples() -> None:
    a = SAMPLES / "azure_2cam"
    rec = read_csv_layout([a / "1E2DB6_01_master_positions_3d.csv", a / "1E2DB6_01_sub_positions_3d.csv"],
                          AZURE_2CAM)
    assert [c.skeleton.n_frames for c in rec.cameras] == [1255, 1223]
    z = np.nanmedian(rec.cameras[0].skeleton.positions[:, 0, 2])
    assert 2.0 < z < 3.0
    k = read_csv_layout(SAMPLES / "kimore" / "JointPositionExercise1.csv", KIMORE).cameras[0].skeleton
    assert k.n_frames == 505 and 2.0 < np.nanmedian(k.positions[:, 0, 2]) < 3.2
