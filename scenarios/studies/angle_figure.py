"""The figure of the joint-angle frames (``docs/studies/angle_frames.png``): the humanoid's Kinect joints at
the top of a right salute, with the ISB pelvis, thorax and humerus frames of
:mod:`fusion.merge.angles` drawn on them and the angles written beside.

Regenerate with ``python -m scenarios.cli angle-figure --out docs/studies/angle_frames.png``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fusion.facing import thorax_frame
from fusion.merge.angles import AngleOptions, humerus_frame, joint_angles, pelvis_frame
from fusion.topology import KINECT_V2, Landmark
from scenarios.config import load_scenario
from scenarios.runner import build_simulation
from scenarios.show import plt, save_figure
from sim.motions import salute
from sim.patient_motion import Movement, MovementProfile, Side

_AXES = (("X forward", "#c62828"), ("Y up", "#2e7d32"), ("Z right", "#1565c0"))


def salute_top_pose() -> np.ndarray:
    """(J, 3) Kinect v2 joints [m] of the ``single`` scenario's humanoid at the highest wrist of one right
    salute."""
    motion = salute(Side.RIGHT, 1, MovementProfile.healthy(Movement.SALUTE), rng=np.random.default_rng(0))
    coords = motion.sample(np.arange(0.0, motion.duration, 0.05))
    joints = build_simulation(load_scenario("single")).humanoid.joint_positions(coords, KINECT_V2)
    return joints[np.argmax(joints[:, KINECT_V2.index(Landmark.WRIST_RIGHT), 2])]


def plot_angle_frames(positions: np.ndarray, path: Path, *, scale_m: float = 0.2) -> None:
    """Draw (J, 3) Kinect v2 joints [m], their segment frames and angles as two views into ``path``."""
    topo, P = KINECT_V2, positions[None]
    j = {lm: positions[topo.index(lm)] for lm in Landmark}
    frames = {
        "pelvis": (j[Landmark.PELVIS], pelvis_frame(P, topo, np.array(AngleOptions().up))[0]),
        "thorax": (j[Landmark.SPINE_SHOULDER], thorax_frame(P, topo)[0]),
        "humerus (right)": (j[Landmark.SHOULDER_RIGHT], humerus_frame(
            j[Landmark.SHOULDER_RIGHT], j[Landmark.ELBOW_RIGHT], j[Landmark.WRIST_RIGHT],
            AngleOptions().min_elbow_flexion_deg)),
    }
    angles = joint_angles(P, topo)
    forward = frames["pelvis"][1][:, 0]
    front_azim = float(np.degrees(np.arctan2(forward[1], forward[0])))
    fig = plt.figure(figsize=(15, 7))
    grid = fig.add_gridspec(1, 3, width_ratios=(1.0, 1.0, 0.7))
    for k, (elev, azim, title) in enumerate(((20, front_azim - 50, "oblique"), (0, front_azim, "front"))):
        ax = fig.add_subplot(grid[0, k], projection="3d")
        for a, b in topo.bones:
            ax.plot(*np.stack([positions[a], positions[b]]).T, color="#90a4ae", lw=2)
        ax.scatter(*positions.T, color="#37474f", s=8)
        for name, (origin, R) in frames.items():
            for c, (label, colour) in enumerate(_AXES):
                ax.quiver(*origin, *(scale_m * R[:, c]), color=colour, lw=2)
            ax.text(*(origin - 0.08 * R[:, 2] - [0.0, 0.0, 0.06]), name, fontsize=9)
        centre = j[Landmark.SPINE_SHOULDER] - [0.0, 0.0, 0.25]
        for axis, set_lim in zip(range(3), (ax.set_xlim, ax.set_ylim, ax.set_zlim)):
            set_lim(centre[axis] - 0.55, centre[axis] + 0.55)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=elev, azim=azim)
        ax.set_title(f"{title} view (world: x, y, z up)")
    text = fig.add_subplot(grid[0, 2])
    text.axis("off")
    lines = [f"{n:34s} {v:7.1f}" for n, v in zip(angles.names, angles.degrees[0])
             if not n.endswith("_left") and np.isfinite(v)]
    text.text(0.0, 1.0, "angles at this pose [deg]\n\n" + "\n".join(lines), va="top", family="monospace", fontsize=9)
    handles = [plt.Line2D([], [], color=c, lw=2, label=lab) for lab, c in _AXES]
    text.legend(handles=handles, loc="lower left", fontsize=8)
    fig.suptitle("ISB segment frames of the joint angles (top of a right salute)")
    save_figure(fig, path)
