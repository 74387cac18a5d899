"""Ground truth of a simulated recording, stored apart from the observations.

On disk (``truth/`` beside ``recording/``)::

    truth.json                       manifest: cameras with T_world_cam, repetitions, metadata, checksums
    reference/{times,joints_world,facing_yaw}.npy      uniform-rate track of the whole session
    <camera>/{true_times,joints_world,facing_yaw,yaw_to_camera,flipped,visible}.npy
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fusion.errors import BadInputError, BenchError, RecordingError, UnknownNameError
from fusion.io.arrayfiles import read_array, write_arrays
from fusion.io.atomic import atomic_directory
from fusion.transforms import validate_transform

FORMAT_NAME = "mocap-bench-truth"
FORMAT_VERSION = 1
MANIFEST = "truth.json"


def _frozen(obj: Any, names: tuple[str, ...]) -> None:
    for n in names:
        arr = np.ascontiguousarray(getattr(obj, n))
        arr.setflags(write=False)
        object.__setattr__(obj, n, arr)


@dataclass(frozen=True, eq=False)
class CameraTruth:
    """What really happened at each frame one camera recorded.

    Attributes
    ----------
    name : str
    T_world_cam : (4, 4) true camera pose.
    true_times : (T,) s, true capture time of each recorded frame.
    joints_world : (T, J, 3) m, true joint positions at those times.
    facing_yaw : (T,) rad, heading of the body's front in the world xy plane.
    yaw_to_camera : (T,) rad in [0, pi], angle between the body's front and the direction to the camera.
    flipped : (T,) bool, the tracker reported a back-facing (left/right swapped) skeleton.
    visible : (T, J) bool, the joint was in the camera's direct line of sight.
    clock_offset_s : the camera clock's true offset: timestamp ~= true time + offset [s].
    """

    name: str
    T_world_cam: np.ndarray
    true_times: np.ndarray
    joints_world: np.ndarray
    facing_yaw: np.ndarray
    yaw_to_camera: np.ndarray
    flipped: np.ndarray
    visible: np.ndarray
    clock_offset_s: float = 0.0

    _ARRAYS = ("true_times", "joints_world", "facing_yaw", "yaw_to_camera", "flipped", "visible")

    def __post_init__(self) -> None:
        object.__setattr__(self, "T_world_cam", validate_transform(self.T_world_cam, f"T_world_cam of {self.name}"))
        T = np.shape(self.true_times)[0]
        for n in self._ARRAYS:
            if np.shape(getattr(self, n))[0] != T:
                raise BadInputError(f"camera truth {self.name}: {n} must have {T} frames")
        _frozen(self, ("T_world_cam",) + self._ARRAYS)


@dataclass(frozen=True, eq=False)
class GroundTruth:
    """Truth of one simulated session.

    Attributes
    ----------
    cameras : per-camera truth, in recording order.
    times : (N,) s, uniform reference time base.
    joints_world : (N, J, 3) m, true joints on that time base.
    facing_yaw : (N,) rad.
    repetitions : list of dicts (movement, side, index, t_start, t_peak, t_end) in true time.
    metadata : JSON-able facts (seed, scenario, subject, clock offsets ...).
    """

    cameras: tuple[CameraTruth, ...]
    times: np.ndarray
    joints_world: np.ndarray
    facing_yaw: np.ndarray
    repetitions: tuple[dict[str, Any], ...] = ()
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "cameras", tuple(self.cameras))
        object.__setattr__(self, "repetitions", tuple(self.repetitions))
        _frozen(self, ("times", "joints_world", "facing_yaw"))

    @property
    def camera_names(self) -> tuple[str, ...]:
        """Camera names in recording order."""
        return tuple(c.name for c in self.cameras)

    def camera(self, name: str) -> CameraTruth:
        """Truth of the camera called ``name``."""
        for c in self.cameras:
            if c.name == name:
                return c
        raise UnknownNameError("camera", name, self.camera_names)

    def T_world_cam(self) -> dict[str, np.ndarray]:
        """True pose of every camera by name."""
        return {c.name: c.T_world_cam for c in self.cameras}


def save_truth(truth: GroundTruth, path: str | os.PathLike, *, overwrite: bool = False) -> Path:
    """Write ``truth`` to the directory ``path`` atomically."""
    path = Path(path)
    manifest: dict[str, Any] = {
        "format": FORMAT_NAME,
        "version": FORMAT_VERSION,
        "metadata": truth.metadata,
        "repetitions": list(truth.repetitions),
        "cameras": [],
    }
    with atomic_directory(path, overwrite=overwrite) as tmp:
        manifest["reference"] = write_arrays(
            tmp, "reference", {"times": truth.times, "joints_world": truth.joints_world, "facing_yaw": truth.facing_yaw}
        )
        for cam in truth.cameras:
            files = write_arrays(tmp, cam.name, {n: getattr(cam, n) for n in CameraTruth._ARRAYS})
            manifest["cameras"].append({"name": cam.name, "T_world_cam": cam.T_world_cam.tolist(),
                                        "clock_offset_s": cam.clock_offset_s, "files": files})
        (tmp / MANIFEST).write_text(json.dumps(manifest, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    return path


def load_truth(path: str | os.PathLike) -> GroundTruth:
    """Read ground truth written by :func:`save_truth`.

    Raises
    ------
    RecordingError
        Missing, truncated or corrupt files or an unsupported format version.
    """
    path = Path(path)
    mpath = path / MANIFEST
    if not mpath.is_file():
        raise RecordingError(f"{path} holds no ground truth ({MANIFEST} missing); real recordings have none")
    try:
        manifest = json.loads(mpath.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise RecordingError(f"{mpath} is corrupt (not valid JSON: {exc})") from None
    if manifest.get("format") != FORMAT_NAME or manifest.get("version") != FORMAT_VERSION:
        raise RecordingError(f"{mpath}: not a {FORMAT_NAME} version {FORMAT_VERSION} manifest")
    try:
        ref = {k: read_array(path, e) for k, e in manifest["reference"].items()}
        cams = tuple(
            CameraTruth(
                name=c["name"],
                T_world_cam=np.array(c["T_world_cam"], dtype=float),
                clock_offset_s=float(c["clock_offset_s"]),
                **{k: read_array(path, e) for k, e in c["files"].items()},
            )
            for c in manifest["cameras"]
        )
        return GroundTruth(cams, ref["times"], ref["joints_world"], ref["facing_yaw"],
                           tuple(manifest.get("repetitions", ())), manifest.get("metadata", {}))
    except RecordingError:
        raise
    except (BenchError, KeyError, TypeError) as exc:
        raise RecordingError(f"{path}: inconsistent ground truth ({type(exc).__name__}: {exc})") from None
