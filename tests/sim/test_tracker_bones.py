"""Bone lengths of the simulated tracker: the body scale (shared process, per-camera part, feet pinned)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fusion.camera import KINECT_V2_DEPTH
from fusion.errors import BadInputError
from fusion.merge.body_scale import body_scale_stats
from fusion.recording import CameraRecording, Recording
from fusion.topology import K4ABT
from sim.tracker_bones import body_scale, draw_waves
from sim.tracker_noise import TrackerNoise
from tests.sim.test_tracker import quiet, run


def _template(sd: float = 0.04, shared: float = 0.6, tau_s: float = 0.5) -> TrackerNoise:
    none = quiet(dataclasses.replace(TrackerNoise.none(), flip_enabled=False))
    return dataclasses.replace(none, body_scale_sd=sd, body_scale_shared=shared, body_scale_tau_s=tau_s)


def test_shared_process_is_a_unit_process_with_the_time_constant() -> None:
    t = np.arange(20000) / 30.0
    lag = int(round(0.5 * 30))
    var, corr = [], []
    for seed in range(8):
        z = draw_waves(0.5, np.random.default_rng(seed))(t)
        var.append(np.var(z))
        corr.append(np.mean(z[lag:] * z[:-lag]) / np.mean(z * z))
    assert np.mean(var) == pytest.approx(1.0, rel=0.15)
    assert np.mean(corr) == pytest.approx(np.exp(-1), abs=0.08)
    with pytest.raises(BadInputError, match="time constant"):
        draw_waves(0.0, np.random.default_rng(0))


def test_cameras_on_their_own_clocks_share_the_session_scale() -> None:
    noise = _template(shared=0.6)
    true = np.arange(12000) / 30.0
    waves = draw_waves(noise.body_scale_tau_s, np.random.default_rng(1))
    # camera timestamps 3.7 s apart: the shared part is taken at the true times
    s1 = body_scale(true, noise, waves(true), np.random.default_rng(2))
    s2 = body_scale(true + 3.7, noise, waves(true), np.random.default_rng(3))
    assert np.corrcoef(s1, s2)[0, 1] == pytest.approx(0.6, abs=0.1)
    assert np.std(s1) == pytest.approx(0.04, rel=0.15)
    alone = body_scale(true, noise, None, np.random.default_rng(2))
    assert abs(np.corrcoef(alone, s2)[0, 1]) < 0.2


def test_tracked_template_is_measured_back() -> None:
    noise = _template(sd=0.04, shared=0.0, tau_s=0.5)
    stream, *_ = run(K4ABT, np.zeros(4000), noise, seed=5)
    stats = body_scale_stats(Recording((CameraRecording("cam", KINECT_V2_DEPTH, stream),), {}))
    assert stats.share == pytest.approx(1.0, abs=1e-6)
    assert stats.sd == pytest.approx(0.04, rel=0.2)
    assert stats.tau_s == pytest.approx(0.5, rel=0.3)


def test_no_body_scale_leaves_the_tracker_as_it_was() -> None:
    noise = quiet(dataclasses.replace(TrackerNoise.none(), flip_enabled=False), jitter_m=0.01)
    a, *_ = run(K4ABT, np.zeros(50), noise, seed=6)
    b, *_ = run(K4ABT, np.zeros(50), dataclasses.replace(noise, body_scale_tau_s=2.0, body_scale_shared=0.5), seed=6)
    np.testing.assert_array_equal(a.positions, b.positions)


@pytest.mark.parametrize("changes", [{"body_scale_sd": 0.3}, {"body_scale_sd": -0.01}, {"body_scale_tau_s": 0.0},
                                     {"body_scale_shared": 1.5}])
def test_bad_body_scale_is_refused(changes) -> None:
    with pytest.raises(BadInputError, match="body_scale"):
        dataclasses.replace(TrackerNoise(), **changes)
