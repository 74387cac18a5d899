"""Clinical angles of a real depth camera and of its simulation, both against an optical reference
(``mocap-bench angle-validate``).

Per episode of a data set that recorded each movement with a Kinect and an optical system at once
(UI-PRMD: :func:`find_episodes`):

- **real**: the optical reference (:func:`fusion.merge.marker_reference.marker_reference`), the
  Kinect episode aligned with it in time and space (:func:`fusion.merge.episode_alignment.align_episodes`)
  and the Kinect's signed angle errors (:func:`fusion.merge.angle_errors.episode_angle_errors`);
- **simulated** (:mod:`scenarios.sensors.angle_replica`): the reference's joint centres (the markers'
  joints through the ``plug_in_gait`` map where the reference has none: head, legs) retargeted onto
  the humanoid (:func:`sim.replay.fit_motion`),
  a virtual camera of the profile placed where the alignment put the real one, the session simulated
  (skeletons only) and the simulated camera's errors against the humanoid's true joints by the same
  alignment and error code. Each real subject is seen as simulated persons of its own, one per seed
  and the same in every episode of that subject, and each episode gets sessions of its own
  (:meth:`Episode.simulation_seeds`): the simulated means pool as many drawn people as subjects
  times seeds, as the real means pool the subjects.

So both sides answer one question (how far the camera's angles are from the truth it saw) with one
code path; what differs is the truth (markers for the real camera, the humanoid for the simulated one)
and the tracker (real or simulated).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from joblib import Parallel, delayed
from scipy import stats

from fma.statistics import mean_interval
from fusion.errors import BadInputError
from fusion.io.formats.ui_prmd import read_ui_prmd_kinect
from fusion.merge.angle_errors import EpisodeAngleErrors, episode_angle_errors
from fusion.merge.angles import joint_angles
from fusion.merge.episode_alignment import EpisodeAlignment, align_episodes, resample
from fusion.skeleton import SkeletonStream
from fusion.topology import Landmark
from fusion.transforms import apply
from scenarios.sensors.angle_clocks import ClockRatios
from scenarios.sensors.angle_replica import replica_trajectory, simulate_replica
from sim.sensor_population import labelled_seed
from sim.tracker_arm_bias import ARM_JOINTS

MOVEMENTS = ("m07", "m08", "m09", "m10")
"""UI-PRMD's shoulder movements: abduction, extension, internal-external rotation, scaption."""

STATISTICS = ("peak_elevation_error_deg", "elbow_flexion_error_deg", "plane_of_elevation_error_deg",
              "elevation_trace_rmse_deg", "peak_elevation_thorax_part_deg")
"""The statistics compared, in order: signed Kinect-minus-reference errors of the peak elevation, the
elbow flexion and the plane of elevation at the peak, the RMS difference of the elevation traces, and
the thorax axis's part of the peak elevation error (:mod:`fusion.merge.angle_errors`)."""

_ERROR_KEYS = dict(zip(STATISTICS, ("peak_elevation", "elbow_flexion_at_peak", "plane_of_elevation_at_peak",
                                    "elevation_rmse", "peak_elevation_thorax_part")))

_EPISODE = re.compile(r"^(m\d\d)_(s\d\d)_e(\d\d)_positions(_inc)?\.txt(\.gz)?$")


@dataclass(frozen=True)
class Episode:
    """One repetition recorded by both systems.

    Attributes
    ----------
    movement, subject : e.g. ``m07``, ``s01``.
    number : the episode's number within the movement and subject.
    kinect, vicon : the positions files.
    incorrect : from the data set's incorrectly performed movements.
    """

    movement: str
    subject: str
    number: int
    kinect: Path
    vicon: Path
    incorrect: bool = False

    @property
    def name(self) -> str:
        """``m07_s01_e01`` (``_inc`` appended for an incorrect one)."""
        return f"{self.movement}_{self.subject}_e{self.number:02d}" + ("_inc" if self.incorrect else "")

    def simulation_seeds(self, seed: int) -> tuple[int, int]:
        """(session seed, person seed) of this episode's simulation number ``seed``: the person depends on
        the subject and ``seed`` alone, the session on the episode as well (stable across runs)."""
        return labelled_seed(seed, self.name), labelled_seed(seed, self.subject)


def _split(root: Path, incorrect: bool) -> Path:
    folder = "Incorrect Segmented Movements" if incorrect else "Segmented Movements"
    for candidate in (root / folder, root):
        if (candidate / "Kinect" / "Positions").is_dir() and (candidate / "Vicon" / "Positions").is_dir():
            if candidate == root and root.name != folder and root.name.endswith("Segmented Movements"):
                break  # the other split's folder: not the one asked for
            return candidate
    raise BadInputError(f"{root}: no '{folder}/Kinect/Positions' and '{folder}/Vicon/Positions' folders; give the "
                        "UI-PRMD folder that holds 'Segmented Movements'")


def find_episodes(dataset: str | Path, subjects: Sequence[str] | None = None, movements: Sequence[str] | None = None,
                  *, incorrect: bool = False, limit: int | None = None) -> list[Episode]:
    """The episodes of a UI-PRMD folder with both a Kinect and a Vicon positions file.

    Parameters
    ----------
    dataset : the folder holding ``Segmented Movements`` (or that folder itself).
    subjects, movements : e.g. ``["s01"]``, ``["m07"]``; None: every one present (movements: :data:`MOVEMENTS`).
    incorrect : the incorrectly performed movements instead.
    limit : at most this many episodes per movement and subject (the lowest numbers).

    Raises
    ------
    BadInputError
        The folder is not UI-PRMD's, or a subject or movement asked for has no episode.
    """
    split = _split(Path(dataset), incorrect)
    vicon = {m.group(0): p for p in (split / "Vicon" / "Positions").iterdir() if (m := _EPISODE.match(p.name))}
    found: list[Episode] = []
    for path in sorted((split / "Kinect" / "Positions").iterdir()):
        m = _EPISODE.match(path.name)
        if not m or path.name not in vicon or bool(m.group(4)) != incorrect:
            continue
        movement, subject, number = m.group(1), m.group(2), int(m.group(3))
        if movements is None and movement not in MOVEMENTS:
            continue
        if (movements is not None and movement not in movements) or (subjects is not None and subject not in subjects):
            continue
        found.append(Episode(movement, subject, number, path, vicon[path.name], incorrect))
    for what, asked, have in (("subject", subjects, {e.subject for e in found}),
                              ("movement", movements, {e.movement for e in found})):
        missing = sorted(set(asked or ()) - have)
        if missing:
            raise BadInputError(f"{split}: no episode pair (Kinect and Vicon positions) of {what}(s) {', '.join(missing)}")
    if limit is not None:
        kept: dict[tuple[str, str], int] = {}
        found = [e for e in found if (kept.__setitem__(k := (e.movement, e.subject), kept.get(k, 0) + 1)
                                      or kept[k] <= limit)]
    return found


@dataclass(frozen=True, eq=False)
class Side:
    """One camera's errors in one episode against its truth, with the traces behind them.

    Attributes
    ----------
    errors : the signed errors (None when the alignment failed).
    alignment : the episode alignment.
    times : (T,) [s] the camera's frame times on the truth's clock.
    elevation_deg, truth_elevation_deg : (T,) [deg] the moving arm's humerothoracic elevation of the
        camera and of the truth at those times.
    arm_change_mm : (3,) [mm] per joint of the moving arm (:data:`ARM_JOINTS`) the RMS frame-to-frame
        change of the camera's error (camera minus truth): how much the error moves, not how large it
        is; NaN when not aligned.
    """

    errors: EpisodeAngleErrors | None
    alignment: EpisodeAlignment
    times: np.ndarray
    elevation_deg: np.ndarray
    truth_elevation_deg: np.ndarray
    arm_change_mm: np.ndarray

    def value(self, statistic: str) -> float:
        """The statistic (:data:`STATISTICS`) of this episode; NaN without errors."""
        if self.errors is None:
            return float("nan")
        return float(self.errors.as_dict()[_ERROR_KEYS[statistic]])


def compare(truth: SkeletonStream, camera: SkeletonStream, rate_ratio: float = 1.0) -> Side:
    """Align a camera's stream with its truth's (the camera's clock running ``rate_ratio`` times the
    truth's) and compute the camera's errors (module docstring)."""
    alignment = align_episodes(truth, camera, rate_ratios=(rate_ratio,))
    side = alignment.side
    errors = episode_angle_errors(truth, camera, alignment) if alignment.ok else None
    t = alignment.rate_ratio * camera.timestamps + (alignment.shift_s if alignment.ok else 0.0)
    cam = joint_angles(apply(alignment.T_vicon_kinect, camera.positions), camera.topology).as_dict()[f"ht_elevation_{side}"]
    ref = joint_angles(truth.positions, truth.topology).as_dict()[f"ht_elevation_{side}"]
    change = np.full(len(ARM_JOINTS), np.nan)
    if alignment.ok:
        seen, true = apply(alignment.T_vicon_kinect, camera.positions), resample(truth.timestamps, truth.positions, t)
        for k, joint in enumerate(ARM_JOINTS):
            lm = Landmark[f"{joint.upper()}_{side.upper()}"]
            step = np.linalg.norm(np.diff(seen[:, camera.topology.index(lm)] - true[:, truth.topology.index(lm)], axis=0),
                                  axis=-1)
            step = step[np.isfinite(step)]
            change[k] = 1e3 * float(np.sqrt(np.mean(step ** 2))) if step.size else np.nan
    return Side(errors, alignment, t, cam, np.interp(t, truth.timestamps, ref, left=np.nan, right=np.nan), change)


@dataclass(frozen=True, eq=False)
class EpisodeResult:
    """The real camera and its simulations in one episode.

    Attributes
    ----------
    episode : the episode.
    real : the real Kinect against the optical reference.
    sims : per seed, the simulated camera against the humanoid's truth (empty when not simulated:
        the real alignment failed).
    problem : why the episode has no result on one side ('' when it has both).
    """

    episode: Episode
    real: Side
    sims: tuple[Side, ...]
    problem: str = ""


def validate_episode(episode: Episode, *, profile: str | None = None, seeds: Sequence[int] = (0,),
                     simulate: bool = True, rate_ratio: float = 1.0) -> EpisodeResult:
    """:class:`EpisodeResult` of one episode (module docstring); ``rate_ratio`` is the episode's
    :func:`~scenarios.sensors.angle_clocks.clock_ratios` (the simulation's clocks agree: ratio 1)."""
    trajectory, reference = replica_trajectory(episode.vicon)
    recording = read_ui_prmd_kinect(episode.kinect)
    real = compare(reference, recording.cameras[0].skeleton, rate_ratio)
    if not real.alignment.ok:
        return EpisodeResult(episode, real, (), "the Kinect and optical recordings could not be aligned")
    if not simulate:
        return EpisodeResult(episode, real, ())
    sessions, persons = zip(*(episode.simulation_seeds(s) for s in seeds)) if seeds else ((), ())
    sims = tuple(compare(truth, camera) for truth, camera in
                 simulate_replica(trajectory, real.alignment.T_vicon_kinect, profile=profile, seeds=sessions,
                                  person_seeds=persons, lab=recording.lab))
    failed = sum(s.errors is None for s in sims)
    return EpisodeResult(episode, real, sims, f"{failed} simulation(s) could not be aligned" if failed else "")


def validate_episodes(episodes: Sequence[Episode], *, profile: str | None | Mapping[str, str] = None,
                      seeds: Sequence[int] = (0,), simulate: bool = True, rate_ratios: ClockRatios | None = None,
                      jobs: int = 1, progress: Callable[[int], None] | None = None) -> list[EpisodeResult]:
    """:func:`validate_episode` of each episode, ``jobs`` at once (joblib; -1: one per core);
    ``profile`` may map each subject to its own; ``rate_ratios`` gives each episode's clock ratio
    (default 1); ``progress`` is called with 1 as each is done. Results keep the
    episodes' order."""
    tick = progress or (lambda n: None)
    results = []
    for result in Parallel(n_jobs=jobs, return_as="generator")(
            delayed(validate_episode)(e, profile=profile.get(e.subject) if isinstance(profile, Mapping) else profile,
                                      seeds=seeds, simulate=simulate,
                                      rate_ratio=rate_ratios.of(e) if rate_ratios else 1.0) for e in episodes):
        results.append(result)
        tick(1)
    return results


def tolerance(statistic: str, real_mean: float) -> float:
    """How far the simulated mean may lie from ``real_mean`` [deg]: max(3 deg, 30 %) for the signed errors,
    30 % for the trace RMSE."""
    if statistic == "elevation_trace_rmse_deg":
        return 0.3 * abs(real_mean)
    return max(3.0, 0.3 * abs(real_mean))


def agrees(statistic: str, real_mean: float, sim_mean: float) -> bool:
    """The simulated mean error matches the real one: within :func:`tolerance` of it."""
    if not (np.isfinite(real_mean) and np.isfinite(sim_mean)):
        return False
    return abs(sim_mean - real_mean) <= tolerance(statistic, real_mean)


def agree_chance(statistic: str, real_mean: float, real: Sequence[tuple[object, float]],
                 sim: Sequence[tuple[object, float]]) -> float:
    """Probability that a simulation whose mean error is exactly right agrees (:func:`agrees`) on as many
    new people as ``real`` holds, given how much the difference real - simulated of each person's mean
    varies between these people: ``2 F(tol / se) - 1``, ``F`` Student-t with people - 1 degrees of
    freedom, ``se`` the standard deviation of the per-person differences over sqrt(people). ``real`` pairs
    (person, value); ``sim`` pairs (person, value) with the real person as the key. NaN below three people."""
    r, m = person_means(real), person_means(sim)
    d = np.array([r[p] - m[p] for p in r if p in m])
    if d.size < 3 or not np.isfinite(real_mean):
        return float("nan")
    se = float(d.std(ddof=1) / np.sqrt(d.size))
    if se == 0:
        return 1.0
    return float(2 * stats.t.cdf(tolerance(statistic, real_mean) / se, d.size - 1) - 1)


def _mean_sd(values: list[float]) -> tuple[float, float, int]:
    v = np.asarray([x for x in values if np.isfinite(x)])
    if v.size == 0:
        return float("nan"), float("nan"), 0
    return float(v.mean()), float(v.std(ddof=1)) if v.size > 1 else 0.0, int(v.size)


def _medians(sides: list[Side]) -> list[float]:
    if not sides:
        return [float("nan")] * len(ARM_JOINTS)
    values = np.array([s.arm_change_mm for s in sides])
    return [float(np.nanmedian(v)) if np.isfinite(v).any() else float("nan") for v in values.T]


def person_means(values: Sequence[tuple[object, float]]) -> dict[object, float]:
    """Per person the mean of its finite values among ``values`` (person, value) pairs; a person without
    one is left out."""
    people: dict[object, list[float]] = {}
    for person, value in values:
        if np.isfinite(value):
            people.setdefault(person, []).append(value)
    return {p: float(np.mean(v)) for p, v in people.items()}


def people_interval(values: Sequence[tuple[object, float]]) -> list[float]:
    """[low, high] 95 % t-interval of the mean over people of ``values`` (person, value) pairs, each
    person counted once by its :func:`person_means` (the person is the unit that varies: a real subject,
    or a simulated person, one per subject and seed); NaN below two people."""
    interval = mean_interval(list(person_means(values).values()))
    return [interval.low, interval.high] if interval.n > 1 else [float("nan")] * 2


def summarise(results: Sequence[EpisodeResult]) -> dict:
    """``{"movements": {m: {statistic: {real_mean, real_sd, real_n, real_interval, sim_mean, sim_sd, sim_n,
    sim_interval, agrees, agree_chance}, "arm_change_mm": {joints, real, sim}}}, "episodes": [...]}`` (errors
    signed: camera minus truth, degrees; the intervals of :func:`people_interval`; :func:`agree_chance`; the
    arm's frame-to-frame error change as the median over episodes, mm); the simulated values pool every
    seed of every episode."""
    movements: dict[str, dict] = {}
    for m in sorted({r.episode.movement for r in results}):
        rows = [r for r in results if r.episode.movement == m]
        table = {}
        for stat in STATISTICS:
            real = [(r.episode.subject, r.real.value(stat)) for r in rows]
            sim = [((r.episode.subject, k), s.value(stat)) for r in rows for k, s in enumerate(r.sims)]
            rm, rs, rn = _mean_sd([v for _, v in real])
            sm, ss, sn = _mean_sd([v for _, v in sim])
            table[stat] = {"real_mean": rm, "real_sd": rs, "real_n": rn, "real_interval": people_interval(real),
                           "sim_mean": sm, "sim_sd": ss, "sim_n": sn, "sim_interval": people_interval(sim),
                           "agrees": agrees(stat, rm, sm) if sn else None,
                           "agree_chance": agree_chance(stat, rm, real, [(p, v) for (p, _), v in sim])}
        table["arm_change_mm"] = {"joints": list(ARM_JOINTS), "real": _medians([r.real for r in rows]),
                                  "sim": _medians([s for r in rows for s in r.sims])}
        movements[m] = table
    episodes = [{"episode": r.episode.name, "movement": r.episode.movement, "subject": r.episode.subject,
                 "side": r.real.alignment.side, "problem": r.problem,
                 "real": {s: r.real.value(s) for s in STATISTICS},
                 "sims": [{s: x.value(s) for s in STATISTICS} for x in r.sims]} for r in results]
    return {"movements": movements, "episodes": episodes}
