"""Refine a fitted profile on replicas of the fitting recordings: a simulation-based fit.

The analytic fit (:mod:`scenarios.sensors.fit`) reads each parameter off one statistic as if the
errors were the only thing in the data. On a replica (:mod:`scenarios.sensors.replica`: the recording's fused
motion retargeted onto the humanoid, its cameras at the calibrated places) the simulated tracker sees
the same motion from the same places, so the statistics of real and simulated recordings can be
matched directly. Each replica is simulated once with an ideal tracker
(:mod:`scenarios.sensors.replica_case`); the tracker model is then re-run on its true joints with trial
profiles, and the re-tracked recording goes through the same statistics as the real one
(:func:`scenarios.sensors.fit.measure`, calibrated afresh from the body at every iteration, as the real
recording was calibrated from its own tracker: poses calibrated once from the starting profile carry
that profile's errors, and the steady cross-camera residual measured through them overstates the
trial's, so the view bias settled 1.4-1.9 times too small).

What each statistic fixes, by fixed-point iteration (each update damped by :data:`DAMPING`). The ratios
real / simulated are pooled robustly (:func:`pooled_ratio`): per statistic (or joint) the median over the
recordings of the log-ratio, then the mean over the statistics. One recording unlike the others (a
quieter tracker, a hand never at full confidence) then leaves the update where the others put it,
which a geometric mean over every recording does not; with one or two recordings the two are the same.

- per joint group, the white jitter and the wobble: the ratios real / simulated of the second-difference
  jitter less the motion's own (the ideal tracker's, in quadrature) and of the fluctuating
  cross-camera residual (over every joint of the group), solved for both sizes (the jitter's variance goes as ``6 w^2 + q c^2``, the
  residual's as ``w^2 + c^2``; the wobble time constant stays that of the analytic fit). One-camera
  recordings have no residual: both sizes are scaled by the jitter ratio, keeping the white share of
  the analytic fit (its lag-one autocorrelation);
- per group, the view bias: the steady cross-camera residual of its joints (kept without residuals);
  the outlier rate: the share of second differences over 5 cm beyond the motion's own (where that
  statistic is measured on the group's own joints: the hips' is the pelvis's, and their rate is kept);
- the bone rigidity of the elbows' and wrists' groups: the upper-arm and forearm length spreads
  (``1 - r`` scales them); the other groups take their mean (no bone of theirs is measured); with a
  body scale (a template tracker) the spreads fix its size instead, and the rigidity is kept;
- the speed dependence (one reference speed): a grid search, each value refined as above, keeping the
  one with the smallest loss over the acceptance statistics (:func:`loss`: per statistic the median
  recording's squared log-ratio; the jitter of the real tracker grows with the motion from recording
  to recording);
- the activity exponent (how every camera session's view bias, jitter and wobble grow with its activity,
  the mean joint speed, taken relative to the recordings' median activity and followed only over their
  range of activities): moved each iteration by the Theil-Sen slope of the recordings' mean log-ratio
  real / simulated of those error statistics against their log activity (:func:`activity_slope`; three
  recordings or more), which the pooled updates above cannot remove;
- per group, the low-confidence shares of hidden and of visible joints: least squares over the
  recordings of ``real low share = hidden share * p_hidden + (1 - hidden share) * p_visible``, the
  hidden share of each recording taken from its replica's visibility;
- when asked, the model's optional parts (:mod:`scenarios.sensors.fit_structure`: the view bias shared
  along a limb, guessed offsets of occluded joints reported confident, ...). With the trunk's turn, which
  a statistic over one person's sessions fixes, each person's replicas are re-tracked as one simulated
  person, each replica a session of its own (:func:`~scenarios.sensors.replica_case.person_seeds`);
  otherwise every replica is re-tracked with the same seed.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from joblib import Parallel, delayed

from fusion.arrays import nanmedian
from fusion.errors import BadInputError
from fusion.merge.sensor_stats import SensorStats
from scenarios.sensors.fit import STATS_OF_GROUP
from scenarios.sensors.fit_confidence import fit_confidence
from scenarios.sensors.fit_structure import (
    check_parts,
    shares_people,
    structure_keys,
    with_structure,
)
from scenarios.sensors.replica_case import (
    Poses,
    ReplicaCase,
    person_seeds,
    retracked_or_none,
)
from scenarios.sensors.replica_ratios import (
    activity_trend,
    jitter_ratio,
    measured_on_own_joints,
)
from scenarios.sensors.sim_to_real import compare_stats
from sim.sensor_profile import SensorProfile
from sim.tracker_noise import JointGroup, joint_groups

DAMPING = 0.8
"""Exponent applied to every multiplicative update (below 1: damped)."""

SPEED_GRID_M_S = (0.0, 0.2, 0.1, 0.05, 0.025)
"""Reference speeds tried [m/s]; 0 is no speed dependence."""


def pooled_ratio(ratios: np.ndarray) -> float:
    """Ratio real / simulated pooled over the recordings, robust to one unlike recording: of ``ratios``
    (R, K), statistic ``k`` on recording ``r`` (entries not finite or not positive are missing), ``exp`` of
    the mean over the statistics of the median over the recordings of the log-ratio; 1 when nothing is
    left. With one or two recordings (none missing) the geometric mean of all."""
    r = np.asarray(ratios, dtype=np.float64)
    usable = np.isfinite(r) & (r > 0)
    logs = np.where(usable, np.log(np.where(usable, r, 1.0)), np.nan)
    per_stat = nanmedian(logs.reshape(len(logs), -1), axis=0)
    per_stat = per_stat[np.isfinite(per_stat)]
    return float(np.exp(per_stat.mean())) if per_stat.size else 1.0


def _group_ratio(cases, sims, g: JointGroup, pick) -> float:
    """Pooled ratio (:func:`pooled_ratio`) of ``pick(case, sim, k)`` over the statistics ``k`` of group ``g``
    (missing where the recording's joint set lacks ``k``)."""
    return pooled_ratio(np.array([[pick(c, s, k) if k in c.real.jitter_mm else np.nan for k in STATS_OF_GROUP[g]]
                                  for c, s in zip(cases, sims)]))


def _joint_ratio(cases, sims, cols: np.ndarray, attribute: str) -> float:
    """Pooled ratio (:func:`pooled_ratio`) real / simulated of the per-joint statistic ``attribute``
    over the joints ``cols``, from the recordings that have it."""
    ratios = [getattr(c.real, attribute)[cols] / getattr(s, attribute)[cols] for c, s in zip(cases, sims)
              if getattr(c.real, attribute).size and getattr(s, attribute).size]
    return pooled_ratio(np.array(ratios)) if ratios else 1.0


def loss(cases: Sequence[ReplicaCase], sims: Sequence[SensorStats]) -> float:
    """Mismatch of the acceptance statistics (:func:`scenarios.sensors.sim_to_real.compare_stats`), robust to one
    unlike recording.

    Each recording's term of a statistic is its squared log-ratio simulated / real (confidence shares:
    the difference in points / 10, squared); per statistic the median term over the recordings that
    have it, times their number, summed over the statistics. With one or two recordings this is the
    sum over the recordings of every term.
    """
    terms: dict[str, list[float]] = {}
    for c, s in zip(cases, sims):
        for row in compare_stats(c.real, s):
            if row.by_points:
                term = ((row.sim - row.real) / 0.1) ** 2
            else:
                term = np.log(row.ratio) ** 2 if np.isfinite(row.ratio) and row.ratio > 0 else np.nan
            terms.setdefault(row.statistic, []).append(term)
    total = 0.0
    for values in terms.values():
        v = np.array(values, dtype=np.float64)
        v = v[np.isfinite(v)]
        total += v.size * float(np.median(v)) if v.size else 0.0
    return float(total)


def _split(w: float, c: float, r_jit: float, r_fl: float | None, q: float) -> tuple[float, float]:
    """White and wobble sizes that scale the jitter by ``r_jit`` and the fluctuating residual by ``r_fl``.

    The jitter's variance goes as ``6 w^2 + q c^2`` and the residual's as ``w^2 + c^2`` (``q`` the
    second-difference variance factor of the wobble), each times a gain the current simulation fixes.
    ``r_fl=None`` (one camera: no residual): both scaled by ``r_jit``, keeping the white share.
    """
    if r_fl is None:
        return w * r_jit, c * r_jit
    jit, fl = r_jit ** 2 * (6 * w * w + q * c * c), r_fl ** 2 * (w * w + c * c)
    white = float(np.clip((jit - q * fl) / (6 - q), 0.0, fl))
    return float(np.sqrt(white)), float(np.sqrt(fl - white))


def _damped(old: float, new: float) -> float:
    return float(old * (new / old) ** DAMPING) if old > 0 and new > 0 else new


_BONE_OF_GROUP = {JointGroup.LIMB: "upper_arm", JointGroup.HAND: "forearm"}
"""The bone (ending at a joint of the group) whose length spread fixes each group's rigidity."""


def _error_log_ratio(case: ReplicaCase, sim: SensorStats, jitter: bool) -> float:
    """Mean log-ratio real / simulated of one recording's error statistics: per joint the steady and the
    fluctuating cross-camera residual and, with ``jitter``, per group the jitter beyond the motion's own."""
    logs = []
    if jitter:
        for g in JointGroup:
            logs.extend(np.log(jitter_ratio(case, sim, k)) for k in STATS_OF_GROUP[g] if k in case.real.jitter_mm)
    for attribute in ("residual_static_joint_mm", "residual_fluct_joint_mm"):
        real, simulated = getattr(case.real, attribute), getattr(sim, attribute)
        if real.size and simulated.size:
            logs.extend(np.log(real / simulated))
    logs = np.asarray(logs, dtype=np.float64)
    return float(np.mean(logs[np.isfinite(logs)])) if np.isfinite(logs).any() else np.nan


def activity_slope(cases: Sequence[ReplicaCase], sims: Sequence[SensorStats], *, jitter: bool = True) -> float | None:
    """Theil-Sen slope of the recordings' mean log-ratio real / simulated of their error statistics
    (:func:`_error_log_ratio`; without the jitter when the groups' own growth takes it) against their log
    activity: how much the activity exponent falls short (:func:`~scenarios.sensors.replica_ratios.activity_trend`)."""
    return activity_trend(cases, [_error_log_ratio(c, s, jitter) for c, s in zip(cases, sims)])


def update_profile(profile: SensorProfile, cases: Sequence[ReplicaCase], sims: Sequence[SensorStats], *,
                   structure: Sequence[str] = ()) -> SensorProfile:
    """One fixed-point step: ``profile``'s tracker parameters scaled (damped) by the pooled ratios real /
    simulated of the statistics of ``cases`` and their re-tracked simulations ``sims`` (one per case), the
    activity exponent moved (damped) by :func:`activity_slope` when the cases differ in activity, and the
    optional parts ``structure`` (:mod:`scenarios.sensors.fit_structure`)."""
    tr = profile.tracker
    slope = activity_slope(cases, sims, jitter="group-activity" not in structure)
    if slope is not None:
        tr = dataclasses.replace(tr, activity_exponent=float(tr.activity_exponent + DAMPING * slope))
    tr, shared_prov = with_structure(tr, cases, sims, structure, profile.topology)
    a = np.exp(-1.0 / (profile.clock.rate_hz * tr.wobble_tau_s))
    q = 2 * (1 - a) * (3 - a)
    r_bone = {b: pooled_ratio(np.array([[c.real.bone_std_mm[b].value / s.bone_std_mm[b].value] for c, s in
                                         zip(cases, sims)])) for b in _BONE_OF_GROUP.values()}
    if tr.body_scale_sd > 0:  # the bones' spread is the body scale's; rigidity kept
        r = float(np.exp(np.mean(np.log(list(r_bone.values())))))
        tr = dataclasses.replace(tr, body_scale_sd=min(tr.body_scale_sd * r ** DAMPING, 0.2))
        rigidity = {g: gn.bone_rigidity for g, gn in tr.groups.items()}
    else:
        rigidity = {g: float(np.clip(1 - (1 - tr.groups[g].bone_rigidity) * r_bone[b] ** DAMPING, 0.0, 0.99))
                    for g, b in _BONE_OF_GROUP.items()}
    unobserved = float(np.mean([rigidity[g] for g in _BONE_OF_GROUP]))
    residuals = any(c.real.residual_fluct_joint_mm.size for c in cases)
    spikes_own = measured_on_own_joints(profile.topology)
    groups = {}
    for g, gn in tr.groups.items():
        r_jit = _group_ratio(cases, sims, g, jitter_ratio)
        cols = np.flatnonzero(np.array(joint_groups(profile.topology)) == g)
        r_fl = _joint_ratio(cases, sims, cols, "residual_fluct_joint_mm") if residuals else None
        r_st = _joint_ratio(cases, sims, cols, "residual_static_joint_mm")
        r_sp = _group_ratio(cases, sims, g, lambda c, s, k: max(c.real.spikes[k].value - c.motion.spikes[k].value, 1e-4)
                            / max(s.spikes[k].value - c.motion.spikes[k].value, 1e-4)) if spikes_own[g] else 1.0
        white, wobble = _split(gn.jitter_m, gn.wobble_m, r_jit, r_fl, q)
        groups[g] = dataclasses.replace(
            gn, jitter_m=_damped(gn.jitter_m, white), wobble_m=_damped(gn.wobble_m, wobble),
            bias_m=tuple(float(b * r_st ** DAMPING) for b in gn.bias_m),
            outlier_rate=float(np.clip(gn.outlier_rate * r_sp ** DAMPING, 0.0, 0.5)),
            bone_rigidity=rigidity.get(g, unobserved))
    return dataclasses.replace(profile, tracker=dataclasses.replace(tr, groups=groups),
                               provenance={**profile.provenance, **shared_prov})


@dataclass(frozen=True)
class ReplicaFit:
    """The refined profile and how the search went.

    Attributes
    ----------
    profile : SensorProfile
        The refined profile (provenance updated).
    losses : mapping speed_ref [m/s] -> float
        Final loss of each reference speed tried.
    sims, poses : tuple
        Per case (in order) the statistics of its replica re-tracked with the refined profile, and the
        poses of the body calibration they were measured through.
    shared_people : bool
        Whether each person's cases were re-tracked as one simulated person
        (:func:`~scenarios.sensors.fit_structure.shares_people`); then the
        population fit re-tracks them itself (:attr:`retracked_per_session`).
    """

    profile: SensorProfile
    losses: Mapping[float, float]
    sims: tuple[SensorStats, ...]
    poses: tuple[Poses, ...]
    shared_people: bool = False

    @property
    def retracked_per_session(self) -> list[tuple[SensorStats, Poses]] | None:
        """:attr:`retracked` when every case was re-tracked with the same seed, as the population fit re-tracks
        them (:func:`scenarios.sensors.fit_population.fit_population`); None when they shared people: one
        person's cases would then carry one simulated person's errors, which the population fit would
        count as the real person's."""
        return None if self.shared_people else self.retracked

    @property
    def retracked(self) -> list[tuple[SensorStats, Poses]]:
        """Per case, its statistics and poses (:func:`~scenarios.sensors.replica_case.retracked_stats`)."""
        return list(zip(self.sims, self.poses, strict=True))


def _refine_speeds(base: SensorProfile, cases: Sequence[ReplicaCase], speeds: Sequence[float], iterations: int,
                   seed: int, jobs: int, tick: Callable[[int], None], structure: Sequence[str],
                   ) -> dict[float, tuple[SensorProfile, list[tuple[SensorStats, Poses]] | None, float]]:
    """``base`` with each reference speed refined by ``iterations`` fixed-point steps: per speed the profile, its
    re-tracked replicas' statistics (calibrated afresh) with their poses, and their loss (infinite, and no
    statistics, when a re-tracked replica cannot be calibrated from the body). Each step re-tracks every
    case of every speed still running, ``jobs`` at once."""
    trials, out = {s: dataclasses.replace(base, tracker=dataclasses.replace(base.tracker, speed_ref_m_s=s))
                   for s in speeds}, {}
    seeds = person_seeds(cases, seed) if shares_people(structure) else [(seed, None)] * len(cases)
    with Parallel(n_jobs=jobs) as parallel:
        for step in range(iterations + 1):
            running = [s for s in speeds if s not in out]
            results = parallel(delayed(retracked_or_none)(c, trials[s], *seeds_of_case)
                               for s in running for c, seeds_of_case in zip(cases, seeds))
            for k, speed in enumerate(running):
                retracked = results[k * len(cases) : (k + 1) * len(cases)]
                if any(r is None for r in retracked):
                    out[speed] = (trials[speed], None, float("inf"))
                elif step < iterations:
                    trials[speed] = update_profile(trials[speed], cases, [stats for stats, _ in retracked],
                                                   structure=structure)
                else:
                    out[speed] = (trials[speed], retracked, loss(cases, [stats for stats, _ in retracked]))
            tick(len(speeds))
    return out


def refine_on_replicas(profile: SensorProfile, cases: Sequence[ReplicaCase], *, iterations: int = 5,
                       speeds: Sequence[float] = SPEED_GRID_M_S, seed: int = 0, jobs: int = 1,
                       progress: Callable[[int], None] | None = None, structure: Sequence[str] = ()) -> ReplicaFit:
    """Refine ``profile`` (usually the analytic fit) on replicas of its fitting recordings.

    Parameters
    ----------
    profile : SensorProfile
        Starting values; parameters the module docstring does not name are kept.
    cases : sequence of ReplicaCase
        The fitting recordings (:func:`prepare_case`).
    iterations : int
        Fixed-point iterations per reference speed.
    speeds : sequence of float
        Reference speeds [m/s] tried (0: no speed dependence).
    seed : int
        Seed of the re-tracking (the same for every trial, so trials differ only by their parameters).
    jobs : int
        Processes (joblib; -1: one per core) re-tracking the cases of every reference speed at once; the
        result does not depend on it.
    progress : callable, optional
        Called with the number of reference speeds as each fixed-point step of all of them finishes.
    structure : sequence of str
        Optional parts of the model to fit as well (:data:`scenarios.sensors.fit_structure.STRUCTURE_PARTS`;
        two-camera recordings); the others keep the profile's values.

    Returns
    -------
    ReplicaFit
    """
    speeds = tuple(speeds)
    if not speeds or not all(np.isfinite(v) and v >= 0 for v in speeds):
        raise BadInputError(f"reference speeds must be one or more finite values >= 0 m/s, got {list(speeds)}")
    tick = progress or (lambda n: None)
    base = fit_confidence(profile, cases)
    activities = [c.activity for c in cases]
    if min(activities) > 0:
        base = dataclasses.replace(base, tracker=dataclasses.replace(
            base.tracker, activity_ref_m_s=float(np.median(activities)),
            activity_range_m_s=(float(min(activities)), float(max(activities)))))
    speeds = tuple(dict.fromkeys(float(v) for v in speeds))
    refined_at = _refine_speeds(base, cases, speeds, iterations, seed, jobs, tick, check_parts(structure))
    best, losses = None, {}
    for speed in speeds:
        trial, retracked, trial_loss = refined_at[speed]
        losses[speed] = trial_loss
        if best is None or trial_loss < best[0]:
            best = (trial_loss, trial, retracked)
    if best[2] is None:
        raise BadInputError("no reference speed gave a tracker whose re-tracked replicas could be calibrated "
                            "from the body; check the recordings' calibrations (sim-to-real on each)")
    _, refined, retracked = best
    sims = [stats for stats, _ in retracked]
    names = ", ".join(c.name for c in cases)
    prov = dict(refined.provenance)
    how = (f"refined on replicas of {names}: simulation-based fit (scenarios.sensors.fit_replica; ratios real / "
           "simulated pooled as the median over the recordings)")
    prov["tracker.speed_ref_m_s"] = (f"{how}, grid {', '.join(f'{s:g}' for s in speeds)} m/s, the smallest loss over "
                                     "the acceptance statistics")
    for k in structure_keys(structure):  # the steps' own words, where a step moved the value
        if prov.get(k) and prov[k] != base.provenance.get(k):
            prov[k] = f"{how}, {prov[k]}"
    prov["tracker.activity_ref_m_s"] = f"median activity (mean true joint speed) of the replicas of {names}"
    prov["tracker.activity_range_m_s"] = f"least and greatest activity (mean true joint speed) of the replicas of {names}"
    prov["tracker.activity_exponent"] = (
        f"{how}, Theil-Sen slope of each recording's mean log-ratio real / simulated of its error statistics "
        "against its log activity, driven to zero" if activity_slope(cases, sims) is not None else
        f"{how}: fewer than three recordings or no spread in activity, nothing to fit (kept)")
    own = measured_on_own_joints(refined.topology)
    for g in JointGroup:
        for key, what in (("jitter_m", "jitter beyond the motion's own and fluctuating residual"),
                          ("wobble_m", "jitter beyond the motion's own and fluctuating residual"),
                          ("bias_m", "steady cross-camera residual"),
                          ("outlier_rate", "share of second differences over 5 cm beyond the motion's own"),
                          ("low_confidence", "least squares of the low-confidence share against the hidden share"),
                          ("hidden_low_confidence", "least squares of the low-confidence share against the hidden share")):
            prov[f"tracker.groups.{g.value}.{key}"] = f"{how}, {what} ({'/'.join(STATS_OF_GROUP[g])})"
        if not own[g]:
            prov[f"tracker.groups.{g.value}.outlier_rate"] = profile.provenance.get(
                f"tracker.groups.{g.value}.outlier_rate", "") + (
                f" (kept by the refinement: its statistic, {'/'.join(STATS_OF_GROUP[g])}, is not measured on this "
                "group's joints)")
        bone = _BONE_OF_GROUP.get(g)
        if refined.tracker.body_scale_sd == 0:
            prov[f"tracker.groups.{g.value}.bone_rigidity"] = (
                f"{how}, {bone.replace('_', '-')} length spread" if bone else
                f"{how}: mean of the upper-arm and forearm rigidities (no bone of this group is measured)")
    if refined.tracker.body_scale_sd > 0:
        prov["tracker.body_scale_sd"] = f"{how}, upper-arm and forearm length spreads (the body scale's)"
    return ReplicaFit(dataclasses.replace(refined, provenance=prov), losses, tuple(sims),
                      tuple(poses for _, poses in retracked), shared_people=shares_people(structure))
