"""The 13 per-frame measurements of the paper's Table 4, for one moving side.

World frame of fused skeletons: z up, floor at z = 0, metres. Angles are in degrees, distances and
heights in metres. A measurement is NaN in every frame where one of its joints is NaN.

Angles. By default (:attr:`AngleDefinitions.ISB`) Table 4's five vertex angles are replaced by the
clinical angles of :func:`fusion.merge.angles.joint_angles` (ISB, Wu et al. 2005) that measure the same
movement (:data:`ISB_REPLACEMENTS`): elbow flexion for Shoulder-Elbow-Wrist, the humerothoracic plane
of elevation for SpineShoulder-Shoulder-Elbow, the humerothoracic elevation for Hip-Shoulder-Elbow,
the trunk's lateral lean toward the moving side for Shoulder-SpineShoulder-SpineMid and the trunk
flexion for Knee-Hip-SpineMid. The plane of elevation is NaN while the arm hangs (below 20 deg of
elevation), and the trunk angles take the world's up (+z) for the level pelvis, so they change under
a tilt of the world. :attr:`AngleDefinitions.TABLE4` keeps the paper's vertex angles
(:func:`fusion.merge.angles.vertex_angle_deg`).
"""

from __future__ import annotations

import enum

import numpy as np

from fusion.errors import BadInputError
from fusion.merge.angles import joint_angles, vertex_angle_deg
from fusion.topology import Landmark, Topology


class Side(enum.Enum):
    """The moving side of a repetition."""

    LEFT = "left"
    RIGHT = "right"


class AngleDefinitions(enum.Enum):
    """Which angles the measurements use (module docstring)."""

    ISB = "isb"
    TABLE4 = "table4"


TABLE4_MEASUREMENT_NAMES: tuple[str, ...] = (
    "Angle(Shoulder-Elbow-Wrist)",
    "Distance(Head-Hand)",
    "Angle(SpineShoulder-Shoulder-Elbow)",
    "Height(Hand)",
    "Height(Elbow)",
    "Height(Wrist)",
    "Angle(Shoulder-SpineShoulder-SpineMid)",
    "Angle(Hip-Shoulder-Elbow)",
    "Distance(Hand-Knee)",
    "Distance(Wrist-Hip)",
    "Angle(Knee-Hip-SpineMid)",
    "Distance(Head-Elbow)",
    "Distance(Camera-Shoulder)",
)
"""Column names of :func:`compute_measurements` with :attr:`AngleDefinitions.TABLE4`, in Table 4's
order (side-free)."""

ISB_REPLACEMENTS: dict[str, tuple[str, str]] = {
    "Angle(Shoulder-Elbow-Wrist)": ("Angle(ElbowFlexion)", "elbow_flexion_{side}"),
    "Angle(SpineShoulder-Shoulder-Elbow)": ("Angle(HTPlaneOfElevation)", "ht_plane_of_elevation_{side}"),
    "Angle(Shoulder-SpineShoulder-SpineMid)": ("Angle(TrunkLateralLean)", "trunk_lateral_lean"),
    "Angle(Hip-Shoulder-Elbow)": ("Angle(HTElevation)", "ht_elevation_{side}"),
    "Angle(Knee-Hip-SpineMid)": ("Angle(TrunkFlexion)", "trunk_flexion"),
}
"""Table 4 vertex angle -> (its ISB measurement's name, the :func:`fusion.merge.angles.joint_angles`
column, ``{side}`` the moving side)."""


def measurement_names(angles: AngleDefinitions = AngleDefinitions.ISB) -> tuple[str, ...]:
    """Column names of :func:`compute_measurements` with ``angles``, in Table 4's order."""
    if angles is AngleDefinitions.TABLE4:
        return TABLE4_MEASUREMENT_NAMES
    return tuple(ISB_REPLACEMENTS.get(n, (n,))[0] for n in TABLE4_MEASUREMENT_NAMES)


MEASUREMENT_NAMES: tuple[str, ...] = measurement_names()
"""Column names of :func:`compute_measurements` with the default (ISB) angles."""

_SIDED = ("SHOULDER", "ELBOW", "WRIST", "HAND", "HIP", "KNEE")


def side_landmarks(side: Side | str) -> dict[str, Landmark]:
    """Landmarks used by the measurements for one side.

    Keys are ``"shoulder", "elbow", "wrist", "hand", "hip", "knee"`` (all on ``side``) and
    ``"head", "spine_shoulder", "spine_mid"``.
    """
    s = as_side(side).value.upper()
    lms = {k.lower(): Landmark[f"{k}_{s}"] for k in _SIDED}
    return lms | {"head": Landmark.HEAD, "spine_shoulder": Landmark.SPINE_SHOULDER, "spine_mid": Landmark.SPINE_MID}


def as_side(side: Side | str) -> Side:
    """``side`` as a :class:`Side`; raises :class:`BadInputError` for anything but left/right."""
    try:
        return Side(side.lower() if isinstance(side, str) else side)
    except ValueError:
        raise BadInputError(f"side must be 'left' or 'right', got {side!r}") from None


def distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Euclidean distance in metres, shape (...,), for points of shape (..., 3)."""
    return np.linalg.norm(a - b, axis=-1)


def compute_measurements(
    positions: np.ndarray,
    topology: Topology,
    side: Side | str,
    *,
    camera_position: np.ndarray | None = None,
    angles: AngleDefinitions = AngleDefinitions.ISB,
) -> np.ndarray:
    """Table 4's measurements per frame for the arm on ``side``.

    Hip, knee, shoulder, elbow, wrist and hand are all taken on the moving side; in particular
    Distance(Hand-Knee) uses the same-side knee (the salute starts with the hand near the opposite
    knee, so the same-side distance still grows monotonically with the lift and is defined for the
    hand lift too).

    Parameters
    ----------
    positions : np.ndarray
        (T, J, 3) world joint positions in metres (z up, floor z = 0); NaN where absent.
    topology : Topology
        Joint set of ``positions``.
    side : Side or {"left", "right"}
        Moving arm.
    camera_position : np.ndarray, optional
        (3,) world position of the camera in metres for Distance(Camera-Shoulder); NaN column when
        omitted.
    angles : AngleDefinitions
        ISB angles (default) or Table 4's vertex angles in the five angle columns.

    Returns
    -------
    np.ndarray
        (T, 13) float64, columns named by :func:`measurement_names` of ``angles``; angles in degrees,
        distances and heights in metres.
    """
    pos = np.asarray(positions, dtype=float)
    if pos.ndim != 3 or pos.shape[1:] != (topology.n_joints, 3):
        raise BadInputError(f"positions must have shape (T, {topology.n_joints}, 3), got {pos.shape}")
    if camera_position is None:
        cam = np.full(3, np.nan)
    else:
        cam = np.asarray(camera_position, dtype=float)
        if cam.shape != (3,) or not np.all(np.isfinite(cam)):
            raise BadInputError(f"camera_position must be a finite (3,) array, got {camera_position!r}")
    j = {k: pos[:, topology.index(lm)] for k, lm in side_landmarks(side).items()}
    columns = (
        vertex_angle_deg(j["shoulder"], j["elbow"], j["wrist"]),
        distance(j["head"], j["hand"]),
        vertex_angle_deg(j["spine_shoulder"], j["shoulder"], j["elbow"]),
        j["hand"][:, 2],
        j["elbow"][:, 2],
        j["wrist"][:, 2],
        vertex_angle_deg(j["shoulder"], j["spine_shoulder"], j["spine_mid"]),
        vertex_angle_deg(j["hip"], j["shoulder"], j["elbow"]),
        distance(j["hand"], j["knee"]),
        distance(j["wrist"], j["hip"]),
        vertex_angle_deg(j["knee"], j["hip"], j["spine_mid"]),
        distance(j["head"], j["elbow"]),
        distance(cam, j["shoulder"]),
    )
    out = np.stack(columns, axis=1)
    if angles is AngleDefinitions.ISB:
        side_name = as_side(side).value
        isb = joint_angles(pos, topology)
        for k, name in enumerate(TABLE4_MEASUREMENT_NAMES):
            if name in ISB_REPLACEMENTS:
                out[:, k] = isb[ISB_REPLACEMENTS[name][1].format(side=side_name)]
        if side_name == "left":  # lean toward the moving side
            out[:, TABLE4_MEASUREMENT_NAMES.index("Angle(Shoulder-SpineShoulder-SpineMid)")] *= -1.0
    return out
