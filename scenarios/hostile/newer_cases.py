"""Hostile cases of the newer commands: the planner's own layouts, the 3D viewer, the device swap, users'
algorithms in the studies, and outputs that must not be overwritten.

See :mod:`scenarios.hostile.suite` for how a case is run and classified.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from fusion.skeleton import SkeletonStream
from fusion.transforms import from_rotvec
from scenarios.hostile.reader_cases import Base, Built, recording_with
from scenarios.hostile.suite import Case, Expect

_RIG = """[scenario]
name = "mine"

[[rig.camera]]
name = "cam1"
position_m = [{x1}, {y1}, {z1}]
target_m = [0.0, 0.0, 1.0]

[[rig.camera]]
name = "cam2"
position_m = [2.0, 1.0, 1.8]
target_m = [0.0, 0.0, 1.0]
"""


def _plan_with(rig: str | bytes | None) -> Callable[[Path], Built]:
    """``plan exam_room --trials 0 --evaluate RIG`` (``None``: a rig file that does not exist)."""
    def build(d: Path) -> Built:
        path = d / "rig.toml"
        if isinstance(rig, bytes):
            path.write_bytes(rig)
        elif rig is not None:
            path.write_text(rig)
        return ["plan", "exam_room", "--trials", "0", "--no-ablation", "--final-seeds", "1", "--workers", "0",
                "--evaluate", str(path), "--out", str(d / "plan")], None
    return build


def _algorithm(body: str, study: str) -> Callable[[Path], Built]:
    """``STUDY fma_2cam`` (one short seed) with a user's algorithm whose module is ``body``."""
    def build(d: Path) -> Built:
        (d / "mine.py").write_text(body)
        spec = f"{d / 'mine.py'}:algo"
        extra = ["--workers", "0"] if study == "calib-study" else []
        return [study, "fma_2cam", "--seeds", "1", "--duration", "8", *extra, "--algorithm", spec,
                "--out", str(d / "study")], None
    return build


def newer_cases(base: Base) -> list[Case]:
    """Cases of plan --evaluate, view, device-swap, --algorithm, replica's no-overwrite rule and a camera
    that moves during a session."""
    def existing(name: str, argv: Callable[[Path], list[str]]) -> Callable[[Path], Built]:
        def build(d: Path) -> Built:
            (d / name).write_text("keep me")
            return argv(d), lambda dd: None if (dd / name).read_text() == "keep me" else f"overwrote {name}"
        return build

    def bumped(s: SkeletonStream) -> dict[str, np.ndarray]:
        """The camera turned 8 degrees about its vertical axis for the second half of the session."""
        p = s.positions.copy()
        late = s.timestamps >= s.timestamps[0] + 0.5 * (s.timestamps[-1] - s.timestamps[0])
        p[late] = p[late] @ from_rotvec(np.array([0.0, np.radians(8.0), 0.0]), np.zeros(3))[:3, :3].T
        return {"skeleton_positions": p}

    def fuse_bumped(d: Path) -> Built:
        return ["fuse", str(recording_with(base, d, "cam2", bumped)), "--calib", str(base.calib), "--out",
                str(d / "out")], None

    def clock_at(offset_s: float) -> Callable[[Path], Built]:
        """``fuse`` with the calibration's second camera's clock offset set to ``offset_s``."""
        def build(d: Path) -> Built:
            text = base.calib.read_text()
            i = text.index("clock_offset_s", text.index("clock_offset_s") + 1)
            (d / "c.toml").write_text(text[:i] + f"clock_offset_s = {offset_s!r}" + text[text.index("\n", i):])
            return ["fuse", str(base.run), "--calib", str(d / "c.toml"), "--out", str(d / "out")], None
        return build

    def not_a_run(d: Path) -> Built:
        (d / "notes").mkdir()
        (d / "notes" / "readme.txt").write_text("nothing the viewer shows")
        return ["view", str(d / "notes"), "--save", str(d / "x.rrd")], None

    E = Expect.ERROR
    return [
        Case("plan --evaluate a rig file that does not exist", "plan", _plan_with(None), E),
        Case("plan --evaluate a garbage rig file", "plan", _plan_with(b"\x00\xff[[["), E),
        Case("plan --evaluate a camera below the floor", "plan", _plan_with(_RIG.format(x1=2.0, y1=-1.0, z1=-0.5)), E),
        Case("plan --evaluate a camera outside the room", "plan", _plan_with(_RIG.format(x1=40.0, y1=0.0, z1=1.5)), E),
        Case("view a folder that is no run, recording, fused output or plan", "view", not_a_run, E),
        Case("view --save onto an existing file", "view",
             existing("x.rrd", lambda d: ["view", str(base.run), "--save", str(d / "x.rrd")]), E),
        Case("device-swap to an unknown sensor profile", "device-swap",
             lambda d: (["device-swap", str(base.run), "--calib", str(base.calib), "--from", "azure_kinect", "--to",
                         "kinect_v9", "--out", str(d / "swap")], None), E),
        Case("calib-study --algorithm that cannot be imported", "algorithm",
             lambda d: (["calib-study", "fma_2cam", "--seeds", "1", "--algorithm", "no_such_package.calib:fn",
                         "--out", str(d / "s")], None), E),
        Case("calib-study --algorithm returning a number", "algorithm",
             _algorithm("def algo(recording, *, rng):\n    return 3\n", "calib-study"), E, quick=False),
        Case("calib-study --algorithm raising inside", "algorithm",
             _algorithm("def algo(recording, *, rng):\n    raise ValueError('my bug')\n", "calib-study"), E,
             quick=False),
        Case("angle-study --algorithm returning the wrong shape", "algorithm",
             _algorithm("import numpy as np\ndef algo(recording, calibration):\n    return np.zeros((3, 3))\n",
                        "angle-study"), E, quick=False),
        Case("fuse: a camera turned 8 deg halfway through the session", "fuse", fuse_bumped, E),
        Case("fuse: a calibration whose clock offset puts a camera 1e12 s away", "fuse", clock_at(1e12), E),
        Case("fuse: a calibration whose clock offset is 1.5 s off (another session's)", "fuse", clock_at(1.5), E),
        Case("replica with a sensor profile that does not exist", "replica",
             lambda d: (["replica", str(base.run), "--calib", str(base.calib), "--profile", "kinect_v9", "--out",
                         str(d / "rep.toml")], None), E),
        Case("replica onto an existing scenario file", "replica",
             existing("rep.toml", lambda d: ["replica", str(base.run), "--calib", str(base.calib), "--out",
                                             str(d / "rep.toml")]), E),
    ]
