"""A session's skeleton cameras and their clocks, the first steps of calibrating from the body.

Each camera's clock offset to the reference camera is estimated from the body motion, widening the
search once (:func:`fusion.calibrate.clock_offset.estimate_clock_offset_widening`). An estimate that
fails falls back to the timestamps, with a note; a person who hardly moves is refused
(:class:`fusion.errors.StaticPersonError`): the body then gives the calibration nothing to work with.
"""

from __future__ import annotations

import numpy as np

from fusion.calibrate.clock_offset import (
    WIDE_CLOCK_SEARCH_S,
    ClockOffset,
    estimate_clock_offset_widening,
)
from fusion.calibrate.options import CalibrationOptions
from fusion.errors import CalibrationError, StaticPersonError, UnknownNameError
from fusion.recording import CameraRecording, Recording
from fusion.topology import TrackingState


def skeleton_cameras(recording: Recording) -> list[CameraRecording]:
    """The cameras with skeleton frames.

    Raises
    ------
    CalibrationError
        Fewer than two, or one that never tracks the person.
    """
    cams = [c for c in recording.cameras if c.skeleton is not None and c.skeleton.n_frames > 0]
    if len(cams) < 2:
        raise CalibrationError(
            f"calibration needs at least two cameras with skeleton streams; this recording has "
            f"{len(cams)} ({', '.join(c.name for c in cams) or 'none'}). Record with two or more cameras."
        )
    for c in cams:
        if not np.any(c.skeleton.states >= TrackingState.TRACKED):
            raise CalibrationError(
                f"camera {c.name} never tracks the person (no Tracked joint in {c.skeleton.n_frames} frames): "
                "check that the person is inside its field of view and range, then record again"
            )
    return cams


def _clock_offsets(ref: CameraRecording, cams: list[CameraRecording], options: CalibrationOptions,
                   notes: list[str]) -> dict[str, float]:
    offsets = {ref.name: 0.0}
    for cam in cams:
        if cam.name == ref.name:
            continue
        offsets[cam.name] = 0.0
        if not options.estimate_clock:
            continue
        try:
            est: ClockOffset = estimate_clock_offset_widening(ref.skeleton, cam.skeleton, options.max_clock_offset_s,
                                                               (ref.name, cam.name))
            if est.widened:
                notes.append(f"clock offset {cam.name}: beyond +-{options.max_clock_offset_s:g} s; found {est.offset_s:+.3f} s "
                             f"searching +-{WIDE_CLOCK_SEARCH_S:g} s (peak score {est.peak_score:.2f}); check the clocks")
        except StaticPersonError:
            raise
        except CalibrationError as exc:
            notes.append(f"clock offset {cam.name}: not estimated ({exc}); timestamps trusted")
            continue
        if est.converged:
            offsets[cam.name] = est.offset_s
        else:
            notes.append(f"clock offset {cam.name}: estimate did not converge (peak score {est.peak_score:.2f}); "
                         "timestamps trusted")
    return offsets


def session_clock_offsets(recording: Recording, options: CalibrationOptions) -> tuple[dict[str, float], list[str]]:
    """Each skeleton camera's clock minus the reference camera's [s], and notes on fallbacks.

    Estimated from the body motion when ``options.estimate_clock``, else all zero.

    Raises
    ------
    CalibrationError
        Fewer than two cameras with skeleton streams, or a camera that never tracks the person.
    StaticPersonError
        With ``options.estimate_clock``, the person hardly moves in a camera's view.
    UnknownNameError
        ``options.reference`` is not a skeleton camera.
    """
    cams = skeleton_cameras(recording)
    by_name = {c.name: c for c in cams}
    reference = options.reference or cams[0].name
    if reference not in by_name:
        raise UnknownNameError("reference camera", reference, by_name)
    notes: list[str] = []
    return _clock_offsets(by_name[reference], cams, options, notes), notes
