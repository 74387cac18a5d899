"""A kinematic MuJoCo humanoid driven by the clinical coordinates of :mod:`sim.coordinates`.

:func:`build_humanoid` builds the model with :class:`mujoco.MjSpec`, sized by an
:class:`~sim.anthropometry.Anthropometry`. Every body frame is parallel to the world frame in the
neutral stance (all coordinates 0): x forward, y to the subject's left, z up. The subject stands
upright facing world +x, arms hanging with the palms towards the thighs (thumbs forward), feet
under the hips.

Joints. A free joint ``root`` on the pelvis carries ``root_x``, ``root_y``, ``root_yaw`` (the height
is chosen so that the lowest point of the feet touches z = 0). Every other coordinate is a hinge
of the same name. Hinges of one body compose as successive intrinsic rotations, in this order:

=============  ====================================================  =============================
body           hinges (left-side axis in the body frame)             pivot
=============  ====================================================  =============================
thorax         trunk_flexion +y, trunk_lateral +x, trunk_rotation +z  lumbopelvic: mid-hip centres
neck           neck_flexion +y                                        mid-neck
head           neck_rotation +z                                       atlanto-occipital (neck axis)
clavicle_s     clav_elevation +x, clav_retraction +z                  sternal notch (both sides)
upper_arm_s    sh_plane -z, sh_elevation +x, sh_rotation +z           glenohumeral
forearm_s      elbow_flexion -y, forearm_rotation +z                  elbow
hand_s         wrist_flexion -x                                       wrist
thigh_s        hip_flexion -y, hip_abduction +x, hip_rotation +z      hip
shank_s        knee_flexion +y                                        knee
foot_s         ankle_flexion -y                                       ankle
=============  ====================================================  =============================

Right-side axes are the mirror images ``(-x, y, -z)`` of the left ones, so a coordinate means the
same movement on both sides. The shoulder is the ISB-like Y-X-Y sequence; its frame rides on the
clavicle, so the shoulder angles are relative to the thorax only while the clavicle coordinates
are 0. As in any Y-X-Y sequence, ``sh_rotation`` = 0 is a pure swing (no axial twist) only in the
abduction plane; a twist-free elevation in plane ``sh_plane`` needs ``sh_rotation = sh_plane``,
and at ``sh_elevation`` = 0 the plane and rotation hinges share one axis.

Every pivot lies at a site of each topology that is a bone end across it (SpineBase / PELVIS for
the trunk, SpineShoulder and both k4abt CLAVICLE joints for the clavicles, Kinect Neck / k4abt
NECK for the neck), so every bone of both topologies is rigid. Hence the trunk pivots at the hip
centre level rather than in the lumbar spine, and both clavicles pivot at the sternal notch, where
both k4abt CLAVICLE joints coincide.

Layout (H = stature, trunk = trunk length, heights above the hip centres; sizes in
:mod:`sim.anthropometry`): pelvis ellipsoid centred 0.07 trunk up and 0.008 H back; abdomen
ellipsoid at 0.40 trunk; chest ellipsoid at 0.72 trunk, 0.005 H forward; sternal notch 0.02 H
forward and 0.012 H below shoulder level; neck from shoulder level up, in two capsules meeting at
the mid-neck pivot; head ellipsoid centre 0.045 H above the atlanto-occipital joint and 0.008 H
forward; foot box from 0.2 foot lengths behind to 0.8 in front of the ankle, from the sole up to
the ankle centre.

Sites. For each joint of :data:`fusion.topology.KINECT_V2` and :data:`fusion.topology.K4ABT` a site
``f"{topology.name}/{joint}"`` at the anatomical point: joint centres for the limbs; SpineBase /
PELVIS mid between the hip centres; SPINE_NAVEL at 0.36 trunk, SpineMid at 0.55 trunk and
SPINE_CHEST at 0.70 trunk; SpineShoulder at the sternal notch; Kinect Neck and k4abt NECK
mid-neck; Head / HEAD at the head centre; hand at 0.3 hand lengths from the wrist; hand tip at
the middle finger tip; thumb at the thumb tip; foot at the forefoot; nose, eyes and ears on the
head surface.

Geoms: floor plane ``"floor"`` at z = 0 in geom group 0; body geoms in group 1, named after their
body (segment) and colliding with the floor only.
"""

from __future__ import annotations

import mujoco
import numpy as np

from fusion.errors import BadInputError
from fusion.topology import K4ABT, KINECT_V2
from sim.anthropometry import Anthropometry
from sim.humanoid import SIDES, Humanoid

BODY_GEOM_GROUP = 1
"""MuJoCo geom group of every body geom (the floor is in group 0)."""


_LEFT_AXES = {
    "clav_elevation": (1, 0, 0),
    "clav_retraction": (0, 0, 1),
    "sh_plane": (0, 0, -1),
    "sh_elevation": (1, 0, 0),
    "sh_rotation": (0, 0, 1),
    "elbow_flexion": (0, -1, 0),
    "forearm_rotation": (0, 0, 1),
    "wrist_flexion": (-1, 0, 0),
    "hip_flexion": (0, -1, 0),
    "hip_abduction": (1, 0, 0),
    "hip_rotation": (0, 0, 1),
    "knee_flexion": (0, 1, 0),
    "ankle_flexion": (0, -1, 0),
}


_KINECT_CENTRAL = {
    "SpineBase": "pelvis",
    "SpineMid": "spine_mid",
    "SpineShoulder": "sternal_notch",
    "Neck": "neck",
    "Head": "head_centre",
}


_KINECT_SIDED = {
    "Shoulder": "shoulder",
    "Elbow": "elbow",
    "Wrist": "wrist",
    "Hand": "hand",
    "HandTip": "handtip",
    "Thumb": "thumb",
    "Hip": "hip",
    "Knee": "knee",
    "Ankle": "ankle",
    "Foot": "foot",
}


_K4ABT_CENTRAL = {
    "PELVIS": "pelvis",
    "SPINE_NAVEL": "navel",
    "SPINE_CHEST": "spine_chest",
    "NECK": "neck",
    "HEAD": "head_centre",
    "NOSE": "nose",
}


_K4ABT_SIDED = {"CLAVICLE": "clavicle", "EYE": "eye", "EAR": "ear"} | {
    k.upper(): v for k, v in _KINECT_SIDED.items()
}


_SITE_POINTS: dict[str, dict[str, str]] = {
    KINECT_V2.name: _KINECT_CENTRAL
    | {f"{k}{side}": f"{v}_{s}" for k, v in _KINECT_SIDED.items() for side, s in (("Left", "l"), ("Right", "r"))},
    K4ABT.name: _K4ABT_CENTRAL
    | {f"{k}_{side}": f"{v}_{s}" for k, v in _K4ABT_SIDED.items() for side, s in (("LEFT", "l"), ("RIGHT", "r"))},
}


_SKIN = (0.80, 0.62, 0.52, 1.0)


_ARMATURE = 0.01
"""Hinge armature, kg m^2: keeps the joint-space inertia invertible at sh_elevation = 0, where the
Y-X-Y shoulder is gimbal-locked (sh_plane and sh_rotation share one axis)."""


def build_humanoid(anthro: Anthropometry) -> Humanoid:
    """Build and compile the humanoid for one subject.

    Parameters
    ----------
    anthro : Anthropometry
        Body proportions.

    Returns
    -------
    Humanoid

    Raises
    ------
    BadInputError
        If ``anthro`` is not an :class:`~sim.anthropometry.Anthropometry`.
    """
    if not isinstance(anthro, Anthropometry):
        raise BadInputError(f"build_humanoid needs an Anthropometry, got {type(anthro).__name__}")
    d = anthro.dimensions
    h, trunk = anthro.height_m, d.trunk
    spec = mujoco.MjSpec()
    spec.modelname = "mocap_bench_humanoid"
    spec.worldbody.add_geom(
        name="floor",
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[0.0, 0.0, 0.05],
        group=0,
        contype=0,
        conaffinity=1,
        rgba=[0.6, 0.6, 0.6, 1.0],
    )
    points: dict[str, tuple[mujoco.MjsBody, np.ndarray]] = {}

    def body(parent: mujoco.MjsBody, name: str, pos, hinges=()) -> mujoco.MjsBody:
        child = parent.add_body(name=name, pos=list(map(float, pos)))
        for joint, axis in hinges:
            child.add_joint(
                name=joint, type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(map(float, axis)), armature=_ARMATURE
            )
        return child

    def geom(parent: mujoco.MjsBody, name: str, gtype: mujoco.mjtGeom, size, **placement) -> None:
        parent.add_geom(
            name=name,
            type=gtype,
            size=[float(x) for x in size],
            group=BODY_GEOM_GROUP,
            contype=1,
            conaffinity=0,
            rgba=list(_SKIN),
            **{k: [float(x) for x in v] for k, v in placement.items()},
        )

    def point(name: str, parent: mujoco.MjsBody, pos=(0.0, 0.0, 0.0)) -> None:
        points[name] = (parent, np.asarray(pos, dtype=float))

    capsule, ellipsoid, box = mujoco.mjtGeom.mjGEOM_CAPSULE, mujoco.mjtGeom.mjGEOM_ELLIPSOID, mujoco.mjtGeom.mjGEOM_BOX

    pelvis = body(spec.worldbody, "pelvis", (0.0, 0.0, d.ankle_height + d.shank + d.thigh))
    pelvis.add_freejoint(name="root")
    geom(pelvis, "pelvis", ellipsoid, d.pelvis_semi_axes, pos=(-0.008 * h, 0.0, 0.07 * trunk))
    point("pelvis", pelvis)

    thorax = body(
        pelvis,
        "thorax",
        (0.0, 0.0, 0.0),
        (("trunk_flexion", (0, 1, 0)), ("trunk_lateral", (1, 0, 0)), ("trunk_rotation", (0, 0, 1))),
    )
    geom(thorax, "thorax_abdomen", ellipsoid, d.abdomen_semi_axes, pos=(0.0, 0.0, 0.40 * trunk))
    geom(thorax, "thorax_chest", ellipsoid, d.chest_semi_axes, pos=(0.005 * h, 0.0, 0.72 * trunk))
    geom(thorax, "thorax_neck", capsule, (d.neck_radius,), fromto=(0.0, 0.0, trunk, 0.0, 0.0, trunk + d.neck / 2))
    point("navel", thorax, (0.0, 0.0, 0.36 * trunk))
    point("spine_mid", thorax, (0.0, 0.0, 0.55 * trunk))
    point("spine_chest", thorax, (0.0, 0.0, 0.70 * trunk))
    sternal_notch = np.array([0.02 * h, 0.0, trunk - 0.012 * h])
    point("sternal_notch", thorax, sternal_notch)

    neck = body(thorax, "neck", (0.0, 0.0, trunk + d.neck / 2), (("neck_flexion", (0, 1, 0)),))
    geom(neck, "neck", capsule, (d.neck_radius,), fromto=(0.0, 0.0, 0.0, 0.0, 0.0, d.neck / 2))
    point("neck", neck)

    head = body(neck, "head", (0.0, 0.0, d.neck / 2), (("neck_rotation", (0, 0, 1)),))
    a, b, c = d.head_semi_axes
    centre = np.array([0.008 * h, 0.0, d.head - c])
    geom(head, "head", ellipsoid, d.head_semi_axes, pos=centre)
    point("head_centre", head, centre)
    point("nose", head, centre + (1.1 * a, 0.0, -0.35 * c))

    for s, y in SIDES.items():
        def hinges(*names: str, s: str = s) -> tuple[tuple[str, tuple[float, float, float]], ...]:
            return tuple((f"{n}_{s}", _side_axis(n, s)) for n in names)

        point(f"eye_{s}", head, centre + (0.8 * a, y * 0.4 * b, 0.0))
        point(f"ear_{s}", head, centre + (-0.1 * a, y * 0.98 * b, -0.1 * c))

        glenohumeral = np.array([0.0, y * d.shoulder_width / 2, trunk])
        clavicle = body(thorax, f"clavicle_{s}", sternal_notch, hinges("clav_elevation", "clav_retraction"))
        geom(
            clavicle,
            f"clavicle_{s}",
            capsule,
            (d.shoulder_girdle_radius,),
            fromto=np.r_[0.0, 0.0, 0.0, glenohumeral - sternal_notch],
        )
        point(f"clavicle_{s}", clavicle)

        upper_arm = body(
            clavicle, f"upper_arm_{s}", glenohumeral - sternal_notch, hinges("sh_plane", "sh_elevation", "sh_rotation")
        )
        geom(upper_arm, f"upper_arm_{s}", capsule, (d.upper_arm_radius,), fromto=(0, 0, 0, 0, 0, -d.upper_arm))
        point(f"shoulder_{s}", upper_arm)

        forearm = body(upper_arm, f"forearm_{s}", (0.0, 0.0, -d.upper_arm), hinges("elbow_flexion", "forearm_rotation"))
        geom(
            forearm,
            f"forearm_{s}",
            capsule,
            (d.forearm_radius,),
            fromto=(0, 0, 0, 0, 0, -(d.forearm - d.forearm_radius)),
        )
        point(f"elbow_{s}", forearm)

        hand = body(forearm, f"hand_{s}", (0.0, 0.0, -d.forearm), hinges("wrist_flexion"))
        geom(
            hand,
            f"hand_{s}",
            box,
            (d.hand_breadth / 2, d.hand_thickness / 2, d.hand / 2),
            pos=(0.0, 0.0, -d.hand / 2),
        )
        thumb_base = np.array([0.30 * d.hand_breadth, -y * 0.3 * d.hand_thickness, -0.12 * d.hand])
        thumb_tip = np.array([0.55 * d.hand_breadth, -y * 0.5 * d.hand_thickness, -0.50 * d.hand])
        direction = (thumb_tip - thumb_base) / np.linalg.norm(thumb_tip - thumb_base)
        geom(
            hand,
            f"hand_{s}_thumb",
            capsule,
            (d.thumb_radius,),
            fromto=np.r_[thumb_base, thumb_tip - d.thumb_radius * direction],
        )
        point(f"wrist_{s}", hand)
        point(f"hand_{s}", hand, (0.0, 0.0, -0.3 * d.hand))
        point(f"handtip_{s}", hand, (0.0, 0.0, -d.hand))
        point(f"thumb_{s}", hand, thumb_tip)

        hip = (0.0, y * d.hip_width / 2, 0.0)
        thigh = body(pelvis, f"thigh_{s}", hip, hinges("hip_flexion", "hip_abduction", "hip_rotation"))
        geom(thigh, f"thigh_{s}", capsule, (d.thigh_radius,), fromto=(0, 0, 0, 0, 0, -d.thigh))
        point(f"hip_{s}", thigh)

        shank = body(thigh, f"shank_{s}", (0.0, 0.0, -d.thigh), hinges("knee_flexion"))
        geom(shank, f"shank_{s}", capsule, (d.shank_radius,), fromto=(0, 0, 0, 0, 0, -(d.shank - d.shank_radius)))
        point(f"knee_{s}", shank)

        foot = body(shank, f"foot_{s}", (0.0, 0.0, -d.shank), hinges("ankle_flexion"))
        geom(
            foot,
            f"foot_{s}",
            box,
            (d.foot_length / 2, d.foot_width / 2, d.ankle_height / 2),
            pos=(0.3 * d.foot_length, 0.0, -d.ankle_height / 2),
        )
        point(f"ankle_{s}", foot)
        point(f"foot_{s}", foot, (0.5 * d.foot_length, 0.0, -0.4 * d.ankle_height))

    for topology, joint_points in _SITE_POINTS.items():
        for joint, name in joint_points.items():
            parent, pos = points[name]
            parent.add_site(name=f"{topology}/{joint}", pos=pos.tolist(), size=[0.01, 0.0, 0.0], group=4)
    return Humanoid(anthro, spec.compile())


def _side_axis(coordinate: str, side: str) -> tuple[float, float, float]:
    """Hinge axis of a sided coordinate: the left axis, mirrored ``(-x, y, -z)`` for the right."""
    ax, ay, az = _LEFT_AXES[coordinate]
    y = SIDES[side]
    return (y * ax, ay, y * az)
