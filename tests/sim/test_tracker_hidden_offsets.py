"""Hidden joints reported at full confidence with a guessed offset, and the far-tail statistic that fits it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from fusion.errors import BadInputError
from fusion.merge.residual_parts import TAIL_M, tracked_tail
from fusion.topology import KINECT_V2, TrackingState
from sim.tracker_noise import TrackerNoise
from tests.sim.test_tracker import quiet, run

ELBOW = KINECT_V2.index("ElbowLeft")


def _hidden_elbow(share: float, n: int = 2000):
    """Errors (T, J, 3) and states of a still body whose left elbow is hidden, none of its hidden frames
    reported at low confidence, the guessed offset in ``share`` of them."""
    base = quiet(TrackerNoise(), jitter_m=0.0, wobble_m=0.0, bias_m=(0.0, 0.0), hidden_low_confidence=0.0)
    noise = dataclasses.replace(base, hip_up_m=0.0, hip_out_m=0.0, flip_enabled=False, hidden_offset_share=share)
    vis = np.ones((n, KINECT_V2.n_joints), dtype=bool)
    vis[:, ELBOW] = False
    stream, truth, *_ = run(KINECT_V2, np.zeros(n), noise, seed=3, visibility=vis)
    return stream.positions - truth.joints_cam, stream.states


@pytest.mark.parametrize("share", [0.0, 0.3, 1.0])
def test_share_of_hidden_confident_frames_with_the_guess(share) -> None:
    err, states = _hidden_elbow(share)
    assert np.all(states[:, ELBOW] == TrackingState.TRACKED)  # reported confident throughout
    offset = np.linalg.norm(err[:, ELBOW], axis=-1)
    guessed = offset > 1e-9
    assert guessed.mean() == pytest.approx(share, abs=0.12)  # runs of frames: a loose tolerance
    lo, hi = TrackerNoise().inferred_offset_m
    assert np.all((offset[guessed] >= lo - 1e-9) & (offset[guessed] <= hi + 1e-9))
    assert np.allclose(np.delete(err, ELBOW, axis=1), 0.0)  # the seen joints keep their (nil) errors
    runs = np.flatnonzero(guessed & ~np.concatenate([[False], guessed[:-1]]))
    if 0 < share < 1:  # each run of guessed frames its own guess, held over the run
        assert len(runs) > 3
        firsts = err[runs, ELBOW]
        assert len(np.unique(np.round(firsts, 12), axis=0)) == len(runs)
        ends = np.r_[np.flatnonzero(guessed[:-1] & ~guessed[1:]), len(guessed) - 1]
        for start, end in zip(runs, ends):
            assert np.allclose(err[start:end + 1, ELBOW], err[start, ELBOW])


@pytest.mark.parametrize("value", [-0.1, 1.5, float("nan")])
def test_bad_share(value) -> None:
    with pytest.raises(BadInputError, match="hidden_offset_share"):
        TrackerNoise(hidden_offset_share=value)


def test_tracked_tail() -> None:
    """The share of elbow and wrist samples beyond the tail threshold; other joints and NaNs do not count."""
    part = np.zeros((100, KINECT_V2.n_joints, 3))
    cols = KINECT_V2.indices(["ElbowLeft", "ElbowRight", "WristLeft", "WristRight"])
    part[:10, cols[0], 0] = TAIL_M + 0.01  # 10 of 400 samples
    part[:, KINECT_V2.index("HandLeft"), 0] = 1.0  # not an elbow or wrist
    part[50:, cols[3]] = np.nan  # 50 samples not Tracked in both
    assert tracked_tail([part], KINECT_V2) == pytest.approx(10 / 350)
    assert np.isnan(tracked_tail([], KINECT_V2))
