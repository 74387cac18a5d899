"""``mocap-bench angle-validate`` as one call: episodes, clock ratios, the optional fit of the arm and
trunk biases (with its profiles written), the real and simulated comparisons and the report."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from joblib import Parallel, delayed
from tqdm import tqdm

from fusion.errors import BadInputError
from fusion.io.atomic import write_text_atomic
from fusion.io.formats.ui_prmd import read_ui_prmd_kinect, read_ui_prmd_vicon
from scenarios.sensors.angle_clocks import ClockRatios, clock_ratios
from scenarios.sensors.angle_validate import (
    Episode,
    EpisodeResult,
    find_episodes,
    validate_episodes,
)
from scenarios.sensors.angle_validate_report import write_report
from scenarios.sensors.fit_arm_bias import (
    FIT_PARTS,
    collect_offsets,
    fit_arm_bias,
    with_arm_bias,
)
from sim.sensor_profile import load_profile, profile_to_toml


@dataclass(frozen=True)
class Validation:
    """What :func:`validate_dataset` did: the results, the clock ratios, the files written, and the
    episodes left out because their files could not be read (episode name -> why)."""

    results: list[EpisodeResult]
    clock_ratios: ClockRatios
    written: list[Path]
    left_out: dict[str, str]


def _problem(episode: Episode) -> str:
    """Why ``episode``'s Kinect or optical files cannot be read ('' when both can)."""
    try:
        read_ui_prmd_kinect(episode.kinect)
        read_ui_prmd_vicon(episode.vicon)
    except BadInputError as exc:
        return str(exc)
    return ""


def readable_episodes(episodes: Sequence[Episode], *, jobs: int = 1) -> tuple[list[Episode], dict[str, str]]:
    """``episodes`` whose Kinect and optical files can both be read, and the others' names with the
    reader's error: one truncated or corrupt file leaves its episode out, not the run."""
    problems = Parallel(n_jobs=jobs)(delayed(_problem)(e) for e in episodes)
    return [e for e, p in zip(episodes, problems) if not p], {e.name: p for e, p in zip(episodes, problems) if p}


def validate_dataset(dataset: str | Path, out: Path, *, command: str, subjects: Sequence[str] | None = None,
                     movements: Sequence[str] | None = None, profile: str = "kinect_v2", seeds: Sequence[int] = (0, 1),
                     limit: int | None = None, incorrect: bool = False, fit: bool | Sequence[str] = False,
                     leave_one_out: bool = False, jobs: int = -1,
                     say: Callable[[str], None] = lambda s: None) -> Validation:
    """Run ``angle-validate`` (see :mod:`scenarios.sensors.angle_validate`) and write its report into ``out``.

    With ``fit`` (True: every part of :data:`~scenarios.sensors.fit_arm_bias.FIT_PARTS`, or the parts
    named) the tracker's arm and trunk biases are fitted to the subjects' real offsets
    (:mod:`scenarios.sensors.fit_arm_bias`) and ``out/profile_fitted.toml`` written; with
    ``leave_one_out`` too, one profile per subject fitted without it (``profile_fitted_without_S.toml``)
    simulates that subject. ``say`` receives progress lines.

    Raises
    ------
    BadInputError
        Bad options, a profile of another topology than Kinect v2, no episode found.
    """
    if not seeds:
        raise BadInputError("give at least one simulation seed")
    if limit is not None and limit < 1:
        raise BadInputError(f"limit must be at least 1, got {limit}")
    parts = tuple(FIT_PARTS if fit is True else fit or ())
    if any(p not in FIT_PARTS for p in parts):
        raise BadInputError(f"can fit the parts {', '.join(FIT_PARTS)}, got {', '.join(parts)}")
    if leave_one_out and not parts:
        raise BadInputError("--leave-one-out refits the biases without each subject: give --fit too")
    base = load_profile(profile)
    if base.topology.name != "kinect_v2":
        raise BadInputError(f"profile {base.name!r} is a {base.topology.name} tracker; UI-PRMD was recorded with a "
                            "Kinect v2: give a kinect_v2 profile")
    episodes, unreadable = readable_episodes(find_episodes(dataset, subjects, movements, incorrect=incorrect, limit=limit),
                                           jobs=jobs)
    for name, why in unreadable.items():
        say(f"left out {name}: {why}")
    if not episodes:
        raise BadInputError(f"{dataset}: no readable episode of the subjects and movements asked for")
    ratios = clock_ratios(episodes, jobs=jobs)
    say("clock ratios (optical / Kinect), per subject and movement:\n" + ratios.text())
    used: str | dict[str, str] = profile
    written: list[Path] = []
    if parts:
        with tqdm(total=len(episodes), desc="landmark offsets", unit="episode", leave=False) as bar:
            offsets = collect_offsets(episodes, rate_ratios=ratios, jobs=jobs, progress=bar.update)
        fits = {None: fit_arm_bias(offsets)}
        if leave_one_out:
            fits.update({s: fit_arm_bias(offsets, exclude=s) for s in ratios.subjects})
        out.mkdir(parents=True, exist_ok=True)
        paths = {}
        for left_out, arm in fits.items():
            paths[left_out] = out / ("profile_fitted.toml" if left_out is None else
                                     f"profile_fitted_without_{left_out}.toml")
            write_text_atomic(paths[left_out], profile_to_toml(with_arm_bias(base, arm, command, parts)))
            written.append(paths[left_out])
        used = {s: str(paths[s if leave_one_out else None]) for s in ratios.subjects}
    with tqdm(total=len(episodes), desc="angle-validate", unit="episode", leave=False) as bar:
        results = validate_episodes(episodes, profile=used, seeds=seeds, rate_ratios=ratios, jobs=jobs,
                                    progress=bar.update)
    label = base.name + (f" + {' and '.join(parts)} bias fitted "
                         + ("without each subject" if leave_one_out else "on these subjects") if parts else "")
    written += write_report(results, out, command, label, ratios, unreadable)
    return Validation(results, ratios, written, unreadable)
