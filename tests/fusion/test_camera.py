import numpy as np
import pytest
from hypothesis import given

from fusion.camera import KINECT_V2_DEPTH, AxisConvention, Intrinsics
from fusion.depth import depth_to_points
from fusion.errors import BadInputError
from tests.strategies import point_sets


@pytest.mark.parametrize("axes", list(AxisConvention))
@given(p=point_sets(scale=1.0))
def test_project_backproject_roundtrip(axes, p):
    intr = Intrinsics(axes=axes)
    p = p + [0.0, 0.0, 2.0]
    uv, z = intr.project(p)
    np.testing.assert_allclose(intr.backproject(uv, z), p, atol=1e-12)


def test_kinect_image_is_mirrored_and_y_up():
    # A point to the sensor's left (+x) appears right of centre; a point above (+y) above centre.
    uv, _ = KINECT_V2_DEPTH.project(np.array([[0.5, 0.5, 2.0]]))
    assert uv[0, 0] > KINECT_V2_DEPTH.cx and uv[0, 1] < KINECT_V2_DEPTH.cy
    uv, _ = Intrinsics(axes=AxisConvention.OPENCV).project(np.array([[0.5, 0.5, 2.0]]))
    assert uv[0, 0] > KINECT_V2_DEPTH.cx and uv[0, 1] > KINECT_V2_DEPTH.cy


def test_depth_to_points_matches_closed_form():
    intr = Intrinsics(width=4, height=3, fx=2.0, fy=2.0, cx=1.5, cy=1.0)
    depth = np.zeros((3, 4), np.uint16)
    depth[2, 3] = 2000
    pts, labels = depth_to_points(depth, intr, np.full((3, 4), 1, np.uint8))
    np.testing.assert_allclose(pts, [[(3 - 1.5) * 2.0 / 2.0, -(2 - 1.0) * 2.0 / 2.0, 2.0]])
    assert labels.tolist() == [1]
    with pytest.raises(BadInputError):
        depth_to_points(np.zeros((2, 2), np.uint16), intr)


def test_bad_intrinsics():
    with pytest.raises(BadInputError):
        Intrinsics(fx=-1.0)
    with pytest.raises(BadInputError):
        Intrinsics(min_depth_m=5.0, max_depth_m=4.0)
    with pytest.raises(BadInputError, match="unknown intrinsics keys"):
        Intrinsics.from_dict({"fx": 1.0, "zoom": 2})
    assert Intrinsics.from_dict(KINECT_V2_DEPTH.to_dict()) == KINECT_V2_DEPTH
