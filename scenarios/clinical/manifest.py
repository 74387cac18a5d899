"""Cohort manifests as the Fugl-Meyer analysis reads them, checked before anything is loaded.

``manifest.json`` is written by ``mocap-bench cohort`` (keys: :mod:`scenarios.clinical.cohort`). The analysis
reads per subject ``id``, ``group``, ``error``, ``files.recording``, ``files.calibration``,
``item_scores`` and the ``blocks`` (``movement``, ``side``, ``t_start``, ``t_end`` [s]).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from fusion.errors import RecordingError
from scenarios.clinical.vocabulary import SIDE_NAMES, Item

MOVEMENTS = tuple(sorted(item.value for item in Item))
"""The movements of a block (:class:`~scenarios.clinical.vocabulary.Item`), in the order of the reports."""


def _manifest_error(mpath: Path, what: str) -> RecordingError:
    return RecordingError(f"{mpath}: {what}; re-create the dataset with `mocap-bench cohort` (or repair the file)")


def _check_subject(root: Path, mpath: Path, i: int, s: Any) -> None:
    """Refuse a manifest entry whose fields the analysis reads are missing, mistyped or point nowhere."""
    if not isinstance(s, dict) or not {"id", "group", "error", "files", "blocks", "item_scores"} <= set(s):
        raise _manifest_error(mpath, f"subjects[{i}] lacks id, group, error, files, blocks or item_scores")
    where = f"subject {s['id']!r}"
    files = s["files"]
    if not isinstance(files, dict) or not all(isinstance(files.get(k), (str, type(None)))
                                              for k in ("recording", "calibration")):
        raise _manifest_error(mpath, f"{where}: files must name the recording and calibration paths")
    if not isinstance(s["blocks"], list) or not all(
            isinstance(b, dict) and b.get("movement") in MOVEMENTS and b.get("side") in SIDE_NAMES.values()
            and all(isinstance(b.get(k), (int, float)) and np.isfinite(b[k]) for k in ("t_start", "t_end"))
            for b in s["blocks"]):
        raise _manifest_error(mpath, f"{where}: each block needs movement, side, t_start and t_end [s]")
    scores = s["item_scores"]
    if not isinstance(scores, dict) or not all(isinstance(scores.get(b["side"]), dict) for b in s["blocks"]):
        raise _manifest_error(mpath, f"{where}: item_scores must hold the scores of every block's side")
    if s["error"] is None and files.get("calibration"):
        for key in ("recording", "calibration"):
            if not files.get(key) or not (root / files[key]).exists():
                raise RecordingError(f"{mpath}: {where}'s {key} {files.get(key)!r} does not exist under {root}; "
                                     "restore it, re-create the dataset with `mocap-bench cohort`, or set the "
                                     "subject's error to skip it")


def read_manifest(root: Path) -> dict[str, Any]:
    """The checked ``manifest.json`` of a cohort directory.

    Raises
    ------
    RecordingError
        No manifest, not JSON (garbage or truncated), a subject entry without the fields the analysis
        reads, or a usable subject whose recording or calibration does not exist.
    """
    mpath = root / "manifest.json"
    if not mpath.is_file():
        raise RecordingError(f"{root} has no manifest.json; create the dataset with `mocap-bench cohort`")
    try:
        manifest = json.loads(mpath.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise _manifest_error(mpath, f"not valid JSON (garbage or truncated: {exc})") from None
    if not isinstance(manifest, dict) or not isinstance(manifest.get("subjects"), list):
        raise _manifest_error(mpath, "no list of subjects")
    for i, subject in enumerate(manifest["subjects"]):
        _check_subject(root, mpath, i, subject)
    return manifest
