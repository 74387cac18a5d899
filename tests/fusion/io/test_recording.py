import dataclasses
import json

import numpy as np
import pytest

from fusion.camera import Intrinsics
from fusion.depth import DepthStream, Label
from fusion.errors import BadInputError, RecordingError, UnknownNameError
from fusion.io.recording_files import load_recording, save_recording
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import K4ABT, KINECT_V2


def _stream(topology, T=20, seed=0):
    rng = np.random.default_rng(seed)
    pos = rng.normal(size=(T, topology.n_joints, 3))
    states = rng.integers(0, 3, size=(T, topology.n_joints)).astype(np.int8)
    pos[states == 0] = np.nan
    return SkeletonStream(topology, np.arange(T) / 30.0 + 0.01, pos, states)


def small_recording(topology=KINECT_V2, with_depth=True):
    intr = Intrinsics(width=8, height=6, fx=5.0, fy=5.0, cx=3.5, cy=2.5)
    depth = None
    if with_depth:
        rng = np.random.default_rng(3)
        depth = DepthStream(
            np.array([0.5, 1.5]),
            rng.integers(0, 4000, size=(2, 6, 8)).astype(np.uint16),
            rng.integers(0, 3, size=(2, 6, 8)).astype(np.uint8),
        )
    cams = (
        CameraRecording("cam1", intr, _stream(topology, seed=1), depth),
        CameraRecording("cam2", intr, _stream(topology, seed=2), None),
    )
    return Recording(cams, {"source": "test", "seed": 7})


@pytest.mark.parametrize("topology", [KINECT_V2, K4ABT])
def test_roundtrip_is_exact(tmp_path, topology):
    rec = small_recording(topology)
    save_recording(rec, tmp_path / "rec")
    back = load_recording(tmp_path / "rec")
    assert back.equals(rec)
    assert back.topology == topology
    assert back.camera("cam1").depth.labels[:].max() <= max(Label)


def test_same_content_gives_identical_bytes(tmp_path):
    save_recording(small_recording(), tmp_path / "a")
    save_recording(small_recording(), tmp_path / "b")
    files = sorted(p.relative_to(tmp_path / "a") for p in (tmp_path / "a").rglob("*") if p.is_file())
    for f in files:
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f


def test_refuses_to_overwrite_unless_asked(tmp_path):
    save_recording(small_recording(), tmp_path / "rec")
    with pytest.raises(BadInputError, match="not empty"):
        save_recording(small_recording(), tmp_path / "rec")
    save_recording(small_recording(with_depth=False), tmp_path / "rec", overwrite=True)
    assert load_recording(tmp_path / "rec").camera("cam1").depth is None


def test_failed_write_leaves_previous_recording(tmp_path, monkeypatch):
    save_recording(small_recording(), tmp_path / "rec")
    import fusion.io.recording_files as mod

    def boom(*args):
        raise RuntimeError("disk full")

    monkeypatch.setattr(mod, "write_arrays", boom)
    with pytest.raises(RuntimeError):
        save_recording(small_recording(with_depth=False), tmp_path / "rec", overwrite=True)
    assert load_recording(tmp_path / "rec").equals(small_recording())
    assert [p.name for p in tmp_path.iterdir()] == ["rec"]


def test_truncated_file_is_reported(tmp_path):
    save_recording(small_recording(), tmp_path / "rec")
    f = tmp_path / "rec" / "cam1" / "skeleton_positions.npy"
    f.write_bytes(f.read_bytes()[:-100])
    with pytest.raises(RecordingError, match="truncated"):
        load_recording(tmp_path / "rec")


def test_corrupt_file_is_reported(tmp_path):
    save_recording(small_recording(), tmp_path / "rec")
    f = tmp_path / "rec" / "cam1" / "skeleton_states.npy"
    data = bytearray(f.read_bytes())
    data[-1] ^= 0xFF
    f.write_bytes(bytes(data))
    with pytest.raises(RecordingError, match="corrupt"):
        load_recording(tmp_path / "rec")


def test_missing_or_bad_manifest(tmp_path):
    with pytest.raises(RecordingError, match="not a recording directory"):
        load_recording(tmp_path / "nothing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(RecordingError, match="no recording.json"):
        load_recording(tmp_path / "empty")
    save_recording(small_recording(), tmp_path / "rec")
    m = tmp_path / "rec" / "recording.json"
    m.write_text(m.read_text()[:50])
    with pytest.raises(RecordingError, match="not valid JSON"):
        load_recording(tmp_path / "rec")


def test_unknown_version(tmp_path):
    save_recording(small_recording(), tmp_path / "rec")
    m = tmp_path / "rec" / "recording.json"
    d = json.loads(m.read_text())
    d["version"] = 99
    m.write_text(json.dumps(d))
    with pytest.raises(RecordingError, match="version 99"):
        load_recording(tmp_path / "rec")


def test_validation_of_streams_and_names():
    with pytest.raises(BadInputError, match="strictly increasing"):
        SkeletonStream(KINECT_V2, np.array([0.0, 0.0]), np.zeros((2, 25, 3)), np.zeros((2, 25), np.int8))
    with pytest.raises(BadInputError, match="shape"):
        SkeletonStream(KINECT_V2, np.array([0.0]), np.zeros((1, 32, 3)), np.zeros((1, 32), np.int8))
    pos = np.zeros((1, 25, 3))
    pos[0, 3] = np.nan
    with pytest.raises(BadInputError, match="NOT_TRACKED"):
        SkeletonStream(KINECT_V2, np.array([0.0]), pos, np.full((1, 25), 2, np.int8))
    rec = small_recording()
    with pytest.raises(UnknownNameError, match="cam1, cam2"):
        rec.camera("cam9")
    with pytest.raises(BadInputError, match="unique"):
        Recording((rec.cameras[0], rec.cameras[0]))
    with pytest.raises(BadInputError, match="same joint topology"):
        Recording((rec.cameras[0], CameraRecording("cam3", rec.cameras[0].intrinsics, _stream(K4ABT))))


@pytest.mark.parametrize("confidence, assumed", [
    ("assumed_tracked", True), ({"cam1": "assumed_tracked", "cam2": "assumed_tracked"}, True),
    ({"cam1": "assumed_tracked", "cam2": "file"}, False), ({}, False), (None, False), ("file", False)])
def test_confidence_assumed_only_when_no_camera_carries_them(confidence, assumed):
    meta = {} if confidence is None else {"confidence": confidence}
    rec = Recording((CameraRecording("cam1", Intrinsics(), _stream(KINECT_V2)),), meta)
    assert rec.confidence_assumed is assumed


def test_joints_never_reported_are_left_out_of_another_recording():
    """A real session that never reports the hands: a simulation of it is measured without them."""
    real = small_recording(KINECT_V2, with_depth=False)
    hands = KINECT_V2.indices(["HandLeft", "HandRight"])
    cams = [dataclasses.replace(c, skeleton=SkeletonStream(
        c.skeleton.topology, c.skeleton.timestamps, np.where(np.isin(np.arange(25), hands)[None, :, None] & (k == 0),
                                                              np.nan, c.skeleton.positions),
        np.where(np.isin(np.arange(25), hands)[None, :] & (k == 0), 0, c.skeleton.states)))
        for k, c in enumerate(real.cameras)]
    real = Recording(tuple(cams), real.metadata)
    masks = real.never_reported()
    assert np.flatnonzero(masks[0]).tolist() == sorted(hands) and not masks[1].any()
    sim = small_recording(KINECT_V2, with_depth=False).without_joints(masks)
    first, second = (c.skeleton for c in sim.cameras)
    assert np.isnan(first.positions[:, hands]).all() and (first.states[:, hands] == 0).all()
    np.testing.assert_array_equal(second.positions, small_recording(KINECT_V2, with_depth=False).cameras[1].skeleton.positions)
    with pytest.raises(BadInputError, match="1 joint masks for 2 cameras"):
        sim.without_joints(masks[:1])


def test_renamed_cameras_take_their_metadata_along():
    rec = small_recording(KINECT_V2, with_depth=False)
    old = rec.camera_names
    rec = Recording(rec.cameras, {"source": "x", "body_ids": {old[0]: 3, old[1]: 1}, "confidence": {old[1]: "read"}})
    named = rec.renamed(["front", "side"])
    assert named.camera_names == ("front", "side")
    assert named.metadata == {"source": "x", "body_ids": {"front": 3, "side": 1}, "confidence": {"side": "read"}}
    np.testing.assert_array_equal(named.camera("side").skeleton.positions, rec.camera(old[1]).skeleton.positions)
    with pytest.raises(BadInputError, match="1 camera name"):
        rec.renamed(["front"])
    with pytest.raises(BadInputError, match="unique"):
        rec.renamed(["front", "front"])
    with pytest.raises(BadInputError, match="camera name must be"):
        rec.renamed(["front", "side view"])
