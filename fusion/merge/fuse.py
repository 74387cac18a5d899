"""Fusing a calibrated recording into one skeleton stream (and one point cloud) in the world frame.

Steps: back-facing detection per camera, the cameras' skeletons resampled on the reference camera's
timestamps and mapped to the world, back-facing flags cross-checked between cameras, merged per
joint and frame (:mod:`fusion.merge.methods`) or fitted with one articulated skeleton
(:mod:`fusion.merge.kinematic`), optionally smoothed over time and made bone-length consistent
(:mod:`fusion.merge.filters`); then the clinical joint angles (:mod:`fusion.merge.angles`), with the
constant offsets of a neutral-pose trial removed when one is given.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field, replace

import numpy as np

from fusion.calibration import Calibration
from fusion.camera import Intrinsics
from fusion.errors import BadInputError
from fusion.facing import detect_back_facing
from fusion.merge.angles import (
    AngleOptions,
    JointAngles,
    joint_angles,
    neutral_offsets,
    remove_offsets,
)
from fusion.merge.backfacing import cross_check_back_facing
from fusion.merge.filters import TemporalFilter, enforce_bone_lengths, smooth
from fusion.merge.kinematic import KinematicOptions, fit_kinematic
from fusion.merge.limb_axes import limb_axes
from fusion.merge.limb_axis_options import LimbAxisOptions
from fusion.merge.limb_corrections import LimbAxes, onto_axes, with_limb_axes
from fusion.merge.methods import (
    MergedSkeleton,
    MergeMethod,
    MergeParams,
    Reliability,
    merge,
)
from fusion.merge.views import CameraViews, views_from_streams
from fusion.recording import CameraRecording, Recording
from fusion.topology import Topology


class Fit(enum.Enum):
    """How the cameras' measurements become one skeleton."""

    MERGE = "merge"
    """Per joint and frame, by the merging method (the paper)."""
    KINEMATIC = "kinematic"
    """One articulated skeleton fitted to all measurements (:mod:`fusion.merge.kinematic`)."""


@dataclass(frozen=True)
class FuseOptions:
    """How to fuse: merge or kinematic fit and their constants, relabelling, temporal filter, bone
    lengths, angle definitions and the neutral-pose trial.

    ``neutral_s`` is the (start, end) time [s, reference clock] of a neutral-pose trial in the
    recording (the subject stands upright, arms hanging, elbows straight); the angles' constant
    offsets over it are removed (:func:`fusion.merge.angles.neutral_offsets`). ``method`` applies to
    ``Fit.MERGE`` only. ``limb_axes``, when given, moves the limb joints onto the limbs' axes fitted
    to the depth clouds (:mod:`fusion.merge.limb_axes`; :func:`fuse_limb_axes`, :func:`fuse_views`).
    """

    method: MergeMethod = MergeMethod.AVG_FRONTAL
    params: MergeParams = MergeParams()
    fit: Fit = Fit.MERGE
    kinematic: KinematicOptions = field(default_factory=KinematicOptions)
    relabel_back_facing: bool = True
    cross_check: bool = True
    temporal: TemporalFilter = TemporalFilter.NONE
    bone_lengths: bool = False
    angles: AngleOptions = field(default_factory=AngleOptions)
    neutral_s: tuple[float, float] | None = None
    limb_axes: LimbAxisOptions | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.fit, Fit):
            raise BadInputError(f"fit must be a Fit ({', '.join(f.name for f in Fit)}), got {self.fit!r}")
        if self.neutral_s is not None:
            a, b = self.neutral_s
            if not (np.isfinite(a) and np.isfinite(b) and a < b):
                raise BadInputError(f"neutral_s must be (start, end) seconds with start < end, got {self.neutral_s}")


def camera_views(recording: Recording, calibration: Calibration, *, cross_check: bool = True) -> CameraViews:
    """Every calibrated camera's skeletons on the reference camera's timestamps, in the world frame.

    Raises
    ------
    BadInputError
        No camera of the recording is calibrated, or the reference camera has no skeletons.
    """
    names = [c.name for c in recording.cameras if c.skeleton is not None and c.name in calibration.T_world_cam]
    if not names:
        raise BadInputError(f"no camera of the recording ({', '.join(recording.camera_names)}) is in the "
                            f"calibration ({', '.join(calibration.camera_names)}); calibrate this recording first")
    ref = calibration.reference if calibration.reference in names else names[0]
    streams = {n: recording.camera(n).skeleton for n in names}
    offsets = {n: calibration.clock_offset_s[n] - calibration.clock_offset_s[ref] for n in names}
    flags = {n: detect_back_facing(s).flipped for n, s in streams.items()}
    views = views_from_streams(streams, calibration.T_world_cam, streams[ref].timestamps, offsets, flags)
    if cross_check:
        views = replace(views, back_facing=cross_check_back_facing(views))
    return views


def fuse_limb_axes(views: CameraViews, recording: Recording, calibration: Calibration,
                   options: FuseOptions) -> LimbAxes | None:
    """The limb axes of the recording's depth frames when ``options.limb_axes`` asks for them, else None."""
    return None if options.limb_axes is None else limb_axes(views, recording, calibration, options.limb_axes)


def fuse_views(views: CameraViews, options: FuseOptions = FuseOptions(),
               axes: LimbAxes | None = None) -> MergedSkeleton:
    """Merge (or fit) prepared views, then apply the optional temporal filter and bone-length constraint.

    With limb ``axes`` (:func:`fuse_limb_axes`) every camera's limb joints are moved onto them first,
    and the kinematic fit's joints again after it (its constant bone lengths pull them off the axes).
    """
    if axes is not None:
        views = with_limb_axes(views, axes)
    if options.fit is Fit.KINEMATIC:
        merged = fit_kinematic(views, options.kinematic).merged
        if axes is not None:
            la = options.limb_axes or LimbAxisOptions()
            merged = replace(merged, positions=onto_axes(merged.positions, merged.times, axes, pull=la.pull,
                                                         tolerance_s=la.tolerance_s, max_gap_s=la.max_gap_s))
    else:
        merged = merge(views, options.method, options.params, relabel_back_facing=options.relabel_back_facing)
    if options.temporal is not TemporalFilter.NONE:
        merged = smooth(merged, options.temporal)
    if options.bone_lengths:
        merged = enforce_bone_lengths(merged, views.topology)
    return merged


def fused_angles(merged: MergedSkeleton, topology: Topology, options: FuseOptions = FuseOptions()) -> JointAngles:
    """The clinical joint angles of a fused skeleton, minus the neutral-pose trial's offsets if
    ``options.neutral_s`` is set.

    Raises
    ------
    BadInputError
        The neutral-pose window holds no frame, or a neutral angle is undefined throughout it.
    """
    angles = joint_angles(merged.positions, topology, options.angles)
    if options.neutral_s is None:
        return angles
    a, b = options.neutral_s
    window = (merged.times >= a) & (merged.times <= b)
    if not window.any():
        raise BadInputError(f"the neutral-pose window {a:.2f}-{b:.2f} s holds no frame (the fused skeleton spans "
                            f"{merged.times[0]:.2f}-{merged.times[-1]:.2f} s)")
    return remove_offsets(angles, neutral_offsets(angles, window))


def fused_recording(merged: MergedSkeleton, views: CameraViews, options: FuseOptions,
                    metadata: dict | None = None) -> Recording:
    """The fused skeleton as a one-camera recording named ``fused`` whose frame is the world frame
    (its intrinsics are placeholders: no image belongs to it)."""
    stream = merged.to_stream(views.topology)
    meta = {"source": "fusion", "frame": "world", "fit": options.fit.value, "method": options.method.value,
            "temporal_filter": options.temporal.value, "bone_lengths": options.bone_lengths,
            "limb_axes": options.limb_axes is not None, "cameras": list(views.names)} | (metadata or {})
    return Recording((CameraRecording("fused", Intrinsics(), stream, None),), meta)


def reliability_fractions(merged: MergedSkeleton) -> dict[str, float]:
    """Share of merged joints per reliability class, over frames with any measurement."""
    present = np.any(merged.reliability > Reliability.NONE, axis=1)
    r = merged.reliability[present]
    total = max(r.size, 1)
    return {rel.name.lower(): float((r == rel).sum() / total) for rel in Reliability}
