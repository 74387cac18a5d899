"""The labels of a cohort dataset, defined once: every file ``mocap-bench cohort`` and the cohort
exports write names groups, sides, items and scores by these tables, with the units of every number.

- Group: :class:`sim.patient_motion.Group` values (``healthy``, ``mild``, ``moderate_severe``), with
  the FMA-UE band of each patient group (:data:`sim.patients.GROUP_BANDS`).
- Side: ``left`` / ``right`` in every file (:data:`SIDE_NAMES`); the simulator's own
  :class:`sim.patient_motion.Side` values are internal and never written.
- Item: :class:`Item`. Each item has a raw measure and a score 0/1/2 that the documented rule of
  :data:`ITEM_RULES` maps it to (:func:`item_score`).
- FMA-UE: the affected arm's upper-extremity Fugl-Meyer motor score, 0-66 points.

The same tables render the vocabulary of ``docs/reference/formats/datasets.md`` (a test keeps them equal).
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from fusion.errors import BadInputError
from sim.anthropometry import Build
from sim.patient_motion import FMA_UE_MAX, Group, Side
from sim.patients import GROUP_BANDS

SIDE_NAMES: Mapping[Side, str] = {Side.LEFT: "left", Side.RIGHT: "right"}
"""The name of each side in every file."""

MISSING = "n/a"
"""A value that does not apply or is unknown, in TSV / CSV / C3D / TRC labels (BIDS convention)."""

SALUTE_COMPONENTS = ("shoulder_retraction", "shoulder_elevation", "shoulder_abduction",
                     "shoulder_external_rotation", "elbow_flexion", "forearm_supination")
"""The salute's six components (:class:`sim.scoring.ItemScores`), each 0/1/2 points."""


class Item(enum.Enum):
    """A Fugl-Meyer item of the protocol, named as in every file."""

    SALUTE = "salute"
    HAND_LIFT = "hand_lift"


@dataclass(frozen=True)
class ItemRule:
    """How one item's raw measure maps to its score 0/1/2.

    Attributes
    ----------
    raw : str
        What the raw measure is.
    raw_max : int
        The raw measure's range is 0 to ``raw_max`` points.
    rule : str
        The mapping, in words.
    two_at, zero_at_most : int
        Score 2 when the raw measure is at least ``two_at``, 0 when it is at most ``zero_at_most``, else 1.
    """

    raw: str
    raw_max: int
    rule: str
    two_at: int
    zero_at_most: int


ITEM_RULES: Mapping[Item, ItemRule] = {
    Item.SALUTE: ItemRule("sum of the six component scores (item A.II)", 12,
                          "2 when all six components score 2 (raw 12), 0 when raw <= 4, else 1", 12, 4),
    Item.HAND_LIFT: ItemRule("the item's own score (item A.III)", 2, "the score is the raw measure", 2, 0),
}
"""The rule of every item (:func:`item_score`)."""


def item_score(item: Item, raw: int) -> int:
    """Score 0/1/2 of ``item`` from its raw measure (points, ``0..ITEM_RULES[item].raw_max``)."""
    rule = ITEM_RULES[Item(item)]
    if isinstance(raw, bool) or not isinstance(raw, int) or not 0 <= raw <= rule.raw_max:
        raise BadInputError(f"the raw {Item(item).value} measure must be an integer 0-{rule.raw_max}, got {raw!r}")
    return 2 if raw >= rule.two_at else 0 if raw <= rule.zero_at_most else 1


def item_raw(item: Item, side_scores: Mapping[str, Any]) -> int:
    """Raw measure of ``item`` from one side's ``item_scores`` entry of ``manifest.json``."""
    if Item(item) is Item.SALUTE:
        return int(sum(int(side_scores[k]) for k in SALUTE_COMPONENTS))
    return int(side_scores["hand_lift"])


def severity_bands() -> dict[str, tuple[float, float] | None]:
    """FMA-UE band [points] of each group by name (None for healthy: not modelled)."""
    return {g.value: GROUP_BANDS.get(g) for g in Group}


class Unit(enum.Enum):
    """Units of the numbers in the files (BIDS / SI spelling)."""

    METRE = "m"
    SECOND = "s"
    RADIAN = "rad"
    HERTZ = "Hz"
    POINTS = "points"
    COUNT = "count"
    RATIO = "1"
    NONE = ""


PROFILE_UNITS: Mapping[str, Unit] = {
    "rise_time": Unit.SECOND, "n_submovements": Unit.COUNT, "peak_velocity_fraction": Unit.RATIO,
    "peak_elevation": Unit.RADIAN, "synergy_onset": Unit.RADIAN, "synergy_elbow_flexion": Unit.RADIAN,
    "synergy_abduction": Unit.RADIAN, "trunk_forward": Unit.METRE, "trunk_lateral": Unit.RADIAN,
    "trunk_rotation": Unit.RADIAN, "shoulder_hiking": Unit.METRE, "tremor_frequency": Unit.HERTZ,
    "tremor_amplitude": Unit.METRE, "duration_cv": Unit.RATIO, "hold_time": Unit.SECOND, "return_time": Unit.SECOND,
}
"""Unit of every :class:`sim.patient_motion.MovementProfile` parameter (``truth.profile`` of the manifest)."""


@dataclass(frozen=True)
class Column:
    """One column of ``participants.tsv`` (and the label set of the exports)."""

    name: str
    unit: Unit
    description: str
    levels: Mapping[str, str] | None = None


_ANTHRO = ("trunk", "upper_arm", "forearm", "hand", "thigh", "shank", "foot", "girth")


def _item_columns() -> list[Column]:
    out = []
    for item in Item:
        rule = ITEM_RULES[item]
        for side in SIDE_NAMES.values():
            out.append(Column(f"{item.value}_{side}_score", Unit.POINTS,
                              f"{item.value} item score of the {side} arm, 0/1/2: {rule.rule}",
                              {"0": "cannot be performed", "1": "performed partly", "2": "performed faultlessly"}))
            out.append(Column(f"{item.value}_{side}_raw", Unit.POINTS,
                              f"raw {item.value} measure of the {side} arm, 0-{rule.raw_max}: {rule.raw}"))
    return out


PARTICIPANT_COLUMNS: tuple[Column, ...] = (
    Column("participant_id", Unit.NONE, "subject id, sub-<number>"),
    Column("group", Unit.NONE, "clinical group", {
        g: "no stroke" if band is None else f"stroke, FMA-UE {band[0]:g}-{band[1]:g}"
        for g, band in severity_bands().items()}),
    Column("affected_side", Unit.NONE, "paretic arm (n/a for a healthy subject)",
           {s: f"{s} arm" for s in SIDE_NAMES.values()}),
    Column("fma_ue", Unit.POINTS, f"upper-extremity Fugl-Meyer motor score of the affected arm, 0-{FMA_UE_MAX} "
                                  "(n/a: healthy, or not modelled by the ranges patient model)"),
    *_item_columns(),
    Column("height_m", Unit.METRE, "stature"),
    Column("build", Unit.NONE, "body build (scales girths)", {b.value: b.value for b in Build}),
    *(Column(f"{name}_scale", Unit.RATIO, f"{name} length multiplier (1 = standard proportion of the height)"
             if name != "girth" else "girth multiplier on top of the build") for name in _ANTHRO),
    Column("seed", Unit.NONE, "the cohort seed; the subject's own seed is its SeedSequence child (subject order)"),
)
"""Every column of ``participants.tsv``, in order."""


def participant_row(subject: Mapping[str, Any], seed: int) -> dict[str, str]:
    """One ``participants.tsv`` row (text, :data:`MISSING` for none) of a ``manifest.json`` subject entry."""
    anthro = subject["anthropometry"]
    row = {"participant_id": subject["id"], "group": subject["group"],
           "affected_side": subject["affected_side"] or MISSING,
           "fma_ue": MISSING if subject["fma_ue"] is None else f"{subject['fma_ue']:g}"}
    for item in Item:
        for side in SIDE_NAMES.values():
            raw = item_raw(item, subject["item_scores"][side])
            row[f"{item.value}_{side}_score"] = str(item_score(item, raw))
            row[f"{item.value}_{side}_raw"] = str(raw)
    row["height_m"] = f"{anthro['height_m']:.4f}"
    row["build"] = str(anthro["build"])
    row.update({f"{name}_scale": f"{anthro[name]:.4f}" for name in _ANTHRO})
    row["seed"] = str(seed)
    return row


def vocabulary_markdown() -> str:
    """The vocabulary as Markdown tables: the columns of ``participants.tsv`` and the item rules."""
    lines = ["| column | unit | description | levels |", "|---|---|---|---|"]
    for c in PARTICIPANT_COLUMNS:
        levels = "; ".join(f"`{k}` {v}" for k, v in c.levels.items()) if c.levels else ""
        lines.append(f"| `{c.name}` | {c.unit.value or '-'} | {c.description} | {levels} |")
    lines += ["", "| item | raw measure | raw range [points] | rule |", "|---|---|---|---|"]
    for item, rule in ITEM_RULES.items():
        lines.append(f"| `{item.value}` | {rule.raw} | 0-{rule.raw_max} | {rule.rule} |")
    return "\n".join(lines) + "\n"
