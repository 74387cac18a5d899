"""The self-describing files of a cohort folder, written beside ``manifest.json``.

- ``manifest.csv``: one row per repetition, labels of :mod:`scenarios.clinical.vocabulary`, units in
  the column names (:data:`MANIFEST_CSV_COLUMNS`);
- ``participants.tsv`` + ``participants.json``: one row per subject and its BIDS-style sidecar
  (``Description``, ``Units``, ``Levels`` of every column);
- ``datasheet.md``: how the data set was generated, what it is for and what it is not, its files.
"""

from __future__ import annotations

import csv
import io
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import sim.patient_motion
import sim.patients
from scenarios.clinical.vocabulary import (
    ITEM_RULES,
    MISSING,
    PARTICIPANT_COLUMNS,
    Item,
    item_raw,
    item_score,
    participant_row,
    vocabulary_markdown,
)
from scenarios.runner import default_profile
from sim.patients import PatientModel
from sim.sensor_profile import load_profile

MANIFEST_CSV_COLUMNS: Mapping[str, str] = {
    "subject": "participant id",
    "group": "clinical group",
    "affected_side": "paretic arm, n/a for healthy",
    "fma_ue": "FMA-UE of the affected arm [points 0-66], n/a when not modelled",
    "height_m": "stature [m]",
    "build": "body build",
    "side": "arm of the row's block",
    "movement": "item of the row's block",
    "item_score": "score 0/1/2 of the row's movement and side (vocabulary rule)",
    "item_raw": "raw measure of the row's movement and side [points]",
    "salute_score": "salute score 0/1/2 of the row's side",
    "salute_raw": "salute raw measure of the row's side [points 0-12]",
    "hand_lift_score": "hand-lift score 0/1/2 of the row's side",
    "hand_lift_raw": "hand-lift raw measure of the row's side [points 0-2]",
    "block_t_start_s": "when the block was asked for [s, session clock]",
    "block_t_end_s": "end of the block [s, session clock]",
    "repetition": "index of the repetition in the session",
    "true_t_start_s": "true start of the repetition [s]",
    "true_t_peak_s": "true peak of the repetition [s]",
    "true_t_end_s": "true end of the repetition [s]",
    "recording": "simulated recording folder", "truth": "ground-truth folder",
    "calibration": "calibration TOML", "fused": "fused recording folder",
    "error": "why calibration or fusion failed (empty when it did not)",
}
"""The columns of ``manifest.csv`` and what each holds (paths relative to the cohort folder)."""


def _labels(scores: Mapping[str, Any], item: Item) -> tuple[int, int]:
    raw = item_raw(item, scores)
    return item_score(item, raw), raw


def manifest_csv(manifest: Mapping[str, Any]) -> str:
    """``manifest.csv``: one row per true repetition of every subject entry of ``manifest.json``."""
    out = io.StringIO()
    writer = csv.DictWriter(out, fieldnames=list(MANIFEST_CSV_COLUMNS), lineterminator="\n")
    writer.writeheader()
    for s in manifest["subjects"]:
        person = participant_row(s, manifest["seed"])
        for block in s["blocks"]:
            scores = s["item_scores"][block["side"]]
            (salute, salute_raw), (lift, lift_raw) = _labels(scores, Item.SALUTE), _labels(scores, Item.HAND_LIFT)
            score, raw = _labels(scores, Item(block["movement"]))
            for rep in block["truth"]["repetitions"]:
                writer.writerow({
                    "subject": s["id"], **{k: person[k] for k in ("group", "affected_side", "fma_ue", "height_m", "build")},
                    "side": block["side"], "movement": block["movement"], "item_score": score, "item_raw": raw,
                    "salute_score": salute, "salute_raw": salute_raw, "hand_lift_score": lift, "hand_lift_raw": lift_raw,
                    "block_t_start_s": block["t_start"], "block_t_end_s": block["t_end"], "repetition": rep["index"],
                    "true_t_start_s": rep["t_start"], "true_t_peak_s": rep["t_peak"], "true_t_end_s": rep["t_end"],
                    **{k: s["files"][k] or "" for k in ("recording", "truth", "calibration", "fused")},
                    "error": s["error"] or "",
                })
    return out.getvalue()


def participants_tsv(manifest: Mapping[str, Any]) -> str:
    """``participants.tsv``: the columns of :data:`~scenarios.clinical.vocabulary.PARTICIPANT_COLUMNS`."""
    names = [c.name for c in PARTICIPANT_COLUMNS]
    rows = ["\t".join(names)]
    for s in manifest["subjects"]:
        row = participant_row(s, manifest["seed"])
        rows.append("\t".join(row[n] for n in names))
    return "\n".join(rows) + "\n"


def participants_json() -> dict[str, Any]:
    """The BIDS sidecar of ``participants.tsv``: per column ``Description``, ``Units``, ``Levels``."""
    doc: dict[str, Any] = {}
    for c in PARTICIPANT_COLUMNS:
        entry: dict[str, Any] = {"Description": c.description}
        if c.unit.value:
            entry["Units"] = c.unit.value
        if c.levels:
            entry["Levels"] = dict(c.levels)
        doc[c.name] = entry
    return doc


def _profile_lines(cohort: Mapping[str, Any]) -> list[str]:
    name = cohort["sensors"]["profile"] or default_profile(cohort["study"]["topology"])
    profile = load_profile(name)
    sources = sorted(set(profile.provenance.values()))
    return [f"- Sensor profile: `{profile.name}` ({profile.description or 'no description'}); its "
            f"{len(profile.provenance)} parameters come from {len(sources)} sources, listed in the profile's "
            "`[provenance]` table."]


def _model_words(model: PatientModel) -> str:
    """The first paragraph of the generating module's documentation and, for the literature model, its constants."""
    module = sim.patients if model is PatientModel.LITERATURE else sim.patient_motion
    words = " ".join((module.__doc__ or "").split("\n\n")[0].split())
    if model is PatientModel.LITERATURE:
        words += (f" FMA-UE bands {', '.join(f'{g.value} {lo:g}-{hi:g}' for g, (lo, hi) in sim.patients.GROUP_BANDS.items())}"
                  f" points; anchors at FMA-UE {sim.patients.ANCHOR_SCORES}; postacute FMA-UE mean, SD "
                  f"{sim.patients.POSTACUTE_FMA}; control response time mean, SD {sim.patients.RT_HEALTHY_MS} ms; "
                  f"tremor prevalence {sim.patients.TREMOR_PREVALENCE:g}.")
    return words


def _rig_words(rig: Mapping[str, Any]) -> str:
    angles = rig["angles_deg"]
    where = f"at {', '.join(f'{a:g}' for a in angles)} degrees" if angles else "evenly spaced"
    return (f"{len(angles) if angles else rig['n_cameras']} cameras {where} on a {rig['radius_m']:g} m ring, "
            f"{rig['height_m']:g} m high")


def datasheet_markdown(manifest: Mapping[str, Any], *, commit: str | None = None) -> str:
    """``datasheet.md`` of a cohort folder, after "Datasheets for Datasets" (Gebru et al. 2021).

    Parameters
    ----------
    manifest : the cohort's ``manifest.json`` content.
    commit : the source checkout's commit, None when unknown.
    """
    cohort = manifest["cohort"]
    study, groups, patients = cohort["study"], cohort["groups"], cohort["patients"]
    protocol = cohort["protocol"]
    model = PatientModel(patients["model"])
    failed = [s["id"] for s in manifest["subjects"] if s["error"] is not None]
    lines = [
        f"# Datasheet: synthetic cohort `{study['name']}`", "",
        *([study["description"], ""] if study["description"] else []),
        "## Motivation and composition", "",
        "A synthetic data set of the Fugl-Meyer salute and hand lift (upper-extremity items A.II and A.III) "
        "seen by depth cameras, made to develop and test motion-capture, segmentation and scoring methods "
        "with known ground truth.", "",
        f"- Subjects: {len(manifest['subjects'])} ({groups['healthy']} healthy, {groups['mild']} mild, "
        f"{groups['moderate_severe']} moderate-severe stroke), ids shuffled so an id does not reveal the group.",
        f"- Subjects whose calibration or fusion failed (kept, `error` set in `manifest.json`): {len(failed)}"
        f"{' (' + ', '.join(failed) + ')' if failed else ''}.",
        f"- Protocol per subject: idle {protocol['idle_s']:g} s, calibration turn {protocol['calibration_turn_s']:g} s, "
        f"then per movement ({', '.join(protocol['movements'])}) and side ({', '.join(protocol['sides'])}) a block of "
        f"{'-'.join(map(str, sorted(set(protocol['repetitions']))))} repetitions (a patient's unaffected side first).",
        "", "## How it was generated", "",
        f"- Generator: mocap-bench {manifest['package_version']}, source commit {commit or 'unknown'}, "
        f"`mocap-bench cohort` with the cohort configuration stored in `manifest.json` (`cohort`).",
        f"- Seed: {manifest['seed']} (split per subject with `numpy.random.SeedSequence.spawn`; the same "
        "configuration and seed give identical arrays).",
        f"- Patient model: `{model.value}`: {_model_words(model)} (severity draw: "
        f"`{patients['severity']}`; parts switched off: {', '.join(patients['ablate']) or 'none'}). "
        "Sources and mappings: the module documentation of `sim.patients` and `docs/studies/patient_model.md`.",
        *_profile_lines(cohort),
        f"- Rig: {_rig_words(cohort['rig'])}; calibration from the body (refinement `{cohort['processing']['refine']}`), "
        f"fusion `{cohort['processing']['fuse_method']}`.",
        "- Labels: item scores follow from each subject's kinematic parameters by the rules of `sim.scoring` "
        "(a synthetic clinician), then map to 0/1/2 by the vocabulary below.",
        "", "## Intended uses and limits", "",
        "- For: testing calibration, fusion, repetition segmentation, feature extraction and classifiers "
        "against known truth; power and sample-size rehearsals; teaching.",
        "- Not for: clinical claims, normative values, or training models meant for patients without "
        "validation on real recordings.",
        "- Not modelled: clothing, occlusion by furniture or a clinician, spasticity and hand function, pain, "
        "fatigue over a session, learning effects, the lower limb; the humanoid is a rigid-segment body and "
        "motions are scripted from the profiles, not recorded.",
        "", "## Files", "",
        "| file | format | content, units |", "|---|---|---|",
        "| `participants.tsv` / `.json` | TSV + BIDS sidecar | one row per subject; units and levels in the sidecar |",
        "| `manifest.json` | JSON | the configuration, every subject's labels, blocks, files and truth (SI units) |",
        "| `manifest.csv` | CSV | one row per repetition; units in the column names (`_s` seconds, `_m` metres) |",
        "| `subjects/<id>/run/recording/` | mocap-bench recording | per camera skeletons [m, camera frame, s] and depth |",
        "| `subjects/<id>/run/truth/` | mocap-bench truth | true joints [m, world frame z up] and camera poses |",
        "| `subjects/<id>/calibration.toml` | TOML | camera poses from the body (`T_world_cam`, m) |",
        "| `subjects/<id>/fused/` | mocap-bench recording | the fused skeleton [m, world frame z up], joint angles [deg] |",
        "", "Exports to CSV, C3D, TRC and Motion-BIDS with the labels inside: `mocap-bench export --cohort`.",
        "", "## Vocabulary", "", vocabulary_markdown(),
        "Missing values are `" + MISSING + "`. Item rules: "
        + "; ".join(f"{i.value}: {r.rule}" for i, r in ITEM_RULES.items()) + ".", "",
    ]
    return "\n".join(lines)


def write_dataset_files(folder: Path, manifest: Mapping[str, Any], *, commit: str | None = None) -> None:
    """Write ``manifest.csv``, ``participants.tsv``, ``participants.json`` and ``datasheet.md`` into ``folder``."""
    (folder / "manifest.csv").write_text(manifest_csv(manifest), encoding="utf-8")
    (folder / "participants.tsv").write_text(participants_tsv(manifest), encoding="utf-8")
    (folder / "participants.json").write_text(json.dumps(participants_json(), indent=2) + "\n", encoding="utf-8")
    (folder / "datasheet.md").write_text(datasheet_markdown(manifest, commit=commit), encoding="utf-8")
