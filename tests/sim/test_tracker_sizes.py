"""The tracker's camera scale and the bone lengths its cameras share."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fusion.camera import KINECT_V2_DEPTH
from fusion.errors import BadInputError
from fusion.merge.camera_sizes import SIZE_BONES, size_agreement
from fusion.recording import CameraRecording, Recording
from fusion.topology import KINECT_V2
from sim.tracker_bones import hold_bone_lengths
from sim.tracker_noise import TrackerNoise
from tests.sim.test_tracker import front_camera, quiet, run


def _two_cameras(**tracker) -> tuple[Recording, np.ndarray]:
    """Two cameras 60 deg apart, a view bias and no other error, each bone held at a length (rigidity 1)."""
    noise = dataclasses.replace(quiet(TrackerNoise(), jitter_m=0.0, wobble_m=0.0, bone_rigidity=1.0),
                                model_fraction=0.0, hip_up_m=0.0, hip_out_m=0.0, **tracker)
    cams, P = [], None
    for k, angle in enumerate((-30.0, 30.0)):
        stream, _, P, _ = run(KINECT_V2, np.zeros(120), noise, seed=k, camera=front_camera(2.5, angle, f"c{k}"))
        cams.append(CameraRecording(f"c{k}", KINECT_V2_DEPTH, stream))
    return Recording(tuple(cams), {}), P


def _true_lengths(P: np.ndarray) -> np.ndarray:
    return np.array([np.linalg.norm(P[0, KINECT_V2.index(b)] - P[0, KINECT_V2.index(a)]) for a, b in SIZE_BONES])


def _lengths(rec: Recording, camera: str) -> np.ndarray:
    p = rec.camera(camera).skeleton.positions
    return np.array([np.median(np.linalg.norm(p[:, KINECT_V2.index(b)] - p[:, KINECT_V2.index(a)], axis=-1))
                     for a, b in SIZE_BONES])


def test_each_camera_holds_its_own_proportions_unless_they_are_shared():
    own, P = _two_cameras()
    assert size_agreement(own, "c0")[1] > 0.01  # the view bias moved each camera's bones its own way
    shared, _ = _two_cameras(shared_bone_lengths=1.0)
    assert size_agreement(shared, "c0")[1] < 1e-6
    for cam in ("c0", "c1"):
        np.testing.assert_allclose(_lengths(shared, cam), _true_lengths(P), rtol=1e-6)


def test_a_camera_scale_scales_every_bone_alike():
    rec, P = _two_cameras(shared_bone_lengths=1.0, camera_scale_sd=0.05)
    for cam in ("c0", "c1"):
        assert np.ptp(np.log(_lengths(rec, cam) / _true_lengths(P))) < 1e-3  # one factor for the whole skeleton
    assert size_agreement(rec, "c0")[0] > 0.01


def test_hold_bone_lengths_without_a_share_ignores_the_truth():
    rng = np.random.default_rng(1)
    pos = rng.normal(size=(50, KINECT_V2.n_joints, 3))
    reported = np.ones(pos.shape[:2], dtype=bool)
    plain = hold_bone_lengths(pos, reported, KINECT_V2, 0.7)
    np.testing.assert_array_equal(hold_bone_lengths(pos, reported, KINECT_V2, 0.7, truth=2 * pos, shared=0.0), plain)


@pytest.mark.parametrize("changes", [{"camera_scale_sd": -0.01}, {"camera_scale_sd": 0.3}, {"shared_bone_lengths": 1.5}])
def test_size_parameters_are_bounded(changes):
    with pytest.raises(BadInputError, match="camera_scale_sd"):
        TrackerNoise(**changes)
