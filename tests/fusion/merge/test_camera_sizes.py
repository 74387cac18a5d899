"""The cameras' agreement on a person's size and proportions, on streams of known scale."""

from __future__ import annotations

import numpy as np
import pytest

from fusion.camera import KINECT_V2_DEPTH
from fusion.merge.camera_sizes import SIZE_BONES, bone_medians, size_agreement
from fusion.merge.sensor_stats import sensor_stats
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from fusion.topology import KINECT_V2, Landmark


def _recording(scales: list[np.ndarray], T: int = 200) -> Recording:
    """Cameras seeing one moving skeleton, each with its bones scaled (root outward) by its (J,) factors."""
    rng = np.random.default_rng(0)
    base = rng.uniform(-0.5, 0.5, size=(KINECT_V2.n_joints, 3)) + [0, 0, 2.5]
    wobble = 0.01 * rng.standard_normal((T, KINECT_V2.n_joints, 3))
    parents = np.asarray(KINECT_V2.parents)
    ts = np.arange(T) / 30.0
    cams = []
    for c, scale in enumerate(scales):
        pos = base + wobble
        out = pos.copy()
        for j in range(len(parents)):  # parents come before their children in this joint set
            if parents[j] >= 0:
                out[:, j] = out[:, parents[j]] + scale[j] * (pos[:, j] - pos[:, parents[j]])
        states = np.full((T, KINECT_V2.n_joints), 2, dtype=np.int8)
        cams.append(CameraRecording(f"c{c}", KINECT_V2_DEPTH, SkeletonStream(KINECT_V2, ts, out, states)))
    return Recording(tuple(cams), {})


def test_a_uniform_scale_is_a_scale_and_no_spread():
    J = KINECT_V2.n_joints
    rec = _recording([np.ones(J), np.full(J, 1.03)])
    scale, spread = size_agreement(rec, "c0")
    assert scale == pytest.approx(np.log(1.03), abs=1e-9)
    assert spread == pytest.approx(0.0, abs=1e-9)
    assert size_agreement(rec, "c1")[0] == pytest.approx(np.log(1.03), abs=1e-9)  # absolute, either way round


def test_bones_scaled_differently_spread_and_their_median_is_the_scale():
    J = KINECT_V2.n_joints
    factors = np.ones(J)
    children = [KINECT_V2.index(b) for _, b in SIZE_BONES]
    factors[children] = np.linspace(0.95, 1.05, len(children))
    scale, spread = size_agreement(_recording([np.ones(J), factors]), "c0")
    logs = np.log(np.linspace(0.95, 1.05, len(children)))
    assert scale == pytest.approx(abs(np.median(logs)), abs=1e-9)
    assert spread == pytest.approx(np.std(logs, ddof=1), rel=1e-6)


def test_one_camera_or_unseen_bones_give_nan():
    J = KINECT_V2.n_joints
    one = _recording([np.ones(J)])
    assert np.isnan(size_agreement(one, "c0")).all()
    s = sensor_stats(one, None, n_boot=0, rng=np.random.default_rng(0))
    assert np.isnan(s.camera_scale) and np.isnan(s.bone_ratio_spread)
    rec = _recording([np.ones(J), np.full(J, 1.02)], T=20)  # fewer frames than a median needs
    assert np.isnan(bone_medians(rec, "c0")).all() and np.isnan(size_agreement(rec, "c0")).all()


def test_sensor_stats_reports_the_size_agreement():
    J = KINECT_V2.n_joints
    rec = _recording([np.ones(J), np.full(J, 0.98)])
    s = sensor_stats(rec, None, n_boot=0, rng=np.random.default_rng(0))
    assert s.camera_scale == pytest.approx(-np.log(0.98), abs=1e-9) and s.bone_ratio_spread < 1e-9
    assert Landmark.SHOULDER_LEFT in dict(SIZE_BONES)
