"""The calibration of a one-camera recording: a level camera raised until the subject's feet touch the floor.

One camera has no partner to calibrate against and, from skeletons alone, no floor. Assuming it stands
level (no pitch, no roll), its world frame has the axes of its upright frame
(:func:`fusion.frames.T_upright_camera`: x along its view, y to its left, z up), the floor at z = 0
and the origin under the subject (the median pelvis over the frames); the camera's height puts the
subject's feet at :data:`FOOT_HEIGHT_M` above the floor (the median over frames of the lowest foot
joint, tracked or inferred).
"""

from __future__ import annotations

import numpy as np

from fusion.calibration import Calibration
from fusion.errors import BadInputError
from fusion.frames import T_upright_camera
from fusion.recording import Recording
from fusion.topology import Landmark
from fusion.transforms import apply, make_transform

FOOT_HEIGHT_M = 0.04
"""Height of the foot joints above the floor when standing [m] (Kinect v2 FootLeft / K4ABT FOOT_LEFT
sit on the instep, about 4 cm up; the humanoid's foot landmarks stand 3.7-4.4 cm up at 1.6-1.9 m)."""

WORLD_LEVEL = "floor z = 0 under the subject's feet, z up, origin under the subject's median pelvis, x along the level camera's view"


def level_camera_calibration(recording: Recording, *, camera: str | None = None,
                             foot_height_m: float = FOOT_HEIGHT_M) -> Calibration:
    """A calibration of one camera assumed level, at the height that puts the subject's feet on the floor.

    Parameters
    ----------
    recording : Recording
        The recording; with ``camera=None`` it must hold exactly one camera with skeletons.
    camera : str, optional
        The camera to place (default: the only skeleton camera).
    foot_height_m : float
        Height of the foot joints above the floor [m] when standing.

    Returns
    -------
    Calibration
        One camera, ``T_world_cam`` = a translation (``h`` up) times the upright turn of its axes,
        clock offset 0; ``info`` holds the world definition, ``camera_height_m`` and a note.

    Raises
    ------
    BadInputError
        Several skeleton cameras and no ``camera`` named, a camera without skeletons, a non-finite
        ``foot_height_m``, or no frame with a foot joint and a pelvis.
    """
    if not np.isfinite(foot_height_m):
        raise BadInputError(f"foot_height_m must be a finite height in metres, got {foot_height_m}")
    if camera is None:
        cams = [c for c in recording.cameras if c.skeleton is not None]
        if len(cams) != 1:
            raise BadInputError(f"a level-camera calibration places one camera; the recording has {len(cams)} with "
                                "skeletons: name one, or calibrate the rig from the body (mocap-bench calibrate)")
        cam = cams[0]
    else:
        cam = recording.camera(camera)
        if cam.skeleton is None:
            raise BadInputError(f"camera {camera} has no skeleton stream to find the feet in")
    topology = cam.skeleton.topology
    T_upright_cam = T_upright_camera(cam.intrinsics.axes)
    p_upright = apply(T_upright_cam, cam.skeleton.positions)
    z = p_upright[:, topology.indices([Landmark.FOOT_LEFT, Landmark.FOOT_RIGHT]), 2]
    lowest = np.nanmin(np.where(np.isfinite(z), z, np.inf), axis=1)
    lowest = lowest[np.isfinite(lowest)]
    pelvis = p_upright[:, topology.index(Landmark.PELVIS), :2]
    pelvis = pelvis[np.isfinite(pelvis[:, 0])]
    if lowest.size == 0 or pelvis.size == 0:
        raise BadInputError(f"camera {cam.name}: no frame has a foot joint (or a pelvis), so the floor and the "
                            "subject's place are unknown; calibrate with a floor (mocap-bench calibrate on depth frames)")
    height = float(foot_height_m - np.median(lowest))
    t_world_upright = np.r_[-np.median(pelvis, axis=0), height]
    T_world_cam = make_transform(np.eye(3), t_world_upright) @ T_upright_cam
    note = (f"one camera, assumed level; height {height:.3f} m puts the median lowest foot joint "
            f"{foot_height_m:.3f} m above the floor")
    return Calibration({cam.name: T_world_cam}, {cam.name: cam.intrinsics}, {cam.name: 0.0}, cam.name,
                       {"world": WORLD_LEVEL, "camera_height_m": height, "notes": [note]})
