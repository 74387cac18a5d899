"""Readers and writers of real-sensor skeleton files: quirks, round trips, errors, real samples."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from fusion.camera import KINECT_V2_DEPTH, AxisConvention
from fusion.errors import BadInputError, RecordingError
from fusion.frames import LengthUnit
from fusion.io.formats import (
    CsvOptions,
    read_csv_skeleton,
    read_k4abt_json,
    read_ntu,
    write_csv_skeleton,
    write_k4abt_json,
    write_ntu,
)
from fusion.io.formats.csv_skeleton import ConfidenceScale
from fusion.io.formats.k4abt_json import K4A_NFOV_UNBINNED
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import K4ABT, KINECT_V2, Topology, TrackingState

SAMPLES = Path("/work/shared/samples/ntu")


def make_recording(topology: Topology, *, seed: int = 0, n_cams: int = 2, n_frames: int = 12,
                   max_state: int = 2, axes: AxisConvention = AxisConvention.KINECT_V2) -> Recording:
    """A recording with random joints (z 1.5-4 m), some NOT_TRACKED joints and one empty frame."""
    rng = np.random.default_rng(seed)
    intr = KINECT_V2_DEPTH if axes is AxisConvention.KINECT_V2 else K4A_NFOV_UNBINNED
    cams = []
    for c in range(n_cams):
        J = topology.n_joints
        pos = rng.uniform([-1, -1, 1.5], [1, 1, 4], size=(n_frames, J, 3))
        states = rng.integers(1, max_state + 1, size=(n_frames, J)).astype(np.int8)
        states[rng.random((n_frames, J)) < 0.1] = 0
        states[n_frames // 2] = 0
        pos[states == 0] = np.nan
        ts = np.arange(n_frames) / 30.0
        cams.append(CameraRecording(f"cam{c + 1}", intr, SkeletonStream(topology, ts, pos, states)))
    return Recording(tuple(cams))


def assert_same_streams(a: Recording, b: Recording, *, atol: float = 0.0) -> None:
    assert a.camera_names == b.camera_names
    for ca, cb in zip(a.cameras, b.cameras):
        sa, sb = ca.skeleton, cb.skeleton
        assert sa.topology == sb.topology
        assert ca.intrinsics == cb.intrinsics
        np.testing.assert_allclose(sb.timestamps, sa.timestamps, rtol=0, atol=max(atol, 1e-6))
        np.testing.assert_allclose(sb.positions, sa.positions, rtol=0, atol=atol)
        np.testing.assert_array_equal(sb.states, sa.states)


# --- NTU ---------------------------------------------------------------------------------------

def _ntu_body(body_id: int, z: float, *, zero_quat_leaves: bool = True, states=None) -> list[str]:
    lines = [f"{body_id} 0 1 1 1 1 0 0.01119184 -0.256052 2", "25"]
    leaves = {3, 15, 19, 21, 22, 23, 24}
    for j in range(25):
        x = 8.094816e-05 if j == 0 else 0.01 * j
        xs = "8.094816E-05" if j == 0 else f"{x:.7g}"
        quat = "0 0 0 0" if zero_quat_leaves and j in leaves else "-0.2218947 0.03421978 0.968875 -0.1042736"
        st = 2 if states is None else states[j]
        lines.append(f"{xs} {0.5 - 0.02 * j:.7g} {z:.7g} 336 192 1184 489 {quat} {st}")
    return lines


def write_ntu_fixture(path: Path) -> None:
    """4 frames: one body; two bodies (main id second); no body; one body with a NotTracked joint."""
    main, other = 72057594037944738, 72057594037932185
    states = [2] * 25
    states[7], states[21] = 1, 0
    lines = ["4", "1", *_ntu_body(main, 3.0), "2", *_ntu_body(other, 2.0), *_ntu_body(main, 3.1), "0",
             "1", *_ntu_body(main, 3.2, states=states)]
    path.write_bytes(("\r\n".join(lines) + "\r\n").encode())


def test_ntu_quirks(tmp_path):
    path = tmp_path / "S001C002P003R001A038.skeleton"
    write_ntu_fixture(path)
    rec = read_ntu(path)
    s = rec.camera("cam2").skeleton
    assert s.topology == KINECT_V2 and s.n_frames == 4
    np.testing.assert_allclose(s.timestamps, np.arange(4) / 30)
    assert rec.metadata["body_ids"] == {"cam2": 72057594037944738}
    assert rec.metadata["action"] == 38 and rec.metadata["performer"] == 3
    np.testing.assert_allclose(s.positions[[0, 1, 3], 0, 2], [3.0, 3.1, 3.2])  # main body chosen in frame 2
    assert s.positions[0, 0, 0] == pytest.approx(8.094816e-05)
    assert np.isnan(s.positions[2]).all() and (s.states[2] == 0).all()  # the 0-body frame
    assert s.states[3, 7] == TrackingState.INFERRED and not np.isnan(s.positions[3, 7]).any()
    assert s.states[3, 21] == TrackingState.NOT_TRACKED and np.isnan(s.positions[3, 21]).all()


def test_ntu_lf_and_crlf_read_the_same(tmp_path):
    crlf = tmp_path / "a" / "S001C001P001R001A001.skeleton"
    lf = tmp_path / "b" / "S001C001P001R001A001.skeleton"
    crlf.parent.mkdir()
    lf.parent.mkdir()
    write_ntu_fixture(crlf)
    lf.write_bytes(crlf.read_bytes().replace(b"\r\n", b"\n"))
    assert read_ntu(crlf).cameras[0].skeleton.equals(read_ntu(lf).cameras[0].skeleton)


def test_ntu_round_trip_and_file_names(tmp_path):
    rec = make_recording(KINECT_V2)
    paths = write_ntu(rec, tmp_path, setup=2, performer=7, replication=1, action=38)
    assert [p.name for p in paths] == ["S002C001P007R001A038.skeleton", "S002C002P007R001A038.skeleton"]
    back = read_ntu(paths)
    assert_same_streams(rec, back)
    assert back.metadata["source_format"] == "ntu_skeleton" and back.metadata["setup"] == 2
    tokens = paths[0].read_text().split()
    assert int(tokens[0]) == 12 and tokens[1] == "1"


def test_ntu_writer_projects_depth_pixels(tmp_path):
    rec = make_recording(KINECT_V2, n_cams=1, n_frames=2)
    path = write_ntu(rec, tmp_path)[0]
    joint = [float(v) for v in path.read_text().splitlines()[4].split()]
    uv, _ = KINECT_V2_DEPTH.project(np.array(joint[:3]))
    np.testing.assert_allclose(joint[3:5], uv)


def test_ntu_writer_leaves_gaps_as_empty_frames(tmp_path):
    rec = make_recording(KINECT_V2, n_cams=1, n_frames=6)
    s = rec.cameras[0].skeleton
    sparse = Recording((CameraRecording("cam1", KINECT_V2_DEPTH, s.subset(np.array([0, 1, 4, 5]))),))
    back = read_ntu(write_ntu(sparse, tmp_path)).cameras[0].skeleton
    assert back.n_frames == 6 and np.isnan(back.positions[2:4]).all()
    np.testing.assert_array_equal(back.positions[[0, 1, 4, 5]], sparse.cameras[0].skeleton.positions)


def test_ntu_rejects_mixed_performances_and_bad_names(tmp_path):
    a, b = tmp_path / "S001C001P001R001A038.skeleton", tmp_path / "S001C002P002R001A038.skeleton"
    write_ntu_fixture(a)
    write_ntu_fixture(b)
    with pytest.raises(BadInputError, match="different performances"):
        read_ntu([a, b])
    bad = tmp_path / "walk.skeleton"
    write_ntu_fixture(bad)
    with pytest.raises(RecordingError, match="SsssCcccPpppRrrrAaaa"):
        read_ntu(bad)


def test_ntu_writer_needs_kinect_v2(tmp_path):
    with pytest.raises(BadInputError, match="kinect_v2"):
        write_ntu(make_recording(K4ABT), tmp_path)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t: t.replace("\r\n25\r\n", "\r\n24\r\n", 1), "joint count"),
        (lambda t: t[: len(t) // 2], "truncated"),
        (lambda t: t.replace("336", "nan", 1), "expected a number"),
        (lambda t: t.replace("1184", "1e999", 1), "out of range"),
        (lambda t: t.replace("4", "3", 1), "after the last frame"),
        (lambda t: "", "empty"),
    ],
)
def test_ntu_errors_name_file_and_place(tmp_path, edit, message):
    path = tmp_path / "S001C001P001R001A001.skeleton"
    write_ntu_fixture(path)
    path.write_bytes(edit(path.read_bytes().decode()).encode())
    with pytest.raises(RecordingError, match=message) as info:
        read_ntu(path)
    assert path.name in str(info.value)


@pytest.mark.skipif(not SAMPLES.is_dir(), reason="real NTU samples not available")
@pytest.mark.parametrize(("name", "n_frames"), [("S001C003P008R002A058.skeleton", 70),
                                                ("S001C001P001R001A050.skeleton", 74)])
def test_real_ntu_samples(name, n_frames):
    rec = read_ntu(SAMPLES / name)
    s = rec.cameras[0].skeleton
    assert s.n_frames == n_frames
    z = s.positions[..., 2]
    assert np.nanmin(z) > 1.5 and np.nanmax(z) < 5.0
    assert (s.states == TrackingState.TRACKED).mean() > 0.5
    # depthX/depthY in the file agree with projecting x, y, z through the default intrinsics
    uv, _ = rec.cameras[0].intrinsics.project(s.positions)
    assert np.nanmax(np.abs(uv - [255.5, 211.5])) < 300


# --- Azure Kinect JSON -------------------------------------------------------------------------

def _k4a_doc(frames: list[dict]) -> dict:
    return {"k4abt_sdk_version": "1.1.2", "source_file": "a.mkv", "joint_names": list(K4ABT.joints),
            "bone_list": [], "frames": frames}


def _k4a_body(body_id: int, z_mm: float, **extra) -> dict:
    pos = [[10.0 * j, -5.0 * j, z_mm] for j in range(32)]
    return {"body_id": body_id, "joint_positions": pos, "joint_orientations": [[1, 0, 0, 0]] * 32, **extra}


def test_k4a_json_reads_mm_as_metres_and_assumes_tracked(tmp_path):
    frames = [
        {"timestamp_usec": 1_000_000, "frame_id": 0, "num_bodies": 1, "bodies": [_k4a_body(2, 2000)]},
        {"timestamp_usec": 1_033_333, "frame_id": 1, "num_bodies": 2,
         "bodies": [_k4a_body(5, 1000), _k4a_body(2, 2100)]},
        {"timestamp_usec": 1_066_666, "frame_id": 2, "num_bodies": 0, "bodies": []},
    ]
    path = tmp_path / "front.json"
    path.write_text(json.dumps(_k4a_doc(frames)))
    rec = read_k4abt_json(path)
    assert rec.camera_names == ("front",)
    cam = rec.cameras[0]
    assert cam.intrinsics.axes is AxisConvention.OPENCV and cam.intrinsics == K4A_NFOV_UNBINNED
    s = cam.skeleton
    np.testing.assert_allclose(s.timestamps, [1.0, 1.033333, 1.066666])
    np.testing.assert_allclose(s.positions[:2, 3], [[0.03, -0.015, 2.0], [0.03, -0.015, 2.1]])
    assert (s.states[:2] == TrackingState.TRACKED).all() and (s.states[2] == 0).all()
    assert rec.metadata["confidence"] == {"front": "assumed_tracked"} and rec.metadata["body_ids"] == {"front": 2}


def test_k4a_json_uses_confidences_when_present(tmp_path):
    conf = [3, 0, 1] + [2] * 29
    frames = [{"timestamp_usec": 0, "frame_id": 0, "num_bodies": 1,
               "bodies": [_k4a_body(1, 2000, confidence_level=conf)]}]
    path = tmp_path / "cam.json"
    path.write_text(json.dumps(_k4a_doc(frames)))
    s = read_k4abt_json(path).cameras[0].skeleton
    np.testing.assert_array_equal(s.states[0], conf)
    assert np.isnan(s.positions[0, 1]).all()


def test_k4a_json_round_trip(tmp_path):
    rec = make_recording(K4ABT, max_state=3, axes=AxisConvention.OPENCV)
    back = read_k4abt_json(write_k4abt_json(rec, tmp_path))
    assert_same_streams(rec, back, atol=1e-12)
    assert back.metadata["confidence"] == {"cam1": "file", "cam2": "file"}


def test_k4a_json_writer_needs_k4abt(tmp_path):
    with pytest.raises(BadInputError, match="k4abt"):
        write_k4abt_json(make_recording(KINECT_V2), tmp_path)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d.pop("frames"), "missing key 'frames'"),
        (lambda d: d["frames"][0].pop("timestamp_usec"), "frame 1: missing key 'timestamp_usec'"),
        (lambda d: d["frames"][0].update(num_bodies=2), "num_bodies"),
        (lambda d: d["frames"][0]["bodies"][0]["joint_positions"].pop(), "32 lists of 3"),
        (lambda d: d["frames"][0]["bodies"][0]["joint_positions"][4].__setitem__(1, "7"), "32 lists of 3"),
        (lambda d: d["joint_names"].pop(), "joint_names"),
        (lambda d: d["frames"][1].update(timestamp_usec=0), "strictly increasing"),
        (lambda d: d["frames"][0]["bodies"][0].update(joint_confidences=[4] * 32), "0..3"),
    ],
)
def test_k4a_json_errors(tmp_path, edit, message):
    frames = [{"timestamp_usec": t, "frame_id": i, "num_bodies": 1, "bodies": [_k4a_body(1, 2000)]}
              for i, t in enumerate((0, 33_333))]
    doc = _k4a_doc(frames)
    edit(doc)
    path = tmp_path / "cam.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(RecordingError, match=message) as info:
        read_k4abt_json(path)
    assert "cam.json" in str(info.value)


def test_k4a_json_rejects_nan_literal(tmp_path):
    path = tmp_path / "cam.json"
    path.write_text(json.dumps(_k4a_doc([{"timestamp_usec": float("nan"), "frame_id": 0, "num_bodies": 0,
                                          "bodies": []}])))
    with pytest.raises(RecordingError, match="cam.json"):
        read_k4abt_json(path)


# --- CSV ---------------------------------------------------------------------------------------

@pytest.mark.parametrize(
    ("topology", "options"),
    [
        (KINECT_V2, CsvOptions()),
        (KINECT_V2, CsvOptions(confidence=ConfidenceScale.PROBABILITY)),
        (K4ABT, CsvOptions(topology=K4ABT, axes=AxisConvention.OPENCV, confidence=ConfidenceScale.STATE_0_3)),
        (K4ABT, CsvOptions(topology=K4ABT, axes=AxisConvention.OPENCV, confidence=ConfidenceScale.PROBABILITY)),
    ],
)
def test_csv_round_trip_exact_in_metres(tmp_path, topology, options):
    max_state = 2 if options.confidence is ConfidenceScale.STATE_0_2 else 3
    rec = make_recording(topology, max_state=max_state, axes=options.axes)
    back = read_csv_skeleton(write_csv_skeleton(rec, tmp_path, options), options)
    assert_same_streams(rec, back)


def test_csv_round_trip_in_millimetres(tmp_path):
    options = CsvOptions(unit=LengthUnit.MM)
    rec = make_recording(KINECT_V2)
    paths = write_csv_skeleton(rec, tmp_path, options)
    first = paths[0].read_text().splitlines()[1].split(",")
    assert 1500 <= float(first[5]) <= 4000  # SpineBase z in mm
    assert_same_streams(rec, read_csv_skeleton(paths, options), atol=1e-12)


def test_csv_keeps_the_main_body(tmp_path):
    options = CsvOptions()
    rec = make_recording(KINECT_V2, n_cams=1, n_frames=3)
    path = write_csv_skeleton(rec, tmp_path, options)[0]
    lines = path.read_text().splitlines()
    intruder = lines[2].split(",")
    intruder[1] = "9"
    path.write_text("\n".join([*lines[:2], ",".join(intruder), *lines[2:]]) + "\n")
    back = read_csv_skeleton(path, options)
    assert back.metadata["body_ids"] == {"cam1": 0}
    assert_same_streams(rec, back)


def test_csv_options_and_axes_are_checked(tmp_path):
    with pytest.raises(BadInputError):
        CsvOptions(unit="mm")
    with pytest.raises(BadInputError):
        CsvOptions(thresholds=(0.5, 0.4, 1.0))
    with pytest.raises(BadInputError, match="axes"):
        write_csv_skeleton(make_recording(KINECT_V2), tmp_path, CsvOptions(axes=AxisConvention.OPENCV))
    with pytest.raises(BadInputError, match="kinect_v2"):
        write_csv_skeleton(make_recording(KINECT_V2), tmp_path, CsvOptions(topology=K4ABT))


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda lines: [lines[0].replace("SpineBase_x", "SpineBase_X"), *lines[1:]], "column 4"),
        (lambda lines: [lines[0], lines[1] + ",1"], "columns"),
        (lambda lines: [lines[0], lines[1].replace(",2,", ",NaN,", 1)], "line 2: expected an integer"),
        (lambda lines: [lines[0], lines[1].replace(",2,", ",7,", 1)], "0..2"),
        (lambda lines: [lines[0], lines[2], lines[1]], "strictly increasing"),
        (lambda lines: [lines[0].split(",", 1)[1]], "header"),
    ],
)
def test_csv_errors(tmp_path, edit, message):
    rec = make_recording(KINECT_V2, n_cams=1, n_frames=2)
    rec = Recording((CameraRecording("cam1", KINECT_V2_DEPTH, rec.cameras[0].skeleton),))
    path = write_csv_skeleton(rec, tmp_path)[0]
    path.write_text("\n".join(edit(path.read_text().splitlines())) + "\n")
    with pytest.raises(RecordingError, match=message) as info:
        read_csv_skeleton(path)
    assert "cam1.csv" in str(info.value)
