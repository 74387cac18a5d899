"""Multi-camera recordings: what each camera recorded (skeleton stream, depth frames, intrinsics).

The on-disk format of a recording directory is :mod:`fusion.io.recording_files`.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fusion.camera import Intrinsics
from fusion.depth import DepthStream
from fusion.errors import BadInputError, UnknownNameError
from fusion.skeleton import SkeletonStream
from fusion.topology import Topology


@dataclass(frozen=True, eq=False)
class CameraRecording:
    """What one camera recorded.

    Attributes
    ----------
    name : str
        Camera name, unique in the recording (``"cam1"`` ...); also its frame's name.
    intrinsics : Intrinsics
        Depth-camera intrinsics.
    skeleton : SkeletonStream or None
        Body-tracker output in this camera's frame.
    depth : DepthStream or None
        Depth frames (possibly only at some instants).
    """

    name: str
    intrinsics: Intrinsics
    skeleton: SkeletonStream | None = None
    depth: DepthStream | None = None

    def __post_init__(self) -> None:
        if not self.name or not self.name.replace("_", "").replace("-", "").isalnum():
            raise BadInputError(f"camera name must be non-empty letters, digits, '-' or '_', got {self.name!r}")
        if self.depth is not None and self.depth.image_shape != (self.intrinsics.height, self.intrinsics.width):
            raise BadInputError(f"camera {self.name}: depth frames do not match the intrinsics' image size")


def check_lab(name: object, where: str = "a lab name", error: type[Exception] = BadInputError) -> str:
    """``name`` as a lab's name: a non-empty string without ``.`` or ``"`` (it names a sensor profile's
    ``[population.labs.<name>]`` table); else ``error`` saying that ``where`` must be one."""
    if not (isinstance(name, str) and name.strip() and "." not in name and '"' not in name):
        raise error(f"{where} must be a non-empty string without '.' or '\"', got {name!r}")
    return name


@dataclass(frozen=True, eq=False)
class Recording:
    """Several cameras recording one person, plus JSON-able metadata (source, sensor, ...)."""

    cameras: tuple[CameraRecording, ...]
    metadata: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "cameras", tuple(self.cameras))
        if not self.cameras:
            raise BadInputError("a recording needs at least one camera")
        names = [c.name for c in self.cameras]
        if len(set(names)) != len(names):
            raise BadInputError(f"camera names must be unique, got {names}")
        topologies = {c.skeleton.topology for c in self.cameras if c.skeleton is not None}
        if len(topologies) > 1:
            raise BadInputError("all cameras of a recording must use the same joint topology")
        try:
            json.dumps(self.metadata)
        except TypeError as exc:
            raise BadInputError(f"metadata must be JSON-serialisable: {exc}") from None

    @property
    def camera_names(self) -> tuple[str, ...]:
        """Camera names in recording order."""
        return tuple(c.name for c in self.cameras)

    @property
    def topology(self) -> Topology | None:
        """The joint topology shared by all skeleton streams (None without skeletons)."""
        return next((c.skeleton.topology for c in self.cameras if c.skeleton is not None), None)

    def as_joint_set(self, topology: Topology) -> "Recording":
        """The recording with every skeleton stream reduced to ``topology``
        (:meth:`fusion.skeleton.SkeletonStream.as_joint_set`); itself when its joint set is that one."""
        if self.topology is None or self.topology == topology:
            return self
        cameras = tuple(dataclasses.replace(c, skeleton=None if c.skeleton is None else c.skeleton.as_joint_set(topology))
                        for c in self.cameras)
        return Recording(cameras, self.metadata)

    def never_reported(self) -> tuple[np.ndarray, ...]:
        """Per camera with skeletons, (J,) bool: the joints it reports in no frame (no finite position),
        such as the hands of an Azure Kinect session tracked without them."""
        return tuple(~np.isfinite(c.skeleton.positions[..., 0]).any(axis=0) for c in self.cameras if c.skeleton is not None)

    def without_joints(self, masks: Sequence[np.ndarray]) -> "Recording":
        """The recording with the joints of ``masks`` (per camera with skeletons, in order, (J,) bool)
        absent from every frame (NaN, not tracked): a simulation measured like a real recording that
        never reports them (:meth:`never_reported`)."""
        with_skeleton = [c for c in self.cameras if c.skeleton is not None]
        if len(masks) != len(with_skeleton):
            raise BadInputError(f"{len(masks)} joint masks for {len(with_skeleton)} cameras with skeletons")
        blank = {c.name: np.asarray(m, dtype=bool) for c, m in zip(with_skeleton, masks)}
        cameras = []
        for c in self.cameras:
            if c.name not in blank or not blank[c.name].any():
                cameras.append(c)
                continue
            s, m = c.skeleton, blank[c.name]
            positions, states = s.positions.copy(), s.states.copy()
            positions[:, m], states[:, m] = np.nan, 0
            cameras.append(dataclasses.replace(c, skeleton=SkeletonStream(s.topology, s.timestamps, positions, states)))
        return Recording(tuple(cameras), self.metadata)

    def renamed(self, names: Sequence[str]) -> "Recording":
        """The recording with its cameras called ``names`` (one per camera, in recording order); metadata
        tables keyed by camera name (body ids, per-camera confidence) follow. Give every session of a rig
        the same names, so that their calibrations can be compared camera by camera."""
        names = list(names)
        if len(names) != len(self.cameras):
            raise BadInputError(f"{len(names)} camera name(s) {names} for {len(self.cameras)} camera(s) "
                                f"{list(self.camera_names)}: give one name per camera, in the files' order")
        new = dict(zip(self.camera_names, names))
        cameras = tuple(dataclasses.replace(c, name=new[c.name]) for c in self.cameras)

        def follow(value: Any) -> Any:
            if isinstance(value, dict) and value and set(value) <= set(new):
                return {new[k]: v for k, v in value.items()}
            return value

        return Recording(cameras, {k: follow(v) for k, v in self.metadata.items()})

    @property
    def lab(self) -> str | None:
        """The lab the recording comes from (metadata ``lab``: set by ``import --lab``, by the readers of
        one lab's dataset, and by a built-in CSV layout); None when not named. A sensor population may
        know the lab's people (:meth:`sim.sensor_population.Population.for_lab`)."""
        value = self.metadata.get("lab")
        return value if isinstance(value, str) and value else None

    def with_lab(self, lab: str | None) -> "Recording":
        """The recording said to come from ``lab`` (None: no lab named; else :func:`check_lab`)."""
        metadata = {k: v for k, v in self.metadata.items() if k != "lab"}
        return Recording(self.cameras, metadata | ({} if lab is None else {"lab": check_lab(lab)}))

    @property
    def confidence_assumed(self) -> bool:
        """Whether the reader assumed the confidences rather than read them (metadata ``confidence``
        ``"assumed_tracked"``, for every camera when given per camera: UI-PRMD, Azure Kinect JSON)."""
        value = self.metadata.get("confidence")
        if isinstance(value, dict):
            return bool(value) and all(v == "assumed_tracked" for v in value.values())
        return value == "assumed_tracked"

    def camera(self, name: str) -> CameraRecording:
        """The camera called ``name``."""
        for c in self.cameras:
            if c.name == name:
                return c
        raise UnknownNameError("camera", name, self.camera_names)

    def equals(self, other: "Recording") -> bool:
        """Exact equality of metadata, intrinsics and every array."""
        if self.metadata != other.metadata or self.camera_names != other.camera_names:
            return False
        for a, b in zip(self.cameras, other.cameras):
            if a.intrinsics != b.intrinsics:
                return False
            for x, y in ((a.skeleton, b.skeleton), (a.depth, b.depth)):
                if (x is None) != (y is None) or (x is not None and not x.equals(y)):
                    return False
        return True
