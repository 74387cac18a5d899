"""Device swap: what changes when a real session's sensors are replaced by another kind.

The session's replica (:mod:`scenarios.sensors.replica`: its motion retargeted onto the humanoid,
virtual cameras at its calibrated poses) is simulated with each of two sensor profiles over the same
scenario seeds, so every seed is a paired comparison: the same motion, rig and scenario seed, only the
sensor models differ. Each simulated session is scored three ways:

- truth-free statistics, as sim-to-real computes them (:func:`scenarios.sensors.sim_to_real.compare_stats`:
  cross-camera residuals after a body calibration, jitter, bone-length spread, confidences), with the
  real session's value beside them;
- the body calibration (skeletons only) against the replica's true camera poses: rotation and
  translation error of each camera relative to the reference (:func:`scenarios.evaluate.score_calibration`);
- the fused skeleton against the replica's true joints: joint position error and the clinical angle
  errors while the arm is raised (:func:`scenarios.skeleton_eval.skeleton_errors`, rigid gauge: a body
  calibration has no floor).

Per metric the table gives each profile's median and :data:`scenarios.sensors.sim_to_real.BAND` over
the seeds and the median of the paired differences (to - from).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from fusion.calibrate.floor import GaugeMode
from fusion.calibration import Calibration
from fusion.errors import BadInputError, CalibrationError
from fusion.merge.fuse import FuseOptions, camera_views, fuse_views
from fusion.merge.sensor_stats import SensorStats
from fusion.recording import Recording
from scenarios.config import Scenario
from scenarios.evaluate import score_calibration
from scenarios.runner import default_profile, simulate
from scenarios.sensors.fit import check_span, measure, session_calibration
from scenarios.sensors.fit_and_compare import session_replica
from scenarios.sensors.sim_to_real import BAND, check_draws, compare_stats, with_profile
from scenarios.skeleton_eval import skeleton_errors
from sim.sensor_profile import load_profile
from sim.truth import GroundTruth

CALIBRATION_METRICS = {"rotation_error_deg": "calibration rotation error [deg]",
                       "translation_error_mm": "calibration translation error [mm]"}
"""Keys of :meth:`scenarios.evaluate.CalibrationScores.summary` reported (their mean over the
non-reference cameras), with their labels."""

JOINT_METRIC = "joint position error, mean [mm]"
"""Label of the fused skeleton's mean joint error against the truth."""

ANGLES = {"elbow_flexion": "elbow flexion error, arm raised, median [deg]",
          "ht_elevation": "humerothoracic elevation error, arm raised, median [deg]"}
"""Clinical angles whose error (both sides pooled, frames with the arm raised) is reported, with labels."""


@dataclass(frozen=True)
class Draw:
    """One simulated session of the replica with one profile.

    Attributes
    ----------
    profile : str
        The sensor profile simulated.
    seed : int
        The scenario seed.
    values : mapping str -> float
        Metric label -> value (NaN where it could not be computed).
    stats : SensorStats or None
        The session's truth-free statistics (None when the body calibration failed).
    """

    profile: str
    seed: int
    values: Mapping[str, float]
    stats: SensorStats | None


@dataclass(frozen=True)
class SwapRow:
    """One metric under both profiles.

    Attributes
    ----------
    metric : str
        What is measured, with its unit.
    kind : str
        ``truth-free``, ``calibration`` or ``skeleton``.
    real : float
        Its value on the real session (truth-free metrics only; NaN otherwise).
    before, after : tuple of float
        Median, low and high :data:`BAND` percentile over the seeds with the ``from`` and the ``to``
        profile (NaN when no seed gave a value).
    change : float
        Median over the seeds of the paired difference ``to - from``.
    """

    metric: str
    kind: str
    real: float
    before: tuple[float, float, float]
    after: tuple[float, float, float]
    change: float


@dataclass(frozen=True)
class DeviceSwap:
    """A real session's replica simulated with two sensor profiles (:func:`device_swap`).

    Attributes
    ----------
    rows : tuple of SwapRow
        Every metric, truth-free first.
    from_profile, to_profile : str
        Names of the two profiles.
    seeds : tuple of int
        The scenario seeds, the same for both profiles.
    draws : tuple of Draw
        Every simulated session, ``from`` profile first.
    scenario : Scenario
        The replica (with its own profile; each draw replaces it).
    real : SensorStats
        The real session's truth-free statistics.
    """

    rows: tuple[SwapRow, ...]
    from_profile: str
    to_profile: str
    seeds: tuple[int, ...]
    draws: tuple[Draw, ...]
    scenario: Scenario
    real: SensorStats

    @property
    def failed(self) -> list[tuple[str, int]]:
        """``(profile, seed)`` of the draws whose cameras could not be calibrated from the body."""
        return [(d.profile, d.seed) for d in self.draws if d.stats is None]


def _summary(values: list[float]) -> tuple[float, float, float]:
    v = np.asarray(values, dtype=np.float64)
    v = v[np.isfinite(v)]
    if not v.size:
        return (np.nan, np.nan, np.nan)
    low, high = np.percentile(v, BAND)
    return (float(np.median(v)), float(low), float(high))


def score_draw(recording: Recording, truth: GroundTruth, *, real: SensorStats, rng: np.random.Generator
               ) -> tuple[dict[str, float], SensorStats]:
    """The metrics of one simulated session (see the module docstring).

    Parameters
    ----------
    recording : Recording
        The simulated session (two or more skeleton cameras).
    truth : GroundTruth
        Its ground truth.
    real : SensorStats
        The real session's statistics (they fix which truth-free statistics are compared).
    rng : np.random.Generator
        Source of the body calibration's randomness.

    Returns
    -------
    (dict, SensorStats)
        Metric label -> value, and the session's truth-free statistics.

    Raises
    ------
    CalibrationError
        The cameras cannot be calibrated from the body.
    """
    calibration = session_calibration(recording, rng=rng)
    stats = measure(recording, calibration.T_world_cam, n_boot=0, rng=rng)
    values = {r.statistic: r.sim for r in compare_stats(real, stats)}
    summary = score_calibration(calibration.T_world_cam, truth, calibration.reference).summary()
    values |= {label: summary[key]["mean"] for key, label in CALIBRATION_METRICS.items()}
    views = camera_views(recording, calibration)
    errors = skeleton_errors(fuse_views(views, FuseOptions()).positions, calibration.T_world_cam, truth,
                             calibration.reference, views.topology, gauge=GaugeMode.RIGID)
    values[JOINT_METRIC] = errors["joint_error_mm"]["mean"]
    values |= {label: errors[f"{a}_raised_error_deg"]["median"] for a, label in ANGLES.items()}
    return {k: float(v) for k, v in values.items()}, stats


def check_swap(real: Recording, draws: int, from_profile: str, to_profile: str) -> tuple[str, str]:
    """Refuse what a device swap cannot compare: fewer than one draw, a session without
    :data:`scenarios.sensors.fit.MIN_SPAN_S` of skeletons or with fewer than two skeleton cameras, a
    profile of another topology than the session's, or two profiles with the same models. Returns
    the two profiles' names."""
    check_draws(draws)
    check_span(real)
    if sum(c.skeleton is not None for c in real.cameras) < 2:
        raise BadInputError("a device swap compares calibrations and cross-camera residuals: it needs a session "
                            "of two or more skeleton cameras")
    topology = real.topology.name
    profiles = [load_profile(p) for p in (from_profile, to_profile)]
    for given, p in zip((from_profile, to_profile), profiles):
        if p.topology.name != topology:
            raise BadInputError(f"sensor profile {given!r} reports {p.topology.name} skeletons, the session "
                                f"{topology}; swap between profiles of the session's topology")
    models = [(p.tracker, p.depth, p.clock, p.population) for p in profiles]
    if models[0] == models[1]:
        raise BadInputError(f"--from and --to give the same sensor models ({profiles[0].name}); choose two "
                            "different profiles")
    return profiles[0].name, profiles[1].name


def device_swap(real: Recording, scenario: Scenario, *, from_profile: str, to_profile: str, draws: int,
                T_world_cam: Mapping[str, np.ndarray] | None = None, rng: np.random.Generator,
                progress: Callable[[int], object] | None = None) -> DeviceSwap:
    """Simulate a real session's stand-in with two sensor profiles over the same seeds and table the changes.

    Parameters
    ----------
    real : Recording
        The real session (two or more skeleton cameras).
    scenario : Scenario
        Its replica (:func:`scenarios.sensors.replica.build_replica`); seeds ``scenario.seed`` ..
        ``scenario.seed + draws - 1`` are simulated with each profile.
    from_profile, to_profile : str
        The sensor profiles (built-in names or TOML paths) of the session's topology.
    draws : int
        Seeds per profile (>= 1).
    T_world_cam : mapping, optional
        The real cameras' calibration (None: calibrated from the body).
    rng : np.random.Generator
        Source of the real session's body calibration (each draw's uses its scenario seed, the same for
        both profiles).
    progress : callable, optional
        Called with 1 after each simulated session.

    Returns
    -------
    DeviceSwap

    Raises
    ------
    CalibrationError
        No draw of one of the profiles could be calibrated from the body.
    """
    names = check_swap(real, draws, from_profile, to_profile)
    real_stats = measure(real, T_world_cam, n_boot=0, rng=rng)
    seeds = tuple(scenario.seed + d for d in range(int(draws)))
    done = []
    for given, name in zip((from_profile, to_profile), names):
        swapped = with_profile(scenario, given)
        for seed in seeds:
            recording, truth = simulate(swapped.replace(seed=seed), progress=False)
            try:  # the same calibration draws for both profiles: the seed's
                values, stats = score_draw(recording, truth, real=real_stats, rng=np.random.default_rng(seed))
            except CalibrationError:
                values, stats = {}, None
            done.append(Draw(name, seed, values, stats))
            if progress is not None:
                progress(1)
    for name in names:
        if all(d.stats is None for d in done if d.profile == name):
            raise CalibrationError(f"no simulated session with {name} could be calibrated from the body; "
                                   "check the replica with sim-to-real")
    return DeviceSwap(swap_rows(real_stats, done, names), names[0], names[1], seeds, tuple(done), scenario,
                      real_stats)


def swap_rows(real: SensorStats, draws: list[Draw], names: tuple[str, str]) -> tuple[SwapRow, ...]:
    """Per metric the real value (truth-free metrics), each profile's median and band over the seeds,
    and the median paired difference; ``draws`` holds both profiles' sessions over the same seeds."""
    truth_free = [r.statistic for r in compare_stats(real, real)]
    metrics = [(m, "truth-free") for m in truth_free] + [(m, "calibration") for m in CALIBRATION_METRICS.values()]
    metrics += [(JOINT_METRIC, "skeleton")] + [(m, "skeleton") for m in ANGLES.values()]
    real_values = {r.statistic: r.real for r in compare_stats(real, real)}
    by = {name: {d.seed: d.values for d in draws if d.profile == name} for name in names}
    seeds = sorted(set(by[names[0]]) & set(by[names[1]]))
    rows = []
    for metric, kind in metrics:
        a, b = ([by[n][s].get(metric, np.nan) for s in seeds] for n in names)
        change = _summary([y - x for x, y in zip(a, b)])[0]
        rows.append(SwapRow(metric, kind, float(real_values.get(metric, np.nan)), _summary(a), _summary(b), change))
    return tuple(rows)


def swap_session(real: Recording, out: Path, *, from_profile: str | None, to_profile: str, draws: int = 3,
                 calibration: Calibration | None = None, seed: int = 0, name: str = "session") -> DeviceSwap:
    """Device swap of one real session (``mocap-bench device-swap``): build its replica (written into
    ``out``: replica.toml and its motion file), then :func:`device_swap`.

    Parameters
    ----------
    real : Recording
        The real session.
    out : Path
        Directory for the replica's files.
    from_profile, to_profile : str
        The two sensor profiles (built-in names or TOML paths); ``from_profile`` None is the built-in of
        the session's topology.
    draws : int
        Seeds per profile.
    calibration : Calibration, optional
        The real cameras' calibration; None calibrates them from the body.
    seed : int
        Seed of the body calibrations and the replica's first scenario seed.
    name : str
        The session's name (the replica is ``replica_<name>``).
    """
    check_span(real)
    from_profile = from_profile or default_profile(real.topology.name)
    check_swap(real, draws, from_profile, to_profile)  # before the replica is built
    rng = np.random.default_rng(seed)
    if calibration is None:
        calibration = session_calibration(real, rng=rng)
    replica, _ = session_replica(real, calibration, out, name=f"replica_{name}")
    with tqdm(total=2 * draws, desc="device-swap", unit="session", leave=False) as bar:
        return device_swap(real, replica.scenario.replace(seed=seed), from_profile=from_profile,
                           to_profile=to_profile, draws=draws, T_world_cam=calibration.T_world_cam, rng=rng,
                           progress=bar.update)
