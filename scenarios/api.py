"""The public Python API: scenarios in code, sessions simulated in memory, the project's calibration and
fusion as functions, and scorers against the truth.

Everything a script or another project's test suite needs is importable from here; the command line
runs these same functions. Names in ``__all__`` are stable within a minor version.

```python
from scenarios import api
scenario = api.scenario("fma_2cam", seed=3, duration_s=20)
session = api.simulate(scenario)                      # skeletons only, nothing written to disk
run = api.calibrate(session.recording, seed=3)        # the project's body calibration
api.score_calibration(run.calibration, session.truth).summary()["rotation_error_deg"]["max"]
```

Bring your own algorithm (see :func:`load_algorithm`): a **calibration** is called as
``fn(recording, rng=rng)`` and returns a :class:`~fusion.calibration.Calibration` or a mapping camera name
-> ``(4, 4)`` pose in any common frame (``T_world_cam``; only relative poses are scored); a **fusion** is
called as ``fn(recording, calibration)`` and returns ``(T, J, 3)`` joint positions [m] in the
calibration's world frame on the reference camera's frames (NaN where a joint is missing).
"""

from __future__ import annotations

import dataclasses
import importlib
import importlib.util
import sys
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fusion.calibrate.floor import GaugeMode
from fusion.calibrate.options import CalibrationOptions
from fusion.calibrate.results import RigCalibration, calibration_from_rig
from fusion.calibrate.sessions import calibrate_sessions
from fusion.calibration import Calibration
from fusion.errors import BadInputError, BenchError
from fusion.merge.fuse import Fit, FuseOptions, camera_views, fuse_views
from fusion.merge.methods import MergedSkeleton
from fusion.merge.metrics import Stats
from fusion.recording import Recording
from fusion.topology import Topology
from fusion.transforms import validate_transform
from scenarios.config import (
    CameraConfig,
    NoiseLevel,
    RigConfig,
    Scenario,
    SegmentConfig,
    SensorConfig,
    SubjectConfig,
    load_scenario,
    scenario_toml,
)
from scenarios.evaluate import CalibrationScores
from scenarios.evaluate import score_calibration as _score_poses
from scenarios.skeleton_eval import skeleton_errors
from sim.truth import GroundTruth

__all__ = [
    "Calibration", "CalibrationOptions", "CalibrationRun", "CalibrationScores", "CameraConfig", "FuseOptions",
    "GaugeMode", "GroundTruth", "NoiseLevel", "Recording", "RigConfig", "Scenario", "SegmentConfig", "SensorConfig", "Session",
    "SkeletonScores", "SubjectConfig", "calibrate", "calibration_from_poses", "fuse", "load_algorithm",
    "run_calibration_algorithm", "run_fusion_algorithm", "scenario", "scenario_toml", "score_calibration",
    "score_skeleton", "simulate", "true_calibration",
]


@dataclass(frozen=True, eq=False)
class Session:
    """A simulated session: what the sensors gave and what truly happened.

    Attributes
    ----------
    scenario : the scenario that made it (its seed included).
    recording : the observations, exactly as a real-sensor reader produces them.
    truth : true camera poses, clock offsets and joints; never an input of calibration or fusion.
    """

    scenario: Scenario
    recording: Recording
    truth: GroundTruth


@dataclass(frozen=True, eq=False)
class CalibrationRun:
    """The project's calibration of a rig: the storable calibration and every diagnostic."""

    calibration: Calibration
    rig: RigCalibration


@dataclass(frozen=True)
class SkeletonScores:
    """Errors of a fused skeleton against the truth.

    Attributes
    ----------
    joint_error_mm : distance of every joint and frame to the true joint [mm].
    angle_error_deg : angle name -> absolute error over all frames [deg] (ISB angles,
        :mod:`fusion.merge.angles`).
    raised_error_deg : arm angle name -> absolute error while that arm is raised (true elevation >= 30
        deg), both sides pooled [deg].
    """

    joint_error_mm: Stats
    angle_error_deg: dict[str, Stats]
    raised_error_deg: dict[str, Stats]


def scenario(name_or_path: str | Path = "fma_2cam", *, seed: int | None = None, duration_s: float | None = None,
             depth: bool = False, **changes: Any) -> Scenario:
    """A built-in scenario (``fma_2cam``, ``ring6``, ...) or a scenario TOML, with changes.

    Parameters
    ----------
    name_or_path : built-in name or path to a scenario TOML (:doc:`reference/scenarios`).
    seed, duration_s : replace the file's seed and session length [s] when given.
    depth : keep the file's depth frames (slow: a depth image per frame kept); default skeletons only.
    changes : other fields of :class:`~scenarios.config.Scenario` to replace (``rig=``, ``subject=``, ...).
    """
    s = load_scenario(name_or_path)
    if seed is not None:
        changes["seed"] = seed
    if duration_s is not None:
        changes["duration_s"] = duration_s
    s = s.replace(**changes)
    if not depth:
        s = s.replace(sensors=dataclasses.replace(s.sensors, depth_rate_hz=0.0))
    return s


def simulate(scenario: Scenario, *, progress: bool = False) -> Session:
    """Simulate ``scenario`` in memory (nothing is written). Same scenario and seed, identical arrays."""
    from scenarios.runner import simulate as run

    recording, truth = run(scenario, progress=progress)
    return Session(scenario, recording, truth)


def calibrate(recordings: Recording | Sequence[Recording], options: CalibrationOptions = CalibrationOptions(), *,
              seed: int = 0, progress: Callable[[str], None] | None = None) -> CalibrationRun:
    """The project's calibration from the body (what ``mocap-bench calibrate`` runs).

    Parameters
    ----------
    recordings : one session, or several sessions of one fixed rig calibrated together.
    options : methods (refinement, rig solver, skeleton fit, ...).
    seed : seed of the random sampling.
    progress : called with a short message after each step.
    """
    if isinstance(recordings, Recording):
        recordings = [recordings]
    rig = calibrate_sessions(list(recordings), options, rng=np.random.default_rng(seed), progress=progress)
    return CalibrationRun(calibration_from_rig(rig), rig)


def fuse(recording: Recording, calibration: Calibration, options: FuseOptions = FuseOptions(fit=Fit.KINEMATIC)
         ) -> MergedSkeleton:
    """The project's fusion of a calibrated recording: one skeleton stream in the world frame, on the
    reference camera's frames (default the kinematic fit; ``FuseOptions(method=...)`` merges per joint)."""
    return fuse_views(camera_views(recording, calibration, cross_check=options.cross_check), options)


def true_calibration(recording: Recording, truth: GroundTruth) -> Calibration:
    """The true camera poses and clock offsets as a calibration (isolates fusion from calibration)."""
    ref = truth.cameras[0]
    return Calibration(truth.T_world_cam(), {c.name: c.intrinsics for c in recording.cameras},
                       {c.name: c.clock_offset_s - ref.clock_offset_s for c in truth.cameras}, ref.name)


def calibration_from_poses(recording: Recording, T_world_cam: Mapping[str, np.ndarray],
                           reference: str | None = None) -> Calibration:
    """A calibration from camera poses alone: intrinsics from the recording, clock offsets zero.

    Raises
    ------
    BadInputError
        A camera of the recording has no pose, or a pose is not a rigid ``(4, 4)`` transform.
    """
    missing = [c.name for c in recording.cameras if c.name not in T_world_cam]
    if missing:
        raise BadInputError(f"the calibration has no pose for camera(s) {missing}; it must give one (4, 4) "
                            f"T_world_cam per camera of the recording {list(recording.camera_names)}")
    poses = {c.name: validate_transform(np.asarray(T_world_cam[c.name], dtype=float), f"T_world_cam of {c.name}")
             for c in recording.cameras}
    return Calibration(poses, {c.name: c.intrinsics for c in recording.cameras},
                       {c.name: 0.0 for c in recording.cameras}, reference or recording.cameras[0].name)


def score_calibration(calibration: Calibration, truth: GroundTruth) -> CalibrationScores:
    """Every camera's rotation and translation error against the truth, relative to the calibration's
    reference camera (gauge-free), and after bringing the world onto the true floor."""
    return _score_poses(calibration.T_world_cam, truth, calibration.reference)


def score_skeleton(positions: np.ndarray, calibration: Calibration, truth: GroundTruth, topology: Topology, *,
                   gauge: GaugeMode = GaugeMode.RIGID) -> SkeletonScores:
    """Errors of a fused skeleton (``(T, J, 3)`` [m], world frame of ``calibration``, reference camera's
    frames; ``topology``: the recording's, ``recording.topology``) against the true joints.

    The calibration's world is first brought onto the true one by the transform of its camera poses:
    any rigid one (``RIGID``, the default: skeleton-only sessions have no floor to hold the world), or
    only a turn about the vertical and a shift along the floor (``FLOOR``: also scores the floor found
    in depth).
    """
    err = skeleton_errors(np.asarray(positions, dtype=float), calibration.T_world_cam, truth, calibration.reference,
                          topology, gauge=gauge)

    def stats(d: dict[str, float]) -> Stats:
        return Stats(**{k: (int(v) if k == "n" else float(v)) for k, v in d.items()})

    raised = {k.removesuffix("_raised_error_deg"): stats(v) for k, v in err.items()
              if k.endswith("_raised_error_deg") and not k.endswith(("_left_raised_error_deg", "_right_raised_error_deg"))}
    angles = {k.removesuffix("_error_deg"): stats(v) for k, v in err.items()
              if k.endswith("_error_deg") and "_raised_" not in k}
    return SkeletonScores(stats(err["joint_error_mm"]), angles, raised)


def load_algorithm(spec: str) -> Callable[..., Any]:
    """The function named by ``package.module:function`` or ``path/to/file.py:function`` (the file's
    folder is then added to ``sys.path``, as running it with ``python`` would).

    Raises
    ------
    BadInputError
        The spec is malformed, the module cannot be imported, or it has no such callable.
    """
    module_name, sep, attr = spec.rpartition(":")
    if not sep or not module_name or not attr.isidentifier():
        raise BadInputError(f"--algorithm {spec!r}: give MODULE:FUNCTION, e.g. mypackage.calib:calibrate or "
                            "path/to/file.py:calibrate")
    try:
        if module_name.endswith(".py"):
            path = Path(module_name)
            if not path.is_file():
                raise BadInputError(f"--algorithm {spec!r}: no file {path}")
            if str(path.resolve().parent) not in sys.path:  # its sibling modules import as with `python FILE`
                sys.path.insert(0, str(path.resolve().parent))
            name = f"mocap_bench_algorithm_{path.stem}"
            module_spec = importlib.util.spec_from_file_location(name, path)
            module = importlib.util.module_from_spec(module_spec)
            sys.modules[name] = module
            module_spec.loader.exec_module(module)
        else:
            module = importlib.import_module(module_name)
    except ImportError as e:
        raise BadInputError(f"--algorithm {spec!r}: cannot import {module_name} ({e}); install the package, add its "
                            "folder to PYTHONPATH, or give a file path") from e
    fn = getattr(module, attr, None)
    if not callable(fn):
        raise BadInputError(f"--algorithm {spec!r}: {module_name} has no function {attr}")
    return fn


def _call(fn: Callable[..., Any], name: str, *args: Any, **kwargs: Any) -> Any:
    """``fn(*args, **kwargs)``; an exception raised inside a user's algorithm becomes a BadInputError naming it."""
    try:
        return fn(*args, **kwargs)
    except BenchError:
        raise
    except Exception as exc:  # noqa: BLE001 - any failure of the user's code is reported as such
        raise BadInputError(f"{name} raised {type(exc).__name__}: {exc}; fix the algorithm (its interface: "
                            "scenarios.api)") from exc


def run_calibration_algorithm(fn: Callable[..., Any], recording: Recording, *, rng: np.random.Generator,
                              name: str = "algorithm") -> Calibration:
    """Call a user's calibration (``fn(recording, rng=rng)``) and check what it returns.

    Raises
    ------
    BadInputError
        It returned neither a :class:`Calibration` nor a mapping of camera poses, or missed a camera.
    """
    out = _call(fn, name, recording, rng=rng)
    if isinstance(out, Calibration):
        missing = [c for c in recording.camera_names if c not in out.T_world_cam]
        if missing:
            raise BadInputError(f"{name} returned a calibration without camera(s) {missing}")
        return out
    if isinstance(out, Mapping):
        return calibration_from_poses(recording, out)
    raise BadInputError(f"{name} returned {type(out).__name__}; a calibration returns a Calibration or a mapping "
                        "camera name -> (4, 4) T_world_cam")


def run_fusion_algorithm(fn: Callable[..., Any], recording: Recording, calibration: Calibration, *,
                         cameras: Sequence[str] | None = None, name: str = "algorithm") -> np.ndarray:
    """Call a user's fusion (``fn(recording, calibration)``) on ``cameras`` (default all, in the recording's
    order) and check its result.

    The fusion sees only those cameras, their calibration and, as reference, the first of them.

    Returns
    -------
    np.ndarray
        ``(T, J, 3)`` world positions [m] on the frames of the first camera.

    Raises
    ------
    BadInputError
        The result has another shape than that camera's ``(T, J, 3)``.
    """
    names = list(recording.camera_names if cameras is None else cameras)
    sub = dataclasses.replace(recording, cameras=tuple(recording.camera(n) for n in names))
    calib = Calibration({n: calibration.pose(n) for n in names}, {n: calibration.intrinsics[n] for n in names},
                        {n: calibration.clock_offset_s[n] for n in names}, names[0], dict(calibration.info))
    shape = sub.cameras[0].skeleton.positions.shape
    out = np.asarray(_call(fn, name, sub, calib), dtype=float)
    if out.shape != shape:
        raise BadInputError(f"{name} returned an array of shape {out.shape}; a fusion returns {shape}: positions [m] "
                            f"on the frames of the reference camera {names[0]}")
    return out
