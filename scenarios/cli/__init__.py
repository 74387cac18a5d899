"""The ``mocap-bench`` command line: the only package that parses arguments.

Each module registers one group of sub-commands (``register(sub)``) whose handlers import the library
lazily, turn the parsed arguments into values and print what was written.

Conventions of every command: ``--version``; ``-v/--verbose`` (debug messages) and ``-q/--quiet``
(warnings and errors only, no progress bars) set up :mod:`logging` on stderr; ``TQDM_DISABLE=1`` also
hides the progress bars; the error prefix is red on a terminal unless ``NO_COLOR`` is set; errors in
the input end with exit status 2 and a message saying what to do; Ctrl-C ends with status 130 and
SIGTERM with 143, both after removing the command's temporary files and folders.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import logging
import os
import signal
import sys
import threading
from collections.abc import Iterator

from fusion.errors import BenchError
from scenarios.cli import (
    calibration_commands,
    clinical_commands,
    formats_commands,
    fusing_commands,
    hostile_commands,
    live_commands,
    patients_commands,
    planning_commands,
    replay_commands,
    sensors_commands,
    simulation_commands,
    studies_commands,
    view_commands,
)

GROUPS = (
    simulation_commands, calibration_commands, fusing_commands, formats_commands, clinical_commands,
    patients_commands, replay_commands, sensors_commands, planning_commands, live_commands, hostile_commands,
    studies_commands, view_commands,
)

log = logging.getLogger("mocap-bench")


class _Version(argparse.Action):
    """``--version``: print the version and exit (imported only when asked for)."""

    def __init__(self, option_strings: list[str], dest: str = argparse.SUPPRESS, **kwargs: object) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS,
                         help="print the version and exit")

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: object,
                 option_string: str | None = None) -> None:
        from scenarios.runner import VERSION

        print(f"mocap-bench {VERSION}")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of every sub-command."""
    parser = argparse.ArgumentParser(
        prog="mocap-bench",
        description="Simulation-backed test bench for marker-less multi-camera motion capture.",
    )
    parser.add_argument("--version", action=_Version)
    level = parser.add_mutually_exclusive_group()
    level.add_argument("-v", "--verbose", action="store_true", help="also print debug messages")
    level.add_argument("-q", "--quiet", action="store_true", help="only warnings and errors, no progress bars")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for group in GROUPS:
        group.register(sub)
    return parser


def commands(parser: argparse.ArgumentParser | None = None) -> dict[str, argparse.ArgumentParser]:
    """The parser of every sub-command by name, in the order of ``mocap-bench --help``."""
    parser = parser or build_parser()
    return dict(next(a for a in parser._actions if a.dest == "command").choices)  # noqa: SLF001


def _use_colour() -> bool:
    """Colour on a terminal unless ``NO_COLOR`` is set (https://no-color.org)."""
    return not os.environ.get("NO_COLOR") and sys.stderr.isatty()


def _setup_logging(verbose: bool, quiet: bool) -> None:
    """Messages of every ``mocap-bench`` and library logger on stderr, at the level the options ask for."""
    logging.basicConfig(format="%(levelname)s: %(message)s", stream=sys.stderr, force=True,
                        level=logging.DEBUG if verbose else logging.WARNING if quiet else logging.INFO)


@contextlib.contextmanager
def _progress_bars(hidden: bool) -> Iterator[None]:
    """Hide every progress bar of the block when ``hidden``: in this process (tqdm reads ``TQDM_*``
    variables once, at import) and in the processes it starts (through ``TQDM_DISABLE``)."""
    if not hidden:
        yield
        return
    import tqdm

    original, saved = tqdm.tqdm.__init__, os.environ.get("TQDM_DISABLE")
    tqdm.tqdm.__init__ = functools.partialmethod(original, disable=True)  # how tqdm applies TQDM_DISABLE itself
    os.environ["TQDM_DISABLE"] = "1"
    try:
        yield
    finally:
        tqdm.tqdm.__init__ = original
        if saved is None:
            os.environ.pop("TQDM_DISABLE", None)
        else:
            os.environ["TQDM_DISABLE"] = saved


class Terminated(BaseException):
    """SIGTERM, raised like Ctrl-C's KeyboardInterrupt so that temporary files and folders are cleaned up."""


@contextlib.contextmanager
def sigterm_raises() -> Iterator[None]:
    """While the block runs, SIGTERM raises :class:`Terminated` in the main thread (once: a second
    SIGTERM does not interrupt the clean-up); the previous handler is restored afterwards.

    Outside the main thread (where ``signal.signal`` is refused) the block runs unchanged. A process
    forked in the block that inherits the handler ends on SIGTERM as by default.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    pid = os.getpid()

    def _raise(signum: int, frame: object) -> None:
        if os.getpid() != pid:
            signal.signal(signal.SIGTERM, signal.SIG_DFL)
            os.kill(os.getpid(), signal.SIGTERM)
            return
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
        raise Terminated

    previous = signal.signal(signal.SIGTERM, _raise)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)


def _quiet_finalizers() -> None:
    """After an interruption, let finalizers of objects whose construction it cut short fail quietly.

    Ctrl-C or SIGTERM landing inside a library's constructor (numba's compiler building an llvmlite
    pass manager, say) leaves a half-built object whose ``__del__`` then raises when it is collected.
    Those errors are consequences of the interruption, not new ones: they go to the debug log instead
    of printing a traceback after "interrupted".
    """
    def hook(unraisable: sys.UnraisableHookArgs) -> None:
        log.debug("after the interruption, ignored %r in %r", unraisable.exc_value, unraisable.object)

    sys.unraisablehook = hook


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``mocap-bench`` console command; returns the exit status."""
    args = build_parser().parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)  # the command line, for reports that quote it
    _setup_logging(args.verbose, args.quiet)
    hidden = args.quiet or os.environ.get("TQDM_DISABLE", "").lower() in ("1", "true", "yes")
    log.debug("arguments: %s", vars(args))
    try:
        with sigterm_raises(), _progress_bars(hidden):
            args.func(args)
    except BenchError as exc:
        prefix = f"mocap-bench {args.command}: error:"
        print(f"\033[31m{prefix}\033[0m {exc}" if _use_colour() else f"{prefix} {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        _quiet_finalizers()
        print("interrupted", file=sys.stderr)
        return 130
    except Terminated:
        _quiet_finalizers()
        print("interrupted (SIGTERM)", file=sys.stderr)
        return 143
    return 0


if __name__ == "__main__":
    sys.exit(main())
