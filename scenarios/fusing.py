"""``mocap-bench fuse``: a calibrated recording into one skeleton stream and one body point cloud.

Output directory::

    recording/     the fused skeleton as a recording with one camera, ``fused``, in the world frame
    angles.csv     clinical joint angles per frame [deg] (fusion.merge.angles; format: fusion.io.angle_tables)
    angles.mot     the same angles as an OpenSim motion file
    cloud.ply      merged body point cloud (world frame, metres) at ``cloud_time_s``; per-point camera
    cloud.glb      the same cloud for viewers that read glTF
    mesh.glb       surface mesh of the cloud (Poisson), when asked for
    limb_axes.png  with limb axes: one depth instant's limb points, fitted axes, tracker and corrected
                   joints (seen along the world's x and y), and per segment the instants whose fit counted
    fused.json     fit, method and options, reliability fractions, bone-length spread, angle offsets of the
                   neutral-pose trial, cloud statistics; with limb axes, each limb segment's radius [mm],
                   the share of depth instants whose axis fit counted, the shoulders' and hips'
                   functional centres (``pivots``: point in the trunk frame [mm] or null, spread, rms [mm]),
                   and per joint the share of instants at which a centre or the hand's cloud placed it
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from fusion.calibrate.clock_offset import clock_residuals, contradicts
from fusion.calibration import Calibration
from fusion.errors import CalibrationError
from fusion.io.angle_tables import write_angles_csv, write_mot
from fusion.io.atomic import atomic_directory
from fusion.io.recording_files import save_recording
from fusion.merge.cloud import merge_clouds
from fusion.merge.fuse import (
    FuseOptions,
    camera_views,
    fuse_limb_axes,
    fuse_views,
    fused_angles,
    fused_recording,
    reliability_fractions,
)
from fusion.merge.mesh import export_glb, export_ply, mesh_from_cloud
from fusion.merge.metrics import bone_length_std
from fusion.merge.rig_drift import rig_drift
from fusion.recording import Recording
from scenarios.show import plot_limb_axes


def fuse_to_disk(recording: Recording, calibration: Calibration, out_dir: Path, options: FuseOptions, *,
                 cloud_time_s: float | None = None, mesh: bool = False, seed: int = 0,
                 overwrite: bool = False, check_moves: bool = True, check_clocks: bool = True) -> dict[str, Any]:
    """Fuse ``recording`` with ``calibration`` and write the output directory atomically.

    Parameters
    ----------
    cloud_time_s : reference-clock time of the merged point cloud; default the depth frame nearest the
        middle of the session.
        Skipped (noted in ``fused.json``) when no camera has depth frames.
    mesh : also reconstruct a surface mesh of the merged cloud.
    seed : seed of the random sampling in the point-cloud step.
    check_moves : refuse a session in which a camera moved (:mod:`fusion.merge.rig_drift`).
    check_clocks : refuse calibration clock offsets that the recording's motion says are wrong
        (:func:`fusion.calibrate.clock_offset.clock_residuals`).

    Raises
    ------
    CalibrationError
        With ``check_moves``, a camera that disagrees with the others for a stretch of the session; with
        ``check_clocks``, a camera whose clock the motion clearly puts more than 0.25 s from where the
        calibration does (:func:`fusion.calibrate.clock_offset.contradicts`).
    """
    residuals = clock_residuals({c.name: c.skeleton for c in recording.cameras if c.skeleton is not None
                                 and c.skeleton.n_frames > 1 and c.name in calibration.clock_offset_s},
                                calibration.clock_offset_s, calibration.reference)
    off = {n: r.offset_s for n, r in residuals.items() if contradicts(r)}
    if check_clocks and off:
        raise CalibrationError("the calibration's clock offsets do not fit this recording: the body's motion puts "
                               + ", ".join(f"{n} {v:+.2f} s" for n, v in off.items()) + " from where the calibration "
                               "does (another session's calibration, or a camera clock reset?); calibrate this "
                               "recording (mocap-bench calibrate), or fuse --no-clock-check to fuse anyway")
    views = camera_views(recording, calibration, cross_check=options.cross_check)
    drift = rig_drift(views) if len(views.names) > 1 else None
    if check_moves and drift is not None and drift.moved:
        raise CalibrationError(f"{drift.describe()}: the camera probably moved during the session, so one calibration "
                               "cannot hold for all of it; cut the recording at the move and calibrate and fuse each "
                               "part, or leave the camera out (fuse --no-move-check fuses anyway)")
    axes = fuse_limb_axes(views, recording, calibration, options)
    merged = fuse_views(views, options, axes)
    fused = fused_recording(merged, views, options)
    angles = fused_angles(merged, views.topology, options)
    summary: dict[str, Any] = {
        "fit": options.fit.value, "method": options.method.value, "temporal_filter": options.temporal.value,
        "bone_lengths": options.bone_lengths, "relabel_back_facing": options.relabel_back_facing,
        "cameras": list(views.names), "frames": int(merged.times.size),
        "reliability": reliability_fractions(merged),
        "back_facing_fraction": {n: float(views.back_facing[i].mean()) for i, n in enumerate(views.names)},
        "bone_length_std_mm": {k: v * 1e3 for k, v in bone_length_std(merged.positions, views.topology).items()},
        "neutral_s": None if options.neutral_s is None else list(options.neutral_s),
        "angle_offsets_deg": {n: float(o) for n, o in zip(angles.names, angles.offsets) if o != 0.0},
        "clock_residual_s": {n: None if r is None or not r.converged else r.offset_s for n, r in residuals.items()},
        "camera_disagreement_mm": None if drift is None else {
            c.name: {"baseline": c.baseline_m * 1e3, "max_window": float(np.nanmax(c.disagreement_m)) * 1e3
                     if np.isfinite(c.disagreement_m).any() else None, "moved_s": c.moved} for c in drift.cameras},
    }
    if axes is not None:
        radius = {n: None if np.isnan(r) else float(r) * 1e3 for n, r in zip(axes.names, axes.radii_m)}
        summary["limb_axes"] = {"radius_mm": radius, "counted_share": axes.counted_share(),
                                "instants": int(axes.times.size), "pivots": axes.pivot_summary(views.topology),
                                "anchored_share": axes.anchored_share(views.topology)}
    cloud = None
    depth_times = [c.depth.timestamps - calibration.clock_offset_s[c.name] for c in recording.cameras
                   if c.depth is not None and c.depth.n_frames and c.name in calibration.clock_offset_s]
    if depth_times:
        stamps = depth_times[0]  # snap the default to a depth frame of the first camera with depth
        t = float(stamps[np.argmin(np.abs(stamps - np.median(views.times)))]) if cloud_time_s is None else cloud_time_s
        cloud = merge_clouds(recording, calibration, t, rng=np.random.default_rng(seed))
        summary["cloud"] = {"time_s": t, "points": cloud.n_points, "notes": list(cloud.notes),
                            "per_camera": dict(zip(cloud.camera_names, cloud.points_per_camera.tolist()))}
    else:
        summary["cloud"] = {"notes": ["no depth frames in the recording: no point cloud"]}
    with atomic_directory(out_dir, overwrite=overwrite) as tmp:
        save_recording(fused, tmp / "recording")
        write_angles_csv(merged.times, angles.names, angles.degrees, tmp / "angles.csv")
        write_mot(merged.times, angles.names, angles.degrees, tmp / "angles.mot")
        if cloud is not None and cloud.n_points:
            export_ply(cloud, tmp / "cloud.ply")
            export_glb(cloud, tmp / "cloud.glb")
            if mesh:
                export_glb(mesh_from_cloud(cloud), tmp / "mesh.glb")
        if axes is not None:
            plot_limb_axes(views, recording, calibration, axes, tmp / "limb_axes.png", options.limb_axes)
        (tmp / "fused.json").write_text(json.dumps(summary, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    return summary
