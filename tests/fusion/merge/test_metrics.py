import numpy as np
import pytest
from hypothesis import given

from fusion.errors import BadInputError
from fusion.merge.metrics import PAPER_BONES, Stats, bone_length_std, held_out_support
from fusion.topology import K4ABT, KINECT_V2, Landmark, TrackingState
from tests.fusion.skeleton_fakes import Motion
from tests.strategies import seeds

TOPO = KINECT_V2
J = TOPO.n_joints


# ---------------------------------------------------------------- Stats


def test_stats_by_hand_ignoring_nan():
    s = Stats.of(np.array([[3.0, -4.0], [np.nan, 0.0]]))
    assert s.n == 3
    assert s.rmse == pytest.approx(np.sqrt(25 / 3))
    assert s.mean == pytest.approx(-1 / 3)
    assert s.median == 0.0 and s.max == 3.0
    assert s.std == pytest.approx(np.std([3.0, -4.0, 0.0]))
    assert s.as_dict()["n"] == 3


def test_stats_of_nothing_is_nan_and_inf_is_rejected():
    for empty in (np.zeros(0), np.full(4, np.nan)):
        s = Stats.of(empty)
        assert s.n == 0 and all(np.isnan(v) for k, v in s.as_dict().items() if k != "n")
    with pytest.raises(BadInputError):
        Stats.of(np.array([1.0, np.inf]))


# ---------------------------------------------------------------- bone_length_std


def _arm_frames(left_lengths, right_lengths) -> np.ndarray:
    """(T, J, 3) frames with only the shoulder-elbow bones, of the given lengths along +x / -x."""
    T = len(left_lengths)
    p = np.full((T, J, 3), np.nan)
    for side, lengths in ((-1.0, left_lengths), (1.0, right_lengths)):
        shoulder = TOPO.index("ShoulderLeft" if side < 0 else "ShoulderRight")
        elbow = TOPO.index("ElbowLeft" if side < 0 else "ElbowRight")
        p[:, shoulder] = (0.2 * side, 1.4, 0.0)
        p[:, elbow] = p[:, shoulder] + np.asarray(lengths)[:, None] * [side, 0.0, 0.0]
    return p


def test_bone_length_std_pools_left_and_right_around_their_own_means():
    p = _arm_frames([0.30, 0.32, 0.28, 0.30], [0.35] * 4)
    std = bone_length_std(p, TOPO)
    assert set(std) == set(PAPER_BONES)
    assert std["shoulder-elbow"] == pytest.approx(np.sqrt((0.02**2 + 0.02**2) / 8))
    assert np.isnan(std["elbow-wrist"]) and np.isnan(std["spine_shoulder-shoulder"])


def test_bone_length_std_uses_only_valid_joints():
    p = _arm_frames([0.30, 0.32, 0.28, 0.30], [0.35, 0.35, 0.35, 0.50])
    valid = np.ones((4, J), bool)
    valid[1:3, TOPO.index("ElbowLeft")] = False
    valid[3, TOPO.index("ShoulderRight")] = False
    assert bone_length_std(p, TOPO, valid=valid)["shoulder-elbow"] == pytest.approx(0.0, abs=1e-15)
    with pytest.raises(BadInputError):
        bone_length_std(p, TOPO, valid=valid[:2])


def test_bone_length_std_accepts_custom_bones_and_other_topologies():
    p = _arm_frames([0.30, 0.34], [0.35, 0.35])
    std = bone_length_std(p, TOPO, {"left": [("ShoulderLeft", Landmark.ELBOW_LEFT)]})
    assert std == {"left": pytest.approx(0.02)}
    assert set(bone_length_std(np.zeros((3, K4ABT.n_joints, 3)), K4ABT)) == set(PAPER_BONES)
    with pytest.raises(BadInputError):
        bone_length_std(np.zeros((3, J, 2)), TOPO)


@given(seeds)
def test_bone_length_std_of_a_rigid_body_in_motion_is_zero(seed):
    p = Motion.random(rng=np.random.default_rng(seed)).joints(np.arange(30) / 30)
    assert max(bone_length_std(p, TOPO).values()) < 1e-12


# ---------------------------------------------------------------- held_out_support


def test_held_out_support_counts_tracked_joints_within_each_distance():
    merged = np.zeros((1, 6, 3))
    merged[0, 4] = np.nan
    held = np.zeros((1, 6, 3))
    held[0, :, 0] = [0.01, 0.06, 0.10, 0.0, 0.0, 0.0]
    states = np.array([[2, 2, 2, 1, 2, 0]])  # joint 3 only inferred, 4 not merged, 5 not seen
    held[0, 5] = np.nan
    support = held_out_support(merged, held, states)
    assert support == {0.05: pytest.approx(25.0), 0.07: pytest.approx(50.0)}
    relaxed = held_out_support(merged, held, states, thresholds=[0.02], min_state=TrackingState.INFERRED)
    assert relaxed == {0.02: pytest.approx(40.0)}


def test_held_out_support_pools_cameras_and_excludes_frames():
    merged = np.zeros((2, 1, 3))
    held = np.zeros((2, 2, 1, 3))
    held[1, :, 0, 0] = 1.0  # camera 1 disagrees everywhere
    states = np.full((2, 2, 1), TrackingState.TRACKED)
    assert held_out_support(merged, held, states, thresholds=[0.05]) == {0.05: 50.0}
    exclude = np.array([[False, False], [True, True]])  # e.g. camera 1 is back-facing
    assert held_out_support(merged, held, states, thresholds=[0.05], exclude_frames=exclude) == {0.05: 100.0}
    assert np.isnan(held_out_support(merged, held, np.zeros((2, 2, 1), int))[0.05])


def test_held_out_support_rejects_bad_input():
    merged = np.zeros((2, 1, 3))
    with pytest.raises(BadInputError):
        held_out_support(merged, np.zeros((2, 2, 3)), np.zeros((2, 2)))
    with pytest.raises(BadInputError):
        held_out_support(merged, np.zeros((2, 1, 3)), np.zeros((3, 1)))
    with pytest.raises(BadInputError):
        held_out_support(merged, np.zeros((2, 1, 3)), np.full((2, 1), 2), thresholds=[0.0])
    with pytest.raises(BadInputError):
        held_out_support(merged, np.zeros((2, 1, 3)), np.full((2, 1), 2), exclude_frames=np.zeros(3, bool))
