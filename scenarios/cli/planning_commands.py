"""Commands of the layout planner: plan."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from scenarios.cli.choices import add_choice
from scenarios.cli.sweep_args import add_sweep_arguments, sweep_options


def _cmd_plan(args: argparse.Namespace) -> None:
    from tqdm import tqdm

    from scenarios.plan.evaluate_rigs import layouts_from_rigs
    from scenarios.plan.plan_report import report_markdown, write_plan
    from scenarios.plan.room import load_room
    from scenarios.plan.search import plan_layouts

    room = load_room(args.room)
    changes = {k: v for k, v in (("trials", args.trials), ("seeds", args.seeds), ("final_seeds", args.final_seeds))
               if v is not None}
    if changes:
        room = room.with_search(**changes)
    sensors = args.sensor or []
    if sensors:
        room = room.with_sensor(sensors[0])
    own = layouts_from_rigs(room, args.evaluate or [])
    with tqdm(desc=f"plan {room.room.name}", unit="step", leave=False) as bar:
        result = plan_layouts(room, evaluate=own, sensors=sensors[1:], ablation=not args.no_ablation,
                              sweep=sweep_options(args), progress=lambda m: (bar.set_postfix_str(m), bar.update(1)))
    files = write_plan(result, args.out, overwrite=args.overwrite)
    print(report_markdown(result))
    for warning in result.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    print(f"wrote {args.out} ({', '.join(files)})")


def register(sub: argparse._SubParsersAction) -> None:
    """Add the plan sub-command."""
    p = sub.add_parser("plan", help="plan where the cameras go in a room for a protocol (ranked layouts, install "
                                    "sheets, rig files); score your own layouts with --evaluate")
    p.add_argument("room", help="room TOML path or built-in name (exam_room, ring6_room)")
    p.add_argument("--out", required=True, type=Path,
                   help="directory for report.md, install.md, plan.json, PNGs, rig TOMLs")
    p.add_argument("--evaluate", nargs="+", type=Path, metavar="RIG.toml",
                   help="score these layouts (rig files as the plan writes them) beside the search's best; "
                        "with --trials 0 only these (and the room's references)")
    add_choice(p, "--sensor", path="scenarios.plan.room.BUILTIN_SENSORS", nargs="+", metavar="PROFILE",
               help="built-in sensor profile(s): the search uses the first (default: the room's [sensors] profile, "
                    "else the subject topology's, named in the report), the final layouts are also scored with "
                    "the others")
    p.add_argument("--trials", type=int, default=None, help="override search.trials (layouts proposed; 0: no search)")
    p.add_argument("--seeds", type=int, default=None, help="override search.seeds (sessions per searched layout)")
    p.add_argument("--final-seeds", type=int, default=None,
                   help="override search.final_seeds (sessions per final, reference, own and ablation layout)")
    p.add_argument("--no-ablation", action="store_true",
                   help="skip the ablation of the best layout (tracker noise off, depth noise off, other sensors)")
    add_sweep_arguments(p)
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_plan)
