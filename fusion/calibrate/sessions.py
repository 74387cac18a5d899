"""One fixed rig calibrated from several sessions at once.

Cameras that stayed in place over several recordings see one rig; pooling the sessions gives the
skeleton RANSAC and its per-joint reweighting thousands more joint measurements in more poses, and
ICP instants from every session. Each session's clocks are first aligned on their own (offsets
may differ between sessions), then the sessions are laid end to end on one time line, separated by
a gap longer than any frame-association tolerance, and the pooled recording is calibrated with the
usual pipeline (:func:`fusion.calibrate.pipeline.calibrate_rig`). The world frame comes from the
first session.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from fusion.calibrate.options import CalibrationOptions
from fusion.calibrate.pipeline import calibrate_rig
from fusion.calibrate.results import RigCalibration
from fusion.calibrate.session_clocks import session_clock_offsets
from fusion.depth import DepthStream, FrameChain
from fusion.errors import BadInputError, CalibrationError
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream

SESSION_GAP_S = 60.0
"""Time [s] between pooled sessions: far beyond any association tolerance or clock offset searched."""


def _span(cam: CameraRecording) -> tuple[float, float]:
    times = [s.timestamps for s in (cam.skeleton, cam.depth) if s is not None and s.n_frames > 0]
    if not times:
        return 0.0, 0.0
    all_t = np.concatenate(times)
    return float(all_t.min()), float(all_t.max())


def pool_sessions(recordings: Sequence[Recording], clock_offsets_s: Sequence[dict[str, float]]) -> Recording:
    """Lay several sessions of one rig end to end on one time line, each camera's clock corrected.

    Parameters
    ----------
    recordings : the sessions; every one must have the same camera names, topologies and intrinsics.
    clock_offsets_s : per session, camera -> its clock minus the reference's [s] (subtracted).

    Returns
    -------
    Recording
        One camera per name with the sessions' skeleton frames (and depth frames, where every
        session has them) concatenated; ``metadata["sessions"]`` gives each session's time shift [s].

    Raises
    ------
    BadInputError
        No recordings, a count mismatch, or sessions whose cameras differ.
    """
    if len(recordings) == 0 or len(recordings) != len(clock_offsets_s):
        raise BadInputError(f"need one clock-offset map per recording, got {len(recordings)} recordings and "
                            f"{len(clock_offsets_s)} maps")
    names = [c.name for c in recordings[0].cameras]
    for k, rec in enumerate(recordings):
        if [c.name for c in rec.cameras] != names:
            raise BadInputError(f"session {k} has cameras {[c.name for c in rec.cameras]}, session 0 has {names}: "
                                "only sessions of one rig (same camera names, in the same order) can be pooled")
    shifts, start = [], 0.0
    for rec, offsets in zip(recordings, clock_offsets_s, strict=True):
        spans = [_span(c) for c in rec.cameras]
        first = min(s[0] - offsets.get(c.name, 0.0) for s, c in zip(spans, rec.cameras, strict=True))
        last = max(s[1] - offsets.get(c.name, 0.0) for s, c in zip(spans, rec.cameras, strict=True))
        shifts.append(start - first)
        start += last - first + SESSION_GAP_S
    cameras = []
    for name in names:
        per = [(rec.camera(name), shift - offsets.get(name, 0.0))
               for rec, offsets, shift in zip(recordings, clock_offsets_s, shifts, strict=True)]
        cam0 = per[0][0]
        if any(c.intrinsics != cam0.intrinsics for c, _ in per):
            raise BadInputError(f"camera {name}: intrinsics differ between sessions; pool only sessions of one rig")
        skeleton = None
        streams = [(c.skeleton, d) for c, d in per if c.skeleton is not None and c.skeleton.n_frames > 0]
        if streams:
            if any(s.topology != streams[0][0].topology for s, _ in streams):
                raise BadInputError(f"camera {name}: skeleton topologies differ between sessions")
            skeleton = SkeletonStream(streams[0][0].topology, np.concatenate([s.timestamps + d for s, d in streams]),
                                      np.concatenate([s.positions for s, _ in streams]),
                                      np.concatenate([s.states for s, _ in streams]))
        depth = None
        if all(c.depth is not None and c.depth.n_frames > 0 for c, _ in per):
            labelled = all(c.depth.labels is not None for c, _ in per)
            depth = DepthStream(np.concatenate([c.depth.timestamps + d for c, d in per]),
                                FrameChain([c.depth.depth_mm for c, _ in per]),
                                FrameChain([c.depth.labels for c, _ in per]) if labelled else None)
        cameras.append(CameraRecording(name, cam0.intrinsics, skeleton, depth))
    metadata = dict(recordings[0].metadata) | {"sessions": [{"time_shift_s": s} for s in shifts]}
    return Recording(tuple(cameras), metadata)


def calibrate_sessions(
    recordings: Sequence[Recording],
    options: CalibrationOptions = CalibrationOptions(),
    *,
    rng: np.random.Generator,
    progress: Callable[[str], None] | None = None,
) -> RigCalibration:
    """Calibrate one fixed rig from several sessions at once (see the module docstring).

    With one recording this is :func:`calibrate_rig`. Otherwise each session's clock offsets are
    estimated (as ``options`` asks), the sessions are pooled with :func:`pool_sessions`, and the
    pooled recording is calibrated with the clocks taken as aligned. The result's clock offsets
    are those of the first session.

    Parameters
    ----------
    recordings : sessions of one rig (same cameras), each with skeleton streams (depth for ICP).
    options : calibration settings.
    rng : the one random source.
    progress : called with a short message after each step.

    Returns
    -------
    RigCalibration

    Raises
    ------
    BadInputError
        No recordings, or sessions of different rigs.
    CalibrationError
        As for :func:`calibrate_rig` on the pooled recording.
    """
    if len(recordings) == 0:
        raise BadInputError("calibrate_sessions needs at least one recording")
    if len(recordings) == 1:
        return calibrate_rig(recordings[0], options, rng=rng, progress=progress)
    offsets, notes = [], []
    for k, rec in enumerate(recordings):
        try:
            found, why = session_clock_offsets(rec, options)
        except CalibrationError as exc:
            raise CalibrationError(f"session {k}: {exc}") from exc
        offsets.append(found)
        notes += [f"session {k}: {n}" for n in why]
    pooled = pool_sessions(recordings, offsets)
    rig = calibrate_rig(pooled, replace(options, estimate_clock=False), rng=rng, progress=progress)
    notes.append(f"{len(recordings)} sessions pooled; clock offsets of the first session reported")
    return replace(rig, clock_offset_s={n: offsets[0].get(n, 0.0) for n in rig.clock_offset_s},
                   notes=rig.notes + tuple(notes))
