"""Tracker errors leaning along the limb bones: the reshaping itself, and the tracker's view bias and noise
with it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fusion.errors import BadInputError
from fusion.merge.limb_sharing import limb_links
from fusion.topology import KINECT_V2
from sim.tracker_axes import bone_aligned
from sim.tracker_noise import TrackerNoise
from tests.sim.test_tracker import quiet, run


def _along_share(err: np.ndarray, P: np.ndarray, child: int, parent: int) -> float:
    """Share of the summed squared errors (T, 3) of ``child`` along its bone from ``parent`` (joints P (T, J, 3))."""
    axis = P[:, child] - P[:, parent]
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    return float(np.sum(np.sum(err * axis, axis=-1) ** 2) / np.sum(err**2))


def test_bone_aligned_reshapes_limb_joints_only() -> None:
    rng = np.random.default_rng(0)
    T, J = 4000, KINECT_V2.n_joints
    joints = rng.normal(size=(T, J, 3))
    v = rng.normal(size=(T, J, 3))
    links = limb_links(KINECT_V2)
    out = bone_aligned(v, joints, links, np.log(3.0))
    parent, child = links[0]
    assert _along_share(out[:, child], joints, child, parent) == pytest.approx(9 / 11, abs=0.03)  # q^2 / (q^2 + 2)
    assert np.mean(np.sum(out[:, child] ** 2, axis=-1)) == pytest.approx(3.0, rel=0.05)  # mean square kept
    others = np.setdiff1d(np.arange(J), links[:, 1])
    np.testing.assert_array_equal(out[:, others], v[:, others])
    np.testing.assert_allclose(bone_aligned(v, joints, links, 0.0), v, atol=1e-12)
    flat = joints.copy()
    flat[:, child] = flat[:, parent]  # a bone without length: left as it was
    np.testing.assert_array_equal(bone_aligned(v, flat, links, 1.0)[:, child], v[:, child])


def _errors(**tracker) -> tuple[np.ndarray, np.ndarray]:
    noise = dataclasses.replace(quiet(TrackerNoise(), jitter_m=0.01, wobble_m=0.0, bone_rigidity=0.0),
                                model_fraction=0.0, hip_up_m=0.0, hip_out_m=0.0, **tracker)
    stream, _, P, cam = run(KINECT_V2, np.zeros(600), noise, seed=4)
    world = stream.positions @ cam.T_world_cam[:3, :3].T + cam.T_world_cam[:3, 3]
    return world - P, P


def test_tracker_noise_and_view_bias_lean_along_the_bones() -> None:
    """With the noise aligned the elbow's frame-to-frame error runs along the upper arm; with the view bias
    aligned its steady error does; a joint that ends no limb bone keeps exactly the errors it had."""
    elbow, shoulder, spine = KINECT_V2.indices(["ElbowLeft", "ShoulderLeft", "SpineShoulder"])
    off, P = _errors()
    noisy, _ = _errors(noise_bone_alignment=1.5)
    viewed, _ = _errors(view_bone_alignment=1.5)
    def steps(e: np.ndarray) -> np.ndarray:  # the view bias is constant, the jitter is not
        return np.diff(e[:, elbow], axis=0)

    def steady(e: np.ndarray) -> np.ndarray:
        return e[:, elbow].mean(axis=0, keepdims=True)

    assert _along_share(steps(off), P[1:], elbow, shoulder) < 0.5
    assert _along_share(steps(noisy), P[1:], elbow, shoulder) > 0.8
    assert _along_share(steady(viewed), P[:1], elbow, shoulder) > _along_share(steady(off), P[:1], elbow, shoulder)
    np.testing.assert_array_equal(noisy[:, spine], off[:, spine])
    np.testing.assert_array_equal(viewed[:, spine], off[:, spine])


@pytest.mark.parametrize("key", ["view_bone_alignment", "noise_bone_alignment"])
def test_alignment_bounds(key) -> None:
    with pytest.raises(BadInputError, match=f"{key} must lie in"):
        TrackerNoise(**{key: 2.5})
