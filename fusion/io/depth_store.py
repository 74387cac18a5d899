"""Depth frames on disk: one chunked, compressed HDF5 file per camera, written frame by frame, read lazily.

File layout (``<camera>/depth.h5`` of a version 2 recording)::

    timestamps   (N,) float64 s on the camera's clock
    depth_mm     (N, H, W) uint16 mm, 0 = no return
    labels       (N, H, W) uint8 fusion.depth.Label   (only if the sensor segments)

Each frame is one chunk (``(1, H, W)``), deflate-compressed (gzip level 1, byte shuffle) with a
Fletcher-32 checksum, so a frame is read alone and a damaged chunk is reported with its frame number.
The file's attribute ``format`` is ``mocap-bench-depth`` and ``version`` 1. Any HDF5 tool reads it
(``h5py``, ``h5dump``, MATLAB, ...).
"""

from __future__ import annotations

import os
from pathlib import Path

import h5py
import numpy as np

from fusion.depth import DepthStream, read_frames
from fusion.errors import BadInputError, RecordingError

FORMAT_NAME = "mocap-bench-depth"
FORMAT_VERSION = 1
_FILTERS = {"compression": "gzip", "compression_opts": 1, "shuffle": True, "fletcher32": True}
_FIX = "re-simulate or re-import the recording (a copy may have been cut short or damaged)"


def _open(path: Path) -> h5py.File:
    try:
        return h5py.File(path, "r")
    except FileNotFoundError:
        raise RecordingError(f"{path} is missing; {_FIX}") from None
    except OSError as exc:
        raise RecordingError(f"{path} is truncated or corrupt, not a readable HDF5 depth file ({exc}); {_FIX}") from None


class StoredFrames:
    """Lazy (N, H, W) frames of one dataset of a depth file: ``frames[k]`` reads frame k from disk.

    Picklable (it holds the path, and reopens the file where it is unpickled). Reading a frame whose
    chunk is damaged raises :class:`~fusion.errors.RecordingError` naming the file and the frame.

    Parameters
    ----------
    path : the HDF5 depth file.
    name : ``"depth_mm"`` or ``"labels"``.
    shape : (N, H, W) the dataset's shape, as checked by :func:`open_depth`.
    dtype : its element type.
    """

    def __init__(self, path: Path, name: str, shape: tuple[int, int, int], dtype: np.dtype) -> None:
        self.path = Path(path)
        self.name = name
        self.shape = tuple(int(n) for n in shape)
        self.dtype = np.dtype(dtype)
        self.ndim = 3
        self._file: h5py.File | None = None

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, index) -> np.ndarray:
        return read_frames(self, index, self._read)

    def _read(self, k: int) -> np.ndarray:
        if self._file is None:
            self._file = _open(self.path)
        try:
            return self._file[self.name][k]
        except (OSError, KeyError) as exc:
            raise RecordingError(f"{self.path}: frame {k} of {self.name} cannot be read ({exc}); {_FIX}") from None

    def __array__(self, dtype=None, copy=None) -> np.ndarray:
        return self[:].astype(dtype or self.dtype, copy=False)

    def close(self) -> None:
        """Close the file handle (reopened on the next read)."""
        if self._file is not None:
            self._file.close()
            self._file = None

    def __getstate__(self) -> dict:
        return {k: v for k, v in self.__dict__.items() if k != "_file"} | {"_file": None}


class DepthWriter:
    """Append depth frames to a new depth file, one frame at a time (memory: one frame).

    Use as a context manager, or call :meth:`close`; :meth:`stream` then gives the lazy stream.

    Parameters
    ----------
    path : the file to create (its folder is created; an existing file is an error).
    height, width : image size [px].
    labels : whether every frame comes with a segmentation.
    """

    def __init__(self, path: str | os.PathLike, height: int, width: int, *, labels: bool) -> None:
        self.path = Path(path)
        if self.path.exists():
            raise BadInputError(f"{self.path} already exists; write depth into a new file")
        if height < 1 or width < 1:
            raise BadInputError(f"image size must be positive, got {height} x {width}")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._shape = (int(height), int(width))
        self._file = h5py.File(self.path, "w")
        self._file.attrs["format"] = FORMAT_NAME
        self._file.attrs["version"] = FORMAT_VERSION
        self._times = self._file.create_dataset("timestamps", shape=(0,), maxshape=(None,), dtype=np.float64,
                                                chunks=(4096,), track_times=False)
        names = ("depth_mm", "labels") if labels else ("depth_mm",)
        self._sets = [self._file.create_dataset(n, shape=(0, *self._shape), maxshape=(None, *self._shape),
                                                dtype=np.uint16 if n == "depth_mm" else np.uint8,
                                                chunks=(1, *self._shape), track_times=False, **_FILTERS)
                      for n in names]
        self._last_t = -np.inf
        self.n_frames = 0

    def append(self, timestamp_s: float, depth_mm: np.ndarray, labels: np.ndarray | None = None) -> None:
        """Write one frame: its time [s] (after the previous one), (H, W) uint16 depth [mm], (H, W) uint8 labels."""
        if self._file is None:
            raise BadInputError(f"{self.path} is closed; frames cannot be appended any more")
        frames = [np.asarray(depth_mm)] + ([] if labels is None else [np.asarray(labels)])
        if len(frames) != len(self._sets):
            raise BadInputError("give labels with every frame or with none, as the writer was opened")
        for arr, ds in zip(frames, self._sets):
            if arr.shape != self._shape or arr.dtype != ds.dtype:
                raise BadInputError(f"{ds.name[1:]} frame must be {ds.dtype} {self._shape}, got {arr.dtype} {arr.shape}")
        if not np.isfinite(timestamp_s) or timestamp_s <= self._last_t:
            raise BadInputError(f"depth timestamps must be finite and increasing, got {timestamp_s} after {self._last_t}")
        k = self.n_frames
        for ds, arr in zip([self._times, *self._sets], [timestamp_s, *frames]):
            ds.resize(k + 1, axis=0)
            ds[k] = arr
        self._last_t = float(timestamp_s)
        self.n_frames = k + 1

    def close(self) -> None:
        """Flush and close the file (idempotent)."""
        if self._file is not None:
            self._file.close()
            self._file = None

    def stream(self) -> DepthStream:
        """The written frames as a lazy :class:`DepthStream` (closes the writer)."""
        self.close()
        return open_depth(self.path)

    def __enter__(self) -> "DepthWriter":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def write_depth(stream: DepthStream, path: str | os.PathLike) -> Path:
    """Write ``stream`` to a new depth file at ``path``, frame by frame (lazy frames stay lazy)."""
    height, width = stream.image_shape
    with DepthWriter(path, height, width, labels=stream.labels is not None) as writer:
        for k, t in enumerate(stream.timestamps):
            writer.append(t, stream.depth_mm[k], None if stream.labels is None else stream.labels[k])
    return Path(path)


def open_depth(path: str | os.PathLike) -> DepthStream:
    """Open a depth file: timestamps read now, frames lazily.

    Raises
    ------
    RecordingError
        The file is missing, truncated, not a depth file, or its datasets disagree in length, size or type.
    """
    path = Path(path)
    with _open(path) as f:
        if f.attrs.get("format") != FORMAT_NAME or f.attrs.get("version") != FORMAT_VERSION:
            raise RecordingError(f"{path} is not a {FORMAT_NAME} version {FORMAT_VERSION} file")
        try:
            times = f["timestamps"][:]
            frames = {n: StoredFrames(path, n, f[n].shape, f[n].dtype) for n in ("depth_mm", "labels") if n in f}
        except (OSError, KeyError) as exc:
            raise RecordingError(f"{path}: unreadable depth file ({exc}); {_FIX}") from None
    if "depth_mm" not in frames:
        raise RecordingError(f"{path} has no depth_mm dataset; {_FIX}")
    try:
        return DepthStream(times, frames["depth_mm"], frames.get("labels"))
    except BadInputError as exc:
        raise RecordingError(f"{path}: inconsistent depth file ({exc}); {_FIX}") from None
