"""Truth-free statistics of the bones: length jitter, steps and steady residuals along the bones, spike
lengths; oracles on constructed streams."""

from __future__ import annotations

import numpy as np
import pytest

from fusion.camera import KINECT_V2_DEPTH
from fusion.merge.limb_sharing import limb_links
from fusion.merge.sensor_stats import sensor_stats
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, Landmark

T = 900
ELBOW, WRIST = KINECT_V2.index(Landmark.ELBOW_LEFT), KINECT_V2.index(Landmark.WRIST_LEFT)
WRISTS = (WRIST, KINECT_V2.index(Landmark.WRIST_RIGHT))
PARENT = {int(c): int(p) for p, c in limb_links(KINECT_V2)}


def _skeleton(seed: int = 0) -> np.ndarray:
    """(T, J, 3) a rigid body turning slowly about the vertical, 2.5 m in front of the origin."""
    rng = np.random.default_rng(seed)
    base = rng.uniform(-0.5, 0.5, size=(KINECT_V2.n_joints, 3))
    a = np.linspace(0, 1.0, T)
    R = np.stack([np.stack([np.cos(a), -np.sin(a), 0 * a], -1), np.stack([np.sin(a), np.cos(a), 0 * a], -1),
                  np.stack([0 * a, 0 * a, 1 + 0 * a], -1)], 1)  # (T, 3, 3)
    return np.einsum("tij,kj->tki", R, base) + [0.0, 0.0, 2.5]


def _axis(P: np.ndarray, joint: int) -> np.ndarray:
    bone = P[:, joint] - P[:, PARENT[joint]]
    return bone / np.linalg.norm(bone, axis=-1, keepdims=True)


def _recording(*cams: np.ndarray) -> Recording:
    ts = np.arange(T) / 30.0
    states = np.full((T, KINECT_V2.n_joints), 2, dtype=np.int8)
    return Recording(tuple(CameraRecording(f"c{k}", KINECT_V2_DEPTH, SkeletonStream(KINECT_V2, ts, p, states))
                           for k, p in enumerate(cams)), {})


def _stats(*cams: np.ndarray, calibrated: bool = False):
    poses = {f"c{k}": np.eye(4) for k in range(len(cams))} if calibrated else None
    return sensor_stats(_recording(*cams), poses, n_boot=0, rng=np.random.default_rng(0))


def test_a_rigid_body_has_no_bone_jitter_and_steps_along_a_bone_are_counted() -> None:
    P = _skeleton()
    rigid = _stats(P)
    assert rigid.bone_jitter_mm["forearm"].value == pytest.approx(0.0, abs=1e-6)
    sigma = 0.004
    moved = P.copy()
    for k, w in enumerate(WRISTS):  # the statistic pools both sides
        moved[:, w] += sigma * np.random.default_rng(k).standard_normal((T, 1)) * _axis(P, w)
    st = _stats(moved)
    # the forearm's length takes the white noise; its second difference has sd sqrt(6) sigma, median |.| 0.674 of that
    assert st.bone_jitter_mm["forearm"].value == pytest.approx(0.674 * np.sqrt(6) * sigma * 1e3, rel=0.15)
    assert st.bone_step_share > 0.95
    iso = P + sigma * np.random.default_rng(2).standard_normal(P.shape)
    assert _stats(iso).bone_step_share == pytest.approx(1 / 3, abs=0.05)


def test_spike_length() -> None:
    P = _skeleton()
    P[::30, WRIST] += [0.1, 0.0, 0.0]  # one-frame outliers: second differences of 10, 20 and 10 cm
    st = _stats(P)
    assert st.spike_mm["wrist"].value == pytest.approx(100.0, rel=0.02)
    assert np.isnan(st.spike_mm["head"].value)


@pytest.mark.parametrize("along, share", [(True, 1.0), (False, 0.0)])
def test_steady_residual_along_the_bones(along, share) -> None:
    P = _skeleton()
    other = P.copy()
    for j in (ELBOW, WRIST):
        axis = _axis(P, j)
        across = np.cross(axis, [0.0, 0.0, 1.0])
        across /= np.linalg.norm(across, axis=-1, keepdims=True)
        other[:, j] += 0.03 * (axis if along else across)
    st = _stats(P, other, calibrated=True)
    assert st.residual_bone_share == pytest.approx(share, abs=0.02)
    assert np.isnan(_stats(P).residual_bone_share)  # one camera: no residual
