"""The hostile suite's base session (written in every format) and its cases of the readers and of
recordings on disk: unit mistakes, foreign clocks, damaged files, randomly damaged files.

See :mod:`scenarios.hostile.suite` for how a case is run and classified, :mod:`scenarios.hostile.command_cases`
for the cases of the commands and exports.
"""

from __future__ import annotations

import json
import shutil
import tomllib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fusion.frames import LengthUnit
from fusion.io.arrayfiles import write_arrays
from fusion.io.calibration_file import save_calibration
from fusion.io.formats import write_csv_skeleton, write_k4abt_json, write_ntu
from fusion.io.formats.csv_skeleton import CsvOptions
from fusion.io.recording_files import (
    MANIFEST,
    depth_file,
    load_recording,
    save_recording,
)
from fusion.recording import CameraRecording, Recording
from fusion.skeleton import SkeletonStream
from scenarios.api import true_calibration
from scenarios.hostile.suite import Case, Expect
from scenarios.runner import load_run, simulate_to_disk

Check = Callable[[Path], str | None]
Built = tuple[list[str], Check | None]

SCENARIO_TEMPLATE = """[scenario]
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
    calib = save_calibration(true_calibration(recording, truth), work / "calib.toml")
    csv = tuple(write_csv_skeleton(recording, work / "csv"))
    ntu = tuple(write_ntu(recording, work / "ntu"))
    k4 = scenario_from_dict(tomllib.loads(SCENARIO_TEMPLATE.format(top="", rig="angles_deg = [-45.0, 45.0]").replace(
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


def copy_into(src: Path, d: Path) -> Path:
    dst = d / src.name
    if src.is_dir():
        shutil.copytree(src, dst)
    else:
        shutil.copy(src, dst)
    return dst


def edit_text(src: Path, d: Path, edit: Callable[[str], str]) -> Path:
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


def recording_with(base: Base, d: Path, camera: str, change: Callable[[SkeletonStream], dict[str, np.ndarray]]
                    ) -> Path:
    rec = copy_into(base.run / "recording", d)
    stream = load_recording(rec).camera(camera).skeleton
    _replace_arrays(rec, camera, change(stream))
    return rec


def import_argv(fmt: str, files: list[Path], d: Path, *extra: str) -> list[str]:
    return ["import", fmt, *map(str, files), "--out", str(d / "out"), *extra]


def _frames_kept(expected: int) -> Check:
    def check(d: Path) -> str | None:
        rec = load_recording(d / "out")
        n = [int((~np.isnan(c.skeleton.positions[..., 0])).any(axis=1).sum()) for c in rec.cameras]
        return None if min(n) >= expected else f"frames with a body: {n}, expected {expected} per camera"
    return check


def head_above_foot(positions: np.ndarray, head: int, foot: int, axis: int) -> str | None:
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
        files = [edit_text(c, d, lambda t: _csv_column(t, 1, lambda v: 7, rows)) for c in (c1, c2)]
        return import_argv("csv", files, d), _frames_kept(int(0.9 * n_frames))

    def two_people(d: Path) -> Built:
        def add(text: str) -> str:
            lines = text.splitlines()
            extra = [_csv_column(lines[0] + "\n" + r, 1, lambda v: 9).splitlines()[1] for r in lines[1::3]]
            extra = [_csv_column(lines[0] + "\n" + r, 3, lambda v: v + 1.0).splitlines()[1] for r in extra]
            by_time = {}
            for r in lines[1:] + extra:
                by_time.setdefault(r.split(",")[0], []).append(r)
            return "\n".join([lines[0]] + [r for k in by_time for r in by_time[k]]) + "\n"
        files = [edit_text(c, d, add) for c in (c1, c2)]
        return import_argv("csv", files, d), _frames_kept(int(0.9 * n_frames))

    def mm_as_m(d: Path) -> Built:
        rec = load_recording(base.run / "recording")
        files = write_csv_skeleton(rec, d, CsvOptions(unit=LengthUnit.MM))
        return import_argv("csv", files, d), None

    def json_edit(edit: Callable[[dict], None]) -> Callable[[Path], Built]:
        def build(d: Path) -> Built:
            files = []
            for p in base.k4_json:
                doc = json.loads(p.read_text())
                edit(doc)
                (d / p.name).write_text(json.dumps(doc))
                files.append(d / p.name)
            return import_argv("k4abt-json", files, d), None
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
        return ["import", "ntu", *(str(edit_text(p, d, scale)) for p in base.ntu), "--out", str(d / "out")], None

    def text_case(src: tuple[Path, Path], fmt: str, edit: Callable[[str], str], both: bool = False
                  ) -> Callable[[Path], Built]:
        def build(d: Path) -> Built:
            files = [edit_text(src[0], d, edit), edit_text(src[1], d, edit) if both else copy_into(src[1], d)]
            return import_argv(fmt, files, d), None
        return build

    def raw(src: tuple[Path, Path], fmt: str, data: bytes) -> Callable[[Path], Built]:
        def build(d: Path) -> Built:
            (d / src[0].name).write_bytes(data)
            return import_argv(fmt, [d / src[0].name, copy_into(src[1], d)], d), None
        return build

    E, R = Expect.ERROR, Expect.RESULT
    cases = [
        Case("csv in millimetres read as metres", "import csv", mm_as_m, E),
        Case("csv in metres read with --csv-unit mm", "import csv",
             lambda d: (import_argv("csv", [copy_into(c1, d), copy_into(c2, d)], d, "--csv-unit", "mm"), None), E),
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
             lambda d: (import_argv("csv", [copy_into(c1, d), copy_into(c2, d)], d), _frames_kept(int(0.9 * n_frames))), R),
        Case("csv person re-acquired under a new body id (21 % of frames)", "import csv", reacquired, R),
        Case("csv second person in a third of the frames", "import csv", two_people, R),
        Case("k4abt-json in metres", "import k4abt-json", json_edit(scale_json_positions), E),
        Case("k4abt-json timestamps in seconds", "import k4abt-json", json_edit(json_seconds), E),
        Case("k4abt-json truncated", "import k4abt-json", text_case(base.k4_json, "k4abt-json", lambda t: t[:-200]), E),
        Case("k4abt-json as written", "import k4abt-json",
             lambda d: (import_argv("k4abt-json", [copy_into(p, d) for p in base.k4_json], d), _frames_kept(100)), R),
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
        return lambda d: (export(recording_with(base, d, camera, change), d), None)

    def garbage_manifest(d: Path) -> Built:
        rec = copy_into(base.run / "recording", d)
        (rec / MANIFEST).write_text('{"format": "mocap-bench-rec')
        return export(rec, d), None

    def truncated_npy(d: Path) -> Built:
        rec = copy_into(base.run / "recording", d)
        p = rec / "cam1" / "skeleton_positions.npy"
        p.write_bytes(p.read_bytes()[:1000])
        return export(rec, d), None

    def calibrate_icp(rec: Path, d: Path) -> list[str]:
        return ["calibrate", str(rec), "--refine", "icp", "--out", str(d / "c.toml")]

    def truncated_depth(d: Path) -> Built:
        rec = copy_into(base.run / "recording", d)
        p = depth_file(rec, "cam1")
        p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
        return calibrate_icp(rec, d), None

    def damaged_depth_frame(d: Path) -> Built:
        import h5py

        rec = copy_into(base.run / "recording", d)
        p = depth_file(rec, "cam1")
        with h5py.File(p) as f:
            chunk = f["depth_mm"].id.get_chunk_info(0)  # frame 0: the calibration's floor reads it
        data = bytearray(p.read_bytes())
        data[chunk.byte_offset + chunk.size // 2] ^= 0xFF
        p.write_bytes(bytes(data))
        return calibrate_icp(rec, d), None

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
        Case("truncated depth file", "recording", truncated_depth, E),
        Case("damaged depth frame", "recording", damaged_depth_frame, E),
    ]


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
            return import_argv(fmt, [d / src[0].name, copy_into(src[1], d)], d), lambda dd: None
        cases.append(Case(f"{fmt} mutant {i}: {name} at byte {at}", f"mutant {fmt}", build, Expect.EITHER))
    return cases
