"""Commands of the 3D viewer: view."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from scenarios.cli.choices import add_choice


def _cmd_view(args: argparse.Namespace) -> None:
    from fusion.errors import BadInputError
    from fusion.io.calibration_file import load_calibration
    from scenarios.interop.rerun_view import Viewer, ViewOptions, view

    if args.save is not None and args.viewer is not None:
        raise BadInputError("--viewer chooses where to show the data when it is not saved; drop --viewer or --save")
    calibration = None if args.calib is None else load_calibration(args.calib)
    viewer = Viewer.NATIVE if args.viewer is None else Viewer(args.viewer)
    result = view(args.path, save=args.save, overwrite=args.overwrite, calibration=calibration, viewer=viewer,
                  options=ViewOptions(depth_points=args.depth_points, depth_interval_s=args.depth_interval))
    print(f"{result.kind.value} {args.path}: cameras from {result.poses}; {result.frames} frames, "
          f"{len(result.entities)} entities")
    for note in result.notes:
        print(f"note: {note}")
    if result.saved is not None:
        print(f"wrote {result.saved} (open it with `rerun {result.saved}`)")
    elif viewer is Viewer.WEB:
        print("serving the web viewer on this machine; press Ctrl-C to stop", flush=True)
        while True:
            time.sleep(3600)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the view sub-command."""
    p = sub.add_parser("view", help="show a run, recording, fused output or plan in the Rerun 3D viewer "
                                    "(needs pip install 'mocap-bench[view]')")
    p.add_argument("path", type=Path,
                   help="run directory (simulate), recording (import), fused output (fuse) or plan output (plan)")
    p.add_argument("--save", type=Path, default=None, metavar="FILE.rrd",
                   help="write a Rerun file instead of opening the viewer (open it later with `rerun FILE.rrd`)")
    p.add_argument("--calib", type=Path, default=None,
                   help="calibration TOML: draw the cameras where it puts them and fuse their skeletons "
                        "(default: the true poses of a simulated run; else each camera at the origin)")
    add_choice(p, "--viewer", path="scenarios.interop.rerun_view.Viewer", default=None,
               help="without --save: the desktop viewer (default native) or the web viewer in a browser")
    p.add_argument("--depth-points", type=int, default=5000, metavar="N", help="most points per depth cloud")
    p.add_argument("--depth-interval", type=float, default=0.5, metavar="SECONDS",
                   help="least time between two depth clouds of one camera (default 0.5)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing --save file")
    p.set_defaults(func=_cmd_view)
