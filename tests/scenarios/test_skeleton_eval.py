"""The angle definitions against the humanoid's true joint angles (MuJoCo segment frames)."""

import numpy as np
import pytest

from fusion.merge.angles import ARM_ANGLES, joint_angles
from fusion.topology import KINECT_V2, Landmark
from scenarios.config import load_scenario
from scenarios.runner import build_simulation
from scenarios.skeleton_eval import TrueThorax, angle_errors_deg, model_angles
from sim.coordinates import INDEX
from sim.motions import hand_lift, salute
from sim.patient_motion import Movement, MovementProfile, Side

ARMS = [f"{a}_{s}" for s in ("left", "right") for a in ARM_ANGLES]
GIRDLE = ("ht_plane_of_elevation", "trunk_axial_rotation")
"""The angles that the thorax's lateral axis turns about its long axis."""


@pytest.fixture(scope="module")
def humanoid():
    return build_simulation(load_scenario("single")).humanoid


def _motion(movement, side):
    make = salute if movement is Movement.SALUTE else hand_lift
    return make(side, 1, MovementProfile.healthy(movement), rng=np.random.default_rng(3))


def _errors(humanoid, motion, *, thorax=TrueThorax.SHOULDER_LINE, girdle=True):
    coords = motion.sample(np.arange(0.0, motion.duration, 0.1))
    if not girdle:
        coords[:, [i for k, i in INDEX.items() if k.startswith("clav_")]] = 0.0
    est = joint_angles(humanoid.joint_positions(coords, KINECT_V2), KINECT_V2)
    true = model_angles(humanoid, coords, thorax=thorax)
    names = [k for k, n in enumerate(true.names) if n.startswith(("trunk", "ht_", "elbow"))]
    assert np.array_equal(np.isnan(est.degrees[:, names]), np.isnan(true.degrees[:, names]))  # NaN at the same frames
    return {k: np.nanmax(v) for k, v in angle_errors_deg(est, true).items() if np.isfinite(v).any()}


@pytest.mark.parametrize("side", list(Side))
@pytest.mark.parametrize("movement", [Movement.SALUTE, Movement.HAND_LIFT])
def test_skeleton_angles_match_the_true_segment_frames(humanoid, movement, side):
    err = _errors(humanoid, _motion(movement, side))
    # the hand lift keeps the elbow straight: no humerus frame, no axial rotation
    defined = ARM_ANGLES if movement is Movement.SALUTE else ARM_ANGLES[:2] + ARM_ANGLES[3:]
    moving = {f"{a}_{side.name.lower()}" for a in defined}
    assert {"trunk_flexion", "trunk_lateral_lean", "trunk_axial_rotation", *moving} <= set(err)
    assert max(err.values()) < 1.0, max(err, key=err.get)


@pytest.mark.parametrize("side", list(Side))
def test_the_anatomical_thorax_differs_by_the_shoulder_girdle_alone(humanoid, side):
    motion = _motion(Movement.SALUTE, side)
    err = _errors(humanoid, motion, thorax=TrueThorax.THORAX_BODY)
    moved = {k: v for k, v in err.items() if v > 1.0}
    assert moved and all(k.startswith(GIRDLE) for k in moved)  # the salute retracts the girdle
    assert max(moved.values()) < 10.0
    assert max(_errors(humanoid, motion, thorax=TrueThorax.THORAX_BODY, girdle=False).values()) < 1e-3


@pytest.mark.parametrize("rotation_deg", [0.0, 40.0])
def test_model_angles_of_a_forward_elevation(humanoid, rotation_deg):
    """The arm raised forward to horizontal (hinges: plane 90, elevation 90), elbow bent 90 deg, turned
    about the humerus by ``sh_rotation``: plane of elevation 90 deg, axial rotation of the hinge's
    size, and, against the thorax's ``Y`` (pelvis pivot to the sternal notch, leaning back from the
    vertical by the notch's forward offset), elevation 90 deg plus that lean."""
    coords = np.zeros((1, len(INDEX)))
    coords[0, [INDEX["sh_plane_r"], INDEX["sh_elevation_r"], INDEX["sh_rotation_r"], INDEX["elbow_flexion_r"]]] = (
        np.radians([90.0, 90.0, rotation_deg, 90.0]))
    a = model_angles(humanoid, coords)
    P = humanoid.joint_positions(np.zeros((1, len(INDEX))), KINECT_V2)[0]
    spine = P[KINECT_V2.index(Landmark.SPINE_SHOULDER)] - P[KINECT_V2.index(Landmark.PELVIS)]
    lean = np.degrees(np.arctan2(spine[0], spine[2]))  # in the neutral stance, facing +x
    np.testing.assert_allclose([a["ht_plane_of_elevation_right"][0], a["ht_elevation_right"][0],
                                abs(a["ht_axial_rotation_right"][0]), a["elbow_flexion_right"][0]],
                               [90.0, 90.0 + lean, rotation_deg, 90.0], atol=1e-6)
