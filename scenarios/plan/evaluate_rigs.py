"""The user's own layouts for ``plan --evaluate``: rig files in, planner layouts out.

A rig file is a scenario TOML as the planner writes for its recommendations (``rig_best.toml``,
``rig_<n>cam.toml``): explicit ``[[rig.camera]]`` entries with ``position_m`` and ``target_m`` in
the simulation's world frame, whose origin is the patient's centre on the floor, +x the direction
the patient faces, +z up. Each camera must aim at a point on the patient's vertical axis (target
x = y = 0; its z is the aim height) and be levelled (no ``up_m``). Only the cameras are read: the
protocol, subject and sensor come from the room, so every layout is scored alike; a hand-written
file therefore needs no more than ``[scenario] name`` and the ``[[rig.camera]]`` entries.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from fusion.errors import BadInputError
from fusion.transforms import apply, invert
from scenarios.config import scenario_from_dict
from scenarios.plan.objectives import Layout
from scenarios.plan.room import Room, check_camera_place
from scenarios.toml_tables import read_toml

AIM_AXIS_TOLERANCE_M = 0.05
"""How far [m] a camera's target may lie from the patient's vertical axis."""


def layout_from_rig(room: Room, path: str | Path) -> tuple[str, Layout]:
    """Read one rig file (see the module docstring) as (name, room-frame layout).

    Parameters
    ----------
    room : the room the layout is for (its frame and walls).
    path : the rig TOML.

    Returns
    -------
    tuple
        The file's stem and the cameras as (x, y, z, aim height) in the room frame [m].

    Raises
    ------
    BadInputError
        Fewer than two explicit cameras, a target off the patient's axis, a rolled camera.
    ScenarioError
        An unreadable file, or a camera outside the room, in an obstacle or a forbidden zone.
    """
    path = Path(path)
    doc = read_toml(path)
    # the room's protocol replaces the file's session: a file without one is validated with a stand-in
    doc.setdefault("session", {"segment": [{"kind": "idle", "duration_s": 1.0}]})
    scenario = scenario_from_dict(doc, where=str(path))
    cams = scenario.rig.camera or []
    if len(cams) < 2:
        raise BadInputError(f"{path}: needs at least two explicit [[rig.camera]] entries (position_m, target_m in the "
                            "world frame: patient at the origin facing +x), as `plan` writes in rig_best.toml")
    T_room_world = invert(room.T_world_room)
    layout = []
    for cam in cams:
        target = np.asarray(cam.target_m, dtype=float)
        if np.hypot(target[0], target[1]) > AIM_AXIS_TOLERANCE_M:
            raise BadInputError(f"{path}: camera {cam.name} aims at {cam.target_m}, off the patient's axis; the planner "
                                f"aims every camera at [0, 0, aim height] (within {AIM_AXIS_TOLERANCE_M} m)")
        if cam.up_m is not None:
            raise BadInputError(f"{path}: camera {cam.name} sets up_m; the planner scores levelled cameras only "
                                "(drop up_m)")
        p_room = apply(T_room_world, np.asarray([cam.position_m], dtype=float))[0]
        check_camera_place(room, p_room, f"{path}: camera {cam.name} at room {np.round(p_room, 2).tolist()}")
        layout.append((*(round(float(v), 4) for v in p_room), float(target[2])))
    return path.stem, tuple(layout)


def layouts_from_rigs(room: Room, paths: Sequence[str | Path]) -> list[tuple[str, Layout]]:
    """:func:`layout_from_rig` for each path; names made unique by a suffix when two files share a stem."""
    out: list[tuple[str, Layout]] = []
    for p in paths:
        name, layout = layout_from_rig(room, p)
        taken = {n for n, _ in out}
        k, unique = 2, name
        while unique in taken:
            unique, k = f"{name} ({k})", k + 1
        out.append((unique, layout))
    return out
