"""Synthetic stroke patients whose kinematics follow a continuous severity, the FMA-UE score.

Every patient has a latent upper-extremity Fugl-Meyer motor score (FMA-UE, 0-66) of the affected
arm, drawn inside the band of the patient's group (:data:`GROUP_BANDS`). From it:

- **Affected arm.** Each kinematic parameter of :class:`sim.patient_motion.MovementProfile` has a mean
  that is piecewise linear in the FMA-UE score through three anchors: the most impaired end of the
  moderate-severe range at FMA-UE 20, the boundary between the mild and moderate-severe ranges at
  50, and the healthy mid-range at 66 (ranges of ``shared/reference/fma.md``). Subjects scatter
  around the mean with a standard deviation of a quarter of the width of their group's range
  (variability within a group beyond what the severity explains). The item scores follow from the
  kinematics by :mod:`sim.scoring` (the item definitions); draws whose lost item points exceed the
  points the FMA-UE score has lost (66 - score) are redrawn, so the items never contradict the total.
- **Ipsilesional ("unaffected") arm.** Healthy parameters, with movement durations scaled by
  ``1 + (R - 1) * severity / 0.5``: ``R`` is the subject's response time over the healthy mean
  (Pauley et al. 2015: controls 332 +- 73 ms; non-paretic limb after right hemiplegia 474 +- 144 ms,
  after left hemiplegia 402 +- 127 ms), ``severity = (66 - FMA-UE) / 46`` (0 at 66, 1 at 20),
  and a mid-range patient (severity 0.5) is taken to have the study's mean deficit. Deficits grow
  with contralesional severity (Maenza et al. 2020).
- **Slowed initiation between repetitions.** The response-time excess ``max(0, RT - 332 ms)`` is
  added as a pause before every repetition (:attr:`SubjectProfile.initiation_delay`).

Any part of the model can be switched off (:class:`ModelPart`, ``ablate``) to measure what it drives:
an ablated affected-arm parameter takes its healthy value (the FMA-UE 66 anchor) for every patient,
an ablated ipsilesional slowing or initiation pause is none. The random draws are made as without the
ablation, so an ablated cohort holds the same subjects with only that part changed (paired comparisons;
the one exception is a patient whose first draw contradicted the FMA-UE score and was redrawn).

Sources, values and the reasoning of each mapping: ``docs/studies/patient_model.md``.
"""

from __future__ import annotations

import enum
import math
from dataclasses import replace

import numpy as np

from fusion.errors import BadInputError
from sim.patient_motion import (
    FMA_UE_MAX,
    Group,
    Movement,
    MovementProfile,
    Side,
    SubjectProfile,
    sample_profile,
)
from sim.scoring import item_scores

GROUP_BANDS: dict[Group, tuple[float, float]] = {Group.MILD: (50.0, 66.0), Group.MODERATE_SEVERE: (20.0, 49.0)}
"""FMA-UE band of each patient group, points (fma.md: mild >= 50, moderate-severe 20-49)."""

ANCHOR_SCORES = (20.0, 50.0, 66.0)
"""FMA-UE scores of the three anchors of every parameter's mean."""

POSTACUTE_FMA = (40.3, 22.8)
"""Mean and SD of the FMA-UE of the impaired side in a postacute sample (points), used by
:attr:`SeverityDistribution.POSTACUTE`."""

RT_HEALTHY_MS = (332.0, 73.0)
"""Response time of controls, mean and SD, ms (Pauley et al. 2015)."""
RT_NONPARETIC_MS = {Side.RIGHT: (474.0, 144.0), Side.LEFT: (402.0, 127.0)}
"""Response time of the non-paretic limb by paretic side, mean and SD, ms (Pauley et al. 2015)."""
REFERENCE_SEVERITY = 0.5
"""Severity at which a patient shows the mean response-time ratio of the study (assumption)."""
TREMOR_PREVALENCE = 0.15
"""Fraction of patients below FMA-UE 50 with a visible 3-6 Hz, 2-5 mm tremor (fma.md: 10-20 %)."""
MAX_REDRAWS = 50
"""Draws tried before falling back to the mean kinematics (which always agree with the score)."""


class ModelPart(enum.Enum):
    """A part of the patient model that ``ablate`` can switch off."""

    TIMING = "timing"
    """Affected arm's rise time, movement units, time to peak velocity and trial-to-trial variability."""
    ELEVATION = "elevation"
    """Affected arm's peak shoulder elevation."""
    SYNERGY = "synergy"
    """Hand lift's flexor synergy: onset, elbow flexion and abduction."""
    TRUNK = "trunk"
    """Trunk forward displacement, lateral lean, axial rotation and shoulder hiking."""
    IPSILESIONAL = "ipsilesional"
    """Slowing of the ipsilesional ("unaffected") arm."""
    INITIATION = "initiation"
    """Pause before every repetition (slowed initiation)."""


_PART_PARAMETERS: dict[ModelPart, frozenset[str]] = {
    ModelPart.TIMING: frozenset({"rise_time", "n_submovements", "peak_velocity_fraction", "duration_cv"}),
    ModelPart.ELEVATION: frozenset({"peak_elevation"}),
    ModelPart.SYNERGY: frozenset({"synergy_onset", "synergy_elbow_flexion", "synergy_abduction"}),
    ModelPart.TRUNK: frozenset({"trunk_forward", "trunk_lateral", "trunk_rotation", "shoulder_hiking"}),
}
"""Affected-arm parameters of each ablatable part (the other parts act on the ipsilesional side)."""


class SeverityDistribution(enum.Enum):
    """How a patient's FMA-UE score is drawn inside the group's band."""

    UNIFORM = "uniform"
    POSTACUTE = "postacute"


def _degs(*values: float) -> tuple[float, ...]:
    return tuple(math.radians(v) for v in values)


def _cms(*values: float) -> tuple[float, ...]:
    return tuple(v / 100.0 for v in values)


# parameter -> (value at FMA-UE 20, 50, 66), then (mild range width, moderate-severe range width):
# from fma.md's table (worst end of moderate-severe; mean of the moderate-severe best end and the mild
# worst end; healthy mid-range).
_ANCHORS: dict[Movement, dict[str, tuple[tuple[float, float, float], tuple[float, float]]]] = {
    Movement.HAND_LIFT: {
        "rise_time": ((5.0, 2.25, 1.2), (1.2, 3.0)),
        "peak_elevation": (_degs(40.0, 77.5, 90.0), _degs(20.0, 40.0)),
        "synergy_onset": (_degs(0.0, 22.5, 70.0), _degs(25.0, 0.0)),
        "synergy_elbow_flexion": (_degs(70.0, 30.0, 5.0), _degs(20.0, 40.0)),
        "synergy_abduction": (_degs(45.0, 22.5, 5.0), _degs(15.0, 25.0)),
    },
    Movement.SALUTE: {
        "rise_time": ((6.0, 2.75, 1.3), (1.5, 3.5)),
        "peak_elevation": (_degs(40.0, 77.5, 95.0), _degs(20.0, 40.0)),
    },
}
_COMMON: dict[str, tuple[tuple[float, float, float], tuple[float, float]]] = {
    "n_submovements": ((8.0, 3.5, 1.0), (2.0, 5.0)),
    "peak_velocity_fraction": ((0.25, 0.35, 0.45), (0.10, 0.15)),
    "trunk_forward": (_cms(15.0, 8.0, 2.5), _cms(5.0, 7.0)),
    "trunk_lateral": (_degs(15.0, 6.5, 1.5), _degs(5.0, 10.0)),
    "trunk_rotation": (_degs(15.0, 6.5, 1.5), _degs(5.0, 10.0)),
    "shoulder_hiking": (_cms(4.0, 2.0, 0.5), _cms(1.0, 2.0)),
    "duration_cv": ((0.30, 0.175, 0.075), (0.10, 0.15)),
}
_LOWER = {"n_submovements": 1, "peak_velocity_fraction": 0.1, "duration_cv": 0.0}
_UPPER = {"n_submovements": 12, "peak_velocity_fraction": 0.9, "duration_cv": 0.5, "trunk_forward": 0.25,
          "shoulder_hiking": 0.06, "peak_elevation": math.radians(150.0), "rise_time": 20.0,
          "trunk_lateral": math.radians(30.0), "trunk_rotation": math.radians(30.0)}


def severity_fraction(fma_ue: float) -> float:
    """Impairment in [0, 1]: 0 at FMA-UE 66, 1 at 20 and below."""
    return float(np.clip((FMA_UE_MAX - fma_ue) / (FMA_UE_MAX - ANCHOR_SCORES[0]), 0.0, 1.0))


def parameter_mean(anchors: tuple[float, float, float], fma_ue: float) -> float:
    """Piecewise-linear mean of a parameter at ``fma_ue`` through its values at :data:`ANCHOR_SCORES`."""
    return float(np.interp(fma_ue, ANCHOR_SCORES, anchors))


def draw_fma(group: Group, distribution: SeverityDistribution, *, rng: np.random.Generator) -> float:
    """An FMA-UE score (points, integer-valued) inside ``group``'s band.

    UNIFORM draws uniformly over the band; POSTACUTE draws from the normal of
    :data:`POSTACUTE_FMA` truncated to the band (rejection sampling).
    """
    if group not in GROUP_BANDS:
        raise BadInputError(f"group must be a patient group ({', '.join(g.name for g in GROUP_BANDS)}), got {group!r}")
    lo, hi = GROUP_BANDS[group]
    if distribution is SeverityDistribution.UNIFORM:
        return float(rng.integers(int(lo), int(hi) + 1))
    if distribution is SeverityDistribution.POSTACUTE:
        for _ in range(10_000):
            x = round(float(rng.normal(*POSTACUTE_FMA)))
            if lo <= x <= hi:
                return float(x)
        return float(round(0.5 * (lo + hi)))
    raise BadInputError(f"distribution must be a SeverityDistribution, got {distribution!r}")


def _affected(movement: Movement, fma_ue: float, tremor: tuple[float, float], noise: bool,
              rng: np.random.Generator, healthy: frozenset[str] = frozenset()) -> MovementProfile:
    """The affected arm's profile of ``movement`` at ``fma_ue``; ``noise`` False gives the means.

    Parameters named in ``healthy`` take their FMA-UE 66 anchor (their scatter is drawn and discarded).
    """
    band = 0 if fma_ue >= GROUP_BANDS[Group.MILD][0] else 1
    values = {}
    for name, (anchors, widths) in {**_COMMON, **_ANCHORS[movement]}.items():
        scatter = rng.normal(0.0, 0.25 * widths[band]) if noise else 0.0
        x = anchors[-1] if name in healthy else parameter_mean(anchors, fma_ue) + scatter
        values[name] = float(np.clip(x, _LOWER.get(name, 0.0), _UPPER.get(name, math.radians(80.0))))
    values["n_submovements"] = int(round(values["n_submovements"]))
    values["rise_time"] = max(values["rise_time"], 0.5)
    values["peak_elevation"] = max(values["peak_elevation"], math.radians(10.0))
    if movement is Movement.SALUTE:  # the salute is itself the flexor synergy (see MovementProfile)
        values.update(synergy_onset=0.0, synergy_elbow_flexion=0.0, synergy_abduction=0.0)
    pace = float(rng.uniform(0.8, 1.1)) if noise else 0.95
    return MovementProfile(tremor_frequency=tremor[0], tremor_amplitude=tremor[1], hold_time=1.0,
                           return_time=values["rise_time"] * pace, **values)


def _response_ratio(affected_side: Side, rng: np.random.Generator) -> float:
    """A patient's non-paretic response time over the healthy mean, >= 1."""
    rt = float(rng.normal(*RT_NONPARETIC_MS[affected_side]))
    return max(1.0, rt / RT_HEALTHY_MS[0])


def sample_patient(
    group: Group,
    *,
    rng: np.random.Generator,
    distribution: SeverityDistribution = SeverityDistribution.UNIFORM,
    fma_ue: float | None = None,
    affected_side: Side | None = None,
    ablate: frozenset[ModelPart] = frozenset(),
) -> SubjectProfile:
    """Draw a patient of ``group`` (MILD or MODERATE_SEVERE) from the literature-based model.

    Parameters
    ----------
    group : Group
    rng : numpy.random.Generator
    distribution : SeverityDistribution
        How the FMA-UE score is drawn when ``fma_ue`` is None.
    fma_ue : float, optional
        The affected arm's FMA-UE score, points in the group's band; drawn when None.
    affected_side : Side, optional
        Paretic side; drawn at random when None.
    ablate : set of ModelPart
        Parts of the model switched off (see the module docstring); the draws are unchanged.

    Returns
    -------
    SubjectProfile
        With ``fma_ue`` and ``initiation_delay`` set; the module docstring gives the model.
        The item scores of the affected side (:func:`sim.scoring.item_scores`) lose at most
        ``66 - fma_ue`` points; the ipsilesional side scores full marks.
    """
    if group not in GROUP_BANDS:
        raise BadInputError(f"group must be Group.MILD or Group.MODERATE_SEVERE, got {group!r}")
    if not isinstance(distribution, SeverityDistribution):
        raise BadInputError(f"distribution must be a SeverityDistribution, got {distribution!r}")
    if affected_side is not None and not isinstance(affected_side, Side):
        raise BadInputError(f"affected_side must be Side.LEFT, Side.RIGHT or None, got {affected_side!r}")
    bad = [p for p in ablate if not isinstance(p, ModelPart)]
    if bad:
        raise BadInputError(f"ablate must hold ModelPart values ({', '.join(p.value for p in ModelPart)}), got {bad[0]!r}")
    lo, hi = GROUP_BANDS[group]
    if fma_ue is None:
        fma_ue = draw_fma(group, distribution, rng=rng)
    elif isinstance(fma_ue, bool) or not isinstance(fma_ue, (int, float)) or not lo <= fma_ue <= hi:
        raise BadInputError(f"fma_ue of a {group.value} patient must be in [{lo:g}, {hi:g}] points, got {fma_ue!r}")
    fma_ue = float(fma_ue)
    side = affected_side or (Side.LEFT if rng.random() < 0.5 else Side.RIGHT)
    other = Side.LEFT if side is Side.RIGHT else Side.RIGHT

    tremor = (0.0, 0.0)
    if fma_ue < GROUP_BANDS[Group.MILD][0] and rng.random() < TREMOR_PREVALENCE:
        tremor = (float(rng.uniform(3.0, 6.0)), float(rng.uniform(0.002, 0.005)))
    ratio = _response_ratio(side, rng)
    slowing = 1.0 + (ratio - 1.0) * severity_fraction(fma_ue) / REFERENCE_SEVERITY
    delay = min(5.0, (ratio - 1.0) * RT_HEALTHY_MS[0] / 1000.0)
    if ModelPart.IPSILESIONAL in ablate:
        slowing = 1.0
    if ModelPart.INITIATION in ablate:
        delay = 0.0
    healthy_parameters = frozenset().union(*(_PART_PARAMETERS.get(p, frozenset()) for p in ablate))
    healthy = sample_profile(Group.HEALTHY, rng=rng)

    def ipsilesional(movement: Movement) -> MovementProfile:
        p = healthy.movement(movement, other)
        return replace(p, rise_time=min(20.0, p.rise_time * slowing), return_time=min(20.0, p.return_time * slowing))

    lost_allowed = FMA_UE_MAX - fma_ue
    profile = None
    for attempt in range(MAX_REDRAWS + 1):
        noise = attempt < MAX_REDRAWS
        moves = {m: _affected(m, fma_ue, tremor, noise, rng, healthy_parameters)
                 for m in (Movement.SALUTE, Movement.HAND_LIFT)}
        sides = {side: moves, other: {m: ipsilesional(m) for m in moves}}
        profile = SubjectProfile(
            group=group, affected_side=side,
            salute_left=sides[Side.LEFT][Movement.SALUTE], salute_right=sides[Side.RIGHT][Movement.SALUTE],
            hand_lift_left=sides[Side.LEFT][Movement.HAND_LIFT],
            hand_lift_right=sides[Side.RIGHT][Movement.HAND_LIFT],
            fma_ue=fma_ue, initiation_delay=delay)
        if 14 - item_scores(profile, side).total <= lost_allowed + 1e-9:
            break
    return profile


class PatientModel(enum.Enum):
    """Which generator draws a cohort's patients."""

    RANGES = "ranges"
    """Group ranges of fma.md, unaffected side 5-25 % slower (:func:`sim.patient_motion.sample_profile`)."""
    LITERATURE = "literature"
    """Continuous FMA-UE severity and the sourced mappings of this module (:func:`sample_patient`)."""


def draw_subject(group: Group, model: PatientModel, distribution: SeverityDistribution, *,
                 rng: np.random.Generator, ablate: frozenset[ModelPart] = frozenset()) -> SubjectProfile:
    """A subject of ``group``: healthy subjects always from the healthy ranges, patients by ``model``.

    ``ablate`` (literature model only) switches parts of the patient model off (:func:`sample_patient`).
    """
    if not isinstance(model, PatientModel):
        raise BadInputError(f"model must be a PatientModel ({', '.join(m.value for m in PatientModel)}), got {model!r}")
    if ablate and model is not PatientModel.LITERATURE:
        raise BadInputError(f"ablate needs the literature patient model, got model {model.value!r}")
    if group is Group.HEALTHY or model is PatientModel.RANGES:
        return sample_profile(group, rng=rng)
    return sample_patient(group, rng=rng, distribution=distribution, ablate=frozenset(ablate))
