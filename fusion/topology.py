"""Joint topologies as values: Kinect v2 (25 joints), Azure Kinect / Orbbec K4ABT (32 joints) and the
22-joint hierarchy of the UI-PRMD data set's Kinect files.

A :class:`Topology` holds joint names, parents, bones, left/right pairs, body regions and a
mapping from topology-independent :class:`Landmark` names to joint indices, so that calibration,
merging and the Fugl-Meyer measurements work for either sensor family. A joint set without a joint
for some landmark declares it in :attr:`Topology.lacks` (UI-PRMD has no hand centre, hand tip or
thumb); looking such a landmark up is an error, never a stand-in joint.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from fusion.errors import BadInputError, UnknownNameError


class TrackingState(enum.IntEnum):
    """Per-joint confidence on one ordered scale shared by all sensors.

    Kinect v2: 0 NotTracked, 1 Inferred, 2 Tracked. K4ABT: 0 NONE, 1 LOW, 2 MEDIUM, 3 HIGH.
    A higher value is a more trustworthy measurement.
    """

    NOT_TRACKED = 0
    INFERRED = 1
    TRACKED = 2
    HIGH = 3


class Region(enum.IntEnum):
    """Body region of a joint, used to spread RANSAC samples over the body."""

    UPPER = 0
    MID = 1
    LOWER = 2


class Landmark(enum.Enum):
    """Anatomical landmarks every supported topology provides, by topology-free name."""

    PELVIS = "pelvis"
    SPINE_MID = "spine_mid"
    SPINE_SHOULDER = "spine_shoulder"
    NECK = "neck"
    HEAD = "head"
    SHOULDER_LEFT = "shoulder_left"
    ELBOW_LEFT = "elbow_left"
    WRIST_LEFT = "wrist_left"
    HAND_LEFT = "hand_left"
    HANDTIP_LEFT = "handtip_left"
    THUMB_LEFT = "thumb_left"
    SHOULDER_RIGHT = "shoulder_right"
    ELBOW_RIGHT = "elbow_right"
    WRIST_RIGHT = "wrist_right"
    HAND_RIGHT = "hand_right"
    HANDTIP_RIGHT = "handtip_right"
    THUMB_RIGHT = "thumb_right"
    HIP_LEFT = "hip_left"
    KNEE_LEFT = "knee_left"
    ANKLE_LEFT = "ankle_left"
    FOOT_LEFT = "foot_left"
    HIP_RIGHT = "hip_right"
    KNEE_RIGHT = "knee_right"
    ANKLE_RIGHT = "ankle_right"
    FOOT_RIGHT = "foot_right"


@dataclass(frozen=True, eq=False)
class Topology:
    """A skeleton's joint set.

    Attributes
    ----------
    name : str
        Identifier written into recordings (``"kinect_v2"`` or ``"k4abt"``).
    joints : tuple of str
        Joint names in the sensor's own order, length J.
    parents : tuple of int
        Parent index per joint, -1 for the root.
    regions : tuple of Region
        Body region per joint.
    landmarks : dict
        :class:`Landmark` -> joint name.
    lacks : frozenset of Landmark
        The landmarks no joint of this set stands for; every :class:`Landmark` is either in
        ``landmarks`` or here. Looking one of them up raises :class:`~fusion.errors.UnknownNameError`.
    reduced_from : str or None
        The joint set this one reduces (UI-PRMD's files: ``"kinect_v2"``); simulations of it track
        that set and keep these joints (:meth:`columns_in`).
    """

    name: str
    joints: tuple[str, ...]
    parents: tuple[int, ...]
    regions: tuple[Region, ...]
    landmarks: dict[Landmark, str] = field(repr=False)
    lacks: frozenset[Landmark] = frozenset()
    reduced_from: str | None = None

    def __post_init__(self) -> None:
        n = len(self.joints)
        if len(set(self.joints)) != n:
            raise BadInputError(f"topology {self.name}: joint names are not unique")
        if len(self.parents) != n or len(self.regions) != n:
            raise BadInputError(f"topology {self.name}: parents/regions must have {n} entries")
        roots = [i for i, p in enumerate(self.parents) if p == -1]
        if len(roots) != 1:
            raise BadInputError(f"topology {self.name}: exactly one root expected, got {roots}")
        for i, p in enumerate(self.parents):
            if not -1 <= p < n or p == i:
                raise BadInputError(f"topology {self.name}: bad parent {p} of joint {i}")
        for lm, joint in self.landmarks.items():
            if joint not in self.joints:
                raise BadInputError(f"topology {self.name}: landmark {lm} names unknown {joint}")
        both = set(self.lacks) & set(self.landmarks)
        if both:
            raise BadInputError(f"topology {self.name}: landmarks both mapped and lacking: {sorted(m.value for m in both)}")
        missing = set(Landmark) - set(self.landmarks) - set(self.lacks)
        if missing:
            raise BadInputError(f"topology {self.name}: landmarks missing: {sorted(m.value for m in missing)}")

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Topology) and other.name == self.name and other.joints == self.joints

    def __hash__(self) -> int:
        return hash((self.name, self.joints))

    @property
    def n_joints(self) -> int:
        """Number of joints J."""
        return len(self.joints)

    def index(self, joint: str | Landmark) -> int:
        """Index of a joint given by its sensor name or by a :class:`Landmark`."""
        if isinstance(joint, Landmark):
            if joint not in self.landmarks:
                raise UnknownNameError(f"landmark of the {self.name} joint set (it has no joint for it)", joint.value,
                                       [lm.value for lm in self.landmarks])
            joint = self.landmarks[joint]
        try:
            return self._index[joint]
        except KeyError:
            raise UnknownNameError(f"{self.name} joint", joint, self.joints) from None

    def indices(self, joints: list[str | Landmark] | tuple[str | Landmark, ...]) -> np.ndarray:
        """Indices of several joints, shape (K,) int."""
        return np.array([self.index(j) for j in joints], dtype=int)

    @property
    def full_set(self) -> Topology:
        """The joint set the tracker that reported this one tracks: :attr:`reduced_from`'s, else this one."""
        return self if self.reduced_from is None else topology_by_name(self.reduced_from)

    def columns_in(self, full: Topology) -> np.ndarray:
        """(J,) int: the joint of ``full`` that stands for each joint of this set: that of its landmark, or
        for a joint without one (UI-PRMD's collars) that of its nearest ancestor with one. Raises
        :class:`~fusion.errors.BadInputError` when ``full`` lacks a landmark of this set."""
        missing = sorted(lm.value for lm in self.landmarks if lm not in full.landmarks)
        if missing:
            raise BadInputError(f"the {full.name} joint set does not cover the {self.name} joint set: it has no "
                                f"joint for {', '.join(missing)}")
        of_joint = {j: lm for lm, j in self.landmarks.items()}
        cols = []
        for i in range(self.n_joints):
            k = i
            while self.joints[k] not in of_joint:
                k = self.parents[k]
                if k < 0:
                    raise BadInputError(f"joint {self.joints[i]} of {self.name} has no landmark above it")
            cols.append(full.index(of_joint[self.joints[k]]))
        return np.array(cols, dtype=int)

    @cached_property
    def _index(self) -> dict[str, int]:
        return {n: i for i, n in enumerate(self.joints)}

    @cached_property
    def bones(self) -> np.ndarray:
        """(B, 2) int array of (parent, child) index pairs."""
        return np.array([(p, c) for c, p in enumerate(self.parents) if p >= 0], dtype=int)

    @cached_property
    def mirror(self) -> np.ndarray:
        """(J,) int permutation mapping each joint to its left/right counterpart (itself if central)."""
        perm = np.arange(self.n_joints)
        for a, b in self.lr_pairs:
            perm[a], perm[b] = b, a
        return perm

    @cached_property
    def lr_pairs(self) -> np.ndarray:
        """(P, 2) int array of (left, right) joint index pairs."""
        pairs = []
        for i, n in enumerate(self.joints):
            other = _swap_side(n)
            if other != n and other in self._index and _is_left(n):
                pairs.append((i, self._index[other]))
        return np.array(pairs, dtype=int).reshape(-1, 2)

    @cached_property
    def region_array(self) -> np.ndarray:
        """(J,) int array of :class:`Region` values."""
        return np.array([int(r) for r in self.regions], dtype=int)


_SIDES = (("Left", "Right"), ("LEFT", "RIGHT"))


def _is_left(name: str) -> bool:
    return any(name.endswith(left) for left, _ in _SIDES)


def _swap_side(name: str) -> str:
    for left, right in _SIDES:
        if name.endswith(left):
            return name[: -len(left)] + right
        if name.endswith(right):
            return name[: -len(right)] + left
    return name


def _build(name: str, spec: list[tuple[str, str | None, Region]], landmarks: dict[Landmark, str],
           lacks: frozenset[Landmark] = frozenset(), reduced_from: str | None = None) -> Topology:
    names = tuple(j for j, _, _ in spec)
    index = {n: i for i, n in enumerate(names)}
    parents = tuple(-1 if p is None else index[p] for _, p, _ in spec)
    regions = tuple(r for _, _, r in spec)
    return Topology(name=name, joints=names, parents=parents, regions=regions, landmarks=landmarks, lacks=lacks,
                    reduced_from=reduced_from)


U, M, L = Region.UPPER, Region.MID, Region.LOWER

KINECT_V2 = _build(
    "kinect_v2",
    [
        ("SpineBase", None, M),
        ("SpineMid", "SpineBase", M),
        ("Neck", "SpineShoulder", U),
        ("Head", "Neck", U),
        ("ShoulderLeft", "SpineShoulder", U),
        ("ElbowLeft", "ShoulderLeft", U),
        ("WristLeft", "ElbowLeft", U),
        ("HandLeft", "WristLeft", U),
        ("ShoulderRight", "SpineShoulder", U),
        ("ElbowRight", "ShoulderRight", U),
        ("WristRight", "ElbowRight", U),
        ("HandRight", "WristRight", U),
        ("HipLeft", "SpineBase", M),
        ("KneeLeft", "HipLeft", L),
        ("AnkleLeft", "KneeLeft", L),
        ("FootLeft", "AnkleLeft", L),
        ("HipRight", "SpineBase", M),
        ("KneeRight", "HipRight", L),
        ("AnkleRight", "KneeRight", L),
        ("FootRight", "AnkleRight", L),
        ("SpineShoulder", "SpineMid", U),
        ("HandTipLeft", "HandLeft", U),
        ("ThumbLeft", "WristLeft", U),
        ("HandTipRight", "HandRight", U),
        ("ThumbRight", "WristRight", U),
    ],
    {
        Landmark.PELVIS: "SpineBase",
        Landmark.SPINE_MID: "SpineMid",
        Landmark.SPINE_SHOULDER: "SpineShoulder",
        Landmark.NECK: "Neck",
        Landmark.HEAD: "Head",
        Landmark.SHOULDER_LEFT: "ShoulderLeft",
        Landmark.ELBOW_LEFT: "ElbowLeft",
        Landmark.WRIST_LEFT: "WristLeft",
        Landmark.HAND_LEFT: "HandLeft",
        Landmark.HANDTIP_LEFT: "HandTipLeft",
        Landmark.THUMB_LEFT: "ThumbLeft",
        Landmark.SHOULDER_RIGHT: "ShoulderRight",
        Landmark.ELBOW_RIGHT: "ElbowRight",
        Landmark.WRIST_RIGHT: "WristRight",
        Landmark.HAND_RIGHT: "HandRight",
        Landmark.HANDTIP_RIGHT: "HandTipRight",
        Landmark.THUMB_RIGHT: "ThumbRight",
        Landmark.HIP_LEFT: "HipLeft",
        Landmark.KNEE_LEFT: "KneeLeft",
        Landmark.ANKLE_LEFT: "AnkleLeft",
        Landmark.FOOT_LEFT: "FootLeft",
        Landmark.HIP_RIGHT: "HipRight",
        Landmark.KNEE_RIGHT: "KneeRight",
        Landmark.ANKLE_RIGHT: "AnkleRight",
        Landmark.FOOT_RIGHT: "FootRight",
    },
)

K4ABT = _build(
    "k4abt",
    [
        ("PELVIS", None, M),
        ("SPINE_NAVEL", "PELVIS", M),
        ("SPINE_CHEST", "SPINE_NAVEL", U),
        ("NECK", "SPINE_CHEST", U),
        ("CLAVICLE_LEFT", "SPINE_CHEST", U),
        ("SHOULDER_LEFT", "CLAVICLE_LEFT", U),
        ("ELBOW_LEFT", "SHOULDER_LEFT", U),
        ("WRIST_LEFT", "ELBOW_LEFT", U),
        ("HAND_LEFT", "WRIST_LEFT", U),
        ("HANDTIP_LEFT", "HAND_LEFT", U),
        ("THUMB_LEFT", "WRIST_LEFT", U),
        ("CLAVICLE_RIGHT", "SPINE_CHEST", U),
        ("SHOULDER_RIGHT", "CLAVICLE_RIGHT", U),
        ("ELBOW_RIGHT", "SHOULDER_RIGHT", U),
        ("WRIST_RIGHT", "ELBOW_RIGHT", U),
        ("HAND_RIGHT", "WRIST_RIGHT", U),
        ("HANDTIP_RIGHT", "HAND_RIGHT", U),
        ("THUMB_RIGHT", "WRIST_RIGHT", U),
        ("HIP_LEFT", "PELVIS", M),
        ("KNEE_LEFT", "HIP_LEFT", L),
        ("ANKLE_LEFT", "KNEE_LEFT", L),
        ("FOOT_LEFT", "ANKLE_LEFT", L),
        ("HIP_RIGHT", "PELVIS", M),
        ("KNEE_RIGHT", "HIP_RIGHT", L),
        ("ANKLE_RIGHT", "KNEE_RIGHT", L),
        ("FOOT_RIGHT", "ANKLE_RIGHT", L),
        ("HEAD", "NECK", U),
        ("NOSE", "HEAD", U),
        ("EYE_LEFT", "HEAD", U),
        ("EAR_LEFT", "HEAD", U),
        ("EYE_RIGHT", "HEAD", U),
        ("EAR_RIGHT", "HEAD", U),
    ],
    {lm: lm.name for lm in Landmark}
    | {Landmark.SPINE_MID: "SPINE_NAVEL", Landmark.SPINE_SHOULDER: "SPINE_CHEST"},
)

UI_PRMD = _build(
    "ui_prmd",
    [
        ("Waist", None, M),
        ("Spine", "Waist", M),
        ("Chest", "Spine", U),
        ("Neck", "Chest", U),
        ("Head", "Neck", U),
        ("HeadTip", "Head", U),
        ("CollarLeft", "Chest", U),
        ("UpperArmLeft", "CollarLeft", U),
        ("ForearmLeft", "UpperArmLeft", U),
        ("HandLeft", "ForearmLeft", U),
        ("CollarRight", "Chest", U),
        ("UpperArmRight", "CollarRight", U),
        ("ForearmRight", "UpperArmRight", U),
        ("HandRight", "ForearmRight", U),
        ("UpperLegLeft", "Waist", M),
        ("LowerLegLeft", "UpperLegLeft", L),
        ("FootLeft", "LowerLegLeft", L),
        ("ToesLeft", "FootLeft", L),
        ("UpperLegRight", "Waist", M),
        ("LowerLegRight", "UpperLegRight", L),
        ("FootRight", "LowerLegRight", L),
        ("ToesRight", "FootRight", L),
    ],
    {
        Landmark.PELVIS: "Waist",
        Landmark.SPINE_MID: "Spine",
        Landmark.SPINE_SHOULDER: "Chest",
        Landmark.NECK: "Head",
        Landmark.HEAD: "HeadTip",
    }
    | {getattr(Landmark, f"{lm}_{side.upper()}"): f"{joint}{side}" for side in ("Left", "Right")
       for lm, joint in (("SHOULDER", "UpperArm"), ("ELBOW", "Forearm"), ("WRIST", "Hand"), ("HIP", "UpperLeg"),
                         ("KNEE", "LowerLeg"), ("ANKLE", "Foot"), ("FOOT", "Toes"))},
    frozenset({Landmark.HAND_LEFT, Landmark.HANDTIP_LEFT, Landmark.THUMB_LEFT,
               Landmark.HAND_RIGHT, Landmark.HANDTIP_RIGHT, Landmark.THUMB_RIGHT}),
    reduced_from="kinect_v2",
)
"""The 22-joint hierarchy of UI-PRMD's Kinect v2 files (:mod:`fusion.io.formats.ui_prmd`), in the files' order.

Joints are named after the segments the data set names (a segment's joint is where it starts):
``UpperArm`` is the shoulder joint, ``Forearm`` the elbow, ``Hand`` the wrist, ``UpperLeg`` the hip,
``LowerLeg`` the knee, ``Foot`` the ankle and ``Toes`` the forefoot. ``Neck`` (under 1 cm above
``Chest``) and the collars (under 2 cm from it) are stand-ins near the base of the neck; ``Head``
lies about 7 cm above ``Chest``, where Kinect v2 puts its neck joint, and ``HeadTip`` about 16 cm
higher, at the level of the head (measured on the data set's standing subjects against their Vicon
head markers). So the landmarks are: ``Chest`` the spine-shoulder, ``Head`` the neck, ``HeadTip`` the
head. There is no joint for the hand centre, the hand tip or the thumb (:attr:`Topology.lacks`).
"""

TOPOLOGIES: dict[str, Topology] = {t.name: t for t in (KINECT_V2, K4ABT, UI_PRMD)}


def topology_by_name(name: str) -> Topology:
    """Look a topology up by its identifier (``"kinect_v2"``, ``"k4abt"`` or ``"ui_prmd"``)."""
    try:
        return TOPOLOGIES[name]
    except KeyError:
        raise UnknownNameError("topology", name, TOPOLOGIES) from None
