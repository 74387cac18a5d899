"""Version 2 depth files: streamed writes, lazy reads, version 1 recordings, damaged files."""

import json
import pickle

import h5py
import numpy as np
import pytest

from fusion.depth import DepthStream, FrameChain
from fusion.errors import BadInputError, RecordingError
from fusion.io.arrayfiles import write_arrays
from fusion.io.depth_store import DepthWriter, StoredFrames, open_depth
from fusion.io.recording_files import (
    FORMAT_NAME,
    depth_file,
    load_recording,
    save_recording,
)
from tests.fusion.io.test_recording import small_recording


def _write_v1(recording, root):
    """A recording in the version 1 layout: every array, depth included, as a checksummed .npy file."""
    root.mkdir()
    cameras = []
    for cam in recording.cameras:
        arrays = {"skeleton_timestamps": cam.skeleton.timestamps, "skeleton_positions": cam.skeleton.positions,
                  "skeleton_states": cam.skeleton.states}
        if cam.depth is not None:
            arrays |= {"depth_timestamps": cam.depth.timestamps, "depth_mm": cam.depth.depth_mm,
                       "depth_labels": cam.depth.labels}
        cameras.append({"name": cam.name, "intrinsics": cam.intrinsics.to_dict(),
                        "files": write_arrays(root, cam.name, arrays)})
    manifest = {"format": FORMAT_NAME, "version": 1, "topology": recording.topology.name,
                "metadata": recording.metadata, "cameras": cameras}
    (root / "recording.json").write_text(json.dumps(manifest))


def test_version_1_recordings_still_read(tmp_path):
    rec = small_recording()
    _write_v1(rec, tmp_path / "v1")
    back = load_recording(tmp_path / "v1")
    assert back.equals(rec)
    assert isinstance(back.camera("cam1").depth.depth_mm, np.ndarray)  # version 1 depth is read whole
    save_recording(back, tmp_path / "v2")  # and re-saved as version 2
    assert json.loads((tmp_path / "v2" / "recording.json").read_text())["version"] == 2
    assert load_recording(tmp_path / "v2").equals(rec)


def test_version_2_reads_depth_lazily_frame_by_frame(tmp_path):
    rec = small_recording()
    save_recording(rec, tmp_path / "rec")
    depth = load_recording(tmp_path / "rec").camera("cam1").depth
    assert isinstance(depth.depth_mm, StoredFrames) and isinstance(depth.labels, StoredFrames)
    original = rec.camera("cam1").depth
    assert np.array_equal(depth.depth_mm[1], original.depth_mm[1])
    assert np.array_equal(depth.depth_mm[-1], original.depth_mm[-1])
    assert np.array_equal(depth.labels[[1, 0]], original.labels[[1, 0]])
    assert np.array_equal(np.asarray(depth.depth_mm), original.depth_mm)
    with pytest.raises(IndexError):
        depth.depth_mm[2]
    copy = pickle.loads(pickle.dumps(depth.depth_mm))  # e.g. sent to a Dask worker
    assert np.array_equal(copy[0], original.depth_mm[0])


def test_writer_streams_frames_and_checks_them(tmp_path):
    path = tmp_path / "cam" / "depth.h5"
    frames = np.arange(3 * 4 * 5, dtype=np.uint16).reshape(3, 4, 5)
    with DepthWriter(path, 4, 5, labels=False) as w:
        for k in range(3):
            w.append(0.1 * k, frames[k])
        with pytest.raises(BadInputError, match="increasing"):
            w.append(0.0, frames[0])
        with pytest.raises(BadInputError, match=r"uint16 \(4, 5\)"):
            w.append(1.0, frames[0].astype(np.int32))
        with pytest.raises(BadInputError, match="labels"):
            w.append(1.0, frames[0], np.zeros((4, 5), np.uint8))
    stream = w.stream()
    assert stream.n_frames == 3 and stream.labels is None
    assert np.array_equal(stream.depth_mm[:], frames)
    assert np.allclose(stream.timestamps, [0.0, 0.1, 0.2])
    with pytest.raises(BadInputError, match="already exists"):
        DepthWriter(path, 4, 5, labels=False)
    with h5py.File(path) as f:  # chunked per frame, compressed, checksummed
        assert f["depth_mm"].chunks == (1, 4, 5)
        assert f["depth_mm"].compression == "gzip" and f["depth_mm"].fletcher32


def test_truncated_depth_file_is_a_clear_error(tmp_path):
    save_recording(small_recording(), tmp_path / "rec")
    f = depth_file(tmp_path / "rec", "cam1")
    data = f.read_bytes()
    f.write_bytes(data[: len(data) // 2])
    with pytest.raises(BadInputError, match="depth.h5 is truncated or altered"):
        load_recording(tmp_path / "rec")
    with pytest.raises(RecordingError, match="truncated or corrupt"):  # the file alone, without its manifest
        open_depth(f)


def test_corrupt_depth_chunk_names_the_frame(tmp_path):
    rec = small_recording()
    save_recording(rec, tmp_path / "rec")
    f = depth_file(tmp_path / "rec", "cam1")
    with h5py.File(f) as h:
        offset, size = h["depth_mm"].id.get_chunk_info(1).byte_offset, h["depth_mm"].id.get_chunk_info(1).size
    data = bytearray(f.read_bytes())
    data[offset + size // 2] ^= 0xFF  # one flipped byte inside frame 1's compressed chunk
    f.write_bytes(bytes(data))
    depth = load_recording(tmp_path / "rec").camera("cam1").depth  # opening reads no frame
    assert np.array_equal(depth.depth_mm[0], rec.camera("cam1").depth.depth_mm[0])
    with pytest.raises(BadInputError, match="frame 1 of depth_mm cannot be read"):
        depth.depth_mm[1]


def test_missing_or_inconsistent_depth_file(tmp_path):
    save_recording(small_recording(), tmp_path / "rec")
    m = tmp_path / "rec" / "recording.json"
    doc = json.loads(m.read_text())
    doc["cameras"][0]["depth"]["frames"] = 5
    m.write_text(json.dumps(doc))
    with pytest.raises(RecordingError, match="holds 2 frames, the manifest says 5"):
        load_recording(tmp_path / "rec")
    depth_file(tmp_path / "rec", "cam1").unlink()
    with pytest.raises(RecordingError, match="depth.h5 is missing"):
        load_recording(tmp_path / "rec")


def test_frame_chain_reads_across_stacks(tmp_path):
    a = np.arange(2 * 3 * 4, dtype=np.uint16).reshape(2, 3, 4)
    b = a + 100
    with DepthWriter(tmp_path / "b.h5", 3, 4, labels=False) as w:
        for k in range(2):
            w.append(float(k), b[k])
    stored = w.stream()
    chain = FrameChain([a, stored.depth_mm, a])
    assert chain.shape == (6, 3, 4)
    assert np.array_equal(chain[2], b[0]) and np.array_equal(chain[5], a[1])
    assert np.array_equal(np.asarray(chain), np.concatenate([a, b, a]))
    assert np.array_equal(chain[[0, 3]], np.stack([a[0], b[1]]))
    assert DepthStream(np.arange(6.0), chain).n_frames == 6
    with pytest.raises(BadInputError, match="share image size"):
        FrameChain([a, np.zeros((1, 2, 2), np.uint16)])
