"""Motion capture clips written from the humanoid's own motion: a BVH writer for the tests.

:func:`write_bvh` writes a motion of the humanoid as a BVH file with the joint names of the CMU
motion capture database (the built-in ``cmu`` marker map), y up, centimetres. Each BVH joint sits
at a pivot of the humanoid (or, for ``Neck`` and ``LeftToeBase``, at a point fixed in its parent
body) and turns with one MuJoCo body, so the file's joints are exactly the humanoid's.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from fusion.topology import KINECT_V2
from sim.humanoid import Humanoid

_R_YUP_ZUP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
"""File axes (x forward, y up, z right) from the humanoid's world axes (x forward, y left, z up)."""

_CM = 100.0


def _joints() -> list[tuple[str, str | None, str | None, str | None]]:
    """(BVH joint, parent joint, the body it turns with, where it sits: a body origin or a Kinect site)."""
    out = [("Hips", None, "pelvis", "body:pelvis"), ("Spine", "Hips", "thorax", "body:thorax"),
           ("Neck", "Spine", "thorax", "site:SpineShoulder"), ("Neck1", "Neck", "neck", "body:neck"),
           ("Head", "Neck1", "head", "body:head")]
    for side, s in (("Left", "l"), ("Right", "r")):
        out += [(f"{side}UpLeg", "Hips", f"thigh_{s}", f"body:thigh_{s}"),
                (f"{side}Leg", f"{side}UpLeg", f"shank_{s}", f"body:shank_{s}"),
                (f"{side}Foot", f"{side}Leg", f"foot_{s}", f"body:foot_{s}"),
                (f"{side}ToeBase", f"{side}Foot", f"foot_{s}", f"site:Foot{side}"),
                (f"{side}Shoulder", "Spine", f"clavicle_{s}", f"body:clavicle_{s}"),
                (f"{side}Arm", f"{side}Shoulder", f"upper_arm_{s}", f"body:upper_arm_{s}"),
                (f"{side}ForeArm", f"{side}Arm", f"forearm_{s}", f"body:forearm_{s}"),
                (f"{side}Hand", f"{side}ForeArm", f"hand_{s}", f"body:hand_{s}")]
    return out


def write_bvh(path: Path, humanoid: Humanoid, times: np.ndarray, coords: np.ndarray) -> Path:
    """Write a motion (T, K) of the humanoid, sampled at the uniform ``times`` (T,) [s], as a BVH file."""
    import mujoco

    m, d = humanoid.model, humanoid.data
    joints = _joints()
    body = {name: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, b) for name, _, b, _ in joints}
    parent = {name: p for name, p, _, _ in joints}

    def points(qpos_row: np.ndarray) -> dict[str, np.ndarray]:
        humanoid.set_qpos(qpos_row)
        sites = dict(zip(KINECT_V2.joints, d.site_xpos[humanoid.site_ids(KINECT_V2)]))
        return {name: (d.xpos[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, at[5:])] if at.startswith("body:")
                       else sites[at[5:]]).copy() for name, _, _, at in joints}

    rest = points(humanoid.qpos(np.zeros((1, coords.shape[1])))[0])  # every body frame parallel to the world
    children: dict[str | None, list[str]] = {}
    for name, p, _, _ in joints:
        children.setdefault(p, []).append(name)

    lines = ["HIERARCHY"]

    def declare(name: str, depth: int) -> None:
        pad = "  " * depth
        offset = np.zeros(3) if parent[name] is None else _R_YUP_ZUP @ (rest[name] - rest[parent[name]]) * _CM
        lines.append(f"{pad}{'ROOT' if parent[name] is None else 'JOINT'} {name}")
        lines.append(f"{pad}{{")
        lines.append(f"{pad}  OFFSET {offset[0]:.6f} {offset[1]:.6f} {offset[2]:.6f}")
        lines.append(f"{pad}  CHANNELS " + ("6 Xposition Yposition Zposition " if parent[name] is None else "3 ")
                     + "Zrotation Xrotation Yrotation")
        for child in children.get(name, []):
            declare(child, depth + 1)
        if name not in children:
            lines.append(f"{pad}  End Site\n{pad}  {{\n{pad}    OFFSET 0.0 -2.0 0.0\n{pad}  }}")
        lines.append(f"{pad}}}")

    declare("Hips", 0)
    order = _depth_first("Hips", children)
    lines += ["MOTION", f"Frames: {len(times)}", f"Frame Time: {float(np.mean(np.diff(times))):.8f}"]
    for qpos_row in humanoid.qpos(coords):
        humanoid.set_qpos(qpos_row)
        R = {name: d.xmat[body[name]].reshape(3, 3).copy() for name in order}
        values = list(_R_YUP_ZUP @ d.xpos[body["Hips"]] * _CM)
        for name in order:
            local = R[name] if parent[name] is None else R[parent[name]].T @ R[name]
            values += list(Rotation.from_matrix(_R_YUP_ZUP @ local @ _R_YUP_ZUP.T).as_euler("ZXY", degrees=True))
        lines.append(" ".join(f"{v:.6f}" for v in values))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _depth_first(name: str, children: dict[str | None, list[str]]) -> list[str]:
    """Joint names in the order BVH lists their channels."""
    out = [name]
    for child in children.get(name, []):
        out += _depth_first(child, children)
    return out
