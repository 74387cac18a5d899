"""A cohort as a Motion-BIDS data set (BIDS 1.9, motion modality)::

    dataset_description.json, README.md (the cohort's datasheet), participants.tsv, participants.json
    sub-<nn>/motion/sub-<nn>_task-fma_tracksys-<fused|truth>_motion.tsv     samples, no header
    sub-<nn>/motion/sub-<nn>_task-fma_tracksys-<fused|truth>_channels.tsv   name, component, type,
                                                                            tracked_point, units, reference_frame
    sub-<nn>/motion/sub-<nn>_task-fma_tracksys-<fused|truth>_channels.json  the reference frame
    sub-<nn>/motion/sub-<nn>_task-fma_tracksys-<fused|truth>_motion.json    SamplingFrequency, TaskName, ...
    sub-<nn>/motion/sub-<nn>_task-fma_events.tsv (+ .json)                  the protocol blocks

Samples lie on a uniform grid at the stream's median frame rate (:func:`fusion.io.export.resample_uniform`);
the first channel is the sample time (LATENCY, s, on the stream's clock), then x, y, z of every joint
(POS, m, world frame: z up, floor z = 0), then the clinical joint angles of those positions (JNTANG,
deg: the ISB angles of :mod:`fusion.merge.angles`). Missing values are ``n/a``. Events are the protocol blocks
(``onset`` when the movement was asked for, on the session clock, which the fused and true streams
share within a frame).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from fusion.io.export import resample_uniform
from fusion.merge.angles import joint_angles
from fusion.skeleton import SkeletonStream
from scenarios.clinical.dataset_files import datasheet_markdown
from scenarios.clinical.vocabulary import MISSING

BIDS_VERSION = "1.9.0"
TASK = "fma"
"""The task label of every file (the Fugl-Meyer salute and hand-lift protocol)."""

TRACKING_SYSTEMS: Mapping[str, str] = {
    "fused": "skeleton fused from the simulated depth cameras' body trackers, calibrated from the body",
    "truth": "ground-truth joints of the simulated humanoid",
}
"""What each ``tracksys`` label holds."""

_FRAME = {"global": {"Description": "world frame of the rig: right-handed, z up, floor at z = 0, metres"}}


def dataset_description(manifest: Mapping[str, Any]) -> dict[str, Any]:
    """``dataset_description.json`` of a cohort's ``manifest.json``."""
    study = manifest["cohort"]["study"]
    return {"Name": f"mocap-bench synthetic cohort {study['name']}", "BIDSVersion": BIDS_VERSION,
            "DatasetType": "raw",
            "GeneratedBy": [{"Name": "mocap-bench", "Version": manifest["package_version"],
                             "Description": f"mocap-bench cohort {study['name']}, seed {manifest['seed']}"}]}


def _rows(values: np.ndarray) -> str:
    """TSV text of a (N, C) array, ``n/a`` for NaN."""
    return "".join("\t".join(MISSING if np.isnan(v) else repr(float(v)) for v in row) + "\n" for row in values)


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")


def _events(subject: Mapping[str, Any]) -> tuple[str, dict[str, Any]]:
    lines = ["onset\tduration\ttrial_type\tside\trepetitions"]
    for b in subject["blocks"]:
        lines.append(f"{b['t_start']!r}\t{b['t_end'] - b['t_start']!r}\t{b['movement']}\t{b['side']}\t{b['repetitions']}")
    sidecar = {"onset": {"Description": "when the movement was asked for", "Units": "s"},
               "duration": {"Description": "length of the block", "Units": "s"},
               "trial_type": {"Description": "Fugl-Meyer item performed",
                              "Levels": {"salute": "item A.II", "hand_lift": "item A.III"}},
               "side": {"Description": "arm that moves", "Levels": {"left": "left arm", "right": "right arm"}},
               "repetitions": {"Description": "repetitions asked for in the block"}}
    return "\n".join(lines) + "\n", sidecar


def write_bids(folder: Path, subject: Mapping[str, Any], streams: Mapping[str, SkeletonStream],
               labels: Mapping[str, str]) -> list[str]:
    """Write one subject's Motion-BIDS files under ``folder``; their paths relative to it.

    Parameters
    ----------
    folder : the data set's root.
    subject : the subject's ``manifest.json`` entry.
    streams : ``fused`` and / or ``truth`` skeletons, (T, J, 3) [m] in the world frame.
    labels : the subject's ``participants.tsv`` row (its group and scores go into ``participants.tsv``,
        the BIDS place for them; the motion sidecar repeats group and affected side).
    """
    sub = subject["id"]
    base = f"{sub}/motion/{sub}_task-{TASK}"
    written = []
    for name, stream in streams.items():
        ts = stream.timestamps
        rate = float(1.0 / np.median(np.diff(ts)))
        times, pos = resample_uniform(stream, rate)
        joints = stream.topology.joints
        angles = joint_angles(pos, stream.topology)
        stem = f"{base}_tracksys-{name}"
        channels = ["name\tcomponent\ttype\ttracked_point\tunits\treference_frame", "time\tn/a\tLATENCY\tn/a\ts\tn/a"]
        channels += [f"{j}_{c}\t{c}\tPOS\t{j}\tm\tglobal" for j in joints for c in "xyz"]
        channels += [f"{a}\tn/a\tJNTANG\t{a}\tdeg\tn/a" for a in angles.names]
        meta = {"TaskName": TASK, "TaskDescription": "Fugl-Meyer salute and hand lift, per side, after an idle "
                "stretch and a calibration turn", "SamplingFrequency": rate,
                "SamplingFrequencyEffective": float((ts.size - 1) / (ts[-1] - ts[0])),
                "TrackingSystemName": TRACKING_SYSTEMS[name], "Manufacturer": "mocap-bench (simulated)",
                "RecordingDuration": float(times[-1] - times[0]), "MotionChannelCount": 1 + 3 * len(joints) + len(angles.names),
                "POSChannelCount": 3 * len(joints), "JNTANGChannelCount": len(angles.names), "LATENCYChannelCount": 1, "TrackedPointsCount": len(joints),
                "MissingValues": MISSING, "SubjectArtefactDescription": f"group {labels['group']}, affected side "
                f"{labels['affected_side']} (labels in participants.tsv)"}
        _write(folder / f"{stem}_motion.tsv", _rows(np.column_stack([times, pos.reshape(times.size, -1), angles.degrees])))
        _write(folder / f"{stem}_channels.tsv", "\n".join(channels) + "\n")
        _write(folder / f"{stem}_channels.json", json.dumps({"reference_frame": {"Levels": _FRAME}}, indent=2) + "\n")
        _write(folder / f"{stem}_motion.json", json.dumps(meta, indent=2) + "\n")
        written += [f"{stem}_{s}" for s in ("motion.tsv", "channels.tsv", "channels.json", "motion.json")]
    events, sidecar = _events(subject)
    _write(folder / f"{base}_events.tsv", events)
    _write(folder / f"{base}_events.json", json.dumps(sidecar, indent=2) + "\n")
    return written + [f"{base}_events.tsv", f"{base}_events.json"]


def write_bids_top(folder: Path, manifest: Mapping[str, Any], datasheet: str | None = None) -> list[str]:
    """``dataset_description.json`` and ``README.md`` under ``folder``: ``datasheet`` (the cohort's
    ``datasheet.md``), or when None one made from ``manifest``."""
    _write(folder / "dataset_description.json", json.dumps(dataset_description(manifest), indent=2) + "\n")
    _write(folder / "README.md", datasheet_markdown(manifest) if datasheet is None else datasheet)
    return ["dataset_description.json", "README.md"]
