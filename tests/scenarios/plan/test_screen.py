"""The planner's geometric screen: candidate places, sight lines through obstacles, field of view."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from fusion.camera import KINECT_V2_DEPTH
from scenarios.plan.screen import (
    candidate_places,
    in_view,
    pose_times,
    screen,
    sight_blocked,
)
from sim.motions import calibration_turn, hand_lift, idle
from sim.patient_motion import Movement, Side, SubjectProfile
from sim.rig import look_at
from sim.timeline import compose
from tests.scenarios.plan.test_room import small


def test_wall_candidates_lie_on_the_wall_at_the_allowed_heights():
    room = small()
    places, mount = candidate_places(room)
    assert places.shape == (room.search.candidates_per_mount * 3, 3) and np.all(mount == 0)
    np.testing.assert_allclose(places[:, 1], 2.9)
    assert places[:, 0].min() > 0.1 and places[:, 0].max() < 3.9
    assert set(np.round(places[:, 2], 3)) == {1.8, 2.0, 2.2}


def test_tripod_candidates_avoid_forbidden_zones_obstacles_and_the_subject():
    room = small(mount=[{"kind": "tripod", "min_m": [0.0, 0.0], "max_m": [4.0, 3.0], "height_m": [1.0, 1.0]}],
                 forbidden=[{"name": "door", "min_m": [0.0, 0.0], "max_m": [1.0, 1.0]}],
                 search={"candidates_per_mount": 100})
    places, _ = candidate_places(room)
    xy = places[:, :2]
    assert not np.any(np.all(xy <= 1.0, axis=1))  # door
    assert not np.any((xy[:, 0] >= 3.0) & (xy[:, 1] <= 0.6))  # cupboard
    assert np.all(np.linalg.norm(xy - [1.5, 1.5], axis=1) >= 1.0)  # subject zone + 0.5 m
    assert places.shape[0] > 50


def test_sight_blocked_against_a_hand_computed_box():
    room = small()  # cupboard x 3-4, y 0-0.6, z 0-2
    origins = np.array([[3.5, -1.0, 1.0], [0.0, -1.0, 1.0]])
    targets = np.array([[3.5, 2.0, 1.0], [3.5, -0.5, 1.0], [3.5, 2.0, 2.5]])
    blocked = sight_blocked(room, origins, targets)
    assert blocked.shape == (2, 3)
    assert blocked[0].tolist() == [True, False, True]  # through it; stops before it; still below z = 2 at y = 0
    assert blocked[1].tolist() == [False, False, False]  # the diagonal reaches x = 3 only at y = 1.57 > 0.6
    assert not sight_blocked(small(obstacle=[]), origins, targets).any()


@given(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0))
def test_segments_beside_the_box_are_free(dx, dz):
    room = small()
    o = np.array([[5.0 + dx, 2.0, 1.0 + dz]])
    t = np.array([[5.0 - dx, -1.0, 1.0 - dz]])  # x > 4 everywhere: beside the cupboard
    assert not sight_blocked(room, o, t).any()


def test_in_view_matches_the_projection():
    T = look_at(np.array([0.0, -3.0, 1.0]), np.array([0.0, 0.0, 1.0]))
    pts = np.array([[0.0, 0.0, 1.0], [0.0, -6.0, 1.0], [5.0, 0.0, 1.0], [0.0, 2.0, 1.0], [0.0, -2.7, 1.0]])
    # ahead at 3 m; behind; far outside the 70 deg field; 5 m away (beyond 4.5 m); 0.3 m (too near)
    assert in_view(T, KINECT_V2_DEPTH, pts).tolist() == [True, False, False, False, False]


def test_pose_times_fall_in_the_arm_movements():
    rng = np.random.default_rng(0)
    profile = SubjectProfile.healthy()
    motion = compose([idle(2.0, rng=rng), calibration_turn(8.0, rng=rng),
                      hand_lift(Side.RIGHT, 2, profile.movement(Movement.HAND_LIFT, Side.RIGHT), rng=rng)])
    t = pose_times(motion, 7)
    spans = [(r.t_start, r.t_end) for r in motion.repetitions if r.side is not None]
    assert t.shape == (7,) and np.all(np.diff(t) > 0)
    assert all(any(a <= x <= b for a, b in spans) for x in t)
    still = compose([idle(2.0, rng=rng)])
    np.testing.assert_allclose(pose_times(still, 4), [0.0, 0.5, 1.0, 1.5])


def test_screen_drops_a_place_behind_a_wall_of_boxes():
    room = small(mount=[{"kind": "points", "points_m": [[1.5, 0.2, 1.2], [3.5, 2.5, 1.2]], "height_m": [1.2, 1.2]}],
                 obstacle=[{"name": "screen", "min_m": [0.5, 0.5, 0.0], "max_m": [2.5, 0.7, 2.5]}],
                 protocol={"segment": [{"kind": "hand_lift", "side": "right", "repetitions": 1}]},
                 search={"screen_poses": 4, "min_visible": 0.5})
    result = screen(room)
    assert result.visible.shape == (2,) and result.poses == 4
    assert result.visible[0] == 0.0 and not result.kept[0]
    assert result.visible[1] > 0.5 and result.kept_indices.tolist() == [1]


@pytest.mark.parametrize("n", [1, 3])
def test_screen_shapes(n):
    room = small(search={"screen_poses": n, "candidates_per_mount": 2})
    result = screen(room)
    assert result.places_room.shape == (6, 3) and np.all((result.visible >= 0) & (result.visible <= 1))
