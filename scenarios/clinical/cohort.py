"""Synthetic Fugl-Meyer cohorts: many subjects simulated, calibrated from the body and fused.

The cohort file is :mod:`scenarios.clinical.cohort_file`. Each subject's session: idle, the calibration turn, then per movement and side a block of
repetitions (a patient shows the unaffected side first, as in the clinic). Output directory::

    manifest.json                  the dataset (layout below)
    manifest.csv, participants.tsv, participants.json, datasheet.md   see scenarios.clinical.dataset_files
    subjects/<id>/run/             recording/, truth/, scenario.json (see scenarios.runner)
    subjects/<id>/calibration.toml calibration from the body (skeleton RANSAC + ICP)
    subjects/<id>/fused/           the fused skeleton (see scenarios.fusing)

``manifest.json``: ``format``, ``version``, ``package_version``, ``seed``, ``cohort`` (the resolved
configuration) and ``subjects``, each with ``id``, ``group``, ``affected_side`` (None for healthy),
``anthropometry``, ``fma_ue`` (the affected arm's FMA-UE score, None when not modelled), ``item_scores`` (per side, see :mod:`sim.scoring`), ``blocks`` (``movement``,
``side``, ``repetitions``, ``t_start`` / ``t_end`` in session seconds: when the movement was asked
for, and ``truth.repetitions``: true start, peak and end of each one), ``files`` (paths relative to
the output directory, None when not written), ``error`` (None, or why calibration or fusion
failed), ``truth.profile`` (the kinematic parameters, SI units, sides ``left`` / ``right``) and
``truth.profile_units`` (the unit of each parameter). Only ``truth`` keys hold what a real session
would not know. Labels and units: :mod:`scenarios.clinical.vocabulary`.
"""

from __future__ import annotations

import dataclasses
import enum
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fusion.calibrate.options import CalibrationOptions
from fusion.calibrate.pipeline import calibrate_rig
from fusion.calibrate.results import calibration_from_rig
from fusion.errors import BadInputError, BenchError
from fusion.io.atomic import atomic_directory
from fusion.io.calibration_file import save_calibration
from fusion.io.recording_files import save_recording
from fusion.merge.fuse import FuseOptions
from scenarios.clinical.cohort_file import Cohort, ProtocolConfig
from scenarios.clinical.dataset_files import write_dataset_files
from scenarios.clinical.vocabulary import PROFILE_UNITS, SIDE_NAMES
from scenarios.config import (
    Scenario,
    SegmentConfig,
    SegmentKind,
    SubjectConfig,
    scenario_to_dict,
)
from scenarios.fusing import fuse_to_disk
from scenarios.runner import VERSION, build_simulation
from scenarios.sweep import SweepOptions, run_sweep
from sim.anthropometry import sample_anthropometry
from sim.humanoid_model import build_humanoid
from sim.motions import calibration_turn, hand_lift, idle, salute
from sim.patient_motion import Group, Movement, Side, SubjectProfile
from sim.patients import draw_subject
from sim.scoring import item_scores
from sim.session import simulate_session
from sim.timeline import Motion, compose
from sim.truth import save_truth

FORMAT_NAME = "mocap-bench-cohort"
FORMAT_VERSION = 2

_MOVEMENTS = {"salute": (Movement.SALUTE, SegmentKind.SALUTE, salute),
              "hand_lift": (Movement.HAND_LIFT, SegmentKind.HAND_LIFT, hand_lift)}
_SIDES = {name: side for side, name in SIDE_NAMES.items()}


@dataclass(frozen=True)
class CohortResult:
    """What :func:`generate_cohort` wrote: the output directory and the parsed ``manifest.json``."""

    out_dir: Path
    manifest: dict[str, Any]

    @property
    def failed(self) -> tuple[str, ...]:
        """Ids of the subjects whose calibration or fusion failed."""
        return tuple(s["id"] for s in self.manifest["subjects"] if s["error"] is not None)


def plain(value: Any) -> Any:
    """JSON-able form of dataclass / enum / numpy values (enums by value)."""
    if dataclasses.is_dataclass(value):
        return {f.name: plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, dict):
        return {k: plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, np.generic):
        return value.item()
    return value


def _session(protocol: ProtocolConfig, profile: SubjectProfile, *, rng: np.random.Generator
             ) -> tuple[Motion, tuple[SegmentConfig, ...], list[dict[str, Any]]]:
    """The subject's motion, its segments and its blocks (movement, side, repetitions, t_start, t_end)."""
    sides = [_SIDES[s] for s in protocol.sides]
    if profile.affected_side is not None:
        sides.sort(key=lambda side: side is profile.affected_side)  # unaffected side first
    segments = [idle(protocol.idle_s, rng=rng), calibration_turn(protocol.calibration_turn_s, rng=rng)]
    configs = [SegmentConfig(SegmentKind.IDLE, duration_s=protocol.idle_s),
               SegmentConfig(SegmentKind.CALIBRATION_TURN, duration_s=protocol.calibration_turn_s)]
    blocks = []
    t = sum(s.duration for s in segments)
    for name in protocol.movements:
        movement, kind, make = _MOVEMENTS[name]
        for side in sides:
            n = int(rng.integers(protocol.repetitions[0], protocol.repetitions[1] + 1))
            rest = protocol.rest_s + profile.initiation_delay
            segment = make(side, n, profile.movement(movement, side), rng=rng, rest=rest)
            segments.append(segment)
            configs.append(SegmentConfig(kind, side=SIDE_NAMES[side], repetitions=n, rest_s=rest))
            blocks.append({"movement": name, "side": SIDE_NAMES[side], "repetitions": n,
                           "t_start": t, "t_end": t + segment.duration})
            t += segment.duration
    motion = compose(segments)
    for block in blocks:
        block["truth"] = {"repetitions": [
            {"index": r.index, "t_start": r.t_start, "t_peak": r.t_peak, "t_end": r.t_end}
            for r in motion.repetitions
            if r.movement.value == block["movement"] and SIDE_NAMES[r.side] == block["side"]
            and block["t_start"] <= r.t_start < block["t_end"]]}
    return motion, tuple(configs), blocks


def _simulate_subject(cohort: Cohort, subject_id: str, group: Group, seed: np.random.SeedSequence,
                      out_dir: Path) -> dict[str, Any]:
    """Simulate, calibrate and fuse one subject into ``out_dir / subjects / subject_id``; its manifest entry."""
    anthro_seq, profile_seq, motion_seq, rig_seq, session_seq, calib_seq, fuse_seq = seed.spawn(7)
    anthro = sample_anthropometry(rng=np.random.default_rng(anthro_seq))
    profile = draw_subject(group, cohort.patients.model, cohort.patients.severity,
                           rng=np.random.default_rng(profile_seq), ablate=frozenset(cohort.patients.ablate))
    motion, segments, blocks = _session(cohort.protocol, profile, rng=np.random.default_rng(motion_seq))
    affected = None if profile.affected_side is None else SIDE_NAMES[profile.affected_side]
    scenario = Scenario(
        name=f"{cohort.study.name}/{subject_id}",
        seed=int(rig_seq.generate_state(1)[0]),  # build_simulation draws varied intrinsics from it
        description=f"{group.value} subject of cohort {cohort.study.name}",
        subject=SubjectConfig(height_m=anthro.height_m, build=anthro.build.value, group=group.value,
                              affected_side=affected, topology=cohort.study.topology),
        rig=cohort.rig, session=segments, sensors=cohort.sensors)
    setup = build_simulation(scenario)  # the rig and sensor models of the scenario machinery
    meta = {"cohort": cohort.study.name, "subject": subject_id, "version": VERSION}
    recording, truth = simulate_session(build_humanoid(anthro), motion, setup.rig, setup.sensors,
                                        seed=session_seq, metadata=meta, person_seed=setup.person_seed)
    rel = Path("subjects") / subject_id
    run = out_dir / rel / "run"
    save_recording(recording, run / "recording")
    save_truth(truth, run / "truth")
    doc = {"scenario": scenario_to_dict(scenario), "cohort_seed": cohort.study.seed, "version": VERSION}
    (run / "scenario.json").write_text(json.dumps(doc, indent=2, sort_keys=True) + "\n", encoding="utf-8")
    files: dict[str, str | None] = {"recording": str(rel / "run" / "recording"), "truth": str(rel / "run" / "truth"),
                                    "calibration": None, "fused": None}
    error = None
    try:
        proc = cohort.processing
        rig = calibrate_rig(recording, CalibrationOptions(refine=proc.refine, rig=proc.rig),
                            rng=np.random.default_rng(calib_seq))
        calibration = calibration_from_rig(rig)
        save_calibration(calibration, out_dir / rel / "calibration.toml")
        files["calibration"] = str(rel / "calibration.toml")
        fuse_to_disk(recording, calibration, out_dir / rel / "fused", FuseOptions(method=proc.fuse_method),
                     seed=int(fuse_seq.generate_state(1)[0]))
        files["fused"] = str(rel / "fused" / "recording")
    except BenchError as exc:
        error = f"{type(exc).__name__}: {exc}"
    return {
        "id": subject_id,
        "group": group.value,
        "affected_side": affected,
        "anthropometry": plain(anthro),
        "fma_ue": profile.fma_ue,
        "item_scores": {SIDE_NAMES[side]: item_scores(profile, side).to_dict() for side in Side},
        "blocks": blocks,
        "files": files,
        "error": error,
        "truth": {"profile": {**plain(profile), "affected_side": affected},
                  "profile_units": {k: u.value for k, u in PROFILE_UNITS.items()}},
    }


def subject_plan(cohort: Cohort) -> list[tuple[str, Group, np.random.SeedSequence]]:
    """Subject ids, groups (shuffled, so an id does not reveal its group) and seeds of ``cohort``.

    The cohort seed is split with ``SeedSequence.spawn``: one child shuffles the groups, one per
    subject seeds everything about that subject (body, kinematics, motion, sensors, calibration).
    """
    g = cohort.groups
    groups = [Group.HEALTHY] * g.healthy + [Group.MILD] * g.mild + [Group.MODERATE_SEVERE] * g.moderate_severe
    shuffle_seq, *seeds = np.random.SeedSequence(cohort.study.seed).spawn(1 + len(groups))
    order = np.random.default_rng(shuffle_seq).permutation(len(groups))
    width = max(2, len(str(len(groups))))
    return [(f"sub-{i + 1:0{width}d}", groups[k], seed) for i, (k, seed) in enumerate(zip(order, seeds))]


def generate_cohort(cohort: Cohort, out_dir: str | Path, *, sweep: SweepOptions | None = None,
                    overwrite: bool = False, commit: str | None = None) -> CohortResult:
    """Simulate, calibrate from the body and fuse every subject of ``cohort``; write the dataset.

    Parameters
    ----------
    cohort : Cohort
    out_dir : output directory (layout in the module docstring), written atomically; workers of a
        remote cluster must see it at the same path.
    sweep : where the subjects run (:mod:`scenarios.sweep`); default a local cluster of
        ``cohort.study.workers`` workers (one per core when unset).
    overwrite : replace an existing non-empty ``out_dir``.
    commit : the source checkout's commit, recorded in ``datasheet.md`` (None: unknown).

    Returns
    -------
    CohortResult
        A subject whose calibration or fusion fails has ``error`` set in the manifest; other
        errors (bad configuration, simulator bugs) abort the cohort and leave ``out_dir`` untouched.
    """
    if not isinstance(cohort, Cohort):
        raise BadInputError(f"cohort must be a Cohort, got {type(cohort).__name__}")
    if sweep is None:
        sweep = SweepOptions(workers=cohort.study.workers)
    plan = subject_plan(cohort)
    out_dir = Path(out_dir)
    with atomic_directory(out_dir, overwrite=overwrite) as tmp:
        entries = run_sweep(_simulate_subject, [(cohort, sid, group, seed, tmp) for sid, group, seed in plan],
                            options=sweep, desc=f"cohort {cohort.study.name}")
        manifest = {"format": FORMAT_NAME, "version": FORMAT_VERSION, "package_version": VERSION,
                    "seed": cohort.study.seed, "cohort": plain(cohort), "subjects": entries}
        (tmp / "manifest.json").write_text(json.dumps(manifest, indent=2, sort_keys=True) + "\n", encoding="utf-8")
        write_dataset_files(tmp, manifest, commit=commit)
    return CohortResult(out_dir, manifest)
