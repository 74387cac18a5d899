"""``mocap-bench export --cohort``: a whole cohort folder to CSV, C3D, TRC or Motion-BIDS in one call.

Nothing is simulated again: each subject's fused skeleton (``files.fused`` of ``manifest.json``) and,
with ``truth``, its ground-truth skeleton (``files.truth``) are read and written, one file per subject
and stream, with the subject's labels inside (its row of ``participants.tsv``): C3D parameters of the ``MOCAP_BENCH`` group, TRC ``name=text`` fields on the first line,
leading CSV columns. Output folder::

    participants.tsv, participants.json   the labels and their sidecar (as in the cohort folder)
    <id>_fused.<ext>                      the fused skeleton [m], world frame (z up, floor z = 0)
    <id>_truth.<ext>                      with ``truth``: the true joints [m], same frame, session clock

The fused stream's clock is the reference camera's (it starts within a frame of the session clock).
A subject whose calibration or fusion failed has no fused file (listed in ``CohortExport.skipped``).
``bids`` writes the Motion-BIDS layout of :mod:`scenarios.clinical.bids_export` instead.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from fusion.errors import BadInputError
from fusion.io import export
from fusion.io.atomic import atomic_directory
from fusion.io.recording_files import load_recording
from fusion.skeleton import SkeletonStream
from fusion.topology import TrackingState, topology_by_name
from scenarios.clinical.bids_export import write_bids, write_bids_top
from scenarios.clinical.dataset_files import participants_json, participants_tsv
from scenarios.clinical.manifest import read_manifest
from scenarios.clinical.vocabulary import participant_row
from sim.truth import load_truth

STREAMS = ("fused", "truth")
"""The skeleton streams of a subject, as named in exported file names."""

_WRITERS: Mapping[export.ExportFormat, Callable[..., Path]] = {
    export.ExportFormat.CSV: export.export_csv, export.ExportFormat.C3D: export.export_c3d,
    export.ExportFormat.TRC: export.export_trc,
}


@dataclass(frozen=True)
class CohortExport:
    """What :func:`export_cohort` wrote.

    Attributes
    ----------
    out_dir : Path
    format : ExportFormat
    files : tuple of str
        Paths of the written files, relative to ``out_dir``.
    skipped : tuple of str
        Ids of the subjects without a fused skeleton (their calibration or fusion failed).
    """

    out_dir: Path
    format: export.ExportFormat
    files: tuple[str, ...]
    skipped: tuple[str, ...]


def subject_streams(root: Path, subject: Mapping[str, Any], topology: str, *, truth: bool
                    ) -> dict[str, SkeletonStream]:
    """A subject's fused skeleton (when it was fused) and, with ``truth``, its true joints.

    Both are (T, J, 3) [m] in the world frame (z up); the truth has every joint TRACKED.
    """
    out: dict[str, SkeletonStream] = {}
    files = subject["files"]
    if files.get("fused"):
        recording = load_recording(root / files["fused"])
        out["fused"] = recording.cameras[0].skeleton
    if truth:
        if not files.get("truth"):
            raise BadInputError(f"subject {subject['id']} of {root} has no truth folder; export without --truth")
        gt = load_truth(root / files["truth"])
        states = np.where(np.isnan(gt.joints_world[..., 0]), TrackingState.NOT_TRACKED, TrackingState.TRACKED)
        out["truth"] = SkeletonStream(topology_by_name(topology), gt.times, gt.joints_world, states.astype(np.int8))
    return out


def export_cohort(root: str | Path, fmt: export.ExportFormat | str, out_dir: str | Path, *, truth: bool = False,
                  overwrite: bool = False, progress: bool = True) -> CohortExport:
    """Export every subject of the cohort folder ``root`` (written by ``mocap-bench cohort``).

    Parameters
    ----------
    root : cohort folder (``manifest.json`` and ``subjects/``).
    fmt : ``csv``, ``c3d``, ``trc`` or ``bids``.
    out_dir : output folder, written atomically.
    truth : also export the ground-truth skeletons.
    overwrite : replace an existing non-empty ``out_dir``.
    progress : show a progress bar over the subjects.

    Returns
    -------
    CohortExport

    Raises
    ------
    RecordingError
        ``root`` is not a cohort folder (no or a broken ``manifest.json``).
    BadInputError
        ``fmt`` is not a skeleton format, or ``out_dir`` exists and is not empty without ``overwrite``.
    """
    fmt = export.ExportFormat(fmt)
    if fmt not in (*_WRITERS, export.ExportFormat.BIDS):
        raise BadInputError(f"a cohort exports to {', '.join(f.value for f in (*_WRITERS, export.ExportFormat.BIDS))}, "
                            f"not {fmt.value}")
    root = Path(root)
    manifest = read_manifest(root)
    topology = manifest["cohort"]["study"]["topology"]
    subjects = manifest["subjects"]
    written: list[str] = []
    with atomic_directory(out_dir, overwrite=overwrite) as tmp:
        for subject in tqdm(subjects, desc=f"export {fmt.value}", unit="subject", leave=False) if progress else subjects:
            streams = subject_streams(root, subject, topology, truth=truth)
            labels = participant_row(subject, manifest["seed"])
            if fmt is export.ExportFormat.BIDS:
                written += write_bids(tmp, subject, streams, labels)
                continue
            for name, stream in streams.items():
                rel = f"{subject['id']}_{name}.{fmt.value}"
                _WRITERS[fmt](stream, tmp / rel, labels=labels)
                written.append(rel)
        if fmt is export.ExportFormat.BIDS:
            sheet = root / "datasheet.md"
            written += write_bids_top(tmp, manifest, sheet.read_text(encoding="utf-8") if sheet.is_file() else None)
        (tmp / "participants.tsv").write_text(participants_tsv(manifest), encoding="utf-8")
        (tmp / "participants.json").write_text(json.dumps(participants_json(), indent=2) + "\n", encoding="utf-8")
    skipped = tuple(s["id"] for s in subjects if not s["files"].get("fused"))
    return CohortExport(Path(out_dir), fmt, tuple(written + ["participants.tsv", "participants.json"]), skipped)

