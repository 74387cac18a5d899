"""The camera-layout search: screen, optimiser, re-evaluation of the best layouts with fresh seeds.

1. :func:`scenarios.plan.screen.screen` keeps the candidate places that see the key joints.
2. Optuna's TPE sampler (seeded with ``room.seed``) proposes layouts: a camera count within the
   room's range, a kept place per camera and an aim height per camera (which sets the tilt; the pan
   always points at the subject). Trials are asked in batches of :data:`BATCH` (fixed, so the
   sequence of proposals does not depend on the cluster); every (layout, seed) session of a batch
   is one task of a Dask sweep; a layout proposed again is told its earlier score. All layouts share the same ``search.seeds`` seeds (common random
   numbers), so differences between layouts are not differences between noise draws.
3. The best layout of each camera count and the room's reference layouts are simulated again with
   ``search.final_seeds`` fresh seeds; these sessions give the reported means and 90 % intervals.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import stats

from fusion.errors import BadInputError
from scenarios.plan.objectives import OBJECTIVES, Layout, evaluate_layout, score
from scenarios.plan.room import Reference, Room
from scenarios.plan.screen import ScreenResult, screen
from scenarios.sweep import SweepOptions, open_sweep, task_seeds

BATCH = 4
"""Layouts proposed per optimiser step."""


@dataclass(frozen=True)
class LayoutResult:
    """One layout and its sessions.

    Attributes
    ----------
    name : ``trial N`` or a reference's name.
    layout : cameras as (x, y, z, aim height) in the room frame [m].
    sessions : per seed, the objectives of :func:`scenarios.plan.objectives.evaluate_layout`.
    scores : (S,) weighted score of each session.
    """

    name: str
    layout: Layout
    sessions: tuple[dict[str, Any], ...]
    scores: tuple[float, ...]

    @property
    def score(self) -> float:
        """Mean score over the sessions (lower is better)."""
        return float(np.mean(self.scores))

    def interval(self, key: str | None = None, level: float = 0.9) -> tuple[float, float, float]:
        """Mean and two-sided ``level`` t-interval of an objective (or of the score) over the sessions."""
        v = np.array(self.scores if key is None else [s[key] for s in self.sessions], dtype=float)
        v = v[np.isfinite(v)]
        if v.size == 0:
            return (float("nan"),) * 3
        mean = float(v.mean())
        if v.size < 2:
            return mean, float("nan"), float("nan")
        half = float(stats.t.ppf(0.5 + level / 2, v.size - 1) * v.std(ddof=1) / np.sqrt(v.size))
        return mean, mean - half, mean + half

    @property
    def failed(self) -> int:
        """Sessions whose calibration or fusion failed."""
        return sum(s["error"] is not None for s in self.sessions)

    def to_dict(self) -> dict[str, Any]:
        """Plain types for ``plan.json``."""
        return {"name": self.name, "layout": [list(c) for c in self.layout], "score": self.score,
                "interval_90": list(self.interval()[1:]), "sessions": list(self.sessions),
                "scores": list(self.scores),
                "objectives": {k: list(self.interval(k)) for k in OBJECTIVES}}


@dataclass(frozen=True)
class PlanResult:
    """Everything the planner measured (see the module docstring)."""

    room: Room
    screen: ScreenResult
    trials: tuple[LayoutResult, ...]
    finals: tuple[LayoutResult, ...]
    references: tuple[LayoutResult, ...]

    @property
    def ranked(self) -> list[LayoutResult]:
        """Searched layouts, best (lowest mean score) first."""
        return sorted(self.trials, key=lambda r: (r.score, r.name))


def reference_layout(room: Room, ref: Reference) -> Layout:
    """A reference ring (subject frame) as room-frame cameras."""
    from fusion.transforms import apply, invert

    a = np.radians(ref.angles_deg)
    p_world = np.column_stack([ref.radius_m * np.cos(a), ref.radius_m * np.sin(a), np.full(a.size, ref.height_m)])
    p_room = apply(invert(room.T_world_room), p_world)
    return tuple((float(x), float(y), float(z), float(ref.aim_height_m)) for x, y, z in p_room)


def _propose(trial: Any, room: Room, places: np.ndarray) -> Layout | None:
    """A layout from an optuna trial; None when two cameras share a place."""
    c = room.cameras
    n = trial.suggest_int("cameras", c.min, c.max)
    lo, hi = room.search.aim_height_m
    chosen = [trial.suggest_categorical(f"place_{i}", list(range(len(places)))) for i in range(n)]
    aims = [trial.suggest_float(f"aim_{i}", lo, hi) for i in range(n)]
    if len(set(chosen)) < n:
        return None
    return tuple((*map(float, places[k]), round(float(aim), 3)) for k, aim in zip(chosen, aims))


def _key(layout: Layout) -> Layout:
    """The layout with its cameras in a canonical order (camera numbering does not matter)."""
    return tuple(sorted(layout))


def _evaluate(room: Room, layouts: list[tuple[str, Layout]], seeds: list[int], sweep: Any, desc: str
              ) -> list[LayoutResult]:
    tasks = [(room, layout, s) for _, layout in layouts for s in seeds]
    sessions = sweep.map(evaluate_layout, tasks, desc=desc)
    out = []
    for k, (name, layout) in enumerate(layouts):
        own = tuple(sessions[k * len(seeds):(k + 1) * len(seeds)])
        out.append(LayoutResult(name, layout, own, tuple(score(room, s) for s in own)))
    return out


def plan_layouts(room: Room, *, sweep: SweepOptions = SweepOptions(),
                 progress: Callable[[str], None] | None = None) -> PlanResult:
    """Plan the cameras of ``room`` (see the module docstring).

    Parameters
    ----------
    room : the planning problem.
    sweep : where the simulated sessions run (:mod:`scenarios.sweep`); the result does not depend on it.
    progress : called with a short message after each stage and optimiser step.

    Returns
    -------
    PlanResult
    """
    import optuna

    if not isinstance(room, Room):
        raise BadInputError(f"room must be a Room, got {type(room).__name__}")
    tell = progress or (lambda msg: None)
    screened = screen(room)
    kept = screened.kept_indices
    if kept.size < room.cameras.min:
        raise BadInputError(f"only {kept.size} candidate places see at least {room.search.min_visible:.0%} of the key "
                            f"joints, fewer than the {room.cameras.min} cameras needed: lower search.min_visible "
                            "or add mount regions")
    places = screened.places_room[kept]
    tell(f"screen: {kept.size} of {screened.visible.size} places kept")
    all_seeds = task_seeds(room.room.seed, room.search.seeds + room.search.final_seeds)
    search_seeds, final_seeds = all_seeds[:room.search.seeds], all_seeds[room.search.seeds:]
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(direction="minimize", sampler=optuna.samplers.TPESampler(seed=room.room.seed))
    trials: list[LayoutResult] = []
    scored: dict[Layout, float] = {}  # a layout proposed again is not simulated again
    with open_sweep(sweep) as runner:
        while len(study.trials) < room.search.trials:
            batch, fresh = [], {}
            for _ in range(min(BATCH, room.search.trials - len(study.trials))):
                trial = study.ask()
                layout = _propose(trial, room, places)
                if layout is None:
                    study.tell(trial, state=optuna.trial.TrialState.FAIL)
                    continue
                batch.append((trial, _key(layout)))
                if batch[-1][1] not in scored:
                    fresh.setdefault(batch[-1][1], (f"trial {trial.number}", layout))
            results = _evaluate(room, list(fresh.values()), search_seeds, runner,
                                f"plan {len(study.trials)}/{room.search.trials}")
            scored.update({key: r.score for key, r in zip(fresh, results)})
            for trial, key in batch:
                study.tell(trial, scored[key])
            trials += results
            tell(f"{len(study.trials)} of {room.search.trials} trials")
        ranked = sorted(trials, key=lambda r: (r.score, r.name))
        best = {}
        for r in ranked:
            best.setdefault(len(r.layout), r)
        finals = _evaluate(room, [(f"best {n} cameras ({r.name})", r.layout) for n, r in sorted(best.items())],
                           final_seeds, runner, "final")
        refs = _evaluate(room, [(ref.name, reference_layout(room, ref)) for ref in room.references], final_seeds,
                         runner, "references")
    tell("final sessions")
    return PlanResult(room, screened, tuple(trials), tuple(finals), tuple(refs))
