"""Back-facing detection from observations only, scored against the simulator's truth."""

import numpy as np
import pytest

from fusion.facing import detect_back_facing, swap_events
from fusion.skeleton import SkeletonStream
from scenarios.config import scenario_from_dict
from scenarios.runner import simulate


@pytest.fixture(scope="module")
def ring_session():
    doc = {
        "scenario": {"name": "t", "seed": 5},
        "rig": {"n_cameras": 6, "radius_m": 2.0},
        "sensors": {"depth_rate_hz": 0.0},
        "session": {"segment": [{"kind": "idle", "duration_s": 1.0}, {"kind": "calibration_turn", "duration_s": 20.0}]},
    }
    return simulate(scenario_from_dict(doc), progress=False)


def test_precision_and_recall_against_truth(ring_session):
    rec, truth = ring_session
    tp = fp = fn = 0
    for cam, ct in zip(rec.cameras, truth.cameras):
        found = detect_back_facing(cam.skeleton).flipped
        tp += int((found & ct.flipped).sum())
        fp += int((found & ~ct.flipped).sum())
        fn += int((~found & ct.flipped).sum())
    assert tp > 0
    assert tp / (tp + fp) > 0.95 and tp / (tp + fn) > 0.95


def test_swap_events_at_label_swaps(ring_session):
    rec, truth = ring_session
    for cam, ct in zip(rec.cameras, truth.cameras):
        events, _ = swap_events(cam.skeleton)
        true_changes = np.flatnonzero(np.diff(ct.flipped.astype(int))) + 1
        for t in true_changes:
            assert np.min(np.abs(events - t)) <= 1


def test_no_flip_in_a_frontal_static_view():
    doc = {"scenario": {"name": "t", "seed": 2}, "rig": {"n_cameras": 1}, "sensors": {"depth_rate_hz": 0.0},
           "session": {"segment": [{"kind": "hand_lift", "side": "left", "repetitions": 2}]}}
    rec, _ = simulate(scenario_from_dict(doc), progress=False)
    result = detect_back_facing(rec.cameras[0].skeleton)
    assert not result.flipped.any() and result.events.size == 0


def test_empty_skeleton_stream(ring_session):
    sk = ring_session[0].cameras[0].skeleton
    empty = SkeletonStream(sk.topology, sk.timestamps[:5], np.full((5, sk.topology.n_joints, 3), np.nan),
                           np.zeros((5, sk.topology.n_joints), np.int8))
    result = detect_back_facing(empty)
    assert not result.flipped.any() and (result.segment == -1).all()
