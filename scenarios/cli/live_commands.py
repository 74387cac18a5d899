"""Commands of live fusion: serve, stream, listen, live-load."""

from __future__ import annotations

import argparse
import contextlib
import json
import signal
import sys
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING

from scenarios.cli.choices import add_choice
from scenarios.cli.outputs import check_output_dir

if TYPE_CHECKING:  # the library is imported when a command runs
    from fusion.live.lsl_outlet import LslOptions


@contextlib.contextmanager
def _stop_on_signals() -> Iterator[threading.Event]:
    """An event set by SIGINT or SIGTERM (graceful shutdown) while the block runs."""
    stop = threading.Event()
    previous = {sig: signal.signal(sig, lambda *_: stop.set()) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield stop
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _cmd_serve(args: argparse.Namespace) -> None:
    import numpy as np
    from tqdm import tqdm

    from fusion.io.calibration_file import load_calibration
    from fusion.live.engine import MAX_CLOCK_STEP_S, EngineOptions
    from fusion.live.protocol import Endpoint
    from fusion.live.server import FusionServer, ServerConfig
    from fusion.merge.filters import TemporalFilter
    from fusion.merge.fuse import FuseOptions
    from fusion.merge.methods import MergeMethod
    from scenarios.live import write_stream

    fuse = FuseOptions(method=MergeMethod(args.method), relabel_back_facing=not args.no_relabel,
                       temporal=TemporalFilter(args.filter))
    engine = EngineOptions(fuse=fuse, deadline_s=args.deadline_ms / 1e3, silent_after_s=args.silent_after,
                           max_held=args.max_held)
    config = ServerConfig(Endpoint.parse(args.listen), token=args.token, queue_size=args.queue,
                          keep_frames=args.out is not None, lsl=_lsl_options(args))
    calibration = None if args.calib is None else load_calibration(args.calib)
    if args.out is not None:
        check_output_dir(args.out, overwrite=args.overwrite)
    autocal = None
    if calibration is None:
        from fusion.live.autocal import AutoCalibrationOptions

        autocal = AutoCalibrationOptions(every_s=args.calibrate_every)
    server = FusionServer(config, engine, calibration, autocal, rng=np.random.default_rng(args.seed))
    endpoint = config.endpoint
    if not args.quiet:
        lsl = server.status().get("lsl")
        print(f"serving on {endpoint.frames_url()} (frames) and {endpoint.publish_url()} (fused, status)"
              + ("" if lsl is None else f" and as LSL stream {lsl['name']!r} (source id {lsl['source_id']})")
              + f"; calibration: {args.calib or 'from the body'}; Ctrl-C stops", flush=True)
    with _stop_on_signals() as stop, tqdm(desc="fused", unit="frame", disable=args.quiet, leave=False) as bar:
        while not stop.wait(0.2):
            status = server.status()
            bar.update(status["counts"]["fused"] - bar.n)
            if args.exit_when_done and server.done():
                break
        result = server.stop()
    s = result.status
    if not args.quiet:
        print(json.dumps({k: s[k] for k in ("counts", "latency_ms", "clock_steps_s", "cpu_s", "max_rss_mb")}))
    engine = s.get("engine", {})
    if engine.get("unknown_cameras"):
        print(f"warning: {engine['unknown_camera']} frames from camera(s) the calibration does not know were not "
              f"fused ({', '.join(f'{n}: {k}' for n, k in engine['unknown_cameras'].items())}; calibrated: "
              f"{', '.join(s.get('cameras', {}))}); name the clients' cameras as in the calibration",
              file=sys.stderr)
    for key, what in (("wrong_topology", "of another joint set than the session's"),
                      ("units", "whose positions are not a person's in metres (bone lengths or distance)"),
                      ("clock", f"whose timestamps lay more than {MAX_CLOCK_STEP_S:g} s from their camera's clock "
                                "(stray, or not seconds)")):
        if engine.get(key):
            print(f"warning: {engine[key]} frames {what} were not fused", file=sys.stderr)
    forgotten = {n: c["forgotten"] for n, c in s.get("cameras", {}).items() if c.get("forgotten")}
    if forgotten:
        print(f"warning: frames forgotten beyond --max-held {args.max_held} ("
              + ", ".join(f"{n}: {k}" for n, k in forgotten.items())
              + "); those cameras ran ahead of the reference, so some instants lacked them; raise --max-held",
              file=sys.stderr)
    if args.out is not None:
        if result.frames:
            write_stream(args.out, result.frames, result.topology, s, {"method": args.method, "temporal_filter": args.filter},
                         overwrite=args.overwrite)
            print(f"wrote {args.out} (recording/, status.json)")
        else:
            print(f"nothing fused; {args.out} not written")


def _lsl_options(args: argparse.Namespace) -> LslOptions | None:
    """The LSL outlet's options of ``serve`` (None without ``--lsl``)."""
    from fusion.errors import BadInputError

    if args.lsl is None:
        if args.lsl_joints is not None or args.lsl_rate is not None:
            raise BadInputError("--lsl-joints and --lsl-rate describe the LSL stream: name it with --lsl NAME")
        return None
    from fusion.live.lsl_outlet import LslOptions
    from fusion.topology import topology_by_name

    given = {"topology": None if args.lsl_joints is None else topology_by_name(args.lsl_joints),
             "rate_hz": args.lsl_rate}
    return LslOptions(args.lsl, **{k: v for k, v in given.items() if v is not None})


def _cmd_stream(args: argparse.Namespace) -> None:
    from tqdm import tqdm

    from fusion.io.recording_files import load_recording
    from fusion.live.client import replay
    from fusion.live.protocol import Endpoint
    from scenarios.runner import recording_dir

    recording = load_recording(recording_dir(args.recording))
    total = sum(c.skeleton.n_frames for c in recording.cameras if c.skeleton is not None)
    with _stop_on_signals() as stop, tqdm(total=total, desc="stream", unit="frame", leave=False) as bar:
        result = replay(recording, Endpoint.parse(args.to), speed=args.speed, token=args.token, progress=bar.update,
                        stop=stop)
    unsent = sum(result.unsent.values())
    if unsent:
        from fusion.errors import BadInputError

        raise BadInputError(f"the server at {args.to} did not take {unsent} frames (camera(s) "
                            f"{', '.join(n for n, k in result.unsent.items() if k)}; "
                            f"{sum(result.sent.values())} sent); is a server listening there, with the same --token?")
    print(f"streamed {sum(result.sent.values())} frames from {len(result.sent)} cameras in {result.wall_s:.1f} s")


def _cmd_listen(args: argparse.Namespace) -> None:
    import numpy as np
    from tqdm import tqdm

    from fusion.errors import BadInputError
    from fusion.live.client import Subscriber, collect
    from fusion.live.protocol import Endpoint
    from scenarios.live import write_stream

    check_output_dir(args.out, overwrite=args.overwrite)
    if not (np.isfinite(args.timeout) and args.timeout > 0):
        raise BadInputError(f"--timeout must be a positive number of seconds, got {args.timeout}")
    subscriber = Subscriber(Endpoint.parse(args.address), token=args.token)
    print(f"listening to {Endpoint.parse(args.address).publish_url()}", flush=True)
    with _stop_on_signals() as stop, tqdm(desc="received", unit="frame", leave=False) as bar:
        collected = collect(subscriber, idle_timeout_s=args.timeout, max_frames=args.frames, stop=stop,
                            progress=bar.update)
    subscriber.close()
    if not collected.frames:
        raise BadInputError(f"no fused frame arrived from {args.address} within {args.timeout} s")
    write_stream(args.out, collected.frames, collected.topology, collected.status,
                 {"server": args.address, "ended": collected.ended}, overwrite=args.overwrite)
    print(f"{len(collected.frames)} fused frames ({'server ended' if collected.ended else 'stopped'}); "
          f"wrote {args.out} (recording/, status.json)")


def _cmd_live_load(args: argparse.Namespace) -> None:
    from fusion.io.atomic import write_text_atomic
    from scenarios.live import load_test, load_test_session

    recording, calibration = load_test_session(args.scenario, args.duration, args.stream_s)
    report = load_test(recording, calibration, speed=args.speed, deadline_ms=args.deadline_ms, queue_size=args.queue)
    summary = {k: v for k, v in report.items() if k != "status"}
    print(json.dumps(summary, indent=1))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(args.out, json.dumps(report, indent=1, sort_keys=True) + "\n")
    print(f"wrote {args.out}")


def register(sub: argparse._SubParsersAction) -> None:
    """Add the serve, stream, listen, live-load sub-commands."""
    p = sub.add_parser("serve", help="live fusion server: camera clients in, fused frames and status out")
    p.add_argument("--calib", type=Path, default=None, help="calibration TOML (default: calibrate from the body)")
    p.add_argument("--listen", default="127.0.0.1:5570", metavar="HOST:PORT",
                   help="frame port; PORT+1 publishes (default 127.0.0.1:5570, loopback)")
    p.add_argument("--token", default=None, help="shared token clients must present (required beyond loopback)")
    add_choice(p, "--method", default="avg_frontal", path="fusion.merge.methods.MergeMethod", help="merging method (default avg_frontal)")
    add_choice(p, "--filter", default="one_euro",
                   path="fusion.merge.filters.TemporalFilter", members=("NONE", "ONE_EURO"), help="causal temporal filter")
    p.add_argument("--no-relabel", action="store_true", help="keep back-facing skeletons' labels as reported")
    p.add_argument("--deadline-ms", type=float, default=100.0,
                   help="merge an instant this long after its reference frame even if cameras are missing "
                        "(inf: wait for all)")
    p.add_argument("--silent-after", type=float, default=1.0, metavar="SECONDS",
                   help="a camera without frames this long is silent and not waited for")
    p.add_argument("--queue", type=int, default=4096, help="bound of the receive queue [messages]")
    p.add_argument("--max-held", type=int, default=300, metavar="FRAMES",
                   help="frames held per camera; a camera further ahead of the reference loses its oldest "
                        "(counted as forgotten in the status)")
    p.add_argument("--calibrate-every", type=float, default=10.0, metavar="SECONDS",
                   help="stream time between calibrations from the body (without --calib)")
    p.add_argument("--seed", type=int, default=0, help="seed of the calibration from the body")
    p.add_argument("--out", type=Path, default=None, help="on shutdown write the fused stream here (atomically)")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty --out directory")
    p.add_argument("--exit-when-done", action="store_true", help="stop once every calibrated camera said bye")
    p.add_argument("--lsl", default=None, metavar="NAME",
                   help="also publish the fused skeleton as a Lab Streaming Layer stream of this name (type MoCap; "
                        "needs pip install 'mocap-bench[lsl]')")
    add_choice(p, "--lsl-joints", default=None, path="fusion.topology.TOPOLOGIES", members=("kinect_v2", "k4abt"),
               help="joint set of the LSL stream, i.e. of the cameras (default kinect_v2)")
    p.add_argument("--lsl-rate", type=float, default=None, metavar="HZ",
                   help="nominal rate of the LSL stream: the cameras' frame rate (default 30)")
    p.add_argument("--quiet", action="store_true", help="no progress bar or summary")
    p.set_defaults(func=_cmd_serve)

    p = sub.add_parser("stream", help="replay a recording as one live client per camera")
    p.add_argument("recording", type=Path, help="run directory or recording directory")
    p.add_argument("--to", required=True, metavar="HOST:PORT", help="the server's frame port")
    p.add_argument("--speed", type=float, default=1.0, help="replay speed (1 real time, 0 as fast as possible)")
    p.add_argument("--token", default=None, help="shared token of the server")
    p.set_defaults(func=_cmd_stream)

    p = sub.add_parser("listen", help="write a server's fused stream as a recording")
    p.add_argument("address", metavar="HOST:PORT", help="the server's frame port (PORT+1 is subscribed)")
    p.add_argument("--out", required=True, type=Path, help="output directory (recording/, status.json)")
    p.add_argument("--timeout", type=float, default=10.0, metavar="SECONDS", help="stop after this long without a message")
    p.add_argument("--frames", type=int, default=None, help="stop after this many fused frames")
    p.add_argument("--token", default=None, help="shared token of the server")
    p.add_argument("--overwrite", action="store_true", help="replace an existing non-empty output directory")
    p.set_defaults(func=_cmd_listen)

    p = sub.add_parser("live-load", help="loopback load test: serve, one client per camera, listen; latency and losses")
    p.add_argument("scenario", nargs="?", default="ring6", help="scenario simulated once and looped (default ring6)")
    p.add_argument("--duration", type=float, default=40.0, metavar="SECONDS", help="simulated session length")
    p.add_argument("--stream-s", type=float, default=600.0, help="stream time [s] (the session looped)")
    p.add_argument("--speed", type=float, default=1.0, help="replay speed (1 real time)")
    p.add_argument("--deadline-ms", type=float, default=100.0, help="the server's deadline")
    p.add_argument("--queue", type=int, default=4096, help="the server's queue bound")
    p.add_argument("--out", required=True, type=Path, help="report JSON")
    p.set_defaults(func=_cmd_live_load)
