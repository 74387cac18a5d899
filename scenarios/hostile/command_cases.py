"""Hostile cases of the commands: calibrations that do not fit, unusable cameras, absurd scenario values,
damaged cohort manifests, and exports of a known pose checked in their target tools.

See :mod:`scenarios.hostile.suite` for how a case is run and classified, :mod:`scenarios.hostile.reader_cases` for the
base session and the reader cases.
"""

from __future__ import annotations

import contextlib
import io
import json
import tomllib
from collections.abc import Callable
from pathlib import Path

import ezc3d
import numpy as np
import tomli_w

from fusion.calibration import Calibration
from fusion.io.calibration_file import load_calibration, save_calibration
from fusion.io.export import export_camera_toml
from fusion.io.recording_files import load_recording
from fusion.skeleton import SkeletonStream
from fusion.topology import Landmark
from scenarios.hostile.live_cases import live_cases
from scenarios.hostile.newer_cases import newer_cases
from scenarios.hostile.reader_cases import (
    SCENARIO_TEMPLATE,
    Base,
    Built,
    copy_into,
    head_above_foot,
    mutant_cases,
    reader_cases,
    recording_cases,
    recording_with,
)
from scenarios.hostile.suite import Case, Expect


def calibration_cases(base: Base) -> list[Case]:
    """Calibrations that do not fit the recording, and recordings with unusable cameras."""
    def calib_with(keep: Callable[[Calibration], Calibration]) -> Callable[[Path], Path]:
        def write(d: Path) -> Path:
            return save_calibration(keep(load_calibration(base.calib)), d / "calib.toml")
        return write

    def drop(c: Calibration) -> Calibration:
        return Calibration({"cam1": c.pose("cam1")}, {"cam1": c.intrinsics["cam1"]}, {"cam1": 0.0}, "cam1")

    def extra(c: Calibration) -> Calibration:
        return Calibration(c.T_world_cam | {"cam3": c.pose("cam2")}, c.intrinsics | {"cam3": c.intrinsics["cam2"]},
                           c.clock_offset_s | {"cam3": 0.0}, c.reference)

    def cmd(name: str, calib: Callable[[Path], Path]) -> Callable[[Path], Built]:
        return lambda d: ([name, str(base.run), "--calib", str(calib(d)), "--out", str(d / "out")], None)

    def truncated(d: Path) -> Path:
        text = base.calib.read_text()
        (d / "calib.toml").write_text(text[: text.index("[[camera]]", text.index("[[camera]]") + 1)])
        return d / "calib.toml"

    def with_camera(change: Callable[[SkeletonStream], dict[str, np.ndarray]], command: str) -> Callable[[Path], Built]:
        def build(d: Path) -> Built:
            rec = recording_with(base, d, "cam2", change)
            if command == "calibrate":
                return ["calibrate", str(rec), "--refine", "none", "--out", str(d / "c.toml")], None
            return ["fuse", str(rec), "--calib", str(base.calib), "--out", str(d / "out")], None
        return build

    def one(s: SkeletonStream) -> dict[str, np.ndarray]:
        return {"skeleton_timestamps": s.timestamps[:1], "skeleton_positions": s.positions[:1],
                "skeleton_states": s.states[:1]}

    def no_joints(s: SkeletonStream) -> dict[str, np.ndarray]:
        return {"skeleton_positions": np.full_like(s.positions, np.nan), "skeleton_states": np.zeros_like(s.states)}

    def camera_toml(units: str | None) -> Callable[[Path], Built]:
        def build(d: Path) -> Built:
            path = export_camera_toml(load_calibration(base.calib), d / "cams.toml")
            if units == "mm":
                doc = tomllib.loads(path.read_text())
                del doc["metadata"]["units"]
                for key, table in doc.items():
                    if key != "metadata":
                        table["translation"] = [v * 1000 for v in table["translation"]]
                path.write_text(tomli_w.dumps(doc))

            def check(dd: Path) -> str | None:
                n = load_recording(dd / "out" / "recording").cameras[0].skeleton.n_frames
                return None if n > 100 else f"only {n} fused frames"
            return ["fuse", str(base.run), "--calib", str(path), "--out", str(d / "out")], check
        return build

    E = Expect.ERROR
    return [
        Case("fuse: calibration lacks a camera", "calibration", cmd("fuse", calib_with(drop)), E),
        Case("fuse: calibration names a camera the recording lacks", "calibration", cmd("fuse", calib_with(extra)), E),
        Case("fuse: truncated calibration", "calibration", cmd("fuse", truncated), E),
        Case("evaluate: calibration lacks a camera", "calibration", cmd("evaluate", calib_with(drop)), E),
        Case("evaluate: calibration names an extra camera", "calibration", cmd("evaluate", calib_with(extra)), E),
        Case("fuse: a camera with one frame", "calibration", with_camera(one, "fuse"), E),
        Case("fuse: a camera that never tracked a joint", "calibration", with_camera(no_joints, "fuse"), E),
        Case("calibrate: a camera with one frame", "calibration", with_camera(one, "calibrate"), E),
        Case("calibrate: --out an existing directory", "calibration",
             lambda d: (["calibrate", str(base.run), "--out", str(d)], None), E),
        Case("fuse: camera TOML with translations in mm, no units", "calibration", camera_toml("mm"), E),
        Case("fuse: aniposelib camera TOML", "calibration", camera_toml(None), Expect.RESULT, quick=False),
    ]


def scenario_cases(base: Base) -> list[Case]:
    """Scenario values a simulation cannot honour, and commands on unfit inputs."""
    def scenario(top: str = "", rig: str = "n_cameras = 2", args: tuple[str, ...] = ()) -> Callable[[Path], Built]:
        def build(d: Path) -> Built:
            (d / "s.toml").write_text(SCENARIO_TEMPLATE.format(top=top, rig=rig))
            return ["simulate", str(d / "s.toml"), "--out", str(d / "out"), *args], None
        return build

    def manifest(text: str | None, drop_recording: bool = False) -> Callable[[Path], Built]:
        def build(d: Path) -> Built:
            subject = {"id": "s1", "group": "healthy", "error": None, "item_scores": {"left": {}},
                       "files": {"recording": "r1", "calibration": "c1.toml"},
                       "blocks": [{"movement": "salute", "side": "left", "t_start": 0.0, "t_end": 5.0}]}
            doc = json.dumps({"subjects": [subject, dict(subject, id="s2")]})
            (d / "manifest.json").write_text(doc if text is None else text)
            if not drop_recording:
                copy_into(base.run / "recording", d).rename(d / "r1")
                copy_into(base.calib, d).rename(d / "c1.toml")
            return ["fma", str(d), "--out", str(d / "out")], None
        return build

    def garbage_scenario(d: Path) -> Built:
        (d / "s.toml").write_bytes(b"\x00\xff[[[")
        return ["simulate", str(d / "s.toml"), "--out", str(d / "out")], None

    def cohort(d: Path) -> Built:
        (d / "c.toml").write_text("[cohort]\nname = \"huge\"\n[groups]\nhealthy = 100000000\n")
        return ["cohort", str(d / "c.toml"), "--out", str(d / "out")], None

    def export_twice(d: Path) -> Built:
        (d / "x.trc").write_text("keep me")
        return ["export", str(base.fused), "--format", "trc", "--out", str(d / "x.trc")], (
            lambda dd: None if (dd / "x.trc").read_text() == "keep me" else "overwrote the file")

    E = Expect.ERROR
    return [
        Case("--duration nan", "simulate", scenario(args=("--duration", "nan")), E),
        Case("--duration 1e9", "simulate", scenario(args=("--duration", "1e9")), E),
        Case("duration_s = nan in the file", "simulate", scenario(top="duration_s = nan"), E),
        Case("300 cameras", "simulate", scenario(rig="n_cameras = 300"), E),
        Case("ring radius 50 m", "simulate", scenario(rig="radius_m = 50.0"), E),
        Case("ring radius inf", "simulate", scenario(rig="radius_m = inf"), E),
        Case("cameras below the floor", "simulate", scenario(rig="height_m = -0.5"), E),
        Case("2 angles with n_cameras = 3", "simulate", scenario(rig="n_cameras = 3\nangles_deg = [0.0, 90.0]"), E),
        Case("subset naming camera 9 of 2", "simulate", scenario(rig="subset = [1, 9]"), E),
        Case("garbage scenario file", "simulate", garbage_scenario, E),
        Case("layout on a two-camera scenario", "layout", lambda d: (["layout", "fma_2cam", "--out", str(d)], None), E),
        Case("cohort with 100,000,000 subjects", "cohort", cohort, E),
        Case("fma on a garbage manifest", "fma", manifest("\x00garbage"), E),
        Case("fma on a truncated manifest", "fma", manifest('{"subjects": [{"id": "s1", "gr'), E),
        Case("fma with a subject's recording deleted", "fma", manifest(None, drop_recording=True), E),
        Case("fma on a manifest without blocks", "fma", manifest('{"subjects": [{"id": "s1"}]}'), E),
        Case("export onto an existing file", "export", export_twice, E),
        Case("export --rate -5", "export",
             lambda d: (["export", str(base.fused), "--format", "trc", "--rate", "-5", "--out", str(d / "x.trc")],
                        None), E),
    ]


def export_cases(base: Base) -> list[Case]:
    """Exports of a known pose (a standing person), checked in the target format's axes."""
    rec = load_recording(base.run / "recording")
    topo = rec.topology
    head, foot = topo.index(Landmark.HEAD), topo.index(Landmark.FOOT_LEFT)

    def trc_rows(path: Path) -> np.ndarray:
        rows = [ln.split("\t") for ln in path.read_text().splitlines()[5:]]
        return np.array([[float(v) if v else np.nan for v in r[2:]] for r in rows]).reshape(len(rows), -1, 3)

    def trc(source: Path, *extra: str) -> Callable[[Path], Built]:
        return lambda d: (["export", str(source), "--format", "trc", "--out", str(d / "x.trc"), *extra],
                          lambda dd: head_above_foot(trc_rows(dd / "x.trc"), head, foot, 1))

    def c3d(source: Path, *extra: str) -> Callable[[Path], Built]:
        def check(dd: Path) -> str | None:
            points = ezc3d.c3d(str(dd / "x.c3d"))["data"]["points"][:3].transpose(2, 1, 0)
            return head_above_foot(points, head, foot, 2)
        return lambda d: (["export", str(source), "--format", "c3d", "--out", str(d / "x.c3d"), *extra], check)

    def cams(d: Path) -> Built:
        def check(dd: Path) -> str | None:
            doc = tomllib.loads((dd / "c.toml").read_text())
            fx = [doc[k]["matrix"][0][0] for k in doc if k != "metadata"]
            return None if min(fx) > 0 else f"fx = {fx}"
        return ["export", str(base.calib), "--format", "camera-toml", "--out", str(d / "c.toml")], check

    def bundle_adjustment(d: Path) -> Built:
        def check(dd: Path) -> str | None:
            return aniposelib_bundle_adjustment_error(load_calibration(base.calib), dd / "c.toml", rng_seed=4)
        return ["export", str(base.calib), "--format", "camera-toml", "--out", str(d / "c.toml")], check

    R = Expect.RESULT
    return [
        Case("camera TOML: aniposelib bundle adjustment converges", "export", bundle_adjustment, R, quick=False),
        Case("trc of a camera frame (--camera cam1): y up", "export", trc(base.run, "--camera", "cam1"), R),
        Case("trc of the world frame: y up", "export", trc(base.fused), R),
        Case("trc of the world frame --units mm --rate 60", "export", trc(base.fused, "--units", "mm", "--rate", "60"),
             R),
        Case("c3d of a camera frame (--camera cam2): z up", "export", c3d(base.run, "--camera", "cam2"), R),
        Case("c3d of the world frame: z up", "export", c3d(base.fused), R),
        Case("camera TOML: fx > 0 by default", "export", cams, R),
    ]


def aniposelib_bundle_adjustment_error(calibration: Calibration, path: Path, *, rng_seed: int) -> str | None:
    """None if aniposelib's bundle adjustment, started from the camera TOML at ``path`` with 60 points
    seen with 0.5 px noise, keeps the median triangulation error under 2 cm; else the error."""
    from aniposelib.cameras import CameraGroup

    from fusion.camera import AxisConvention
    from fusion.transforms import apply, invert

    group = CameraGroup.load(str(path))
    rng = np.random.default_rng(rng_seed)
    p_world = rng.uniform([-0.4, -0.4, 0.2], [0.4, 0.4, 1.8], size=(60, 3))
    uv = []
    for name, camera in zip(calibration.camera_names, group.cameras):
        intr = calibration.intrinsics[name]
        px, _ = intr.project(apply(invert(calibration.pose(name)), p_world))
        if intr.axes is AxisConvention.KINECT_V2 and camera.get_camera_matrix()[0, 0] > 0:
            px[:, 0] = intr.width - 1 - px[:, 0]  # the unmirrored image a file with fx > 0 describes
        uv.append(px)
    noisy = np.array(uv) + rng.normal(0.0, 0.5, (len(uv), *uv[0].shape))
    with contextlib.redirect_stdout(io.StringIO()):
        group.bundle_adjust(noisy, max_nfev=30, verbose=False)
    error = float(np.median(np.linalg.norm(group.triangulate(noisy) - p_world, axis=1)))
    return None if error < 0.02 else f"median triangulation error {error * 1000:.0f} mm after bundle adjustment"



def all_cases(base: Base, *, mutants: int, rng: np.random.Generator) -> list[Case]:
    """Every hand-written case plus ``mutants`` random ones."""
    return (reader_cases(base) + recording_cases(base) + calibration_cases(base) + scenario_cases(base)
            + export_cases(base) + newer_cases(base) + live_cases(base) + mutant_cases(base, mutants, rng=rng))
