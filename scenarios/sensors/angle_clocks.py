"""How fast a data set's Kinect clock ran against its optical one, per subject and movement
(:func:`clock_ratios`, used by ``mocap-bench angle-validate``).

UI-PRMD's Kinect frames carry no times and are read at the nominal 30 Hz. Where the Kinect dropped
frames or ran slower, its episodes are shorter than their optical ones and the two elevation traces
only agree once the Kinect's clock is stretched. How much differs between one subject's movements,
each recorded in a session of its own: s01's abduction episodes (m07) fit at a ratio of about 1.6
(the optical trace's time above half its range is 1.54-1.73 times the Kinect's in its first five
episodes), its scaption episodes (m10) at about 0.9 (0.87-0.99), while the other subjects' movements
lie within 0.85-1.1. So the ratio is estimated per subject and movement, from several episodes (one
clock per recording session), not per episode, where a free ratio would also absorb the tracker's
errors.

A movement whose arm hardly rises (internal-external rotation, m09: the optical elevation spans 7-25
deg) cannot fix a ratio: stretching a flat trace keeps raising its correlation, and the ratios found
scatter over the whole search range. It borrows the median of the subject's other movements.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

import numpy as np
from joblib import Parallel, delayed

from fusion.io.formats.ui_prmd import read_ui_prmd_kinect
from fusion.merge.angles import joint_angles
from fusion.merge.episode_alignment import align_episodes, moving_side
from scenarios.sensors.angle_replica import replica_trajectory

RATE_RATIOS = np.round(np.arange(0.6, 1.6001, 0.025), 3)
"""Candidate ratios of the optical clock's rate to the Kinect's."""
CLOCK_EPISODES = 3
"""Episodes per subject and movement (the lowest numbers) that :func:`clock_ratios` looks at."""
MIN_RANGE_DEG = 30.0
"""Least range of the optical reference's moving-arm elevation [deg] for an episode to fix a ratio."""


class Episode(Protocol):
    """What the clocks read of an episode (:class:`scenarios.sensors.angle_validate.Episode`)."""

    subject: str
    movement: str
    number: int
    kinect: Path
    vicon: Path


@dataclass(frozen=True)
class ClockRatios:
    """Per subject and movement, the ratio of the optical clock's rate to the Kinect's (a Kinect sample
    at ``t`` on its own clock is the moment ``ratio * t + shift`` of the optical clock).

    Attributes
    ----------
    ratios : subject -> movement -> ratio.
    borrowed : the (subject, movement) pairs whose own episodes could not fix a ratio: theirs is the
        median of the subject's other movements (1 if none could).
    """

    ratios: Mapping[str, Mapping[str, float]]
    borrowed: frozenset[tuple[str, str]] = frozenset()

    @property
    def subjects(self) -> list[str]:
        """The subjects, sorted."""
        return sorted(self.ratios)

    def of(self, episode: Episode) -> float:
        """The ratio of ``episode``'s subject and movement (1 when unknown)."""
        return float(self.ratios.get(episode.subject, {}).get(episode.movement, 1.0))

    def as_dict(self) -> dict[str, dict[str, float]]:
        """``{subject: {movement: ratio}}`` for ``results.json``."""
        return {s: {m: float(r) for m, r in sorted(by.items())} for s, by in sorted(self.ratios.items())}

    def text(self) -> str:
        """One line per subject: ``s01: m07 1.600 (at the search's end), m09 1.150 (borrowed), ...``; a ratio
        at either end of :data:`RATE_RATIOS` may lie beyond it (stretching one trace keeps raising the
        correlation where the other covers part of the motion: check such a movement's traces)."""
        def note(s: str, m: str, r: float) -> str:
            if (s, m) in self.borrowed:
                return " (borrowed)"
            return " (at the search's end)" if np.isclose(r, RATE_RATIOS[[0, -1]]).any() else ""
        return "\n".join(f"{s}: " + ", ".join(f"{m} {r:.3f}{note(s, m, r)}" for m, r in sorted(self.ratios[s].items()))
                         for s in self.subjects)


def episode_ratio(episode: Episode) -> tuple[float, float]:
    """(ratio of :data:`RATE_RATIOS` that best aligns the episode's elevation traces, NaN when they do not
    align; the optical moving arm's elevation range [deg])."""
    _, reference = replica_trajectory(episode.vicon)
    kinect = read_ui_prmd_kinect(episode.kinect).cameras[0].skeleton
    angles = joint_angles(reference.positions, reference.topology)
    side = moving_side(angles["ht_elevation_left"], angles["ht_elevation_right"])
    elevation = angles[f"ht_elevation_{side}"]
    span = float(np.nanmax(elevation) - np.nanmin(elevation)) if np.isfinite(elevation).any() else 0.0
    alignment = align_episodes(reference, kinect, rate_ratios=RATE_RATIOS, side=side)
    return (alignment.rate_ratio if alignment.ok else float("nan")), span


def clock_ratios(episodes: Sequence[Episode], *, jobs: int = 1) -> ClockRatios:
    """:class:`ClockRatios` of the episodes' subjects and movements (module docstring): per subject and
    movement the median of :func:`episode_ratio` over its episodes numbered up to :data:`CLOCK_EPISODES`
    whose optical elevation spans at least :data:`MIN_RANGE_DEG`."""
    sample = [e for e in episodes if e.number <= CLOCK_EPISODES]
    found = Parallel(n_jobs=jobs)(delayed(episode_ratio)(e) for e in sample)
    ratios: dict[str, dict[str, float]] = {}
    borrowed = set()
    for subject in sorted({e.subject for e in episodes}):
        own = {}
        for movement in sorted({e.movement for e in episodes if e.subject == subject}):
            good = [r for e, (r, span) in zip(sample, found)
                    if e.subject == subject and e.movement == movement and np.isfinite(r) and span >= MIN_RANGE_DEG]
            own[movement] = float(np.median(good)) if good else float("nan")
        fixed = [r for r in own.values() if np.isfinite(r)]
        fallback = float(np.median(fixed)) if fixed else 1.0
        borrowed |= {(subject, m) for m, r in own.items() if not np.isfinite(r)}
        ratios[subject] = {m: (r if np.isfinite(r) else fallback) for m, r in own.items()}
    return ClockRatios(ratios, frozenset(borrowed))
