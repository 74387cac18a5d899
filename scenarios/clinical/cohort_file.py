"""Cohort files: TOML in, validated frozen dataclasses out.

A cohort TOML (strict keys; built-ins in ``scenarios/cohorts/``)::

    [cohort]      name, description = "", seed = 0, workers (default: one per core), topology = "kinect_v2"
    [groups]      healthy = 10, mild = 6, moderate_severe = 6          (subject counts)
    [protocol]    idle_s = 2.0, calibration_turn_s = 16.0, repetitions = [3, 5] (inclusive range,
                  drawn per block), rest_s = 1.0, movements = ["salute", "hand_lift"],
                  sides = ["right", "left"]
    [rig]         as in a scenario (:class:`scenarios.config.RigConfig`)
    [sensors]     as in a scenario (:class:`scenarios.config.SensorConfig`)
    [processing]  refine = "icp", rig = "graph", fuse_method = "avg_frontal"
    [patients]    model = "ranges" | "literature" (continuous FMA-UE severity, :mod:`sim.patients`),
                  severity = "uniform" | "postacute" (how the literature model draws the FMA-UE),
                  ablate = [] (literature model parts switched off: "timing", "elevation", "synergy",
                  "trunk", "ipsilesional", "initiation"; :class:`sim.patients.ModelPart`)
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fusion.calibrate.options import Refinement, RigMethod
from fusion.errors import BenchError, ScenarioError
from fusion.merge.methods import MergeMethod
from fusion.topology import topology_by_name
from scenarios.clinical.vocabulary import SIDE_NAMES, Item
from scenarios.config import SCENARIO_DIR, RigConfig, SensorConfig
from scenarios.toml_tables import build_table, read_toml, resolve_builtin
from sim.patients import ModelPart, PatientModel, SeverityDistribution

COHORT_DIR = SCENARIO_DIR / "cohorts"
MOVEMENTS = tuple(item.value for item in Item)
"""The protocol's movements, as named in a cohort file."""
SIDES = tuple(SIDE_NAMES.values())
"""The arms, as named in a cohort file."""


@dataclass(frozen=True)
class StudyConfig:
    """Name, seed and parallelism of a cohort; ``workers`` of the local Dask cluster, None = one per core."""

    name: str
    description: str = ""
    seed: int = 0
    workers: int | None = None
    topology: str = "kinect_v2"


@dataclass(frozen=True)
class GroupCounts:
    """Number of subjects per clinical group."""

    healthy: int = 10
    mild: int = 6
    moderate_severe: int = 6

    @property
    def total(self) -> int:
        return self.healthy + self.mild + self.moderate_severe


@dataclass(frozen=True)
class ProtocolConfig:
    """Session of every subject; ``repetitions`` is an inclusive [low, high] range drawn per block."""

    idle_s: float = 2.0
    calibration_turn_s: float = 16.0
    repetitions: list[int] = field(default_factory=lambda: [3, 5])
    rest_s: float = 1.0
    movements: list[str] = field(default_factory=lambda: ["salute", "hand_lift"])
    sides: list[str] = field(default_factory=lambda: ["right", "left"])


@dataclass(frozen=True)
class ProcessingConfig:
    """Calibration from the body and skeleton fusion applied to every subject."""

    refine: Refinement = Refinement.ICP
    rig: RigMethod = RigMethod.GRAPH
    fuse_method: MergeMethod = MergeMethod.AVG_FRONTAL


@dataclass(frozen=True)
class PatientConfig:
    """Which patient model draws the patients, and how it draws their severity."""

    model: PatientModel = PatientModel.RANGES
    severity: SeverityDistribution = SeverityDistribution.UNIFORM
    ablate: list[ModelPart] = field(default_factory=list)


@dataclass(frozen=True)
class Cohort:
    """A complete, reproducible cohort set-up (see the module docstring for the TOML layout)."""

    study: StudyConfig
    groups: GroupCounts = field(default_factory=GroupCounts)
    protocol: ProtocolConfig = field(default_factory=ProtocolConfig)
    rig: RigConfig = field(default_factory=RigConfig)
    sensors: SensorConfig = field(default_factory=SensorConfig)
    processing: ProcessingConfig = field(default_factory=ProcessingConfig)
    patients: PatientConfig = field(default_factory=PatientConfig)


_TABLES = {"cohort": StudyConfig, "groups": GroupCounts, "protocol": ProtocolConfig, "rig": RigConfig,
           "sensors": SensorConfig, "processing": ProcessingConfig, "patients": PatientConfig}


def cohort_from_dict(data: dict[str, Any], where: str = "cohort") -> Cohort:
    """Validate a parsed cohort TOML document into a :class:`Cohort`.

    Raises
    ------
    ScenarioError
        Unknown table or key (naming the allowed ones), wrong type, or a value out of range.
    """
    unknown = [k for k in data if k not in _TABLES]
    if unknown:
        raise ScenarioError(f"{where}: unknown table [{unknown[0]}]; allowed: "
                            + ", ".join(f"[{t}]" for t in _TABLES))
    if "cohort" not in data:
        raise ScenarioError(f"{where}: missing [cohort] table with at least name = ...")
    parts = {name: build_table(cls, data.get(name, {}), name) for name, cls in _TABLES.items()}
    cohort = Cohort(study=parts.pop("cohort"), **parts)
    _check_cohort(cohort)
    return cohort


MAX_SUBJECTS = 500
"""Most subjects a cohort file may ask for (each one is a whole simulated, calibrated and fused session)."""


def _check_cohort(c: Cohort) -> None:
    s, g, p = c.study, c.groups, c.protocol
    if s.seed < 0:
        raise ScenarioError("cohort.seed must be >= 0")
    if s.workers is not None and s.workers < 0:
        raise ScenarioError("cohort.workers must be >= 0 (0 = in one process)")
    try:
        topology_by_name(s.topology)
    except BenchError as exc:
        raise ScenarioError(f"cohort.topology: {exc}") from None
    if min(g.healthy, g.mild, g.moderate_severe) < 0 or g.total < 1:
        raise ScenarioError("[groups] counts must be >= 0 with at least one subject")
    if g.total > MAX_SUBJECTS:
        raise ScenarioError(f"the cohort has {g.total} subjects, each simulated, calibrated and fused in turn; at most "
                            f"{MAX_SUBJECTS} are supported (the paper's study had 22): lower the [groups] counts")
    if len(p.repetitions) != 2 or not 1 <= p.repetitions[0] <= p.repetitions[1]:
        raise ScenarioError(f"protocol.repetitions must be [low, high] with 1 <= low <= high, got {p.repetitions}")
    if p.idle_s <= 0 or p.rest_s < 0:
        raise ScenarioError("protocol.idle_s must be > 0 and protocol.rest_s >= 0")
    if p.calibration_turn_s < 4:
        raise ScenarioError("protocol.calibration_turn_s must be >= 4 s (calibration needs the turn)")
    for key, allowed in (("movements", MOVEMENTS), ("sides", SIDES)):
        values = getattr(p, key)
        if not values or len(set(values)) != len(values) or set(values) - set(allowed):
            raise ScenarioError(f"protocol.{key} must list distinct values of {list(allowed)}, got {values}")
    if c.patients.ablate and (c.patients.model is not PatientModel.LITERATURE
                              or len(set(c.patients.ablate)) != len(c.patients.ablate)):
        raise ScenarioError('patients.ablate needs model = "literature" and lists each part once, got '
                            f"{[p.value for p in c.patients.ablate]} with model = {c.patients.model.value!r}")
    n_cameras = len(c.rig.subset or c.rig.angles_deg or range(c.rig.n_cameras))
    if n_cameras < 2:
        raise ScenarioError("[rig] needs at least two cameras (calibration from the body pairs them)")
    if c.sensors.person_seed is not None:
        raise ScenarioError("sensors.person_seed would make every subject the same person; leave it out (each "
                            "subject is a person drawn from the sensor profile's population)")


def resolve_cohort_path(name_or_path: str | Path) -> Path:
    """A cohort file by path, or by the name of a built-in cohort in ``scenarios/cohorts/``."""
    return resolve_builtin(name_or_path, COHORT_DIR, "cohort")


def load_cohort(name_or_path: str | Path) -> Cohort:
    """Read and validate a cohort TOML file (path or built-in name)."""
    path = resolve_cohort_path(name_or_path)
    return cohort_from_dict(read_toml(path), where=str(path))
