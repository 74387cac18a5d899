"""Fugl-Meyer item scores that a subject profile's kinematics earn (the synthetic clinician).

Rules, following ``shared/reference/fma.md`` and the way :mod:`sim.motions` turns a profile into
motion (0 = cannot be performed, 1 = performed partly, 2 = performed faultlessly):

Hand lift (item A.III), from the hand-lift profile of the side:
    The synergy (elbow flexion, abduction) *appears* when ``synergy_onset`` lies below
    ``peak_elevation`` and elbow flexion or abduction at the top exceeds 10 degrees.

    - 0: peak flexion below 45 degrees, or the synergy appears immediately (onset below 5 degrees);
    - 2: peak flexion at least 85 degrees and no synergy;
    - 1: otherwise (the synergy appears during the movement, or the range is incomplete).

Salute (item A.II, six components), from the salute profile of the side:
    :func:`sim.motions.salute` scales every arm component (shoulder-girdle retraction and
    elevation, abduction, external rotation, elbow flexion, forearm supination) by the fraction
    ``f = min(1, peak_elevation / 90 degrees)`` of the full salute.

    - shoulder abduction: 2 at 90 degrees or more, 1 from 30 degrees, else 0;
    - each other component: 2 when ``f >= 0.9``, 1 when ``f >= 1/3``, else 0.

Healthy profiles (fma.md ranges) earn full scores: 12 for the salute, 2 for the hand lift.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from fusion.errors import BadInputError
from sim.patient_motion import Movement, MovementProfile, Side, SubjectProfile

LIFT_FULL_DEG = 85.0
"""Hand lift: peak shoulder flexion that counts as the full 90 degrees."""
LIFT_MIN_DEG = 45.0
"""Hand lift: below this peak flexion the item cannot be performed."""
SYNERGY_VISIBLE_DEG = 10.0
"""Hand lift: elbow flexion or abduction above this at the top is a visible synergy."""
SYNERGY_IMMEDIATE_DEG = 5.0
"""Hand lift: a synergy onset below this shoulder flexion is immediate."""
SALUTE_FULL_DEG = 90.0
"""Salute: abduction of the full salute (the other components reach their full range there)."""
SALUTE_NEAR_FULL = 0.9
"""Salute: fraction of the full salute that earns 2 on a component other than abduction."""
SALUTE_PARTIAL = 1.0 / 3.0
"""Salute: fraction of the full salute that earns 1 (abduction: 30 degrees)."""

_TOLERANCE_DEG = 1e-6


@dataclass(frozen=True)
class ItemScores:
    """Fugl-Meyer item scores of one side, each 0, 1 or 2.

    Attributes
    ----------
    side : Side
    shoulder_retraction, shoulder_elevation, shoulder_abduction, shoulder_external_rotation,
    elbow_flexion, forearm_supination : int
        The salute's six components.
    hand_lift : int
    """

    side: Side
    shoulder_retraction: int
    shoulder_elevation: int
    shoulder_abduction: int
    shoulder_external_rotation: int
    elbow_flexion: int
    forearm_supination: int
    hand_lift: int

    def __post_init__(self) -> None:
        if not isinstance(self.side, Side):
            raise BadInputError(f"side must be Side.LEFT or Side.RIGHT, got {self.side!r}")
        for name, value in asdict(self).items():
            if name != "side" and (isinstance(value, bool) or value not in (0, 1, 2)):
                raise BadInputError(f"{name} must be a score 0, 1 or 2, got {value!r}")

    @property
    def salute(self) -> int:
        """Sum of the salute's six components, 0-12."""
        return (self.shoulder_retraction + self.shoulder_elevation + self.shoulder_abduction
                + self.shoulder_external_rotation + self.elbow_flexion + self.forearm_supination)

    @property
    def total(self) -> int:
        """Salute plus hand lift, 0-14."""
        return self.salute + self.hand_lift

    def to_dict(self) -> dict[str, int | str]:
        """JSON-able form: side by name, every component, ``salute`` and ``total``."""
        doc: dict[str, int | str] = {k: v for k, v in asdict(self).items() if k != "side"}
        return {"side": self.side.name.lower(), **doc, "salute": self.salute, "total": self.total}


def hand_lift_score(profile: MovementProfile) -> int:
    """Item A.III score (0, 1, 2) of a hand-lift profile; rules in the module docstring."""
    peak = math.degrees(profile.peak_elevation)
    onset = math.degrees(profile.synergy_onset)
    largest = max(math.degrees(profile.synergy_elbow_flexion), math.degrees(profile.synergy_abduction))
    synergy = onset < peak and largest > SYNERGY_VISIBLE_DEG + _TOLERANCE_DEG
    if peak < LIFT_MIN_DEG or (synergy and onset < SYNERGY_IMMEDIATE_DEG):
        return 0
    if peak >= LIFT_FULL_DEG - _TOLERANCE_DEG and not synergy:
        return 2
    return 1


def item_scores(profile: SubjectProfile, side: Side) -> ItemScores:
    """The item scores ``profile``'s kinematics earn on ``side``.

    Parameters
    ----------
    profile : SubjectProfile
    side : Side

    Returns
    -------
    ItemScores
        Salute components and hand lift by the rules of the module docstring.
    """
    if not isinstance(profile, SubjectProfile):
        raise BadInputError(f"profile must be a SubjectProfile, got {type(profile).__name__}")
    if not isinstance(side, Side):
        raise BadInputError(f"side must be Side.LEFT or Side.RIGHT, got {side!r}")
    peak = math.degrees(profile.movement(Movement.SALUTE, side).peak_elevation)
    fraction = min(1.0, peak / SALUTE_FULL_DEG) + _TOLERANCE_DEG / SALUTE_FULL_DEG
    component = 2 if fraction >= SALUTE_NEAR_FULL else 1 if fraction >= SALUTE_PARTIAL else 0
    abduction = 2 if peak >= SALUTE_FULL_DEG - _TOLERANCE_DEG else 1 if fraction >= SALUTE_PARTIAL else 0
    return ItemScores(
        side=side,
        shoulder_retraction=component,
        shoulder_elevation=component,
        shoulder_abduction=abduction,
        shoulder_external_rotation=component,
        elbow_flexion=component,
        forearm_supination=component,
        hand_lift=hand_lift_score(profile.movement(Movement.HAND_LIFT, side)),
    )
