"""Fused skeletons scored against ground truth: per-joint position error and clinical joint angles,
and the humanoid's true joint angles from its body rotations (the oracle of the angle definitions)."""

from __future__ import annotations

import enum

import numpy as np

from fusion.arrays import unit
from fusion.calibrate.floor import GaugeMode, align_gauge
from fusion.merge.angles import (
    ARM_ANGLES,
    SIDES,
    TRUNK_ANGLES,
    AngleOptions,
    JointAngles,
    angle_names,
    humerothoracic_deg,
    joint_angles,
    mirrored,
    relative_rotation,
    trunk_deg,
    vertex_angle_deg,
)
from fusion.merge.metrics import Stats
from fusion.topology import KINECT_V2, Topology
from fusion.transforms import apply
from sim.humanoid import Humanoid
from sim.truth import GroundTruth

RAISED_ELEVATION_DEG = 30.0
"""An arm counts as raised while its true humerothoracic elevation is at least this [deg]."""

CIRCULAR = ("ht_plane_of_elevation", "ht_axial_rotation", "trunk_axial_rotation")
"""Angles compared modulo 360 degrees."""

_ISB_OF_BODY = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
"""Columns: the ISB axes X forward, Y up, Z right in the humanoid's body axes (x forward, y left, z up)."""


def angle_errors_deg(est: JointAngles, true: JointAngles) -> dict[str, np.ndarray]:
    """(T,) absolute error [deg] per angle name; circular angles wrapped to [0, 180]."""
    out = {}
    for name in est.names:
        d = est[name] - true[name]
        if name.startswith(CIRCULAR):
            d = (d + 180.0) % 360.0 - 180.0
        out[name] = np.abs(d)
    return out


def skeleton_errors(positions_world: np.ndarray, T_world_cam_est: dict[str, np.ndarray], truth: GroundTruth,
                    reference: str, topology: Topology, *, gauge: GaugeMode = GaugeMode.FLOOR
                    ) -> dict[str, dict[str, float]]:
    """Errors of a fused skeleton on the reference camera's frames against the true joints.

    The estimated world is brought onto the true one by the gauge transform of the camera poses
    first (see :mod:`scenarios.evaluate`): FLOOR when the calibration found the floor (depth),
    RIGID when it could not (skeleton-only sessions have no floor). Both skeletons' angles use
    :func:`fusion.merge.angles.joint_angles`.

    Returns
    -------
    dict
        ``joint_error_mm`` (all joints and frames); per angle ``<angle>_error_deg`` over all frames and,
        for the arm angles, ``<angle>_<side>_raised_error_deg`` over the frames where that arm's true
        elevation is at least :data:`RAISED_ELEVATION_DEG` and ``<angle>_raised_error_deg`` with both
        sides pooled; each as rmse / mean / median / std / max / n.
    """
    T_true_est, _ = align_gauge(T_world_cam_est, truth.T_world_cam(), mode=gauge)
    est = apply(T_true_est, positions_world)
    true = truth.camera(reference).joints_world
    if est.shape != true.shape:
        raise ValueError(f"fused skeleton {est.shape} does not match the reference camera's truth {true.shape}")
    out = {"joint_error_mm": Stats.of(np.linalg.norm(est - true, axis=-1).ravel() * 1e3).as_dict()}
    a_true = joint_angles(true, topology)
    errors = angle_errors_deg(joint_angles(est, topology), a_true)
    for name, e in errors.items():
        out[f"{name}_error_deg"] = Stats.of(e).as_dict()
    raised = {side: a_true[f"ht_elevation_{side}"] >= RAISED_ELEVATION_DEG for side in SIDES}
    for a in ARM_ANGLES:
        for side in SIDES:
            out[f"{a}_{side}_raised_error_deg"] = Stats.of(errors[f"{a}_{side}"][raised[side]]).as_dict()
        out[f"{a}_raised_error_deg"] = Stats.of(np.concatenate([errors[f"{a}_{s}"][raised[s]] for s in SIDES])).as_dict()
    return out


class TrueThorax(enum.Enum):
    """Which lateral axis the humanoid's true thorax frame takes (its ``Y`` is always the
    thorax-fixed pivot to the sternal notch)."""

    SHOULDER_LINE = "shoulder_line"
    """The line through the true glenohumeral centres (the upper arms' pivots): the skeleton
    definition's thorax (:func:`fusion.facing.thorax_frame`) on the true segment positions, so
    the comparison is like with like."""
    THORAX_BODY = "thorax_body"
    """The thorax body's own lateral axis: the anatomical thorax, which the shoulder-girdle
    coordinates do not move. Its difference from ``SHOULDER_LINE`` is what the skeleton's
    definition cannot see (the girdle's protraction / retraction and elevation turn the shoulder
    line)."""


def model_angles(humanoid: Humanoid, coords: np.ndarray, options: AngleOptions = AngleOptions(), *,
                 thorax: TrueThorax = TrueThorax.SHOULDER_LINE) -> JointAngles:
    """The humanoid's true trunk, humerothoracic and elbow angles over a motion, from its segment
    frames (MuJoCo body rotations and pivots), not from its hinge coordinates.

    Segment frames are the ISB frames fixed in the humanoid's bodies: the pelvis body's axes; the
    thorax axes with ``Y`` through the thorax-fixed pelvis pivot and sternal notch (the landmarks
    of :func:`fusion.facing.thorax_frame`) and ``Z`` after ``thorax``; the upper arm's axes (``Y``
    along the humerus, ``X`` normal to the elbow's flexion axis). Elbow flexion is the angle between
    the upper arm's and the forearm's long axes. Table 4's vertex angles are NaN (they are defined on
    joint positions only).

    Parameters
    ----------
    humanoid : the subject's model.
    coords : (T, K) motion coordinates [m, rad].
    options : the same thresholds as the skeleton's angles.
    thorax : the thorax's lateral axis (:class:`TrueThorax`).

    Returns
    -------
    JointAngles
        (T, K) degrees, columns :func:`fusion.merge.angles.angle_names`.
    """
    m, d = humanoid.model, humanoid.data
    qpos = humanoid.qpos(coords)
    bodies = {n: m.body(n).id for n in ("pelvis", "thorax", "upper_arm_l", "upper_arm_r", "forearm_l", "forearm_r")}
    R = np.empty((len(qpos), len(bodies), 3, 3))
    p = np.empty((len(qpos), len(bodies), 3))
    for t, row in enumerate(qpos):
        humanoid.set_qpos(row)
        R[t] = d.xmat[list(bodies.values())].reshape(-1, 3, 3)
        p[t] = d.xpos[list(bodies.values())]
    Rb = dict(zip(bodies, np.moveaxis(R, 1, 0)))
    pb = dict(zip(bodies, np.moveaxis(p, 1, 0)))
    humanoid.set_qpos(qpos[0])
    sites = [m.site(f"{KINECT_V2.name}/{j}").id for j in ("SpineBase", "SpineShoulder")]
    up_world = d.site_xpos[sites[1]] - d.site_xpos[sites[0]]
    y = Rb["thorax"] @ unit(Rb["thorax"][0].T @ up_world)  # thorax-fixed: both landmarks ride on the thorax
    if thorax is TrueThorax.SHOULDER_LINE:
        right = pb["upper_arm_r"] - pb["upper_arm_l"]
    else:
        right = Rb["thorax"] @ np.array([0.0, -1.0, 0.0])
    z = unit(right - np.einsum("tk,tk->t", right, y)[:, None] * y)
    thorax_R = np.stack([np.cross(y, z), y, z], axis=-1)
    columns = dict(zip(TRUNK_ANGLES, np.moveaxis(trunk_deg(relative_rotation(Rb["pelvis"] @ _ISB_OF_BODY, thorax_R)), -1, 0)))
    for side in SIDES:
        s = side[0]
        # long axes (+z): elbow to shoulder on the upper arm, wrist to elbow on the forearm
        flexion = 180.0 - vertex_angle_deg(Rb[f"upper_arm_{s}"][..., :, 2], np.zeros(3), -Rb[f"forearm_{s}"][..., :, 2])
        Rht = relative_rotation(thorax_R, Rb[f"upper_arm_{s}"] @ _ISB_OF_BODY)
        if side == "left":
            Rht = mirrored(Rht)
        ht = humerothoracic_deg(Rht, options.min_elevation_deg)
        ht[:, 2] = np.where(flexion >= options.min_elbow_flexion_deg, ht[:, 2], np.nan)
        columns |= {f"{n}_{side}": ht[:, k] for k, n in enumerate(ARM_ANGLES[:3])}
        columns[f"elbow_flexion_{side}"] = flexion
    names = angle_names()
    T = len(qpos)
    return JointAngles(names, np.stack([columns.get(n, np.full(T, np.nan)) for n in names], axis=1), np.zeros(len(names)))
