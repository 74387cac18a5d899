"""The camera-layout search: screen, optimiser, re-evaluation of the best layouts with fresh seeds.

1. :func:`scenarios.plan.screen.screen` keeps the candidate places that see the key joints.
2. Optuna's TPE sampler (seeded with ``room.seed``) proposes layouts: a camera count within the
   room's range, a kept place per camera and an aim height per camera (which sets the tilt; the pan
   always points at the subject). Trials are asked in batches of :data:`BATCH` (fixed, so the
   sequence of proposals does not depend on the cluster); every (layout, seed) session of a batch
   is one task of a Dask sweep; a layout proposed again is told its earlier score. All layouts share the same ``search.seeds`` seeds (common random
   numbers), so differences between layouts are not differences between noise draws.
   Degenerate layouts (:func:`scenarios.plan.rules.degenerate_reason`: two cameras too close, or
   nearly in line as seen from the patient) and layouts repeating a place are refused before they
   are simulated and do not count against ``search.trials`` (up to :data:`PROPOSALS_PER_TRIAL`
   proposals per trial).
3. The best layout of each camera count, the room's reference layouts and the user's own layouts
   (``evaluate``) are simulated again with ``search.final_seeds`` fresh seeds, the same for all;
   these sessions give the reported means and 90 % bootstrap intervals. With ``search.trials = 0``
   only the user's layouts (and the references) are scored.
4. The final layouts are scored again with each further sensor asked for, and the best one in an
   ablation (tracker noise off, depth noise off when the room simulates depth, every other built-in
   sensor) that shows what dominates its expected error.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from fusion.errors import BadInputError, BenchError
from scenarios.config import NoiseLevel
from scenarios.plan.objectives import (
    CLINICAL,
    FAILURE_PENALTY,
    OBJECTIVES,
    Layout,
    evaluate_layout,
    score,
)
from scenarios.plan.room import BUILTIN_SENSORS, Reference, Room
from scenarios.plan.rules import bootstrap_interval, degenerate_reason, overlap_warning
from scenarios.plan.screen import ScreenResult, screen
from scenarios.sweep import SweepOptions, open_sweep, task_seeds

BATCH = 4
"""Layouts proposed per optimiser step."""


PROPOSALS_PER_TRIAL = 10
"""The search stops after this many proposals per trial of the budget, valid or not."""


class NoValidLayoutError(BenchError):
    """The search found no layout whose sessions calibrate (every proposal degenerate or failed)."""


@dataclass(frozen=True)
class LayoutResult:
    """One layout and its sessions.

    Attributes
    ----------
    name : ``trial N``, ``best N cameras (...)``, a reference's name or a user layout's name.
    layout : cameras as (x, y, z, aim height) in the room frame [m].
    sessions : per seed, the objectives of :func:`scenarios.plan.objectives.evaluate_layout`.
    scores : (S,) weighted score of each session.
    sensor : the sensor profile of the sessions.
    note : what else differs (an ablation's switch) or what is wrong with the layout ("" if nothing).
    """

    name: str
    layout: Layout
    sessions: tuple[dict[str, Any], ...]
    scores: tuple[float, ...]
    sensor: str = ""
    note: str = ""

    @property
    def score(self) -> float:
        """Mean score over the sessions (lower is better)."""
        return float(np.mean(self.scores))

    def interval(self, key: str | None = None, level: float = 0.9) -> tuple[float, float, float]:
        """Mean and two-sided ``level`` bootstrap interval (:func:`scenarios.plan.rules.bootstrap_interval`)
        of an objective (or of the score) over the sessions; the resamples are seeded by the sessions' seeds."""
        v = self.scores if key is None else [s[key] for s in self.sessions]
        rng = np.random.default_rng([int(s["seed"]) for s in self.sessions])
        return bootstrap_interval(v, rng=rng, level=level)

    @property
    def failed(self) -> int:
        """Sessions whose calibration or fusion failed."""
        return sum(s["error"] is not None for s in self.sessions)

    def to_dict(self) -> dict[str, Any]:
        """Plain types for ``plan.json``."""
        return {"name": self.name, "sensor": self.sensor, "note": self.note,
                "layout": [list(c) for c in self.layout], "score": self.score,
                "interval_90": list(self.interval()[1:]), "sessions": list(self.sessions),
                "scores": list(self.scores),
                "objectives": {k: list(self.interval(k)) for k in (*OBJECTIVES, *CLINICAL)}}


@dataclass(frozen=True)
class PlanResult:
    """Everything the planner measured (see the module docstring)."""

    room: Room
    screen: ScreenResult
    trials: tuple[LayoutResult, ...]
    finals: tuple[LayoutResult, ...]
    references: tuple[LayoutResult, ...]
    evaluated: tuple[LayoutResult, ...] = ()
    sensors: tuple[LayoutResult, ...] = ()
    ablation: tuple[LayoutResult, ...] = ()
    warnings: tuple[str, ...] = ()
    refused: int = 0
    """Proposals the search refused before simulating them (degenerate or repeating a place)."""

    @property
    def ranked(self) -> list[LayoutResult]:
        """Searched layouts, best (lowest mean score) first."""
        return sorted(self.trials, key=lambda r: (r.score, r.name))

    @property
    def recommended(self) -> list[LayoutResult]:
        """The final layouts and the user's layouts (room's sensor), best (lowest mean score) first."""
        return sorted((*self.finals, *self.evaluated), key=lambda r: (r.score, r.name))


def reference_layout(room: Room, ref: Reference) -> Layout:
    """A reference ring (subject frame) as room-frame cameras."""
    from fusion.transforms import apply, invert

    a = np.radians(ref.angles_deg)
    p_world = np.column_stack([ref.radius_m * np.cos(a), ref.radius_m * np.sin(a), np.full(a.size, ref.height_m)])
    p_room = apply(invert(room.T_world_room), p_world)
    return tuple((float(x), float(y), float(z), float(ref.aim_height_m)) for x, y, z in p_room)


def degenerate(room: Room, layout: Layout) -> str | None:
    """Why ``layout`` is degenerate in ``room`` (:func:`scenarios.plan.rules.degenerate_reason`), or None."""
    aim = float(np.mean([c[3] for c in layout]))
    return degenerate_reason(np.array([*room.subject.position_m, aim]), np.array([c[:3] for c in layout]))


def _propose(trial: Any, room: Room, places: np.ndarray) -> Layout | None:
    """A layout from an optuna trial; None when two cameras share a place or the layout is degenerate."""
    c = room.cameras
    n = trial.suggest_int("cameras", c.min, c.max)
    lo, hi = room.search.aim_height_m
    chosen = [trial.suggest_categorical(f"place_{i}", list(range(len(places)))) for i in range(n)]
    aims = [trial.suggest_float(f"aim_{i}", lo, hi) for i in range(n)]
    if len(set(chosen)) < n:
        return None
    layout = tuple((*map(float, places[k]), round(float(aim), 3)) for k, aim in zip(chosen, aims))
    return None if degenerate(room, layout) else layout


def _key(layout: Layout) -> Layout:
    """The layout with its cameras in a canonical order (camera numbering does not matter)."""
    return tuple(sorted(layout))


def _evaluate(room: Room, layouts: Sequence[tuple[str, Layout]], seeds: list[int], sweep: Any, desc: str,
              note: str = "") -> list[LayoutResult]:
    tasks = [(room, layout, s) for _, layout in layouts for s in seeds]
    sessions = sweep.map(evaluate_layout, tasks, desc=desc) if tasks else []
    out = []
    for k, (name, layout) in enumerate(layouts):
        own = tuple(sessions[k * len(seeds):(k + 1) * len(seeds)])
        out.append(LayoutResult(name, layout, own, tuple(score(room, s) for s in own), room.sensor_name,
                                note or (degenerate(room, layout) or "")))
    return out


def seed_warnings(trials: Sequence[LayoutResult]) -> list[str]:
    """A warning per search seed whose session failed for every one of at least two searched layouts:
    a property of that simulated session, not of the layouts (it shifts every score alike, so the
    ranking stands on the other seeds)."""
    if len(trials) < 2:
        return []
    out = []
    for k, session in enumerate(trials[0].sessions):
        errors = [r.sessions[k]["error"] for r in trials]
        if all(e is not None for e in errors):
            first = str(errors[0]).splitlines()[-1].strip()
            out.append(f"search seed {session['seed']} failed to calibrate with every one of the {len(trials)} searched "
                       f"layouts ({first}); the simulated session, not the layouts, fails: each searched score carries "
                       f"its {FAILURE_PENALTY:g} alike and the ranking rests on the other seeds")
    return out


def ablation_rooms(room: Room, scored: Sequence[str]) -> list[tuple[str, Room]]:
    """The variants of ``room`` the ablation scores: tracker noise off, depth noise off (only when the
    room simulates depth frames) and the first built-in sensor (by name) not in ``scored`` (kept cheap:
    the sensors asked for are scored in full anyway)."""
    sensor = room.sensor_name
    out = [("tracker noise off", room.with_sensor(sensor, tracker_noise=NoiseLevel.NONE))]
    if room.sensors.depth_rate_hz > 0:
        out.append(("depth noise off", room.with_sensor(sensor, depth_noise=NoiseLevel.NONE)))
    return out + [(f"sensor {p}", room.with_sensor(p)) for p in [p for p in BUILTIN_SENSORS if p not in scored][:1]]


def _search(room: Room, screened: ScreenResult, seeds: list[int], runner: Any, tell: Callable[[str], None]
            ) -> tuple[list[LayoutResult], int]:
    """Every layout the optimiser proposed, simulated with ``seeds`` (see the module docstring), and the
    number of proposals refused (degenerate or repeating a place)."""
    import optuna

    kept = screened.kept_indices
    if kept.size < room.cameras.min:
        raise BadInputError(f"only {kept.size} candidate places see at least {room.search.min_visible:.0%} of the key "
                            f"joints, fewer than the {room.cameras.min} cameras needed: lower search.min_visible "
                            "or add mount regions")
    places = screened.places_room[kept]
    tell(f"screen: {kept.size} of {screened.visible.size} places kept")
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(direction="minimize", sampler=optuna.samplers.TPESampler(seed=room.room.seed))
    trials: list[LayoutResult] = []
    scored: dict[Layout, float] = {}  # a layout proposed again is not simulated again
    budget = room.search.trials
    while (told := sum(t.state is optuna.trial.TrialState.COMPLETE for t in study.trials)) < budget \
            and len(study.trials) < PROPOSALS_PER_TRIAL * budget:
        batch, fresh = [], {}
        for _ in range(min(BATCH, budget - told)):
            trial = study.ask()
            layout = _propose(trial, room, places)
            if layout is None:
                study.tell(trial, state=optuna.trial.TrialState.FAIL)
                continue
            batch.append((trial, _key(layout)))
            if batch[-1][1] not in scored:
                fresh.setdefault(batch[-1][1], (f"trial {trial.number}", layout))
        results = _evaluate(room, list(fresh.values()), seeds, runner, f"plan {len(study.trials)}/{room.search.trials}")
        scored.update({key: r.score for key, r in zip(fresh, results)})
        for trial, key in batch:
            study.tell(trial, scored[key])
        trials += results
        tell(f"{told + len(batch)} of {budget} trials ({len(study.trials)} proposals)")
    if not any(r.failed < len(r.sessions) for r in trials):
        raise NoValidLayoutError(
            f"no valid layout in {len(study.trials)} proposals: {len(trials)} simulated, every session's calibration "
            f"failed, the other proposals repeated a place or were degenerate; raise the budget (--trials, "
            f"search.candidates_per_mount) or change the room (more or wider mount regions, lower search.min_visible)")
    return trials, sum(t.state is optuna.trial.TrialState.FAIL for t in study.trials)


def plan_layouts(room: Room, *, evaluate: Sequence[tuple[str, Layout]] = (), sensors: Sequence[str] = (),
                 ablation: bool = True, sweep: SweepOptions = SweepOptions(),
                 progress: Callable[[str], None] | None = None) -> PlanResult:
    """Plan the cameras of ``room`` (see the module docstring).

    Parameters
    ----------
    room : the planning problem (its ``[sensors]`` profile is the sensor searched with).
    evaluate : the user's own layouts as (name, layout), scored beside the search's best.
    sensors : further sensor profiles (built-in names or paths) the final layouts are scored with.
    ablation : score the best final layout in the ablation (module docstring, step 4).
    sweep : where the simulated sessions run (:mod:`scenarios.sweep`); the result does not depend on it.
    progress : called with a short message after each stage and optimiser step.

    Returns
    -------
    PlanResult

    Raises
    ------
    BadInputError
        Not a room, too few places pass the screen, or nothing to score (no trials and no layouts).
    NoValidLayoutError
        Every searched layout failed or was refused.
    """
    if not isinstance(room, Room):
        raise BadInputError(f"room must be a Room, got {type(room).__name__}")
    if room.search.trials == 0 and not evaluate:
        raise BadInputError("search.trials = 0 scores only the given layouts, and none was given: pass --evaluate "
                            "RIG.toml or a budget of at least one trial")
    tell = progress or (lambda msg: None)
    screened = screen(room)
    all_seeds = task_seeds(room.room.seed, room.search.seeds + room.search.final_seeds)
    search_seeds, final_seeds = all_seeds[:room.search.seeds], all_seeds[room.search.seeds:]
    with open_sweep(sweep) as runner:
        trials, refused = _search(room, screened, search_seeds, runner, tell) if room.search.trials else ([], 0)
        best: dict[int, LayoutResult] = {}
        for r in sorted(trials, key=lambda r: (r.score, r.name)):
            best.setdefault(len(r.layout), r)
        finals = _evaluate(room, [(f"best {n} cameras ({r.name})", r.layout) for n, r in sorted(best.items())],
                           final_seeds, runner, "final")
        refs = _evaluate(room, [(ref.name, reference_layout(room, ref)) for ref in room.references], final_seeds,
                         runner, "references")
        own = _evaluate(room, list(evaluate), final_seeds, runner, "evaluate")
        tell("final sessions")
        chosen = [(r.name, r.layout) for r in (*finals, *own)]
        others = [r for p in dict.fromkeys(sensors) if p != room.sensor_name
                  for r in _evaluate(room.with_sensor(p), chosen, final_seeds, runner, f"sensor {p}")]
        top = sorted((*finals, *own), key=lambda r: (r.score, r.name))[:1]
        ablated = [r for label, variant in (ablation_rooms(room, [room.sensor_name, *sensors]) if ablation and top
                                            else [])
                   for r in _evaluate(variant, [(top[0].name, top[0].layout)], final_seeds, runner, label, label)]
    warnings = [*seed_warnings(trials), overlap_warning([r.name for r in (*finals, *own)],
                                                      [r.interval() for r in (*finals, *own)])]
    return PlanResult(room, screened, tuple(trials), tuple(finals), tuple(refs), tuple(own), tuple(others),
                      tuple(ablated), tuple(w for w in warnings if w), refused)
