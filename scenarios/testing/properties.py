"""Property checks for calibration and fusion whose failures say what failed, on which rig, and how to
reproduce it.

Inside a hypothesis test a failing check raises :class:`PropertyViolation`; hypothesis then shrinks the
drawn scenario and reports the smallest one that still fails, with this message: the rig, sensor and
seed in one line, the scenario as TOML, and the ``mocap-bench`` command that re-runs that one case.

```python
from hypothesis import given, settings
from scenarios import api
from scenarios.testing import properties, strategies as mb
@settings(max_examples=20, deadline=None)
@given(mb.scenarios(rig=mb.ring_rigs(2, 4)))
def test_within_bounds(scenario):
    session = api.simulate(scenario)
    calibration = my_calibration(session.recording)
    properties.check_calibration(calibration, session, max_rotation_deg=2, max_translation_mm=50,
                                 algorithm="mypackage.calib:my_calibration")
```
"""

from __future__ import annotations

import numpy as np

from scenarios.api import (
    Calibration,
    CalibrationScores,
    Scenario,
    Session,
    SkeletonScores,
    scenario_toml,
)
from scenarios.api import score_calibration as score_poses
from scenarios.api import score_skeleton as score_positions


class PropertyViolation(AssertionError):
    """A property of an algorithm does not hold on a scenario; the message says how to reproduce it."""


def describe(scenario: Scenario) -> str:
    """One line naming a scenario's rig, sensor, subject, motion and seed."""
    r, s, subj = scenario.rig, scenario.sensors, scenario.subject
    if r.camera:
        rig = f"{len(r.camera)} placed cameras at " + ", ".join(
            f"{c.name} ({', '.join(f'{v:.2f}' for v in c.position_m)}) m" for c in r.camera)
    else:
        n = len(r.angles_deg) if r.angles_deg is not None else r.n_cameras
        angles = "" if r.angles_deg is None else " at " + ", ".join(f"{a:.0f}" for a in r.angles_deg) + " deg"
        rig = (f"{n} cameras on a ring{angles}, radius {r.radius_m:.2f} m, height {r.height_m:.2f} m, "
               f"aimed at {r.target_height_m:.2f} m")
    sensor = (f"{s.profile or 'default'} sensor, tracker noise {s.tracker_noise.value}, clock offset sd "
              f"{s.clock_offset_sd_ms if s.clock_offset_sd_ms is not None else 'default'} ms, drops "
              f"{s.drop_probability if s.drop_probability is not None else 'default'}")
    motion = " + ".join(seg.kind.value for seg in scenario.session)
    return (f"{rig}; {sensor}; subject {subj.height_m:.2f} m {subj.build} {subj.group}; motion {motion}; "
            f"seed {scenario.seed}")


def reproduction(scenario: Scenario, *, algorithm: str | None = None, study: str = "calib-study") -> str:
    """Shell lines that write the scenario to ``repro.toml`` and re-run it in ``study`` (``calib-study``
    or ``angle-study``) with the user's algorithm beside the built-in methods."""
    algo = f" --algorithm {algorithm}" if algorithm else ""
    return (f"cat > repro.toml <<'EOF'\n{scenario_toml(scenario)}EOF\n"
            f"mocap-bench {study} repro.toml --seeds 1 --first-seed {scenario.seed}{algo} --out repro_{study}")


def _fail(what: str, scenario: Scenario, algorithm: str | None, study: str) -> None:
    raise PropertyViolation(f"{what}\non: {describe(scenario)}\nreproduce with:\n"
                            f"{reproduction(scenario, algorithm=algorithm, study=study)}")


def check_calibration(calibration: Calibration, session: Session, *, max_rotation_deg: float,
                      max_translation_mm: float, algorithm: str | None = None) -> CalibrationScores:
    """Every camera's pose relative to the reference within the bounds [deg, mm], or
    :class:`PropertyViolation` naming the worst camera. Returns the scores."""
    scores = score_poses(calibration, session.truth)
    others = [c for c in scores.cameras if c.name != scores.reference]
    rot = max(others, key=lambda c: c.rotation_error_deg, default=None)
    trans = max(others, key=lambda c: c.translation_error_mm, default=None)
    if rot is not None and not rot.rotation_error_deg <= max_rotation_deg:
        _fail(f"rotation error of {rot.name} {rot.rotation_error_deg:.3f} deg > {max_rotation_deg} deg",
              session.scenario, algorithm, "calib-study")
    if trans is not None and not trans.translation_error_mm <= max_translation_mm:
        _fail(f"translation error of {trans.name} {trans.translation_error_mm:.1f} mm > {max_translation_mm} mm",
              session.scenario, algorithm, "calib-study")
    return scores


def check_skeleton(positions: np.ndarray, calibration: Calibration, session: Session, *,
                   max_joint_error_mm: float, max_raised_angle_error_deg: float | None = None,
                   algorithm: str | None = None) -> SkeletonScores:
    """A fused skeleton's median joint error [mm] (and, if given, the median error of each arm angle
    while the arm is raised [deg]) within bounds, or :class:`PropertyViolation`. Returns the scores."""
    scores = score_positions(positions, calibration, session.truth, session.recording.topology)
    if not scores.joint_error_mm.median <= max_joint_error_mm:
        _fail(f"median joint error {scores.joint_error_mm.median:.1f} mm > {max_joint_error_mm} mm",
              session.scenario, algorithm, "angle-study")
    if max_raised_angle_error_deg is not None:
        for name, s in scores.raised_error_deg.items():
            if s.n and not s.median <= max_raised_angle_error_deg:
                _fail(f"median {name} error while raised {s.median:.1f} deg > {max_raised_angle_error_deg} deg",
                      session.scenario, algorithm, "angle-study")
    return scores
