"""Marker-to-landmark maps: which markers (or BVH joints) make each joint of a topology.

A :class:`MarkerMap` gives, per joint of :data:`~fusion.topology.KINECT_V2` or
:data:`~fusion.topology.K4ABT`, the markers whose weighted mean is that joint (weights sum to 1).
Joints a map leaves out are absent in the trajectory; every limb must keep its three joints
(shoulder, elbow, wrist; hip, knee, ankle) and the trunk its pelvis and spine-shoulder joints.

Built-in maps (:data:`BUILTIN_MAPS`), all onto Kinect v2 joints:

- ``body25``: the OpenPose BODY_25 keypoints as Pose2Sim / OpenCap write them into TRC files
  (``RShoulder``, ``MidHip``, ...). BODY_25's ``Neck`` is the mid-shoulder point, i.e. Kinect's
  SpineShoulder; the head is the mean of the ears.
- ``cmu``: the joints of the CMU motion capture database's BVH files (``Hips``, ``LeftUpLeg``,
  ``LeftLeg``, ``LeftFoot``, ``LeftToeBase``, ``LeftArm``, ``LeftForeArm``, ``LeftHand``,
  ``Neck``, ``Neck1``, ``Head``): ``Neck`` is the base of the neck (SpineShoulder), ``Neck1`` the
  mid-neck (halfway between ``Neck`` and ``Head``, the skull base, in the CMU skeleton); the head
  centre is left out (no joint marks it).
- ``kinect_v2``: markers named after the Kinect v2 joints, as :func:`fusion.io.export.export_trc`
  and :func:`fusion.io.export.export_c3d` write a Kinect v2 stream.
- ``plug_in_gait``: the Vicon Plug-in-Gait skin markers (as in UI-PRMD's Vicon files,
  :data:`fusion.io.formats.ui_prmd.VICON_MARKERS`). Skin markers are not joint centres, and a map
  only averages markers: estimating joint centres (offsets by segment widths, regressions) is a
  later step. What each joint is here, and how far it is from the joint it stands for:

  - ``ShoulderX`` = ``xSHO``, the acromion marker: it rides the scapula, several centimetres above
    (and lateral of) the glenohumeral joint centre, and rises with the shoulder girdle when the arm
    is raised;
  - ``ElbowX`` = ``xELB``, the lateral epicondyle: about half the elbow's width lateral of its
    centre;
  - ``WristX`` = the mean of ``xWRA`` and ``xWRB`` (radial and ulnar styloid markers): near the wrist
    centre;
  - ``HandX`` = ``xFIN``, on the back of the second metacarpal head: more distal than Kinect's
    mid-hand joint;
  - ``HipX`` = the mean of ``xASI`` and ``xPSI`` (anterior and posterior superior iliac spines):
    within a few centimetres of the hip joint centre across and along the body (for a typical
    pelvis), but in the plane of the pelvis markers, about 8 cm above it;
  - ``KneeX`` = ``xKNE`` and ``AnkleX`` = ``xANK``, the lateral femoral epicondyle and the lateral
    malleolus: about half the knee's or ankle's width lateral of their centres;
  - ``FootX`` = ``xTOE``, the second metatarsal head;
  - ``SpineBase`` = the mean of the four pelvis markers (``LASI RASI LPSI RPSI``): the midpoint of
    the two hips above, so as far above the hip centres' level, where Kinect puts it;
  - ``SpineMid`` = the mean of ``T10`` and ``STRN`` (absent where the sternum marker is lost);
    ``SpineShoulder`` = the mean of ``C7`` and ``CLAV``; ``Head`` = the mean of the four head
    markers; ``Neck`` left out (no marker marks it).

User maps are TOML::

    topology = "kinect_v2"            # or "k4abt"
    [landmarks]
    ShoulderLeft = "LSHO"             # one marker
    WristLeft = ["LWRA", "LWRB"]      # the mean of several
    SpineBase = { LASI = 0.25, RASI = 0.25, LPSI = 0.25, RPSI = 0.25 }   # weights summing to 1
"""

from __future__ import annotations

import os
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fusion.errors import BadInputError, UnknownNameError
from fusion.io.mocap import LandmarkTrajectory
from fusion.io.mocap_files import MarkerData
from fusion.topology import KINECT_V2, Landmark, Topology, topology_by_name

LIMBS: dict[str, tuple[Landmark, ...]] = {
    "trunk": (Landmark.PELVIS, Landmark.SPINE_SHOULDER),
    "left arm": (Landmark.SHOULDER_LEFT, Landmark.ELBOW_LEFT, Landmark.WRIST_LEFT),
    "right arm": (Landmark.SHOULDER_RIGHT, Landmark.ELBOW_RIGHT, Landmark.WRIST_RIGHT),
    "left leg": (Landmark.HIP_LEFT, Landmark.KNEE_LEFT, Landmark.ANKLE_LEFT),
    "right leg": (Landmark.HIP_RIGHT, Landmark.KNEE_RIGHT, Landmark.ANKLE_RIGHT),
}
"""Each limb and the joints a map must give it."""


@dataclass(frozen=True)
class MarkerMap:
    """Joint -> ((marker, weight), ...) for one topology.

    Raises
    ------
    UnknownNameError
        A joint is not in the topology (lists its joints).
    BadInputError
        A joint has no marker, a weight is not finite, the weights do not sum to 1, or a limb of
        :data:`LIMBS` lacks a joint (names the limb and the joints).
    """

    topology: Topology
    landmarks: tuple[tuple[str, tuple[tuple[str, float], ...]], ...]

    def __post_init__(self) -> None:
        for joint, markers in self.landmarks:
            self.topology.index(joint)
            weights = np.array([w for _, w in markers], dtype=float)
            if not markers or not np.isfinite(weights).all() or abs(weights.sum() - 1.0) > 1e-6:
                raise BadInputError(f"marker map: joint {joint} needs markers whose weights sum to 1, got {markers}")
        mapped = {j for j, _ in self.landmarks}
        for limb, joints in LIMBS.items():
            missing = [self.topology.landmarks[lm] for lm in joints if self.topology.landmarks[lm] not in mapped]
            if missing:
                raise BadInputError(f"the marker map leaves the {limb} unconstrained: no marker for "
                                    f"{', '.join(missing)}; add them to its [landmarks] table")

    @property
    def markers(self) -> tuple[str, ...]:
        """Every marker the map uses, sorted."""
        return tuple(sorted({m for _, ms in self.landmarks for m, _ in ms}))


def _single(pairs: dict[str, str | list[str]]) -> tuple[tuple[str, tuple[tuple[str, float], ...]], ...]:
    out = []
    for joint, markers in pairs.items():
        names = [markers] if isinstance(markers, str) else markers
        out.append((joint, tuple((m, 1.0 / len(names)) for m in names)))
    return tuple(out)


_SIDED = {"Shoulder": "Shoulder", "Elbow": "Elbow", "Wrist": "Wrist", "Hip": "Hip", "Knee": "Knee",
          "Ankle": "Ankle"}

BUILTIN_MAPS: dict[str, MarkerMap] = {
    "body25": MarkerMap(KINECT_V2, _single(
        {"SpineBase": "MidHip", "SpineShoulder": "Neck", "Head": ["LEar", "REar"]}
        | {f"{k}{side}": f"{side[0]}{v}" for k, v in _SIDED.items() for side in ("Left", "Right")}
        | {f"Foot{side}": [f"{side[0]}BigToe", f"{side[0]}SmallToe"] for side in ("Left", "Right")})),
    "cmu": MarkerMap(KINECT_V2, _single(
        {"SpineBase": "Hips", "SpineShoulder": "Neck", "Neck": "Neck1"}
        | {f"{k}{side}": f"{side}{v}" for side in ("Left", "Right")
           for k, v in (("Shoulder", "Arm"), ("Elbow", "ForeArm"), ("Wrist", "Hand"), ("Hip", "UpLeg"),
                        ("Knee", "Leg"), ("Ankle", "Foot"), ("Foot", "ToeBase"))})),
    "kinect_v2": MarkerMap(KINECT_V2, _single({j: j for j in KINECT_V2.joints})),
    # Skin markers standing in for joints, with the offsets listed in the module docstring.
    "plug_in_gait": MarkerMap(KINECT_V2, _single(
        {"SpineBase": ["LASI", "RASI", "LPSI", "RPSI"], "SpineMid": ["T10", "STRN"], "SpineShoulder": ["C7", "CLAV"],
         "Head": ["LFHD", "RFHD", "LBHD", "RBHD"]}
        | {f"{k}{side}": f"{side[0]}{v}" for side in ("Left", "Right")
           for k, v in (("Shoulder", "SHO"), ("Elbow", "ELB"), ("Hand", "FIN"), ("Knee", "KNE"), ("Ankle", "ANK"),
                        ("Foot", "TOE"))}
        | {f"Wrist{side}": [f"{side[0]}WRA", f"{side[0]}WRB"] for side in ("Left", "Right")}
        | {f"Hip{side}": [f"{side[0]}ASI", f"{side[0]}PSI"] for side in ("Left", "Right")})),
}
"""Built-in maps by name (module docstring)."""


def load_marker_map(name_or_path: str | os.PathLike) -> MarkerMap:
    """A built-in map by name, or a user map from a TOML file (module docstring).

    Raises
    ------
    BadInputError
        Neither a built-in name nor a readable map file (lists the built-ins), or a malformed table.
    """
    if str(name_or_path) in BUILTIN_MAPS:
        return BUILTIN_MAPS[str(name_or_path)]
    path = Path(name_or_path)
    if not path.is_file():
        raise BadInputError(f"marker map {str(name_or_path)!r} is neither a file nor a built-in map "
                            f"({', '.join(BUILTIN_MAPS)})")
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except (OSError, tomllib.TOMLDecodeError) as exc:
        raise BadInputError(f"{path}: not a readable TOML marker map: {exc}") from None
    table = doc.get("landmarks")
    if not isinstance(table, dict) or set(doc) - {"topology", "landmarks"}:
        raise BadInputError(f"{path}: a marker map holds topology = \"...\" and a [landmarks] table only")
    entries = []
    for joint, value in table.items():
        if isinstance(value, dict):
            entries.append((joint, tuple((str(m), float(w)) for m, w in value.items())))
        elif isinstance(value, (str, list)):
            entries.extend(_single({joint: value}))
        else:
            raise BadInputError(f"{path}: landmarks.{joint} must be a marker name, a list or a table of weights")
    return MarkerMap(topology_by_name(doc.get("topology", KINECT_V2.name)), tuple(entries))


def apply_marker_map(markers: MarkerData, marker_map: MarkerMap) -> LandmarkTrajectory:
    """Joint positions from marker positions.

    A joint is absent in a frame where any of its markers is absent (NaN); present joints have
    confidence 1.

    Parameters
    ----------
    markers : MarkerData
        (T, M, 3) marker positions [m], z up.
    marker_map : MarkerMap

    Returns
    -------
    LandmarkTrajectory

    Raises
    ------
    UnknownNameError
        The map uses a marker the file does not have (lists the file's markers).
    """
    index = {n: i for i, n in enumerate(markers.names)}
    for m in marker_map.markers:
        if m not in index:
            raise UnknownNameError(f"marker of the map in {markers.source}", m, markers.names)
    topo = marker_map.topology
    T = markers.times.size
    pos = np.full((T, topo.n_joints, 3), np.nan)
    for joint, pairs in marker_map.landmarks:
        pos[:, topo.index(joint)] = sum(w * markers.positions[:, index[m]] for m, w in pairs)
    conf = np.where(np.isnan(pos).any(axis=-1), 0.0, 1.0)
    return LandmarkTrajectory(topo, markers.times, pos, conf, markers.source)
