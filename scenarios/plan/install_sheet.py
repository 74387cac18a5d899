"""Install sheets: what a technician needs to mount a planned layout, and what it will measure.

Per camera: the mount region, position (x, y) and height in the room frame, pan, tilt and roll,
distance and bearing to the patient, and what the image must hold; a top view and a side elevation
drawn to scale; the expected error of each clinical angle and joint group over the final seeds.

Angles (degrees): *pan* is the optical axis's direction in the floor plane, counter-clockwise from
the room's +x; *tilt* its elevation above the horizontal (negative: looking down); *roll* the turn
of the image about the optical axis away from level (positive: the image's top towards the
sensor's left, i.e. counter-clockwise as seen from behind the camera). *Bearing* is where the
camera stands as seen from the patient, counter-clockwise from the direction the patient faces
(+90: on the patient's left); *distance* the horizontal distance to the patient's centre.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fusion.camera import KINECT_V2_DEPTH, Intrinsics
from fusion.errors import BadInputError
from scenarios.plan.objectives import CLINICAL_ANGLES, JOINT_GROUPS
from scenarios.plan.room import MountKind, Room
from scenarios.plan.search import LayoutResult
from scenarios.show import plt, save_figure
from sim.rig import look_at

REACH_FACTOR = 1.3
"""Top of the raised hand as a multiple of the patient's height (the image must hold it)."""

WALL_TOLERANCE_M = 0.15
"""A camera this close [m] to a wall mount's line (or to the outline) counts as wall-mounted."""


@dataclass(frozen=True)
class CameraInstall:
    """One camera of an install sheet (units in the module docstring): metres and degrees."""

    number: int
    mount: str
    x_m: float
    y_m: float
    height_m: float
    pan_deg: float
    tilt_deg: float
    roll_deg: float
    distance_m: float
    bearing_deg: float
    aim_height_m: float
    sees: str


def pan_tilt_roll_deg(R_room_cam: np.ndarray) -> tuple[float, float, float]:
    """Pan, tilt and roll [deg] (module docstring) of a Kinect-convention camera (+z optical axis,
    +y image top, +x sensor's left) from its (3, 3) rotation in the room frame (z up)."""
    R = np.asarray(R_room_cam, dtype=float)
    if R.shape != (3, 3) or not np.allclose(R.T @ R, np.eye(3), atol=1e-6):
        raise BadInputError(f"R_room_cam must be a (3, 3) rotation, got shape {R.shape}")
    z, y = R[:, 2], R[:, 1]
    pan = float(np.degrees(np.arctan2(z[1], z[0])))
    tilt = float(np.degrees(np.arcsin(np.clip(z[2], -1.0, 1.0))))
    level_up = np.array([0.0, 0.0, 1.0]) - z[2] * z  # world up across the view: the image top without roll
    level_up /= np.linalg.norm(level_up)
    level_left = np.cross(level_up, z)  # the sensor's left without roll
    roll = float(np.degrees(np.arctan2(np.dot(y, level_left), np.dot(y, level_up))))
    return pan, tilt, roll


def mount_name(room: Room, p_room: np.ndarray) -> str:
    """The room's mount region a camera centre (3,) [m] lies on, else ``wall`` / ``tripod`` with "(own place)"."""
    xy = np.asarray(p_room[:2], dtype=float)
    for m in room.mounts:
        label = f"{m.kind.value}: {m.name}" if m.name else m.kind.value
        if m.kind is MountKind.WALL and _segment_distance(xy, m.from_m, m.to_m) <= WALL_TOLERANCE_M:
            return label
        if m.kind is MountKind.TRIPOD and np.all(xy >= np.asarray(m.min_m) - 1e-9) \
                and np.all(xy <= np.asarray(m.max_m) + 1e-9):
            return label
        if m.kind is MountKind.POINTS and any(np.allclose(p_room, q, atol=1e-3) for q in m.points_m):
            return label
    outline = np.asarray(room.room.outline_m, dtype=float)
    near_wall = min(_segment_distance(xy, a, b) for a, b in zip(outline, np.roll(outline, -1, axis=0)))
    return "wall (own place)" if near_wall <= WALL_TOLERANCE_M else "tripod (own place)"


def _segment_distance(p: np.ndarray, a: Any, b: Any) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    t = np.clip(np.dot(p - a, b - a) / max(np.dot(b - a, b - a), 1e-12), 0.0, 1.0)
    return float(np.linalg.norm(p - (a + t * (b - a))))


def camera_installs(room: Room, layout: LayoutResult, intrinsics: Intrinsics = KINECT_V2_DEPTH) -> list[CameraInstall]:
    """Every camera of ``layout`` as an install-sheet row (the image check uses ``intrinsics``' field of view)."""
    centre = np.asarray(room.subject.position_m, dtype=float)
    facing = room.subject.facing_deg
    half_v = np.degrees(np.arctan(intrinsics.height / 2 / intrinsics.fy))
    half_h = np.degrees(np.arctan(intrinsics.width / 2 / intrinsics.fx))
    reach = REACH_FACTOR * room.subject.height_m
    rows = []
    for k, (x, y, z, aim) in enumerate(layout.layout):
        T_room_cam = look_at(np.array([x, y, z]), np.array([*centre, aim]))
        pan, tilt, roll = pan_tilt_roll_deg(T_room_cam[:3, :3])
        d = float(np.hypot(*(centre - [x, y])))
        bearing = (np.degrees(np.arctan2(y - centre[1], x - centre[0])) - facing + 180.0) % 360.0 - 180.0
        top, feet = (np.degrees(np.arctan2(h - z, d)) - tilt for h in (reach, 0.0))
        width = 2 * d * np.tan(np.radians(half_h))
        cut = [part for part, out in (("the raised hand", top > half_v), ("the feet", feet < -half_v)) if out]
        sees = (f"the whole patient, feet to raised hand (0-{reach:.1f} m), centred at {aim:.2f} m; the image spans "
                f"{width:.1f} m across at the patient"
                + (f"; **{' and '.join(cut)} {'fall' if len(cut) > 1 else 'falls'} outside the image** (move the "
                   "camera back or change its height)"
                   if cut else ""))
        rows.append(CameraInstall(k + 1, mount_name(room, np.array([x, y, z])), float(x), float(y), float(z), pan, tilt,
                                  roll, d, float(bearing), float(aim), sees))
    return rows


_ANGLE_LABELS = {"ht_elevation_error_deg": "humerothoracic elevation",
                 "ht_plane_of_elevation_error_deg": "plane of elevation",
                 "elbow_flexion_error_deg": "elbow flexion", "trunk_flexion_error_deg": "trunk lean forward (flexion)",
                 "trunk_lateral_lean_error_deg": "trunk lean sideways"}


def _cell(r: LayoutResult, key: str | None, fmt: str = ".1f") -> str:
    mean, lo, hi = r.interval(key)
    return "n/a" if not np.isfinite(mean) else f"{mean:{fmt}} [{lo:{fmt}}, {hi:{fmt}}]"


def error_table(rows: list[LayoutResult]) -> list[str]:
    """Markdown: expected error of each clinical angle [deg] and joint group [mm], one column per layout."""
    out = ["| expected error | " + " | ".join(f"{r.name} ({r.sensor}{', ' + r.note if r.note else ''})"
                                              for r in rows) + " |",
           "| --- |" + " --- |" * len(rows)]
    keys = [(k, f"{v} [deg]") for k, v in _ANGLE_LABELS.items() if k in CLINICAL_ANGLES]
    keys += [(k, f"{k.removesuffix('_error_mm')} position [mm]") for k in JOINT_GROUPS]
    keys += [("joint_error_mm", "all joints [mm]")]
    out += [f"| {label} | " + " | ".join(_cell(r, k) for r in rows) + " |" for k, label in keys]
    return out


def install_markdown(room: Room, layout: LayoutResult, picture: str) -> list[str]:
    """One layout's install sheet as Markdown lines (``picture``: the PNG's file name)."""
    h, v = (np.degrees(2 * np.arctan(n / 2 / f)) for n, f in ((KINECT_V2_DEPTH.width, KINECT_V2_DEPTH.fx),
                                                              (KINECT_V2_DEPTH.height, KINECT_V2_DEPTH.fy)))
    lines = [f"## {layout.name}", "", f"Sensor: {layout.sensor}; what the image must hold is checked with the Kinect "
             f"v2 depth camera's field of view ({h:.0f} x {v:.0f} deg), as the screen does. Score {_cell(layout, None)} over "
             f"{len(layout.sessions)} seeds (mean [90 % bootstrap interval], lower is better); "
             f"{layout.failed} failed sessions." + (f" **Warning:** {layout.note}." if layout.note else ""), "",
             f"![top view and side elevation]({picture})", "",
             "| camera | mount | x [m] | y [m] | height [m] | pan [deg] | tilt [deg] | roll [deg] | distance [m] "
             "| bearing [deg] | must see |", "| --- " * 11 + "|"]
    for c in camera_installs(room, layout):
        pan, tilt, roll, bearing = (f"{v:.0f}" if abs(v) >= 0.5 else "0"
                                    for v in (c.pan_deg, c.tilt_deg, c.roll_deg, c.bearing_deg))
        lines.append(f"| {c.number} | {c.mount} | {c.x_m:.2f} | {c.y_m:.2f} | {c.height_m:.2f} | {pan} | {tilt} | "
                     f"{roll} | {c.distance_m:.2f} | {'+' * (bearing[0] not in '-0')}{bearing} | {c.sees} |")
    return lines + ["", *error_table([layout]), ""]


def draw_room(ax: Any, room: Room) -> None:
    """The room from above (outline, obstacles, forbidden zones, the patient and the facing arrow), metres."""
    outline = np.asarray(room.room.outline_m)
    ax.fill(outline[:, 0], outline[:, 1], color="#fafafa", ec="#37474f", lw=2)
    for box in room.obstacles:
        ax.add_patch(plt.Rectangle(box.min_m[:2], box.max_m[0] - box.min_m[0], box.max_m[1] - box.min_m[1],
                                   color="#8d6e63", alpha=0.6))
        ax.annotate(box.name, ((box.min_m[0] + box.max_m[0]) / 2, (box.min_m[1] + box.max_m[1]) / 2), ha="center",
                    fontsize=7)
    for z in room.forbidden:
        ax.add_patch(plt.Rectangle(z.min_m, z.max_m[0] - z.min_m[0], z.max_m[1] - z.min_m[1], fill=False,
                                   hatch="//", ec="#c62828"))
    c = np.asarray(room.subject.position_m)
    ax.add_patch(plt.Circle(c, room.subject.radius_m, color="#c62828", alpha=0.35))
    f = np.radians(room.subject.facing_deg)
    ax.arrow(c[0], c[1], 0.5 * np.cos(f), 0.5 * np.sin(f), width=0.03, color="#c62828")


def plot_install(room: Room, layout: LayoutResult, path: Path, *, pdf: Path | None = None,
                 intrinsics: Intrinsics = KINECT_V2_DEPTH) -> None:
    """Top view and side elevation of ``layout``, both to scale (1 m grid), as a PNG (and a PDF)."""
    cams = camera_installs(room, layout, intrinsics)
    fig, (top, side) = plt.subplots(1, 2, figsize=(11.7, 5.6), gridspec_kw={"width_ratios": [1.1, 1]})
    draw_room(top, room)
    centre = np.asarray(room.subject.position_m)
    half_h = np.arctan(intrinsics.width / 2 / intrinsics.fx)
    half_v = np.degrees(np.arctan(intrinsics.height / 2 / intrinsics.fy))
    for c in cams:
        a = np.radians(c.pan_deg) + np.linspace(-half_h, half_h, 2)
        r = c.distance_m + 0.5
        top.fill([c.x_m, c.x_m + r * np.cos(a[0]), c.x_m + r * np.cos(a[1])],
                 [c.y_m, c.y_m + r * np.sin(a[0]), c.y_m + r * np.sin(a[1])], color="#90caf9", alpha=0.25)
        top.plot([c.x_m, centre[0]], [c.y_m, centre[1]], ":", color="#1a237e", lw=0.8)
        top.plot(c.x_m, c.y_m, "s", color="#1a237e", ms=7)
        top.annotate(str(c.number), (c.x_m, c.y_m), textcoords="offset points", xytext=(5, 5), fontsize=9)
        # side elevation: horizontal distance from the patient against height, one line per camera
        for t in (c.tilt_deg - half_v, c.tilt_deg + half_v):
            side.plot([-c.distance_m, -c.distance_m + (c.distance_m + 0.3)],
                      [c.height_m, c.height_m + (c.distance_m + 0.3) * np.tan(np.radians(t))], color="#90caf9", lw=0.8)
        side.plot([-c.distance_m, 0.0], [c.height_m, c.aim_height_m], ":", color="#1a237e", lw=0.8)
        side.plot(-c.distance_m, c.height_m, "s", color="#1a237e", ms=7)
        side.annotate(str(c.number), (-c.distance_m, c.height_m), textcoords="offset points", xytext=(5, 6),
                      fontsize=9)
    h = room.subject.height_m
    side.add_patch(plt.Rectangle((-0.2, 0.0), 0.4, h, color="#c62828", alpha=0.35))
    side.plot([0.0, 0.0], [h * 0.8, REACH_FACTOR * h], color="#c62828", lw=3, alpha=0.5)
    side.axhline(0.0, color="#37474f", lw=2)
    side.axhline(room.room.ceiling_m, color="#37474f", lw=1, ls="--")
    far = max(c.distance_m for c in cams) + 0.4
    side.set_xlim(-far, 0.6)
    side.set_ylim(-0.1, room.room.ceiling_m + 0.2)
    outline = np.asarray(room.room.outline_m)
    top.set_xlim(outline[:, 0].min() - 0.3, outline[:, 0].max() + 0.3)
    top.set_ylim(outline[:, 1].min() - 0.3, outline[:, 1].max() + 0.3)
    for ax, (xl, yl) in zip((top, side), (("x [m]", "y [m]"), ("horizontal distance from the patient [m]",
                                                                "height [m]"))):
        ax.set_aspect("equal")
        ax.set_xticks(np.arange(np.ceil(ax.get_xlim()[0]), ax.get_xlim()[1], 1.0))
        ax.set_yticks(np.arange(np.ceil(ax.get_ylim()[0]), ax.get_ylim()[1], 1.0))
        ax.grid(alpha=0.3)
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
    top.set_title("top view (patient red, arrow: facing)", fontsize=9)
    side.set_title("side elevation (each camera unfolded onto its line to the patient)", fontsize=9)
    fig.suptitle(f"{room.room.name}: {layout.name} ({layout.sensor})", fontsize=10)
    if pdf is not None:
        fig.savefig(pdf, format="pdf", bbox_inches="tight")
    save_figure(fig, path)
