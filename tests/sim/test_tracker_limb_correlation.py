"""The view bias shared along a limb: its correlation, its unchanged marginals, the chains it follows."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fusion.errors import BadInputError
from fusion.merge.limb_sharing import limb_cosine, limb_links
from fusion.topology import K4ABT, KINECT_V2
from sim.tracker_draws import chain_ordered
from sim.tracker_noise import (
    DEFAULT_GROUP_NOISE,
    JointGroup,
    TrackerNoise,
    joint_groups,
)
from tests.sim.test_tracker import quiet, run


def _view_errors(correlation: float, sessions: int) -> np.ndarray:
    """(S, J, 3) world error of one frame seen from the front camera, view bias only, per session."""
    noise = dataclasses.replace(quiet(TrackerNoise(), jitter_m=0.0), model_fraction=0.0, hip_up_m=0.0, hip_out_m=0.0,
                                view_limb_correlation=correlation)
    out = []
    for s in range(sessions):
        stream, _, P, cam = run(KINECT_V2, np.zeros(1), noise, seed=s)
        out.append((stream.positions[0] @ cam.T_world_cam[:3, :3].T + cam.T_world_cam[:3, 3]) - P[0])
    return np.stack(out)


@pytest.fixture(scope="module")
def errors() -> dict[float, np.ndarray]:
    return {rho: _view_errors(rho, 400) for rho in (0.0, 0.9)}


def test_limb_joints_err_together(errors) -> None:
    """Across the ray (the front camera's horizontal lateral axis is world y) the elbow's and the wrist's
    view biases correlate about as set; the spine and the shoulder, not joined by a limb link, do not."""
    i = KINECT_V2.indices(["ElbowLeft", "WristLeft", "SpineShoulder", "ShoulderLeft"])
    for rho, err in errors.items():
        along_limb = np.corrcoef(err[:, i[0], 1], err[:, i[1], 1])[0, 1]
        across = np.corrcoef(err[:, i[2], 1], err[:, i[3], 1])[0, 1]
        assert along_limb == pytest.approx(rho, abs=0.15), rho
        assert abs(across) < 0.15, rho


def test_marginals_unchanged(errors) -> None:
    """Each joint's view bias keeps its size (the RMS of U(low, high) times sqrt(1 - model share) = U(range)
    here) and its lean toward the camera (+x is toward the front camera)."""
    groups = np.array(joint_groups(KINECT_V2))
    err = errors[0.9]
    for group in (JointGroup.LIMB, JointGroup.HAND):
        lo, hi = DEFAULT_GROUP_NOISE[group].bias_m
        rms = np.sqrt(np.mean(np.sum(err[:, groups == group] ** 2, axis=-1)))
        assert rms == pytest.approx(np.sqrt((lo**2 + lo * hi + hi**2) / 3), rel=0.1), group
    toward = np.mean(err[:, groups == JointGroup.LIMB, 0] > 0)
    assert toward == pytest.approx(TrackerNoise().toward_camera_fraction, abs=0.05)


@pytest.mark.parametrize("topology", [KINECT_V2, K4ABT])
def test_limb_links_follow_each_limb_outward(topology) -> None:
    links = limb_links(topology)
    assert links.shape == (14, 2)  # per side: shoulder-elbow-wrist-hand, hand tip, thumb; knee-ankle-foot
    names = {(topology.joints[p], topology.joints[c]) for p, c in links}
    assert (topology.joints[topology.index("ELBOW_LEFT" if topology is K4ABT else "ElbowLeft")],
            topology.joints[topology.index("WRIST_LEFT" if topology is K4ABT else "WristLeft")]) in names
    ordered = chain_ordered(links, topology)
    seen = set()
    for parent, child in ordered:  # a child's draw is final before it is followed
        assert parent not in {c for _, c in ordered} or parent in seen
        seen.add(child)


def test_limb_cosine() -> None:
    links = limb_links(KINECT_V2)
    steady = np.zeros((2, KINECT_V2.n_joints, 3))
    steady[:, :, 0] = 5.0
    assert limb_cosine(steady, KINECT_V2) == pytest.approx(1.0)
    for parent, child in chain_ordered(links, KINECT_V2):  # each joint opposite its parent
        steady[:, child] = -steady[:, parent]
    assert limb_cosine(steady, KINECT_V2) == pytest.approx(-1.0)
    assert np.isnan(limb_cosine(np.zeros((0, 0, 3)), KINECT_V2))
    assert np.isnan(limb_cosine(np.full((1, KINECT_V2.n_joints, 3), np.nan), KINECT_V2))
    rng = np.random.default_rng(0)
    assert abs(limb_cosine(rng.standard_normal((200, KINECT_V2.n_joints, 3)), KINECT_V2)) < 0.05


@pytest.mark.parametrize("value", [-0.1, 0.995, float("nan")])
def test_bad_correlation(value) -> None:
    with pytest.raises(BadInputError, match="view_limb_correlation"):
        TrackerNoise(view_limb_correlation=value)
