"""Atomic writes on a full disk or a read-only file system: a clear BadInputError, no temporary left, the old target kept.

The failures are simulated with monkeypatch (the tests run as root, so permissions cannot be relied on).
"""

from __future__ import annotations

import errno
import os
import re

import ezc3d
import numpy as np
import pytest

from fusion.errors import BadInputError
from fusion.io import atomic
from fusion.io.atomic import atomic_directory, write_bytes_atomic, write_text_atomic
from fusion.io.export import export_c3d
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, TrackingState


def _fail_writes_under(monkeypatch, folder, err: int) -> None:
    """``os.write`` raises ``OSError(err)`` for files under ``folder`` (other descriptors write as usual)."""
    real = os.write

    def write(fd, data):
        try:
            target = os.readlink(f"/proc/self/fd/{fd}")
        except OSError:
            target = ""
        if target.startswith(str(folder)):
            raise OSError(err, os.strerror(err))
        return real(fd, data)

    monkeypatch.setattr(os, "write", write)


def _stream(T: int = 30) -> SkeletonStream:
    """``T`` frames at 30 Hz of random positions [m]."""
    rng = np.random.default_rng(0)
    pos = rng.uniform([-0.3, -0.3, 0.7], [0.3, 0.3, 1.3], size=(T, KINECT_V2.n_joints, 3))
    states = np.full(pos.shape[:2], TrackingState.TRACKED, dtype=np.int8)
    return SkeletonStream(KINECT_V2, np.arange(T) / 30.0, pos, states)


@pytest.mark.parametrize("write", [write_bytes_atomic, write_text_atomic])
def test_no_space_keeps_the_old_file_and_leaves_no_temporary(tmp_path, monkeypatch, write):
    target = tmp_path / "out.txt"
    target.write_text("old")
    _fail_writes_under(monkeypatch, tmp_path, errno.ENOSPC)
    with pytest.raises(BadInputError, match="space") as info:
        write(target, b"new" if write is write_bytes_atomic else "new")
    assert str(target) in str(info.value)
    assert isinstance(info.value.__cause__, OSError) and info.value.__cause__.errno == errno.ENOSPC
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.txt"]


def test_read_only_rename_says_so(tmp_path, monkeypatch):
    target = tmp_path / "out.txt"

    def replace(src, dst):
        raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(dst))

    monkeypatch.setattr(atomic.os, "replace", replace)
    with pytest.raises(BadInputError, match="read-only.*writable"):
        write_text_atomic(target, "new")
    assert list(tmp_path.iterdir()) == []


def test_other_os_errors_pass_through(tmp_path, monkeypatch):
    _fail_writes_under(monkeypatch, tmp_path, errno.EIO)
    with pytest.raises(OSError) as info:
        write_text_atomic(tmp_path / "out.txt", "new")
    assert not isinstance(info.value, BadInputError)
    assert list(tmp_path.iterdir()) == []


def test_atomic_directory_failure_inside_leaves_no_temporary(tmp_path):
    out = tmp_path / "run"
    with pytest.raises(RuntimeError), atomic_directory(out) as tmp:
        (tmp / "a.txt").write_text("partial")
        raise RuntimeError("boom")
    assert list(tmp_path.iterdir()) == []


def test_atomic_directory_no_space_inside_keeps_the_old_directory(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / "old.txt").write_text("old")
    with pytest.raises(BadInputError, match="space") as info, atomic_directory(out, overwrite=True) as tmp:
        (tmp / "a.txt").write_text("partial")
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    assert str(out) in str(info.value)
    assert [p.name for p in tmp_path.iterdir()] == ["run"]
    assert [p.name for p in out.iterdir()] == ["old.txt"]


def test_atomic_directory_read_only_rename_keeps_the_old_directory(tmp_path, monkeypatch):
    out = tmp_path / "run"
    out.mkdir()
    (out / "old.txt").write_text("old")
    real = os.replace

    def replace(src, dst):
        if str(src).endswith(".tmp"):  # the new directory onto the target
            raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(dst))
        return real(src, dst)

    monkeypatch.setattr(atomic.os, "replace", replace)
    with pytest.raises(BadInputError, match="read-only"), atomic_directory(out, overwrite=True) as tmp:
        (tmp / "a.txt").write_text("new")
    assert [p.name for p in tmp_path.iterdir()] == ["run"]
    assert (out / "old.txt").read_text() == "old"


def test_atomic_directory_does_not_blame_the_output_for_an_unreadable_input(tmp_path):
    with pytest.raises(PermissionError), atomic_directory(tmp_path / "run"):
        raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), "/elsewhere/input.txt")
    assert list(tmp_path.iterdir()) == []


def test_export_c3d_short_write_is_an_error(tmp_path, monkeypatch):
    real = ezc3d.c3d.write

    def short_write(self, path, *args, **kwargs):
        real(self, path, *args, **kwargs)
        with open(path, "r+b") as f:  # what a full disk leaves when ezc3d does not notice
            f.truncate(os.path.getsize(path) // 2)

    monkeypatch.setattr(ezc3d.c3d, "write", short_write)
    target = tmp_path / "s.c3d"
    with pytest.raises(BadInputError, match=re.escape(str(target))):
        export_c3d(_stream(300), target)
    assert list(tmp_path.iterdir()) == []


def test_export_c3d_no_file_written_is_an_error(tmp_path, monkeypatch):
    monkeypatch.setattr(ezc3d.c3d, "write", lambda self, path, *a, **k: None)  # ezc3d fails silently
    target = tmp_path / "s.c3d"
    target.write_bytes(b"old")
    with pytest.raises(BadInputError, match="no file was written"):
        export_c3d(_stream(), target)
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["s.c3d"]


def test_export_c3d_no_space_keeps_the_old_file(tmp_path, monkeypatch):
    def write(self, path, *args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(ezc3d.c3d, "write", write)
    target = tmp_path / "s.c3d"
    target.write_bytes(b"old")
    with pytest.raises(BadInputError, match="no space left"):
        export_c3d(_stream(), target)
    assert target.read_bytes() == b"old"
    assert [p.name for p in tmp_path.iterdir()] == ["s.c3d"]


def test_export_c3d_still_writes(tmp_path):
    path = export_c3d(_stream(300), tmp_path / "s.c3d")
    assert ezc3d.c3d(str(path))["data"]["points"].shape == (4, KINECT_V2.n_joints, 300)
    assert [p.name for p in tmp_path.iterdir()] == ["s.c3d"]
