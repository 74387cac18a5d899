"""A simulated person's systematic tracker errors: the same person seed keeps the tracker's model bias and
each camera's view bias from session to session (tracker, session and scenario runner)."""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path

import numpy as np
import pytest

from fusion.topology import KINECT_V2
from fusion.transforms import apply, invert
from scenarios.config import scenario_from_dict
from scenarios.runner import build_simulation, simulate
from sim.sensor_profile import load_profile, profile_from_dict, profile_to_toml
from sim.session import simulate_session
from sim.tracker import track
from sim.tracker_model_bias import sample_model_bias
from sim.tracker_noise import TrackerNoise
from tests.sim.test_tracker import front_camera, world_joints

BIAS_ONLY = {"jitter_m": 0.0, "wobble_m": 0.0, "outlier_rate": 0.0, "low_confidence": (0.0, 0.0),
             "hidden_low_confidence": 0.0}
"""Group fields that leave a tracker with its static bias alone (no jitter, wobble, outliers, guesses)."""


def _bias_only(tracker: TrackerNoise) -> TrackerNoise:
    groups = {g: dataclasses.replace(n, **BIAS_ONLY) for g, n in tracker.groups.items()}
    return dataclasses.replace(tracker, groups=groups, flip_enabled=False)


def _still(seed: int = 0, extra: str = "") -> str:
    """A scenario document: the subject stands still for 3 s before the default two-camera ring."""
    return (f'[scenario]\nname = "still"\nseed = {seed}\n{extra}'
            '[[session.segment]]\nkind = "idle"\nduration_s = 3.0\n')


def _offsets(recording, truth) -> np.ndarray:
    """(C, J, 3) [m] per camera and joint the median reported minus true joint, in the camera frame."""
    out = []
    for cam, ct in zip(recording.cameras, truth.cameras, strict=True):
        true_cam = apply(invert(ct.T_world_cam), ct.joints_world)
        out.append(np.nanmedian(cam.skeleton.positions - true_cam, axis=0))
    return np.array(out)


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.nanmean(np.square(x))))


def test_track_takes_the_view_bias_from_view_rng() -> None:
    noise = _bias_only(load_profile("kinect_v2").tracker)
    yaw = np.zeros(30)
    P, ts, cam = world_joints(KINECT_V2, yaw), np.arange(30) / 30.0, front_camera()
    model = sample_model_bias(KINECT_V2, noise, rng=np.random.default_rng(0))

    def reported(seed: int, view: int | None) -> np.ndarray:
        view_rng = None if view is None else np.random.default_rng(view)
        stream, _ = track(P, yaw, ts, cam, KINECT_V2, noise, model, rng=np.random.default_rng(seed), view_rng=view_rng)
        return stream.positions

    np.testing.assert_array_equal(reported(1, 9), reported(2, 9))  # the session's stream does not matter
    assert _rms(reported(1, 9) - reported(1, 10)) > 0.005
    assert _rms(reported(1, None) - reported(2, None)) > 0.005  # without view_rng: the session's stream


@pytest.fixture(scope="module")
def still():
    sim = build_simulation(scenario_from_dict(tomllib.loads(_still())))
    sensors = dataclasses.replace(sim.sensors, tracker=_bias_only(sim.sensors.tracker), depth_rate_hz=0.0)
    return sim, sensors


def _session(still, seed: int, person_seed: int | None, sensors=None):
    sim, bias_only = still
    return simulate_session(sim.humanoid, sim.motion, sim.rig, sensors or bias_only, seed=seed, duration_s=3.0,
                            person_seed=person_seed)


def test_sessions_of_one_person_share_the_tracker_bias(still) -> None:
    a, b = (_offsets(*_session(still, seed, person_seed=5)) for seed in (1, 2))
    assert a.shape[0] == 2 and _rms(a) > 0.02  # the bias is there, some centimetres
    assert _rms(a - b) < 0.002  # only the clock's sampling of the still pose differs
    c, d = (_offsets(*_session(still, seed, person_seed=None)) for seed in (1, 2))
    assert _rms(c - d) > 10 * max(_rms(a - b), 1e-4)  # without a person: a new bias each session
    other = _offsets(*_session(still, 1, person_seed=6))
    assert _rms(a - other) > 0.02
    # each camera has its own view bias: the cameras' offsets differ (in each camera's frame)
    assert _rms(a[0] - a[1]) > 0.01


def test_person_seed_keeps_the_session_noise_of_the_seed(still) -> None:
    sim, _ = still
    sensors = dataclasses.replace(sim.sensors, depth_rate_hz=0.0)  # the profile's tracker, with jitter
    a, _ = _session(still, 1, person_seed=5, sensors=sensors)
    b, _ = _session(still, 2, person_seed=5, sensors=sensors)
    again, _ = _session(still, 1, person_seed=5, sensors=sensors)
    pa, pb = a.cameras[0].skeleton.positions, b.cameras[0].skeleton.positions
    n = min(len(pa), len(pb))
    assert not np.allclose(pa[:n], pb[:n], equal_nan=True)
    np.testing.assert_array_equal(pa, again.cameras[0].skeleton.positions)


def _profile(tmp_path: Path) -> Path:
    """The Kinect v2 profile with only its static bias, written to ``tmp_path``."""
    doc = tomllib.loads(profile_to_toml(load_profile("kinect_v2")))
    for group in doc["tracker"]["groups"].values():
        group.update({k: list(v) if isinstance(v, tuple) else v for k, v in BIAS_ONLY.items()})
    doc["tracker"]["flip_enabled"] = False
    path = tmp_path / "bias_only.toml"
    path.write_text(profile_to_toml(profile_from_dict(doc)))
    return path


def _scenario(seed: int, person_seed: int | None = None, profile: Path | None = None):
    sensors = "" if profile is None else f'profile = "{profile}"\ndepth_rate_hz = 0.0\n'
    sensors += "" if person_seed is None else f"person_seed = {person_seed}\n"
    return scenario_from_dict(tomllib.loads(_still(seed, f"[sensors]\n{sensors}" if sensors else "")))


def test_build_simulation_person_seed() -> None:
    assert build_simulation(_scenario(1, person_seed=5)).person_seed == 5
    assert build_simulation(_scenario(2, person_seed=5)).person_seed == 5
    assert build_simulation(_scenario(1, person_seed=0)).person_seed == 0
    own = [build_simulation(_scenario(seed)).person_seed for seed in (1, 1, 2, 3)]
    assert own[0] == own[1] and len(set(own[1:])) == 3  # from the scenario's seed
    assert all(isinstance(s, int) and s >= 0 for s in own)


def test_scenarios_with_one_person_seed_share_the_tracker_bias(tmp_path: Path) -> None:
    profile = _profile(tmp_path)
    a, b = (_offsets(*simulate(_scenario(seed, 5, profile), progress=False)) for seed in (1, 2))
    c, d = (_offsets(*simulate(_scenario(seed, None, profile), progress=False)) for seed in (1, 2))
    assert _rms(a) > 0.02
    assert _rms(a - b) < 0.002
    assert _rms(c - d) > 10 * max(_rms(a - b), 1e-4)
