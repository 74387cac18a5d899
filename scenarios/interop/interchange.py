"""Real-sensor file formats at the command line: import, write, and the round-trip check.

The round trip writes a simulated session in a real format, imports it again, calibrates both the
native and the imported recording from the body (skeleton only: the formats carry no depth),
scores both calibrations against the same truth and fuses both (Avg(Frontal)), so that a reader or
writer that loses or distorts information shows up as a difference in calibration error or in the
fused skeleton's bone-length spread.
"""

from __future__ import annotations

import dataclasses
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fusion.calibrate.options import CalibrationOptions, Refinement
from fusion.calibrate.pipeline import calibrate_rig
from fusion.calibrate.results import calibration_from_rig
from fusion.errors import BadInputError
from fusion.io.formats import (
    FORMAT_TOPOLOGY,
    FileFormat,
    read_csv_skeleton,
    read_k4abt_json,
    read_ntu,
    read_ui_prmd_kinect,
    write_csv_skeleton,
    write_k4abt_json,
    write_ntu,
)
from fusion.io.formats.csv_skeleton import CsvOptions
from fusion.io.formats.ui_prmd import file_kind, join_episodes
from fusion.merge.fuse import FuseOptions, camera_views, fuse_views
from fusion.merge.metrics import bone_length_std
from fusion.recording import Recording
from fusion.topology import KINECT_V2
from scenarios.config import Scenario
from scenarios.evaluate import score_calibration
from scenarios.sweep import SweepOptions, run_sweep
from sim.truth import GroundTruth


def csv_options_for(recording: Recording) -> CsvOptions:
    """CSV layout matching a recording's topology and camera axes (metres, tracking states 0..3)."""
    from fusion.io.formats.csv_skeleton import ConfidenceScale

    axes = recording.cameras[0].intrinsics.axes
    return CsvOptions(topology=recording.topology, axes=axes, confidence=ConfidenceScale.STATE_0_3)


def import_files(fmt: FileFormat, paths: Sequence[Path], *, csv_options: CsvOptions | None = None) -> Recording:
    """Read real-sensor files of one format into a recording (one camera per file).

    A UI-PRMD Kinect episode is one camera in two files: ``paths`` is its positions file, optionally
    followed by its angles file (default: found by name beside it); several positions files are one
    person's episodes joined into one recording (:func:`fusion.io.formats.ui_prmd.join_episodes`).

    Raises
    ------
    BadInputError
        UI-PRMD Kinect files that are neither one episode nor several episodes' positions files.
    """
    if fmt is FileFormat.UI_PRMD_KINECT:
        kinds = [file_kind(p) for p in paths]
        if len(paths) <= 2 and "positions" not in kinds[1:]:
            return read_ui_prmd_kinect(paths[0], paths[1] if len(paths) == 2 else None)
        if any(k != "positions" for k in kinds):
            raise BadInputError(f"{fmt.value} reads one episode: its positions file, optionally followed by its angles "
                                "file; or several episodes of one person: their positions files (the angles files are "
                                f"found by name); got {len(paths)} files, not all of them positions files")
        return join_episodes([read_ui_prmd_kinect(p) for p in paths])
    if fmt is FileFormat.NTU:
        return read_ntu(paths)
    if fmt is FileFormat.K4ABT_JSON:
        return read_k4abt_json(paths)
    return read_csv_skeleton(paths, csv_options or CsvOptions())


def write_files(fmt: FileFormat, recording: Recording, out_dir: Path) -> list[Path]:
    """Write a recording's skeletons in a real-sensor format, one file per camera.

    Raises
    ------
    BadInputError
        A format that is only read (:attr:`FileFormat.writable`), or a recording of another joint set
        than the format holds.
    """
    if not fmt.writable:
        raise BadInputError(f"{fmt.value} files are only read, not written; write one of "
                            f"{', '.join(f.value for f in FileFormat if f.writable)}")
    needed = FORMAT_TOPOLOGY[fmt]
    if needed is not None and recording.topology != needed:
        raise BadInputError(f"{fmt.value} files hold {needed.name} skeletons; this recording has "
                            f"{recording.topology.name} (simulate with subject.topology = '{needed.name}')")
    if fmt is FileFormat.NTU:
        return write_ntu(recording, out_dir)
    if fmt is FileFormat.K4ABT_JSON:
        return write_k4abt_json(recording, out_dir)
    return write_csv_skeleton(recording, out_dir, csv_options_for(recording))


def _errors(recording: Recording, truth: GroundTruth, seed: int) -> dict[str, float]:
    """Calibration errors against truth, and the fused skeleton's mean bone-length spread [mm]."""
    rig = calibrate_rig(recording, CalibrationOptions(refine=Refinement.NONE), rng=np.random.default_rng(seed))
    scores = score_calibration(rig.T_world_cam, truth, rig.reference).summary()
    views = camera_views(recording, calibration_from_rig(rig))
    bones = bone_length_std(fuse_views(views, FuseOptions()).positions, views.topology)
    return {"rotation_error_deg": scores["rotation_error_deg"]["median"],
            "translation_error_mm": scores["translation_error_mm"]["median"],
            "rmse_points_mm": scores["rmse_points_mm"]["median"],
            "fused_bone_std_mm": float(np.mean(list(bones.values())) * 1e3)}


def round_trip(recording: Recording, truth: GroundTruth, fmt: FileFormat, *, seed: int = 0) -> dict[str, Any]:
    """Calibration errors of the native recording and of its write-then-import copy in ``fmt``."""
    with tempfile.TemporaryDirectory() as tmp:
        files = write_files(fmt, recording, Path(tmp))
        csv_options = csv_options_for(recording) if fmt is FileFormat.CSV else None
        imported = import_files(fmt, sorted(files), csv_options=csv_options)
    if imported.camera_names != recording.camera_names:
        raise BadInputError(f"{fmt.value}: imported cameras {imported.camera_names} differ from the written "
                            f"{recording.camera_names}")
    frames = {c.name: (c.skeleton.n_frames, imported.camera(c.name).skeleton.n_frames) for c in recording.cameras}
    return {"format": fmt.value, "topology": recording.topology.name, "cameras": len(recording.cameras),
            "native": _errors(recording, truth, seed), "imported": _errors(imported, truth, seed), "frames": frames}


def _front_arc_round_trip(scenario: Scenario, fmt: FileFormat, n: int) -> dict[str, Any]:
    """:func:`round_trip` of ``scenario`` re-rigged as a front arc of ``n`` cameras, in ``fmt``."""
    from scenarios.runner import simulate

    span = 45.0 if n == 2 else 60.0
    angles = list(np.linspace(span, -span, n))
    topology = FORMAT_TOPOLOGY[fmt] or KINECT_V2
    sc = dataclasses.replace(scenario, rig=dataclasses.replace(scenario.rig, angles_deg=angles, camera=None, subset=None),
                             subject=dataclasses.replace(scenario.subject, topology=topology.name))
    recording, truth = simulate(sc, progress=False)
    return round_trip(recording, truth, fmt, seed=scenario.seed)


def round_trip_study(scenario: Scenario, formats: Sequence[FileFormat], camera_counts: Sequence[int], *,
                     sweep: SweepOptions = SweepOptions()) -> list[dict[str, Any]]:
    """:func:`round_trip` for every format and camera count, on ``scenario`` re-rigged as a front arc.

    ``n`` cameras stand on the scenario's ring radius at angles spread over +-45 degrees (two
    cameras) or +-60 degrees (more); each format is simulated with the joint set it holds. Each
    session is one task of a Dask sweep (:mod:`scenarios.sweep`); rows come in (count, format) order.
    """
    for n in camera_counts:
        if n < 2:
            raise BadInputError(f"a round trip needs at least two cameras per session, got {n}")
    tasks = [(scenario, fmt, n) for n in camera_counts for fmt in formats]
    return run_sweep(_front_arc_round_trip, tasks, options=sweep, desc="round trip")


def round_trip_table(rows: list[dict[str, Any]]) -> str:
    """Markdown table of native against imported calibration errors."""
    lines = ["| format | topology | cameras | native rotation [deg] | imported rotation [deg] | native translation [mm] | "
             "imported translation [mm] | native points RMSE [mm] | imported points RMSE [mm] | "
             "native fused bone std [mm] | imported fused bone std [mm] |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        n, i = r["native"], r["imported"]
        lines.append(f"| {r['format']} | {r['topology']} | {r['cameras']} | {n['rotation_error_deg']:.3f} | "
                     f"{i['rotation_error_deg']:.3f} | {n['translation_error_mm']:.1f} | {i['translation_error_mm']:.1f} | "
                     f"{n['rmse_points_mm']:.1f} | {i['rmse_points_mm']:.1f} | {n['fused_bone_std_mm']:.1f} | "
                     f"{i['fused_bone_std_mm']:.1f} |")
    return "\n".join(lines) + "\n"
