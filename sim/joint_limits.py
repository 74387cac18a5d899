"""Ranges of the humanoid's coordinates that retargeting respects.

Source: the normal adult active ranges of motion of the American Academy of Orthopaedic Surgeons
(Greene & Heckman, *The Clinical Measurement of Joint Motion*, AAOS 1994), mapped onto the
coordinates of :mod:`sim.coordinates` and widened so that a tracker's noise at the end of a normal
range is not clipped: every limit below is the AAOS value rounded up by 5 to 10 degrees. Where the
coordinate has no AAOS counterpart the note says where the range comes from.

==================  ===============  =================================================================
coordinate          range [deg]      AAOS normal range (or other source)
==================  ===============  =================================================================
trunk_flexion       -30 .. 100       thoracolumbar flexion 80 (+ pelvic tilt: the pelvis has yaw only)
                                     / extension 25
trunk_lateral       -40 .. 40        lateral flexion 35
trunk_rotation      -50 .. 50        rotation 45
neck_flexion        -65 .. 55        cervical flexion 45-50 / extension 60 (here one hinge for both
                                     the neck's and the head's nodding)
neck_rotation       -85 .. 85        cervical rotation 80
clav_elevation      -15 .. 45        sternoclavicular elevation about 35-45 (Ludewig et al., JBJS
                                     2009), depression 10
clav_retraction     -35 .. 35        sternoclavicular protraction / retraction about 30 each
                                     (Ludewig et al. 2009)
sh_plane            -90 .. 150       horizontal extension 45 .. horizontal flexion 135 (the plane of
                                     elevation of the Y-X-Y sequence; wider because at low elevation
                                     the plane is ill-defined)
sh_elevation        -3 .. 180        flexion 180, abduction 180 (a few degrees below 0 so the hanging
                                     arm is not pinned to the gimbal-locked bound)
sh_rotation         -180 .. 180      not limited: in the Y-X-Y sequence axial rotation is
                                     sh_rotation - sh_plane, not one hinge
elbow_flexion       -10 .. 155       flexion 150, hyperextension up to 10
forearm_rotation    -90 .. 90        pronation 80, supination 80
wrist_flexion       -80 .. 90        extension 70, flexion 80
hip_flexion         -35 .. 130       flexion 120, extension 30
hip_abduction       -35 .. 50        abduction 45, adduction 30
hip_rotation        -50 .. 50        internal 45, external 45
knee_flexion        -10 .. 145       flexion 135, hyperextension up to 10
ankle_flexion       -55 .. 30        plantarflexion 50, dorsiflexion 20
==================  ===============  =================================================================

``root_x``, ``root_y`` and ``root_yaw`` are not limited.
"""

from __future__ import annotations

import numpy as np

from sim.coordinates import ARM, COORDINATES, LEG, SIDES, TRUNK

_DEG = {
    "trunk_flexion": (-30, 100),
    "trunk_lateral": (-40, 40),
    "trunk_rotation": (-50, 50),
    "neck_flexion": (-65, 55),
    "neck_rotation": (-85, 85),
    "clav_elevation": (-15, 45),
    "clav_retraction": (-35, 35),
    "sh_plane": (-90, 150),
    "sh_elevation": (-3, 180),
    "sh_rotation": (-180, 180),
    "elbow_flexion": (-10, 155),
    "forearm_rotation": (-90, 90),
    "wrist_flexion": (-80, 90),
    "hip_flexion": (-35, 130),
    "hip_abduction": (-35, 50),
    "hip_rotation": (-50, 50),
    "knee_flexion": (-10, 145),
    "ankle_flexion": (-55, 30),
}


def coordinate_limits() -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bound of every coordinate.

    Returns
    -------
    lower, upper : numpy.ndarray
        (K,) each, in the order of :data:`sim.coordinates.COORDINATES`; radians (metres for
        ``root_x``/``root_y``), -inf / +inf where a coordinate is not limited.
    """
    lower = np.full(len(COORDINATES), -np.inf)
    upper = np.full(len(COORDINATES), np.inf)
    names = {c: c for c in TRUNK} | {f"{c}_{s}": c for s in SIDES for c in ARM + LEG}
    for i, name in enumerate(COORDINATES):
        if name in names:
            lo, hi = _DEG[names[name]]
            lower[i], upper[i] = np.radians(lo), np.radians(hi)
    return lower, upper
