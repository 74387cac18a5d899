"""Camera poses of explicit rigs: look_at with and without an up direction, and view_of back."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings

from fusion.camera import AxisConvention
from fusion.errors import BadInputError
from sim.rig import CameraPlacement, as_azure_kinect, look_at, view_of
from tests.strategies import transforms


def test_look_at_without_up_levels_the_camera():
    T = look_at([2.0, 1.0, 1.5], [0.0, 0.0, 1.0])
    x, y, z = T[:3, 0], T[:3, 1], T[:3, 2]
    assert x[2] == pytest.approx(0.0, abs=1e-12)  # no roll: the sensor's left axis is horizontal
    assert y[2] > 0 and np.allclose(z, np.subtract([0.0, 0.0, 1.0], [2.0, 1.0, 1.5]) / np.linalg.norm([2, 1, 0.5]))


def test_look_at_with_up_keeps_the_roll():
    roll = np.radians(25.0)
    level = look_at([2.0, 0.0, 1.2], [0.0, 0.0, 1.0])
    up = np.cos(roll) * level[:3, 1] + np.sin(roll) * level[:3, 0]
    T = look_at([2.0, 0.0, 1.2], [0.0, 0.0, 1.0], up)
    np.testing.assert_allclose(T[:3, 1], up, atol=1e-12)
    np.testing.assert_allclose(T[:3, 2], level[:3, 2], atol=1e-12)
    # only the part of up across the view counts
    np.testing.assert_allclose(look_at([2.0, 0.0, 1.2], [0.0, 0.0, 1.0], 3 * up + 2 * T[:3, 2]), T, atol=1e-12)


@settings(max_examples=40)
@given(T=transforms())
def test_view_of_and_look_at_give_the_pose_back_in_either_convention(T):
    centre, forward, up = view_of(T, AxisConvention.KINECT_V2)
    np.testing.assert_allclose(look_at(centre, centre + forward, up), T, atol=1e-9)
    centre, forward, up = view_of(T, AxisConvention.OPENCV)  # T in OpenCV axes (x right, y down)
    back = as_azure_kinect(CameraPlacement("c", look_at(centre, centre + forward, up))).T_world_cam
    np.testing.assert_allclose(back, T, atol=1e-9)


def test_look_at_rejects_an_up_along_the_view():
    with pytest.raises(BadInputError, match="along its view"):
        look_at([1.0, 0.0, 1.0], [0.0, 0.0, 1.0], [2.0, 0.0, 0.0])
    with pytest.raises(BadInputError, match="straight up or down"):
        look_at([0.0, 0.0, 3.0], [0.0, 0.0, 1.0])
    T = look_at([0.0, 0.0, 3.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0])  # straight down is fine with an up
    np.testing.assert_allclose(T[:3, 1], [1.0, 0.0, 0.0], atol=1e-12)
