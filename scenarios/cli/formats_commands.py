"""Commands that read and write real body-tracker files: import, write, roundtrip."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from scenarios.cli.choices import LazyChoices, add_choice

if TYPE_CHECKING:
    from fusion.io.formats.csv_layout import CsvLayout

from scenarios.cli.sweep_args import add_sweep_arguments, sweep_options


def _cmd_import(args: argparse.Namespace) -> None:
    from fusion.camera import AxisConvention
    from fusion.errors import BadInputError
    from fusion.frames import LengthUnit
    from fusion.io.formats import FileFormat
    from fusion.io.formats.csv_skeleton import ConfidenceScale, CsvOptions
    from fusion.io.recording_files import save_recording
    from fusion.topology import topology_by_name
    from scenarios.interop.interchange import import_files

    csv_options = CsvOptions(topology=topology_by_name(args.csv_topology), unit=LengthUnit(args.csv_unit),
                             axes=AxisConvention(args.csv_axes), confidence=ConfidenceScale(args.csv_confidence))
    if args.layout is not None:
        if FileFormat(args.format) is not FileFormat.CSV:
            raise BadInputError("--layout applies to the csv format only")
        recording = layout_recording(args.files, args.layout)
    else:
        recording = import_files(FileFormat(args.format), args.files, csv_options=csv_options)
    if args.names is not None:
        recording = recording.renamed(args.names)
    if args.lab is not None:
        recording = recording.with_lab(args.lab)
    save_recording(recording, args.out, overwrite=args.overwrite)
    for cam in recording.cameras:
        sk = cam.skeleton
        print(f"{cam.name}: {sk.n_frames} frames, {sk.topology.name}, tracked {(sk.states >= 2).mean():.0%}")
    print(f"wrote {args.out}")


def layout_recording(files: list[Path], name_or_path: str, names: list[str] | None = None):
    """CSV files read through a layout (:func:`csv_layout`); a built-in layout is one dataset's, so the
    recording is said to come from the lab of that name (:attr:`fusion.recording.Recording.lab`)."""
    from fusion.io.formats.csv_layout import LAYOUTS, read_csv_layout

    recording = read_csv_layout(files, csv_layout(name_or_path), names=names)
    return recording.with_lab(name_or_path) if name_or_path in LAYOUTS else recording


def csv_layout(name_or_path: str) -> CsvLayout:
    """A built-in CSV layout by name, or one read from the ``[layout]`` table of a TOML file."""
    import tomllib

    from fusion.errors import BadInputError
    from fusion.io.formats.csv_layout import LAYOUTS, layout_from_dict

    if name_or_path in LAYOUTS:
        return LAYOUTS[name_or_path]
    path = Path(name_or_path)
    if not path.is_file():
        raise BadInputError(f"CSV layout {name_or_path!r} is neither a built-in ({', '.join(LAYOUTS)}) nor a file")
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise BadInputError(f"{path}: not valid TOML: {exc}") from None
    return layout_from_dict(doc.get("layout", doc))


def _cmd_write(args: argparse.Namespace) -> None:
    from fusion.io.formats import FileFormat
    from fusion.io.recording_files import load_recording
    from scenarios.interop.interchange import write_files
    from scenarios.runner import recording_dir

    for path in write_files(FileFormat(args.format), load_recording(recording_dir(args.run)), args.out):
        print(f"wrote {path}")


def _cmd_roundtrip(args: argparse.Namespace) -> None:
    from fusion.io.atomic import atomic_directory
    from fusion.io.formats import FileFormat
    from scenarios.config import load_scenario
    from scenarios.interop.interchange import round_trip_study, round_trip_table

    scenario = load_scenario(args.scenario)
    if args.duration is not None:
        scenario = scenario.replace(duration_s=args.duration)
    formats = [FileFormat(f) for f in args.formats]
    rows = round_trip_study(scenario, formats, args.camera_counts, sweep=sweep_options(args))
    table = round_trip_table(rows)
    with atomic_directory(args.out, overwrite=args.overwrite) as tmp:
        import json

        (tmp / "roundtrip.json").write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")
        (tmp / "roundtrip.md").write_text("# Write, import, calibrate (skeleton only)\n\n" + table, encoding="utf-8")
    print(table)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the import, write, roundtrip sub-commands."""
    formats = LazyChoices("fusion.io.formats.FileFormat", where="writable")
    p = sub.add_parser("import", help="read real body-tracker files into a recording")
    add_choice(p, "format", path="fusion.io.formats.FileFormat", help="file format")
    p.add_argument("files", nargs="+", type=Path,
                   help="one file per camera (ui-prmd-kinect: an episode's positions file, optionally followed by "
                        "its angles file, found by name otherwise; or one person's episodes' positions files, "
                        "joined into one recording)")
    p.add_argument("--out", required=True, type=Path, help="recording directory to write")
    add_choice(p, "--csv-topology", default="kinect_v2", path="fusion.topology.TOPOLOGIES", help="CSV joint set")
    add_choice(p, "--csv-unit", default="m", path="fusion.frames.LengthUnit", help="CSV length unit")
    add_choice(p, "--csv-axes", default="kinect_v2", path="fusion.camera.AxisConvention",
                   help="CSV camera axes: kinect_v2 (+x left, +y up) or opencv (+x right, +y down)")
    add_choice(p, "--csv-confidence", default="state_0_2", path="fusion.io.formats.csv_skeleton.ConfidenceScale",
                   help="CSV confidence scale")
    p.add_argument("--layout", default=None, metavar="NAME|TOML",
                   help="read CSVs through a layout mapping: azure_2cam, kimore, or a TOML file with a [layout] "
                        "table (replaces the --csv-* options)")
    p.add_argument("--names", nargs="+", default=None, metavar="NAME",
                   help="camera names, one per camera in the files' order (default: the file stems when they are "
                        "valid and unique, else cam1 .. camN); give every session of a rig the same names, so that "
                        "`evaluate --compare` can compare their calibrations")
    p.add_argument("--lab", default=None, metavar="NAME",
                   help="the lab the files come from (its sensors' set-up), kept with the recording: a sensor "
                        "population fitted on several labs draws people of a lab it knows from that lab "
                        "(default: the dataset's, for ui-prmd-kinect and a built-in --layout; else none)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_import)

    p = sub.add_parser("write", help="write a recording's skeletons as real body-tracker files")
    p.add_argument("format", choices=formats, metavar="FORMAT", help="file format; one of %(choices)s")
    p.add_argument("run", type=Path, help="run directory or recording directory")
    p.add_argument("--out", required=True, type=Path, help="directory for the files")
    p.set_defaults(func=_cmd_write)

    p = sub.add_parser("roundtrip", help="write a simulated session in each format, import it, compare calibrations")
    p.add_argument("scenario", nargs="?", default="fma_2cam", help="scenario (default fma_2cam)")
    p.add_argument("--out", required=True, type=Path, help="directory for roundtrip.md and roundtrip.json")
    p.add_argument("--formats", nargs="+", default=formats, choices=formats, metavar="FORMAT",
                   help="formats to write and import (default all); any of %(choices)s")
    p.add_argument("--camera-counts", nargs="+", type=int, default=[2, 3], metavar="N",
                   help="numbers of cameras of the simulated rigs, on the scenario's ring radius spread over the front (default 2 3)")
    p.add_argument("--duration", type=float, default=None, metavar="SECONDS", help="truncate the session")
    add_sweep_arguments(p)
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_roundtrip)
