"""Body scale of a tracker's skeletons: oracles on synthetic streams whose bones move together or apart."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from fusion.camera import KINECT_V2_DEPTH
from fusion.merge.body_scale import (
    MIN_FRAMES,
    body_scale_stats,
    scale_series,
    stretch_bones,
    without_body_scale,
)
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import K4ABT, KINECT_V2, Topology


def _ar1(n: int, a: float, rng: np.random.Generator) -> np.ndarray:
    e = rng.standard_normal(n)
    e[1:] *= np.sqrt(1 - a * a)
    return lfilter([1.0], [1.0, -a], e)


def _stream(topology: Topology, scale: np.ndarray, own: np.ndarray, offsets: np.ndarray) -> SkeletonStream:
    """Joints built root outward: each bone ``offset * scale(t) * (1 + own(t, j))``."""
    T, parents = len(scale), np.asarray(topology.parents)
    p = np.zeros((T, topology.n_joints, 3))
    p[:, parents < 0] = [0.0, 0.0, 2.5]
    def depth(j: int) -> int:
        return 0 if parents[j] < 0 else 1 + depth(parents[j])

    for j in sorted(np.flatnonzero(parents >= 0), key=depth):
        p[:, j] = p[:, parents[j]] + offsets[j] * (scale * (1 + own[:, j]))[:, None]
    return SkeletonStream(topology, np.arange(T) / 30.0, p, np.full((T, topology.n_joints), 2, dtype=np.int8))


def _recording(topology: Topology, *, sd: float, own_sd: float, shared: float, tau_s: float, T: int = 6000,
               seed: int = 0) -> Recording:
    rng = np.random.default_rng(seed)
    offsets = rng.uniform(-0.3, 0.3, (topology.n_joints, 3))
    a = np.exp(-1 / 30 / tau_s)
    common = _ar1(T, a, rng)
    cams = []
    for name in ("cam1", "cam2"):
        z = np.sqrt(shared) * common + np.sqrt(1 - shared) * _ar1(T, a, rng)
        own = own_sd * rng.standard_normal((T, topology.n_joints))
        cams.append(CameraRecording(name, KINECT_V2_DEPTH, _stream(topology, 1 + sd * z, own, offsets)))
    return Recording(tuple(cams), {})


def test_a_template_tracker_is_measured() -> None:
    stats = body_scale_stats(_recording(K4ABT, sd=0.04, own_sd=0.0, shared=0.7, tau_s=0.5))
    assert stats.share == pytest.approx(1.0, abs=1e-6)
    assert stats.sd == pytest.approx(0.04, rel=0.15)
    assert stats.tau_s == pytest.approx(0.5, rel=0.25)
    assert stats.shared == pytest.approx(0.7, abs=0.1)


def test_bones_that_vary_on_their_own_are_not_a_scale() -> None:
    stats = body_scale_stats(_recording(KINECT_V2, sd=0.0, own_sd=0.03, shared=0.0, tau_s=0.5))
    assert stats.share < 0.3
    mixed = body_scale_stats(_recording(KINECT_V2, sd=0.03, own_sd=0.03, shared=0.0, tau_s=0.5))
    assert 0.3 < mixed.share < 0.7  # equal parts: the median of eight bones follows the common factor


def test_too_few_complete_frames_give_nan() -> None:
    rec = _recording(K4ABT, sd=0.04, own_sd=0.0, shared=0.5, tau_s=0.5, T=MIN_FRAMES - 1)
    stats = body_scale_stats(rec)
    assert np.isnan([stats.share, stats.sd, stats.tau_s, stats.shared]).all()
    scale, rel, _ = scale_series(rec.cameras[0].skeleton)
    assert scale.shape == (MIN_FRAMES - 1,) and rel.shape == (MIN_FRAMES - 1, 8)


@pytest.mark.parametrize("topology", [K4ABT, KINECT_V2])
def test_stretched_bones_move_together_by_the_least_displacement(topology) -> None:
    rng = np.random.default_rng(4)
    p = rng.uniform(-0.5, 0.5, (topology.n_joints, 3))[None] + 0.002 * rng.standard_normal((300, topology.n_joints, 3))
    scale = 1 + 0.05 * np.sin(np.arange(300) / 20)
    out = stretch_bones(p, topology, scale)
    parents = np.asarray(topology.parents)
    for j in np.flatnonzero(parents >= 0):
        before = np.linalg.norm(p[:, j] - p[:, parents[j]], axis=-1)
        after = np.linalg.norm(out[:, j] - out[:, parents[j]], axis=-1)
        np.testing.assert_allclose(after / before, scale, rtol=1e-6)
    moved = np.linalg.norm(out - p, axis=-1)
    # no joint pinned: the body keeps its centre, and moves less than scaled about any one joint
    np.testing.assert_allclose((out - p).mean(axis=1), 0.0, atol=1e-3)
    about_root = np.abs(scale - 1)[:, None] * np.linalg.norm(p - p[:, [0]], axis=-1)
    assert np.sum(moved ** 2) < np.sum(about_root ** 2)
    np.testing.assert_array_equal(stretch_bones(p, topology, np.ones(300)), p)


def test_stretching_leaves_missing_joints_out() -> None:
    rng = np.random.default_rng(5)
    p = rng.uniform(-0.5, 0.5, (40, K4ABT.n_joints, 3))
    p[:, 9] = np.nan  # a hand tip never seen
    p[10:20, 7] = np.nan  # a wrist lost for a while
    scale = np.full(40, 1.04)
    scale[5] = np.nan  # no scale: unchanged
    out = stretch_bones(p, K4ABT, scale)
    np.testing.assert_array_equal(np.isnan(out), np.isnan(p))
    np.testing.assert_allclose(out[5], p[5], atol=1e-12)
    parents = np.asarray(K4ABT.parents)
    both = [j for j in np.flatnonzero(parents >= 0) if j not in (9, 7) and parents[j] not in (9, 7)]
    for j in both:
        ratio = np.linalg.norm(out[:, j] - out[:, parents[j]], axis=-1) / np.linalg.norm(p[:, j] - p[:, parents[j]], axis=-1)
        np.testing.assert_allclose(np.delete(ratio, 5), 1.04, rtol=1e-6)


def test_the_scale_of_a_template_tracker_is_taken_out() -> None:
    template = _recording(K4ABT, sd=0.04, own_sd=0.0, shared=0.7, tau_s=0.5, T=1200)
    assert body_scale_stats(without_body_scale(template)).sd < 1e-6
    independent = _recording(KINECT_V2, sd=0.0, own_sd=0.03, shared=0.0, tau_s=0.5, T=1200)
    assert without_body_scale(independent) is independent  # no template: nothing to take out
