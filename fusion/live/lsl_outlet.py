"""The fused skeleton as a Lab Streaming Layer (LSL) stream, for LabRecorder (XDF) and other LSL tools.

The stream (``pylsl``, the ``lsl`` extra, imported only when an outlet is made):

- type ``MoCap``, channel format float32, nominal rate the cameras' frame rate
  (:attr:`LslOptions.rate_hz`: one sample per fused instant, and instants follow the reference
  camera's frames);
- four channels per joint of the topology, in its joint order: ``<joint>_X``, ``<joint>_Y``,
  ``<joint>_Z`` (types ``PositionX/Y/Z``, metres, world frame of the calibration, NaN where the joint
  is absent) and ``<joint>_Confidence`` (type ``Confidence``, normalized: the fused tracking state
  over 2, so 1 tracked by a camera, 0.5 inferred or back-facing only, 0 absent);
- the MoCap meta-data of the XDF conventions in the stream's description: ``channels`` (label,
  marker = joint name, type, unit), ``acquisition`` (manufacturer ``mocap-bench``, model, settings of
  the fusion, ``compensated_lag`` 0) and ``setup`` (name, joint topology, world frame, cameras with
  their positions, markers with their parent joints);
- a source id that stays the same across restarts with the same name, joint set and calibration
  (:func:`lsl_source_id`), so LSL inlets and LabRecorder reconnect to a restarted server.

Timestamps are LSL's clock (``pylsl.local_clock()``). Fused frame times are on the reference camera's
clock; the first fused frame fixes one offset: ``stamp = t + (ready_at_0 - t_0) + (L - P)``, where
``t_0`` is the first frame's time, ``ready_at_0`` the server's clock (``time.perf_counter``) when the
last camera frame it needed arrived, and ``L - P`` is ``local_clock() - perf_counter()`` read together
when the outlet opened. So the stamps keep the cameras' own spacing of the frames (no network jitter)
and the first one is the local LSL time its data arrived at; the capture-to-arrival latency of that
frame (milliseconds on a lab network) is not compensated, nor is a drift of the reference camera's
clock against the server's.
"""

from __future__ import annotations

import hashlib
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from fusion.calibration import Calibration
from fusion.errors import BadInputError
from fusion.live.protocol import FusedFrame
from fusion.topology import KINECT_V2, Topology, TrackingState

STREAM_TYPE = "MoCap"
"""The LSL content type of the stream."""

MANUFACTURER = "mocap-bench"
"""``acquisition/manufacturer`` of the stream's description."""

CHANNELS_PER_JOINT = (("X", "PositionX", "meters"), ("Y", "PositionY", "meters"), ("Z", "PositionZ", "meters"),
                      ("Confidence", "Confidence", "normalized"))
"""Per joint, in order: label suffix, MoCap channel type and unit of each channel."""


@dataclass(frozen=True)
class LslOptions:
    """What the LSL stream is called and what it carries.

    Attributes
    ----------
    name : str
        The stream's name (what LabRecorder lists and ``resolve_byprop("name", ...)`` finds).
    topology : Topology
        Joint set of the stream (its channel layout is fixed when the outlet opens, before any frame):
        frames of another joint set are not fused.
    rate_hz : float
        Nominal rate [Hz]: the cameras' frame rate (30 for Kinect v2, Azure Kinect and Orbbec Femto).
    """

    name: str
    topology: Topology = KINECT_V2
    rate_hz: float = 30.0

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name.strip() or not self.name.isprintable():
            raise BadInputError(f"an LSL stream name is a non-empty printable text, got {self.name!r}")
        if not isinstance(self.topology, Topology):
            raise BadInputError(f"topology must be a Topology, got {type(self.topology).__name__}")
        if not (math.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise BadInputError(f"the nominal rate must be a positive number of Hz (the cameras' frame rate), "
                                f"got {self.rate_hz}")

    @property
    def channel_count(self) -> int:
        """Channels of the stream: ``4 J``."""
        return len(CHANNELS_PER_JOINT) * self.topology.n_joints


def import_pylsl() -> Any:
    """The ``pylsl`` module, with its liblsl binary loaded.

    Raises
    ------
    BadInputError
        ``pylsl`` is not installed, or it cannot load its liblsl library.
    """
    try:
        import pylsl
    except ImportError:
        raise BadInputError("the LSL outlet needs pylsl: pip install 'mocap-bench[lsl]'") from None
    except (RuntimeError, OSError) as exc:  # pylsl found no usable liblsl binary
        raise BadInputError(f"pylsl could not load its liblsl library ({exc}); reinstall pylsl, whose wheels "
                            "bundle it (pip install --force-reinstall pylsl), or name a liblsl in PYLSL_LIB") from None
    return pylsl


def lsl_source_id(options: LslOptions, calibration: Calibration | None) -> str:
    """``mocap-bench:NAME:TOPOLOGY:HASH``: the stream name, its joint set and a hash of the calibration's
    cameras, reference and poses (``body`` when the server calibrates from the body)."""
    cal = "body"
    if calibration is not None:
        digest = hashlib.sha256(calibration.reference.encode())
        for name in calibration.camera_names:
            digest.update(name.encode() + (np.round(calibration.T_world_cam[name], 6) + 0.0).tobytes())  # no -0.0
        cal = digest.hexdigest()[:16]
    return f"{MANUFACTURER}:{options.name}:{options.topology.name}:{cal}"


def lsl_sample(frame: FusedFrame) -> np.ndarray:
    """One stream sample of a fused frame.

    Returns
    -------
    np.ndarray
        (4 J,) float32: per joint x, y, z [m] (NaN where absent) and the confidence (state / 2, at most 1).
    """
    positions = np.asarray(frame.positions, dtype=np.float64)
    confidence = np.minimum(np.asarray(frame.states, dtype=np.float64) / float(TrackingState.TRACKED), 1.0)
    return np.column_stack([positions, confidence]).astype(np.float32).ravel()


def _add_values(node: Any, values: dict[str, object]) -> None:
    for key, value in values.items():
        node.append_child_value(key, str(value))


def stream_info(options: LslOptions, calibration: Calibration | None, settings: dict[str, object]) -> Any:
    """The ``pylsl.StreamInfo`` of the stream, its description filled (see the module docstring).

    Parameters
    ----------
    options : LslOptions
        Name, joint set and nominal rate.
    calibration : Calibration or None
        The rig (world frame, camera positions); None while the server calibrates from the body.
    settings : dict
        Fusion settings written under ``acquisition/settings`` (name -> value).
    """
    pylsl = import_pylsl()
    topology = options.topology
    info = pylsl.StreamInfo(options.name, STREAM_TYPE, options.channel_count, float(options.rate_hz),
                            pylsl.cf_float32, lsl_source_id(options, calibration))
    desc = info.desc()
    channels = desc.append_child("channels")
    for joint in topology.joints:
        for suffix, kind, unit in CHANNELS_PER_JOINT:
            _add_values(channels.append_child("channel"),
                        {"label": f"{joint}_{suffix}", "marker": joint, "type": kind, "unit": unit})
    acquisition = desc.append_child("acquisition")
    _add_values(acquisition, {"manufacturer": MANUFACTURER, "model": "live fusion of depth-camera skeletons"})
    _add_values(acquisition.append_child("settings"), settings)
    acquisition.append_child_value("compensated_lag", "0")
    setup = desc.append_child("setup")
    world = "calibrated from the body while streaming" if calibration is None else \
        str(calibration.info.get("world", f"the calibration's world frame (reference camera {calibration.reference})"))
    _add_values(setup, {"name": options.name, "topology": topology.name, "world": world, "unit": "meters"})
    if calibration is not None:
        cameras = setup.append_child("cameras")
        for name in calibration.camera_names:
            camera = cameras.append_child("camera")
            camera.append_child_value("label", name)
            _add_values(camera.append_child("position"),
                        dict(zip("XYZ", (f"{v:.6f}" for v in calibration.T_world_cam[name][:3, 3]))))
    markers = setup.append_child("markers")
    for joint, parent in zip(topology.joints, topology.parents):
        _add_values(markers.append_child("marker"),
                    {"label": joint, "parent": "" if parent < 0 else topology.joints[parent]})
    return info


class LslOutlet:
    """An open LSL outlet of fused frames (see the module docstring).

    Parameters
    ----------
    options : LslOptions
        Name, joint set and nominal rate.
    calibration : Calibration or None
        The rig at start (None: calibrated from the body later).
    settings : dict
        Fusion settings for the description (name -> value).

    Raises
    ------
    BadInputError
        ``pylsl`` or its liblsl library is missing.
    """

    def __init__(self, options: LslOptions, calibration: Calibration | None, settings: dict[str, object]) -> None:
        pylsl = import_pylsl()
        self.options = options
        self.info = stream_info(options, calibration, settings)
        self._outlet = pylsl.StreamOutlet(self.info)
        self.local_minus_perf_s = pylsl.local_clock() - time.perf_counter()
        self.offset_s: float | None = None  # stamp - frame time, fixed by the first frame
        self.pushed = 0

    def push(self, frame: FusedFrame) -> float:
        """Push one fused frame of the outlet's joint set; returns its LSL timestamp [s]."""
        if self.offset_s is None:
            ready = frame.ready_at if np.isfinite(frame.ready_at) else time.perf_counter()
            self.offset_s = ready - frame.time + self.local_minus_perf_s
        stamp = frame.time + self.offset_s
        self._outlet.push_sample(lsl_sample(frame), stamp)
        self.pushed += 1
        return stamp

    def status(self) -> dict[str, object]:
        """Name, source id, samples pushed, whether an inlet is connected, and the clock offset [s]."""
        return {"name": self.options.name, "source_id": self.info.source_id(), "pushed": self.pushed,
                "consumers": self._outlet is not None and bool(self._outlet.have_consumers()),
                "offset_s": self.offset_s}

    def close(self, linger_s: float = 0.5) -> None:
        """Withdraw the stream (inlets stop receiving; it is no longer discoverable), after ``linger_s``
        [s] if an inlet is connected, so that it takes the last samples."""
        if self._outlet is not None and self._outlet.have_consumers():
            time.sleep(linger_s)
        self._outlet = None
