"""The hostile cases: unit mistakes, foreign clocks, damaged and inconsistent files, absurd scenario
values and export checks with a known pose, built from one small simulated base session.

See :mod:`scenarios.hostile` for how a case is run and classified.
"""

from __future__ import annotations

import contextlib
import io
import json
import shutil
import tomllib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import ezc3d
import numpy as np
import tomli_w

from fusion.io.arrayfiles import write_arrays
from fusion.io.calibration_file import Calibration, load_calibration, save_calibration
from fusion.io.export import export_camera_toml
from fusion.io.formats import write_csv_skeleton, write_k4abt_json, write_ntu
from fusion.io.formats.csv_skeleton import CsvOptions, LengthUnit
from fusion.io.recording import MANIFEST, CameraRecording, Recording, load_recording, save_recording
from fusion.skeleton import SkeletonStream
from fusion.topology import Landmark
from scenarios.hostile import Case, Expect
from scenarios.runner import load_run, simulate_to_disk

Check = Callable[[Path], str | None]
Built = tuple[list[str], Check | None]

_SCENARIO = """[scenario]
name = "hostile"
{top}
[[session.segment]]
kind = "calibration_turn"
duration_s = 8.0
[rig]
{rig}
"""


@dataclass(frozen=True)
class Base:
    """The base session every case starts from (paths under one directory)."""

    run: Path
    """Simulated Kinect v2 run, two cameras (fma_2cam, 10 s)."""
    calib: Path
    """Calibration TOML of that run from its true camera poses."""
    csv: tuple[Path, Path]
    ntu: tuple[Path, Path]
    k4_json: tuple[Path, Path]
    fused: Path
    """A fused-like recording: one camera ``fused`` in the world frame (the true joints)."""


def build_base(work: Path, *, seed: int = 1) -> Base:
    """Simulate the base sessions (about 30 s of work) and write them in every format under ``work``."""
    from scenarios.config import load_scenario, scenario_from_dict

    run = simulate_to_disk(load_scenario("fma_2cam"), work / "run", seed=seed, duration_s=10.0, progress=False)
    recording, truth = load_run(run)
    ref = truth.cameras[0]
    calib = save_calibration(Calibration(truth.T_world_cam(), {c.name: c.intrinsics for c in recording.cameras},
                                         {c.name: c.clock_offset_s - ref.clock_offset_s for c in truth.cameras},
                                         ref.name), work / "calib.toml")
    csv = tuple(write_csv_skeleton(recording, work / "csv"))
    ntu = tuple(write_ntu(recording, work / "ntu"))
    k4 = scenario_from_dict(tomllib.loads(_SCENARIO.format(top="", rig="angles_deg = [-45.0, 45.0]").replace(
        "[rig]", "[subject]\ntopology = \"k4abt\"\n[rig]")))
    k4_run = simulate_to_disk(k4, work / "k4run", seed=seed, progress=False)
    k4_json = tuple(write_k4abt_json(load_recording(k4_run / "recording"), work / "k4json"))
    topo = recording.topology
    stream = SkeletonStream(topo, truth.times, truth.joints_world,
                            np.full(truth.joints_world.shape[:2], 2, dtype=np.int8))
    fused = save_recording(Recording((CameraRecording("fused", recording.cameras[0].intrinsics, stream),),
                                     {"frame": "world"}), work / "fused" / "recording")
    return Base(run, calib, csv, ntu, k4_json, fused.parent)


# ------------------------------------------------------------------------------------------ helpers


def _copy(src: Path, d: Path) -> Path:
    dst = d / src.name
    if src.is_dir():
        shutil.copytree(src, dst)
    else:
        shutil.copy(src, dst)
    return dst


def _edit_text(src: Path, d: Path, edit: Callable[[str], str]) -> Path:
    dst = d / src.name
    dst.write_text(edit(src.read_text(encoding="utf-8")), encoding="utf-8")
    return dst


def _csv_column(text: str, col: int, f: Callable[[float], float], rows: slice = slice(None)) -> str:
    lines = text.splitlines()
    body = lines[1:]
    for i in range(len(body))[rows]:
        cells = body[i].split(",")
        cells[col] = repr(f(float(cells[col])))
        body[i] = ",".join(cells)
    return "\n".join([lines[0], *body]) + "\n"


def _replace_arrays(rec: Path, camera: str, arrays: dict[str, np.ndarray]) -> None:
    """Rewrite some arrays of one camera in a recording directory, manifest sizes and checksums included."""
    manifest = json.loads((rec / MANIFEST).read_text())
    entries = write_arrays(rec, camera, arrays)
    cam = next(c for c in manifest["cameras"] if c["name"] == camera)
    cam["files"].update(entries)
    (rec / MANIFEST).write_text(json.dumps(manifest))


def _recording_with(base: Base, d: Path, camera: str, change: Callable[[SkeletonStream], dict[str, np.ndarray]]
                    ) -> Path:
    rec = _copy(base.run / "recording", d)
    stream = load_recording(rec).camera(camera).skeleton
    _replace_arrays(rec, camera, change(stream))
    return rec


def _import(fmt: str, files: list[Path], d: Path, *extra: str) -> list[str]:
    return ["import", fmt, *map(str, files), "--out", str(d / "out"), *extra]


def _frames_kept(expected: int) -> Check:
    def check(d: Path) -> str | None:
        rec = load_recording(d / "out")
        n = [int((~np.isnan(c.skeleton.positions[..., 0])).any(axis=1).sum()) for c in rec.cameras]
        return None if min(n) >= expected else f"frames with a body: {n}, expected {expected} per camera"
    return check


def _vertical(positions: np.ndarray, head: int, foot: int, axis: int) -> str | None:
    """None if the head is above the foot along ``axis`` in most frames, else the reason."""
    dz = positions[:, head, axis] - positions[:, foot, axis]
    dz = dz[np.isfinite(dz)]
    up = float(np.mean(dz > 0.5)) if dz.size else 0.0
    return None if up > 0.9 else f"head above foot along axis {'XYZ'[axis]} in only {up:.0%} of frames"


# ------------------------------------------------------------------------------------------ cases


def reader_cases(base: Base) -> list[Case]:
    """Unit, clock and damage cases of the three readers."""
    c1, c2 = base.csv
    n_frames = load_recording(base.run / "recording").camera("cam1").skeleton.n_frames
    rows = slice(int(0.4 * n_frames), int(0.61 * n_frames))

    def reacquired(d: Path) -> Built:
        files = [_edit_text(c, d, lambda t: _csv_column(t, 1, lambda v: 7, rows)) for c in (c1, c2)]
        return _import("csv", files, d), _frames_kept(int(0.9 * n_frames))

    def two_people(d: Path) -> Built:
        def add(text: str) -> str:
            lines = text.splitlines()
            extra = [_csv_column(lines[0] + "\n" + r, 1, lambda v: 9).splitlines()[1] for r in lines[1::3]]
            extra = [_csv_column(lines[0] + "\n" + r, 3, lambda v: v + 1.0).splitlines()[1] for r in extra]
            by_time = {}
            for r in lines[1:] + extra:
                by_time.setdefault(r.split(",")[0], []).append(r)
            return "\n".join([lines[0]] + [r for k in by_time for r in by_time[k]]) + "\n"
        files = [_edit_text(c, d, add) for c in (c1, c2)]
        return _import("csv", files, d), _frames_kept(int(0.9 * n_frames))

    def mm_as_m(d: Path) -> Built:
        rec = load_recording(base.run / "recording")
        files = write_csv_skeleton(rec, d, CsvOptions(unit=LengthUnit.MM))
        return _import("csv", files, d), None

    def json_edit(edit: Callable[[dict], None]) -> Callable[[Path], Built]:
        def build(d: Path) -> Built:
            files = []
            for p in base.k4_json:
                doc = json.loads(p.read_text())
                edit(doc)
                (d / p.name).write_text(json.dumps(doc))
                files.append(d / p.name)
            return _import("k4abt-json", files, d), None
        return build

    def scale_json_positions(doc: dict) -> None:
        for f in doc["frames"]:
            for b in f["bodies"]:
                b["joint_positions"] = (np.array(b["joint_positions"]) / 1000).tolist()

    def json_seconds(doc: dict) -> None:
        for f in doc["frames"]:
            f["timestamp_usec"] = f["timestamp_usec"] / 1e6

    def ntu_mm(d: Path) -> Built:
        def scale(text: str) -> str:
            out = []
            for line in text.splitlines():
                parts = line.split()
                if len(parts) == 12:  # a joint line: x y z first
                    parts[:3] = [repr(float(v) * 1000) for v in parts[:3]]
                out.append(" ".join(parts))
            return "\n".join(out) + "\n"
        return ["import", "ntu", *(str(_edit_text(p, d, scale)) for p in base.ntu), "--out", str(d / "out")], None

    def text_case(src: tuple[Path, Path], fmt: str, edit: Callable[[str], str], both: bool = False
                  ) -> Callable[[Path], Built]:
        def build(d: Path) -> Built:
            files = [_edit_text(src[0], d, edit), _edit_text(src[1], d, edit) if both else _copy(src[1], d)]
            return _import(fmt, files, d), None
        return build

    def raw(src: tuple[Path, Path], fmt: str, data: bytes) -> Callable[[Path], Built]:
        def build(d: Path) -> Built:
            (d / src[0].name).write_bytes(data)
            return _import(fmt, [d / src[0].name, _copy(src[1], d)], d), None
        return build

    E, R = Expect.ERROR, Expect.RESULT
    cases = [
        Case("csv in millimetres read as metres", "import csv", mm_as_m, E),
        Case("csv in metres read with --csv-unit mm", "import csv",
             lambda d: (_import("csv", [_copy(c1, d), _copy(c2, d)], d, "--csv-unit", "mm"), None), E),
        Case("csv timestamps in microseconds", "import csv",
             text_case(base.csv, "csv", lambda t: _csv_column(t, 0, lambda v: v * 1e6), True), E),
        Case("csv timestamps in milliseconds", "import csv",
             text_case(base.csv, "csv", lambda t: _csv_column(t, 0, lambda v: v * 1e3), True), E),
        Case("csv epoch offset on one camera", "import csv",
             text_case(base.csv, "csv", lambda t: _csv_column(t, 0, lambda v: v + 1.7e9)), E),
        Case("csv fractional tracking state", "import csv",
             text_case(base.csv, "csv", lambda t: _csv_column(t, 2, lambda v: 1.5, slice(3, 4))), E),
        Case("csv NaN cell", "import csv", text_case(base.csv, "csv", lambda t: t.replace(",0.", ",nan", 1)), E),
        Case("csv truncated in a row", "import csv", text_case(base.csv, "csv", lambda t: t[: len(t) // 2]), E),
        Case("csv timestamps going back", "import csv",
             text_case(base.csv, "csv", lambda t: _csv_column(t, 0, lambda v: 5.0, slice(10, 11))), E),
        Case("csv as written", "import csv",
             lambda d: (_import("csv", [_copy(c1, d), _copy(c2, d)], d), _frames_kept(int(0.9 * n_frames))), R),
        Case("csv person re-acquired under a new body id (21 % of frames)", "import csv", reacquired, R),
        Case("csv second person in a third of the frames", "import csv", two_people, R),
        Case("k4abt-json in metres", "import k4abt-json", json_edit(scale_json_positions), E),
        Case("k4abt-json timestamps in seconds", "import k4abt-json", json_edit(json_seconds), E),
        Case("k4abt-json truncated", "import k4abt-json", text_case(base.k4_json, "k4abt-json", lambda t: t[:-200]), E),
        Case("k4abt-json as written", "import k4abt-json",
             lambda d: (_import("k4abt-json", [_copy(p, d) for p in base.k4_json], d), _frames_kept(100)), R),
        Case("ntu in millimetres", "import ntu", ntu_mm, E),
        Case("ntu truncated", "import ntu", text_case(base.ntu, "ntu", lambda t: t[: len(t) // 3]), E),
    ]
    for fmt, src in (("csv", base.csv), ("k4abt-json", base.k4_json), ("ntu", base.ntu)):
        cases += [Case(f"{fmt} garbage bytes", f"import {fmt}", raw(src, fmt, bytes(range(256)) * 4), E),
                  Case(f"{fmt} empty file", f"import {fmt}", raw(src, fmt, b""), E)]
    return cases


def recording_cases(base: Base) -> list[Case]:
    """Recordings on disk whose arrays are in the wrong unit, type or clock, or damaged."""
    def export(rec: Path, d: Path) -> list[str]:
        return ["export", str(rec), "--format", "csv", "--camera", "cam1", "--out", str(d / "x.csv")]

    def changed(camera: str, change: Callable[[SkeletonStream], dict[str, np.ndarray]]) -> Callable[[Path], Built]:
        return lambda d: (export(_recording_with(base, d, camera, change), d), None)

    def garbage_manifest(d: Path) -> Built:
        rec = _copy(base.run / "recording", d)
        (rec / MANIFEST).write_text('{"format": "mocap-bench-rec')
        return export(rec, d), None

    def truncated_npy(d: Path) -> Built:
        rec = _copy(base.run / "recording", d)
        p = rec / "cam1" / "skeleton_positions.npy"
        p.write_bytes(p.read_bytes()[:1000])
        return export(rec, d), None

    E = Expect.ERROR
    return [
        Case("float tracking states (1.7)", "recording",
             changed("cam1", lambda s: {"skeleton_states": np.where(s.states > 0, s.states + 0.7, 0.0)}), E),
        Case("positions in millimetres", "recording",
             changed("cam1", lambda s: {"skeleton_positions": s.positions * 1000}), E),
        Case("timestamps in microseconds", "recording",
             changed("cam1", lambda s: {"skeleton_timestamps": s.timestamps * 1e6}), E),
        Case("epoch offset on one camera", "recording",
             changed("cam2", lambda s: {"skeleton_timestamps": s.timestamps + 1.7e9}), E),
        Case("garbage manifest", "recording", garbage_manifest, E),
        Case("truncated array", "recording", truncated_npy, E),
    ]


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
            rec = _recording_with(base, d, "cam2", change)
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
            (d / "s.toml").write_text(_SCENARIO.format(top=top, rig=rig))
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
                _copy(base.run / "recording", d).rename(d / "r1")
                _copy(base.calib, d).rename(d / "c1.toml")
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
                          lambda dd: _vertical(trc_rows(dd / "x.trc"), head, foot, 1))

    def c3d(source: Path, *extra: str) -> Callable[[Path], Built]:
        def check(dd: Path) -> str | None:
            points = ezc3d.c3d(str(dd / "x.c3d"))["data"]["points"][:3].transpose(2, 1, 0)
            return _vertical(points, head, foot, 2)
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


def mutant_cases(base: Base, n: int, *, rng: np.random.Generator) -> list[Case]:
    """``n`` randomly damaged reader files (truncated, bytes overwritten, a line doubled or dropped)."""
    sources = [("csv", base.csv), ("k4abt-json", base.k4_json), ("ntu", base.ntu)]
    cases = []
    for i in range(n):
        fmt, src = sources[int(rng.integers(len(sources)))]
        data = bytearray(src[0].read_bytes())
        kind = int(rng.integers(4))
        at = int(rng.integers(len(data)))
        if kind == 0:
            data = data[:at]
        elif kind == 1:
            for k in rng.integers(len(data), size=int(rng.integers(1, 8))):
                data[int(k)] = int(rng.integers(256))
        else:
            lines = bytes(data).split(b"\n")
            j = int(rng.integers(len(lines)))
            lines = lines[:j + 1] + lines[j:] if kind == 2 else lines[:j] + lines[j + 1:]
            data = bytearray(b"\n".join(lines))
        name = ("truncated", "bytes overwritten", "a line doubled", "a line dropped")[kind]

        def build(d: Path, fmt: str = fmt, src: tuple[Path, Path] = src, data: bytes = bytes(data)) -> Built:
            (d / src[0].name).write_bytes(data)
            return _import(fmt, [d / src[0].name, _copy(src[1], d)], d), lambda dd: None
        cases.append(Case(f"{fmt} mutant {i}: {name} at byte {at}", f"mutant {fmt}", build, Expect.EITHER))
    return cases


def all_cases(base: Base, *, mutants: int, rng: np.random.Generator) -> list[Case]:
    """Every hand-written case plus ``mutants`` random ones."""
    return (reader_cases(base) + recording_cases(base) + calibration_cases(base) + scenario_cases(base)
            + export_cases(base) + mutant_cases(base, mutants, rng=rng))
