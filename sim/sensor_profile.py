"""Sensor profiles: every parameter of a sensor's depth, tracker and clock models as one data file.

A profile is a TOML file (the built-ins live in ``sim/sensor_profiles/``)::

    [profile]      name, topology ("kinect_v2" or "k4abt"), description
    [depth]        the fields of :class:`sim.depth_noise.DepthNoise`
    [tracker]      the scalar fields of :class:`sim.tracker_noise.TrackerNoise`
                   (view_limb_correlation, hidden_offset_share, view_bone_alignment,
                   noise_bone_alignment, camera_scale_sd, shared_bone_lengths and
                   trunk_turn_sd_deg optional, 0)
    [tracker.groups.<group>]   the fields of :class:`sim.tracker_noise.GroupNoise` per joint group
                               (activity_exponent optional, 0)
    [tracker.arm_bias]   optional: mean_m, person_modes_m and yaw_scaled of :class:`sim.tracker_arm_bias.ArmBias`
    [tracker.trunk_bias] optional: mean_m and person_modes_m of :class:`sim.tracker_trunk_bias.TrunkBias`
                   (shoulder, elbow and wrist joints that follow the arm; nested joint x power x axis)
    [clock]        rate_hz, offset_sigma_s, jitter_sigma_s, drop_probability, drift_ppm
    [population]   optional: how people and sessions vary around the tracker's typical person
                   (:mod:`sim.sensor_population`); without it every simulated person is the typical one
    [provenance]   "<table>.<key>" = where the value came from (which files and statistic, or which
                   published source); every parameter needs one

so that a value without a stated source is an error, not a silent default.
"""

from __future__ import annotations

import dataclasses
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from fusion.errors import BadInputError
from fusion.topology import Topology, topology_by_name
from sim.camera_clock import ClockModel
from sim.depth_noise import DepthNoise
from sim.sensor_population import (
    Population,
    population_from_table,
    population_keys,
    population_tables,
)
from sim.tracker_arm_bias import ArmBias
from sim.tracker_noise import GroupNoise, JointGroup, TrackerNoise
from sim.tracker_trunk_bias import TrunkBias

PROFILE_DIR = Path(__file__).resolve().parent / "sensor_profiles"

_CLOCK_KEYS = ("rate_hz", "offset_sigma_s", "jitter_sigma_s", "drop_probability", "drift_ppm")
_KNOT_BIASES = {"arm_bias": ArmBias, "trunk_bias": TrunkBias}
"""The tracker's optional tables of fitted landmark offsets, and their classes."""
_TRACKER_KEYS = tuple(f.name for f in dataclasses.fields(TrackerNoise) if f.name not in ("groups", *_KNOT_BIASES))
_OPTIONAL_TRACKER_KEYS = ("view_limb_correlation", "hidden_offset_share", "view_bone_alignment",
                          "noise_bone_alignment", "camera_scale_sd", "shared_bone_lengths", "trunk_turn_sd_deg")
"""Tracker keys a profile may leave out (their default, 0, is the model without that part) and that are
written, and need a provenance, only when set."""
_OPTIONAL_GROUP_KEYS = ("activity_exponent",)
"""The same for the keys of a joint group's table."""
_GROUP_KEYS = tuple(f.name for f in dataclasses.fields(GroupNoise))
_DEPTH_KEYS = tuple(f.name for f in dataclasses.fields(DepthNoise))


def parameter_keys(tracker: TrackerNoise | None = None) -> list[str]:
    """Every ``table.key`` a profile must set (and give a provenance for); with ``tracker``, those of its
    optional parts that it sets too."""
    keys = [f"depth.{k}" for k in _DEPTH_KEYS]
    keys += [f"tracker.{k}" for k in _set_keys(_TRACKER_KEYS, _OPTIONAL_TRACKER_KEYS, tracker)]
    keys += [f"tracker.groups.{g.value}.{k}" for g in JointGroup
             for k in _set_keys(_GROUP_KEYS, _OPTIONAL_GROUP_KEYS, None if tracker is None else tracker.groups[g])]
    for name, kind in _KNOT_BIASES.items():
        if tracker is not None and getattr(tracker, name) is not None:
            keys += [f"tracker.{name}.{f.name}" for f in dataclasses.fields(kind)]
    return keys + [f"clock.{k}" for k in _CLOCK_KEYS]


def _set_keys(keys: tuple[str, ...], optional: tuple[str, ...], values: object | None) -> tuple[str, ...]:
    """The ``keys`` of a table, the ``optional`` ones only where ``values`` (the table's object; None: none)
    sets them (nonzero)."""
    return tuple(k for k in keys if k not in optional or (values is not None and getattr(values, k)))


@dataclass(frozen=True)
class SensorProfile:
    """One sensor kind's models with the source of each parameter.

    Attributes
    ----------
    name : str
        Profile name (e.g. ``azure_kinect``).
    topology : Topology
        Joint set its body tracker reports.
    tracker : TrackerNoise
        Skeleton tracker error model.
    depth : DepthNoise
        Depth noise model.
    clock : ClockModel
        Camera clock model (phase and offset drawn per camera).
    provenance : mapping str -> str
        ``"table.key"`` -> source of that value, for every key of :func:`parameter_keys`.
    description : str
        One line on what the profile models.
    population : Population or None
        How the tracker varies between people and sessions (None: one typical person).
    """

    name: str
    topology: Topology
    tracker: TrackerNoise
    depth: DepthNoise
    clock: ClockModel
    provenance: Mapping[str, str]
    description: str = ""
    population: Population | None = None

    def __post_init__(self) -> None:
        if not self.name:
            raise BadInputError("a sensor profile needs a name")
        keys = parameter_keys(self.tracker) + (population_keys(self.population) if self.population is not None else [])
        missing = [k for k in keys if not str(self.provenance.get(k, "")).strip()]
        if missing:
            raise BadInputError(f"profile {self.name!r}: no provenance for {', '.join(missing[:5])}"
                                f"{' ...' if len(missing) > 5 else ''}; add it to [provenance]")
        object.__setattr__(self, "provenance", MappingProxyType(dict(self.provenance)))


def _table(doc: Mapping[str, Any], key: str, where: str) -> dict[str, Any]:
    table = doc.get(key, {})
    if not isinstance(table, dict):
        raise BadInputError(f"{where}: [{key}] must be a table")
    return table


def _build(cls: type, table: dict[str, Any], allowed: tuple[str, ...], where: str,
           optional: tuple[str, ...] = ()) -> Any:
    unknown = [k for k in table if k not in allowed]
    if unknown:
        raise BadInputError(f"{where}: unknown key {unknown[0]!r}; allowed: {', '.join(allowed)}")
    missing = [k for k in allowed if k not in table and k not in optional]
    if missing:
        raise BadInputError(f"{where}: missing key(s) {', '.join(missing)} (a profile sets every parameter)")
    kw = {k: tuple(tuple(x) if isinstance(x, list) else x for x in v) if isinstance(v, list) else v
          for k, v in table.items()}
    try:
        return cls(**kw)
    except TypeError as exc:
        raise BadInputError(f"{where}: {exc}") from None


def profile_from_dict(doc: Mapping[str, Any], where: str = "profile") -> SensorProfile:
    """A :class:`SensorProfile` from a parsed TOML document (see the module docstring)."""
    head = _table(doc, "profile", where)
    tables = ("profile", "depth", "tracker", "clock", "population", "provenance")
    unknown = [k for k in doc if k not in tables]
    if unknown:
        raise BadInputError(f"{where}: unknown table [{unknown[0]}]; allowed: {', '.join(tables)}")
    tracker = dict(_table(doc, "tracker", where))
    groups_table = tracker.pop("groups", {})
    names = [g.value for g in JointGroup]
    if set(groups_table) != set(names):
        raise BadInputError(f"{where}: [tracker.groups] must have exactly the groups {names}, got {sorted(groups_table)}")
    groups = {JointGroup(g): _build(GroupNoise, dict(t), _GROUP_KEYS, f"{where} [tracker.groups.{g}]",
                                    optional=_OPTIONAL_GROUP_KEYS)
              for g, t in groups_table.items()}
    for name, kind in _KNOT_BIASES.items():
        table = tracker.pop(name, None)
        if table is not None:
            if not isinstance(table, dict):
                raise BadInputError(f"{where}: [tracker.{name}] must be a table")
            tracker[name] = _build(kind, dict(table), tuple(f.name for f in dataclasses.fields(kind)),
                                   f"{where} [tracker.{name}]", optional=("yaw_scaled",))
    return SensorProfile(
        name=str(head.get("name", "")),
        topology=topology_by_name(str(head.get("topology", ""))),
        tracker=_build(TrackerNoise, {**tracker, "groups": groups}, _TRACKER_KEYS + ("groups", *_KNOT_BIASES),
                       f"{where} [tracker]", optional=(*_KNOT_BIASES, *_OPTIONAL_TRACKER_KEYS)),
        depth=_build(DepthNoise, dict(_table(doc, "depth", where)), _DEPTH_KEYS, f"{where} [depth]"),
        clock=_build(ClockModel, dict(_table(doc, "clock", where)), _CLOCK_KEYS, f"{where} [clock]"),
        provenance={str(k): str(v) for k, v in _table(doc, "provenance", where).items()},
        description=str(head.get("description", "")),
        population=population_from_table(_table(doc, "population", where), where) if "population" in doc else None,
    )


def builtin_profiles() -> list[str]:
    """Names of the built-in profiles."""
    return sorted(p.stem for p in PROFILE_DIR.glob("*.toml"))


def load_profile(name_or_path: str | Path) -> SensorProfile:
    """A built-in profile by name (``kinect_v2``, ``azure_kinect``, ``orbbec_femto_bolt``,
    ``orbbec_femto_mega``: :func:`builtin_profiles`) or a profile TOML file by path."""
    path = Path(name_or_path)
    if not path.is_file():
        path = PROFILE_DIR / f"{name_or_path}.toml"
        if not path.is_file():
            raise BadInputError(f"sensor profile {str(name_or_path)!r} not found; give a TOML path or a built-in: "
                                f"{', '.join(builtin_profiles())}")
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise BadInputError(f"{path}: not valid TOML: {exc}") from None
    return profile_from_dict(doc, where=str(path))


def _value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (tuple, list)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    return repr(float(v)) if isinstance(v, float) else str(v)


def profile_to_toml(profile: SensorProfile) -> str:
    """The TOML text of a profile; :func:`profile_from_dict` of its parse gives the profile back."""
    lines = ["[profile]", f"name = {_value(profile.name)}", f"topology = {_value(profile.topology.name)}",
             f"description = {_value(profile.description)}", "", "[depth]"]
    lines += [f"{k} = {_value(getattr(profile.depth, k))}" for k in _DEPTH_KEYS]
    tracker = profile.tracker
    lines += ["", "[tracker]"] + [f"{k} = {_value(getattr(tracker, k))}"
                                  for k in _set_keys(_TRACKER_KEYS, _OPTIONAL_TRACKER_KEYS, tracker)]
    for g in JointGroup:
        lines += ["", f"[tracker.groups.{g.value}]"]
        group = tracker.groups[g]
        lines += [f"{k} = {_value(getattr(group, k))}" for k in _set_keys(_GROUP_KEYS, _OPTIONAL_GROUP_KEYS, group)]
    for name in _KNOT_BIASES:
        if (bias := getattr(profile.tracker, name)) is not None:
            lines += ["", f"[tracker.{name}]"]
            lines += [f"{f.name} = {_value(np.asarray(getattr(bias, f.name)).tolist())}" for f in dataclasses.fields(bias)]
    lines += ["", "[clock]"] + [f"{k} = {_value(getattr(profile.clock, k))}" for k in _CLOCK_KEYS]
    keys = parameter_keys(profile.tracker)
    if profile.population is not None:
        lines += ["", *population_tables(profile.population)]
        keys += population_keys(profile.population)
    lines += ["", "[provenance]"] + [f"{_value(k)} = {_value(profile.provenance[k])}" for k in keys]
    return "\n".join(lines) + "\n"
