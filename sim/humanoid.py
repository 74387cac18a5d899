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

from collections.abc import Mapping
from types import MappingProxyType

import mujoco
import numpy as np

from fusion.errors import BadInputError, UnknownNameError
from fusion.topology import K4ABT, KINECT_V2, Topology
from sim.anthropometry import Anthropometry
from sim.coordinates import COORDINATES, INDEX, ROOT

BODY_GEOM_GROUP = 1
"""MuJoCo geom group of every body geom (the floor is in group 0)."""

_SIDES = {"l": 1.0, "r": -1.0}  # side suffix -> sign of the lateral (y) direction

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
_TOPOLOGIES = {t.name: t for t in (KINECT_V2, K4ABT)}

_SKIN = (0.80, 0.62, 0.52, 1.0)

_ARMATURE = 0.01
"""Hinge armature, kg m^2: keeps the joint-space inertia invertible at sh_elevation = 0, where the
Y-X-Y shoulder is gimbal-locked (sh_plane and sh_rotation share one axis)."""


class Humanoid:
    """A compiled humanoid and vectorised kinematics over coordinate arrays.

    Build it with :func:`build_humanoid`. Coordinate arrays have shape ``(T, K)`` with columns in
    the order of :data:`sim.coordinates.COORDINATES` (metres for ``root_x``/``root_y``, radians
    otherwise).

    Attributes
    ----------
    anthro : Anthropometry
        The subject's proportions.
    model : mujoco.MjModel
        The compiled model.
    data : mujoco.MjData
        Scratch data; :meth:`set_pose` writes into it.
    qpos_adr : Mapping[str, int]
        Coordinate name -> address in ``qpos``. Hinge coordinates map to their joint's single
        entry; ``root_x``/``root_y`` to the free joint's x/y; ``root_yaw`` to the start of the
        free joint's quaternion ``(w, x, y, z)``, which holds a rotation about world z.
    """

    def __init__(self, anthro: Anthropometry, model: mujoco.MjModel) -> None:
        """Wrap a model compiled by :func:`build_humanoid` (it relies on its joint and body names)."""
        self.anthro = anthro
        self.model = model
        self.data = mujoco.MjData(model)
        m = model
        root = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "root")
        self._root_adr = int(m.jnt_qposadr[root])
        hinge_names = [c for c in COORDINATES if c not in ROOT]
        hinge_adr = [int(m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, c)]) for c in hinge_names]
        self._hinge_cols = np.array([INDEX[c] for c in hinge_names], dtype=int)
        self._hinge_adr = np.array(hinge_adr, dtype=int)
        adr = dict(zip(hinge_names, hinge_adr))
        adr |= {"root_x": self._root_adr, "root_y": self._root_adr + 1, "root_yaw": self._root_adr + 3}
        self.qpos_adr: Mapping[str, int] = MappingProxyType({c: adr[c] for c in COORDINATES})

        self._body_R = np.empty((m.nbody, 3, 3))
        for b in range(m.nbody):
            mat = np.empty(9)
            mujoco.mju_quat2Mat(mat, m.body_quat[b])
            self._body_R[b] = mat.reshape(3, 3)
        self._joints = []  # per body: (type, qpos address, skew(axis), skew(axis)^2, anchor)
        for b in range(m.nbody):
            entries = []
            for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]):
                k = _skew(m.jnt_axis[j])
                entries.append((int(m.jnt_type[j]), int(m.jnt_qposadr[j]), k, k @ k, m.jnt_pos[j].copy()))
            self._joints.append(entries)

        self._thorax = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "thorax")
        feet = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"foot_{s}") for s in _SIDES]
        self._foot_geoms = np.flatnonzero(np.isin(m.geom_bodyid, feet))
        self._foot_geom_R = _quat_to_mat(m.geom_quat[self._foot_geoms])
        self._body_geoms = np.flatnonzero(m.geom_bodyid != 0)
        self._floor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
        self._sites = {
            name: np.array([mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, f"{name}/{j}") for j in topo.joints])
            for name, topo in _TOPOLOGIES.items()
        }

    @property
    def body_geom_ids(self) -> np.ndarray:
        """(G,) int ids of every geom attached to a body of the humanoid (not the floor)."""
        return self._body_geoms.copy()

    @property
    def floor_geom_id(self) -> int:
        """Id of the floor plane geom."""
        return self._floor

    def site_ids(self, topology: Topology) -> np.ndarray:
        """Site ids of a topology's joints.

        Parameters
        ----------
        topology : Topology
            :data:`~fusion.topology.KINECT_V2` or :data:`~fusion.topology.K4ABT`.

        Returns
        -------
        numpy.ndarray
            (J,) int site ids in the topology's joint order.

        Raises
        ------
        UnknownNameError
            If the humanoid has no sites for this topology.
        """
        if _TOPOLOGIES.get(topology.name) != topology:
            raise UnknownNameError("humanoid topology", topology.name, _TOPOLOGIES)
        return self._sites[topology.name].copy()

    def qpos(self, coords: np.ndarray) -> np.ndarray:
        """MuJoCo generalised positions of a motion, grounded on the floor.

        Parameters
        ----------
        coords : numpy.ndarray
            (T, K) coordinates, metres / radians.

        Returns
        -------
        numpy.ndarray
            (T, nq) qpos; the root height puts the lowest point of the feet at z = 0 in each frame.

        Raises
        ------
        BadInputError
            If ``coords`` is not a finite (T, K) array.
        """
        return self._solve(_check_coords(coords, 2))[0]

    def set_pose(self, coords_row: np.ndarray) -> None:
        """Pose :attr:`data` (``qpos`` and ``mj_kinematics``) for one frame.

        Afterwards ``data.xpos``, ``data.geom_xpos``, ``data.geom_xmat`` and ``data.site_xpos`` are
        valid, e.g. for ``mujoco.mj_ray``.

        Parameters
        ----------
        coords_row : numpy.ndarray
            (K,) coordinates of one frame, metres / radians.

        Raises
        ------
        BadInputError
            If ``coords_row`` is not a finite (K,) array.
        """
        self.data.qpos[:] = self._solve(_check_coords(coords_row, 1)[None])[0][0]
        mujoco.mj_kinematics(self.model, self.data)

    def set_qpos(self, qpos_row: np.ndarray) -> None:
        """Pose :attr:`data` from a row of :meth:`qpos` (no re-grounding) and run ``mj_kinematics``.

        The fast path for loops over frames: compute ``qpos(coords)`` once, then call this per frame.

        Parameters
        ----------
        qpos_row : numpy.ndarray
            (nq,) generalised positions.
        """
        self.data.qpos[:] = qpos_row
        mujoco.mj_kinematics(self.model, self.data)

    def joint_positions(self, coords: np.ndarray, topology: Topology) -> np.ndarray:
        """True world positions of a topology's joints over a motion.

        Parameters
        ----------
        coords : numpy.ndarray
            (T, K) coordinates, metres / radians.
        topology : Topology
            :data:`~fusion.topology.KINECT_V2` or :data:`~fusion.topology.K4ABT`.

        Returns
        -------
        numpy.ndarray
            (T, J, 3) site positions in the world frame, metres.

        Raises
        ------
        BadInputError
            If ``coords`` is not a finite (T, K) array.
        UnknownNameError
            If the humanoid has no sites for this topology.
        """
        _, R, p = self._solve(_check_coords(coords, 2))
        return self._sites_from(R, p, topology)

    def facing_yaw(self, coords: np.ndarray) -> np.ndarray:
        """Heading of the thorax in the world xy plane.

        The heading is the direction 90 degrees clockwise (seen from above) of the thorax's
        left-pointing axis, i.e. the chest's forward direction, robust to trunk flexion.

        Parameters
        ----------
        coords : numpy.ndarray
            (T, K) coordinates, metres / radians.

        Returns
        -------
        numpy.ndarray
            (T,) yaw in radians in [-pi, pi]; 0 faces world +x, pi/2 faces world +y.

        Raises
        ------
        BadInputError
            If ``coords`` is not a finite (T, K) array.
        """
        _, R, _ = self._solve(_check_coords(coords, 2))
        return self._facing_from(R)

    def track(self, coords: np.ndarray, topology: Topology) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`qpos`, :meth:`joint_positions` and :meth:`facing_yaw` from one kinematics pass.

        Returns
        -------
        qpos : (T, nq); joints : (T, J, 3) world [m]; facing : (T,) [rad].
        """
        qpos, R, p = self._solve(_check_coords(coords, 2))
        return qpos, self._sites_from(R, p, topology), self._facing_from(R)

    def _sites_from(self, R: np.ndarray, p: np.ndarray, topology: Topology) -> np.ndarray:
        sites = self.site_ids(topology)
        body = self.model.site_bodyid[sites]
        return p[:, body] + np.einsum("tjab,jb->tja", R[:, body], self.model.site_pos[sites])

    def _facing_from(self, R: np.ndarray) -> np.ndarray:
        left = R[:, self._thorax, :, 1]
        return np.arctan2(-left[:, 0], left[:, 1])

    def _solve(self, coords: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Grounded qpos (T, nq), body rotations (T, nbody, 3, 3) and positions (T, nbody, 3)."""
        n = len(coords)
        qpos = np.tile(self.model.qpos0, (n, 1))
        a = self._root_adr
        yaw = coords[:, INDEX["root_yaw"]]
        qpos[:, a] = coords[:, INDEX["root_x"]]
        qpos[:, a + 1] = coords[:, INDEX["root_y"]]
        qpos[:, a + 2] = 0.0
        qpos[:, a + 3 : a + 7] = 0.0
        qpos[:, a + 3] = np.cos(yaw / 2)
        qpos[:, a + 6] = np.sin(yaw / 2)
        qpos[:, self._hinge_adr] = coords[:, self._hinge_cols]
        R, p = self._forward(qpos)
        lift = -self._lowest_foot_z(R, p)
        qpos[:, a + 2] = lift
        p[:, 1:, 2] += lift[:, None]
        return qpos, R, p

    def _forward(self, qpos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Body rotations (T, nbody, 3, 3) and positions (T, nbody, 3) for (T, nq) qpos, as mj_kinematics."""
        m, n = self.model, len(qpos)
        R = np.empty((n, m.nbody, 3, 3))
        p = np.empty((n, m.nbody, 3))
        R[:, 0], p[:, 0] = np.eye(3), 0.0
        for b in range(1, m.nbody):
            parent = m.body_parentid[b]
            Rb = R[:, parent] @ self._body_R[b]
            pb = p[:, parent] + R[:, parent] @ m.body_pos[b]
            for jtype, adr, k, k2, anchor in self._joints[b]:
                if jtype == mujoco.mjtJoint.mjJNT_FREE:
                    pb = qpos[:, adr : adr + 3].copy()
                    Rb = _quat_to_mat(qpos[:, adr + 3 : adr + 7])
                else:  # hinge about the anchor, as mj_kinematics does
                    q = qpos[:, adr, None, None]
                    x_anchor = pb + Rb @ anchor
                    Rb = Rb @ (np.eye(3) + np.sin(q) * k + (1.0 - np.cos(q)) * k2)
                    pb = x_anchor - Rb @ anchor
            R[:, b], p[:, b] = Rb, pb
        return R, p

    def _lowest_foot_z(self, R: np.ndarray, p: np.ndarray) -> np.ndarray:
        """(T,) lowest z of the foot boxes, metres."""
        m = self.model
        g = self._foot_geoms
        body = m.geom_bodyid[g]
        centre_z = p[:, body, 2] + np.einsum("tgb,gb->tg", R[:, body, 2], m.geom_pos[g])
        world_row_z = np.einsum("tgb,gbc->tgc", R[:, body, 2], self._foot_geom_R)  # z-row of each box's rotation
        reach = np.einsum("tgc,gc->tg", np.abs(world_row_z), m.geom_size[g])
        return (centre_z - reach).min(axis=1)


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

    for s, y in _SIDES.items():
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
    y = _SIDES[side]
    return (y * ax, ay, y * az)


def _check_coords(coords: np.ndarray, ndim: int) -> np.ndarray:
    """Validate (T, K) (``ndim`` 2) or (K,) (``ndim`` 1) coordinates; float64 copy."""
    k = len(COORDINATES)
    want = f"(T, {k})" if ndim == 2 else f"({k},)"
    try:
        arr = np.array(coords, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise BadInputError(f"coordinates must be a numeric array of shape {want}: {err}") from None
    if arr.ndim != ndim or arr.shape[-1] != k:
        raise BadInputError(
            f"coordinates must have shape {want} with columns sim.coordinates.COORDINATES, got {arr.shape}"
        )
    bad = ~np.isfinite(arr)
    if bad.any():
        where = np.argwhere(bad.reshape(-1, k))[0]
        raise BadInputError(
            f"coordinates contain NaN or inf ({int(bad.sum())} values), first at frame {where[0]}, "
            f"coordinate {COORDINATES[where[1]]!r}"
        )
    return arr


def _skew(v: np.ndarray) -> np.ndarray:
    """(3, 3) cross-product matrix of a (3,) vector."""
    x, y, z = v
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def _quat_to_mat(q: np.ndarray) -> np.ndarray:
    """(N, 3, 3) rotation matrices of (N, 4) quaternions (w, x, y, z), normalised first."""
    w, x, y, z = (q / np.linalg.norm(q, axis=1, keepdims=True)).T
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], axis=-1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], axis=-1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=-1),
        ],
        axis=-2,
    )
