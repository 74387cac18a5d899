"""Plausibility checks of skeleton data at the input boundary: units, time units, clocks, camera sets.

Readers and :func:`~fusion.io.recording_files.load_recording` call these so that a file in the wrong unit
or on a foreign clock is refused with what to do, instead of being fused into nonsense.

The limits are wide on purpose (a factor of about 10 around what people and body trackers do) so
that a unit mistake (a factor of 1000) is caught and nothing real is:

- bone lengths of a person are 0.03-0.5 m (hand to hand tip about 0.03 m, thigh about 0.45 m), so
  the median bone length of a stream must lie in [:data:`MIN_BONE_M`, :data:`MAX_BONE_M`];
- depth sensors see a person at 0.5-10 m, so the median distance of the body from the frame's
  origin must be at most :data:`MAX_DISTANCE_M`;
- body trackers run at 5-120 Hz, so the median frame interval must lie in
  [:data:`MIN_INTERVAL_S`, :data:`MAX_INTERVAL_S`];
- cameras of one recording share a time base (the clock sync searches offsets of 0.2 s), so each
  camera's time span must overlap another camera's by at least half the shorter span.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from fusion.errors import BadInputError, RecordingError
from fusion.skeleton import SkeletonStream
from fusion.topology import Topology

MIN_BONE_M = 0.003
MAX_BONE_M = 5.0
MAX_DISTANCE_M = 30.0
MIN_INTERVAL_S = 1.0 / 1000.0
MAX_INTERVAL_S = 2.0
MIN_OVERLAP = 0.5

_UNIT_NAMES = ((1e9, "nanoseconds"), (1e6, "microseconds"), (1e3, "milliseconds"))


def median_bone_length_m(stream: SkeletonStream) -> float:
    """Median length [m] of every bone in every frame where both its joints are present (NaN if none)."""
    return _median_bone_length_m(stream.positions, stream.topology)


def _median_bone_length_m(positions: np.ndarray, topology: Topology) -> float:
    bones = topology.bones
    if len(bones) == 0 or len(positions) == 0:
        return float("nan")
    with np.errstate(over="ignore", invalid="ignore"):  # absurd coordinates overflow to inf: kept, and refused
        d = np.linalg.norm(positions[:, bones[:, 0]] - positions[:, bones[:, 1]], axis=-1)
    d = d[~np.isnan(d)]
    return float(np.median(d)) if d.size else float("nan")


def median_distance_m(stream: SkeletonStream) -> float:
    """Median distance [m] of the body's centroid from the frame's origin (NaN without joints)."""
    return _median_distance_m(stream.positions)


def _median_distance_m(positions: np.ndarray) -> float:
    with np.errstate(over="ignore", invalid="ignore"):
        present = ~np.isnan(positions[..., 0])
        frames = present.any(axis=1)
        if not frames.any():
            return float("nan")
        centroid = np.nanmean(positions[frames], axis=1)
    return float(np.median(np.linalg.norm(centroid, axis=-1)))


def median_interval_s(stream: SkeletonStream) -> float:
    """Median frame interval [s] (NaN for fewer than 2 frames)."""
    return float(np.median(np.diff(stream.timestamps))) if stream.n_frames > 1 else float("nan")


def check_stream_units(stream: SkeletonStream, where: str, *, length_hint: str = "", time_hint: str = "") -> None:
    """Refuse a stream whose body size, distance or frame interval says it is in another unit.

    Parameters
    ----------
    stream : SkeletonStream
        Positions (T, J, 3) meant to be metres, timestamps (T,) meant to be seconds.
    where : str
        The file or camera, for the message.
    length_hint, time_hint : str
        What the caller's user can do about a length or time unit mistake (e.g. an option name).

    Raises
    ------
    RecordingError
        The median bone length, body distance or frame interval is outside the module's limits.
    """
    check_length_units(stream.positions, stream.topology, where, length_hint=length_hint)
    step = median_interval_s(stream)
    if np.isfinite(step) and not MIN_INTERVAL_S <= step <= MAX_INTERVAL_S:
        guess = next((name for scale, name in _UNIT_NAMES if step > MAX_INTERVAL_S and 0.001 <= step / scale <= 2.0),
                     "another unit than seconds")
        raise RecordingError(f"{where}: the median frame interval is {step:.6g} s ({1 / step:.4g} Hz), not a body "
                             f"tracker's (5-120 Hz): the timestamps look like {guess}. {time_hint}".rstrip())


def check_length_units(positions: np.ndarray, topology: Topology, where: str, *, length_hint: str = "") -> None:
    """Refuse positions whose body size or distance from the camera says they are not metres.

    Parameters
    ----------
    positions : np.ndarray
        (T, J, 3) positions meant to be metres, NaN where absent (one live frame: T = 1).
    topology : Topology
        Joint set (J joints) whose bones are measured.
    where : str
        The file or camera, for the message.
    length_hint : str
        What the caller's user can do about it.

    Raises
    ------
    RecordingError
        The median bone length or body distance is outside the module's limits.
    """
    bone = _median_bone_length_m(positions, topology)
    if not np.isnan(bone) and not MIN_BONE_M <= bone <= MAX_BONE_M:
        guess = ("absurd values (they overflow)" if np.isinf(bone) else "millimetres" if bone > MAX_BONE_M
                 else "metres read as millimetres (or smaller units)")
        raise RecordingError(f"{where}: the median bone length is {bone:.4g} m, not a person's "
                             f"({MIN_BONE_M}-{MAX_BONE_M} m): the positions look like {guess}. {length_hint}".rstrip())
    dist = _median_distance_m(positions)
    if not np.isnan(dist) and dist > MAX_DISTANCE_M:
        raise RecordingError(f"{where}: the body is {dist:.4g} m from the camera (a depth sensor sees at most "
                             f"~10 m): the positions look like millimetres or carry an offset. {length_hint}".rstrip())


def check_integer_states(states: np.ndarray, where: str) -> None:
    """Refuse tracking states that are not whole numbers (a float array would be truncated silently).

    Raises
    ------
    RecordingError
        ``states`` has a non-integer value or a non-numeric dtype.
    """
    states = np.asarray(states)
    if states.dtype.kind in "iu":
        return
    if states.dtype.kind != "f" or not np.all(np.isfinite(states)) or np.any(states != np.round(states)):
        raise RecordingError(f"{where}: tracking states must be whole numbers 0..3 (dtype {states.dtype}); "
                             "rewrite the states as integers")


def check_clock_overlap(spans: dict[str, tuple[float, float]], where: str) -> None:
    """Refuse cameras whose time spans do not overlap: their clocks do not share a time base.

    Parameters
    ----------
    spans : dict
        Camera name -> (first, last) timestamp [s].
    where : str
        The recording, for the message.

    Raises
    ------
    RecordingError
        A camera overlaps no other camera by at least :data:`MIN_OVERLAP` of the shorter span.
    """
    if len(spans) < 2:
        return
    for a, (a0, a1) in spans.items():
        best = 0.0
        for b, (b0, b1) in spans.items():
            if b == a:
                continue
            shorter = min(a1 - a0, b1 - b0)
            overlap = min(a1, b1) - max(a0, b0)
            best = max(best, 1.0 if shorter <= 0 and overlap >= 0 else overlap / shorter if shorter > 0 else 0.0)
        if best < MIN_OVERLAP:
            others = ", ".join(f"{b} {b0:.6g}-{b1:.6g} s" for b, (b0, b1) in spans.items() if b != a)
            raise RecordingError(f"{where}: camera {a}'s clock spans {a0:.6g}-{a1:.6g} s, which does not overlap "
                                 f"the other cameras ({others}): the clocks do not share a time base (an epoch or "
                                 "unit offset?); subtract the offset or export all cameras with one time base")


def check_usable_streams(streams: dict[str, SkeletonStream | None], where: str) -> None:
    """Refuse cameras that cannot contribute: no skeleton, fewer than 2 frames, or no joint ever present.

    Raises
    ------
    RecordingError
        Naming the camera and what it lacks.
    """
    for name, s in streams.items():
        if s is None:
            raise RecordingError(f"{where}: camera {name} has no skeleton stream; remove it from the recording")
        if s.n_frames < 2:
            raise RecordingError(f"{where}: camera {name} has {s.n_frames} frame(s); at least 2 are needed; "
                                 "remove the camera or record longer")
        if np.all(np.isnan(s.positions)):
            raise RecordingError(f"{where}: camera {name} never tracked a joint; remove the camera")


def check_camera_sets(recording_cameras: Iterable[str], calibration_cameras: Iterable[str], where: str) -> None:
    """Refuse a calibration that lacks a camera of the recording or names one the recording lacks.

    Raises
    ------
    BadInputError
        Listing the cameras on each side.
    """
    rec, cal = list(recording_cameras), list(calibration_cameras)
    missing = [c for c in rec if c not in cal]
    extra = [c for c in cal if c not in rec]
    if missing or extra:
        parts = ([f"lacks recording camera(s) {', '.join(missing)}"] if missing else []) + (
            [f"names camera(s) {', '.join(extra)} the recording does not have"] if extra else [])
        raise BadInputError(f"{where}: the calibration {' and '.join(parts)} (recording: {', '.join(rec)}; "
                            f"calibration: {', '.join(cal)}); calibrate this recording with `mocap-bench calibrate`")
