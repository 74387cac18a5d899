"""The hostile suite: bad inputs through every reader and command, each outcome classified and counted.

Each case builds its inputs in a directory of its own (from a small simulated base session), runs one
``mocap-bench`` command in this process (through the command runner it is given, the CLI's ``main``) and says what a correct outcome is: a clear error (exit
status 2 with a message) or a correct result (exit status 0 and a check of the output against what
the case knows to be true). The outcome is one of :class:`Outcome`; the targets are no traceback,
no hang and no silent wrong result. The cases are in :mod:`scenarios.hostile.reader_cases` (base session, readers,
recordings) and :mod:`scenarios.hostile.command_cases` (commands, exports).

Command: ``mocap-bench hostile --out REPORT.md [--quick] [--mutants N] [--seed N]``.
"""

from __future__ import annotations

import contextlib
import enum
import io
import signal
import traceback
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fusion.errors import BadInputError


class Expect(enum.Enum):
    """What a correct program does with a case's input."""

    ERROR = "error"
    """Refuse it: exit status 2 and a message."""
    RESULT = "result"
    """Accept it: exit status 0 and output that passes the case's check."""
    EITHER = "either"
    """A randomly damaged file: a clear error, or a result (that is then checked)."""


class Outcome(enum.Enum):
    """What happened."""

    CLEAR_ERROR = "clear error"
    CORRECT = "correct result"
    TRACEBACK = "traceback"
    HANG = "hang"
    SILENT_WRONG = "silent wrong result"
    WRONG_REFUSAL = "refused a good input"


GOOD = (Outcome.CLEAR_ERROR, Outcome.CORRECT)


@dataclass(frozen=True)
class Case:
    """One hostile input.

    Attributes
    ----------
    name : str
        Short description.
    group : str
        Which reader or command it attacks.
    build : callable
        ``build(directory) -> (argv, check)``: writes the inputs, returns the command line and, for
        accepted input, ``check(directory) -> None`` or the reason the output is wrong.
    expect : Expect
        The correct outcome.
    quick : bool
        Part of the quick subset (no calibration or fusion of a whole session).
    """

    name: str
    group: str
    build: Callable[[Path], tuple[list[str], Callable[[Path], str | None] | None]]
    expect: Expect
    quick: bool = True


@dataclass(frozen=True)
class CaseResult:
    """The outcome of one case, with the exit status and the last line of its message."""

    case: Case
    outcome: Outcome
    status: int | None
    message: str


class _Timeout(Exception):
    pass


def _alarm(signum: int, frame: object) -> None:
    raise _Timeout


Command = Callable[[list[str]], int]
"""Runs one command line (arguments without the program name) and returns its exit status."""


def run_case(case: Case, directory: Path, main: Command, *, timeout_s: float) -> CaseResult:
    """Build and run one case in this process with ``main``; a run longer than ``timeout_s`` counts as a hang."""
    directory.mkdir(parents=True, exist_ok=True)
    err = io.StringIO()
    status: int | None = None
    previous = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout_s)
    try:
        argv, check = case.build(directory)
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
            try:
                status = main(argv)
            except SystemExit as exc:  # argparse usage errors
                status = exc.code if isinstance(exc.code, int) else 2
        signal.setitimer(signal.ITIMER_REAL, 0)
        message = err.getvalue().strip().splitlines()[-1] if err.getvalue().strip() else ""
        if status == 0:
            reason = check(directory) if check is not None else None
            if case.expect is Expect.ERROR or reason is not None:
                return CaseResult(case, Outcome.SILENT_WRONG, status, reason or "accepted an input it must refuse")
            return CaseResult(case, Outcome.CORRECT, status, "")
        if status == 2 and message:
            outcome = Outcome.WRONG_REFUSAL if case.expect is Expect.RESULT else Outcome.CLEAR_ERROR
            return CaseResult(case, outcome, status, message)
        return CaseResult(case, Outcome.TRACEBACK, status, message or f"exit status {status} without a message")
    except _Timeout:
        return CaseResult(case, Outcome.HANG, status, f"no answer within {timeout_s:g} s")
    except Exception as exc:  # noqa: BLE001 - a traceback is the outcome being counted
        frames = traceback.extract_tb(exc.__traceback__)
        where = f" at {Path(frames[-1].filename).name}:{frames[-1].lineno}" if frames else ""
        return CaseResult(case, Outcome.TRACEBACK, status, f"{type(exc).__name__}: {exc}{where}"[:300])
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def run_suite(cases: Sequence[Case], work: Path, main: Command, *, timeout_s: float = 120.0,
              progress: Callable[[CaseResult], None] | None = None) -> list[CaseResult]:
    """Run every case with ``main`` in its own directory under ``work``; returns the results in case order."""
    if not cases:
        raise BadInputError("no hostile cases to run")
    if not (np.isfinite(timeout_s) and timeout_s > 0):
        raise BadInputError(f"timeout_s must be positive, got {timeout_s}")
    results = []
    for i, case in enumerate(cases):
        result = run_case(case, Path(work) / f"case{i:03d}", main, timeout_s=timeout_s)
        results.append(result)
        if progress is not None:
            progress(result)
    return results


def counts(results: Sequence[CaseResult]) -> dict[str, int]:
    """Number of results per outcome (every outcome listed, zeros included)."""
    c = Counter(r.outcome for r in results)
    return {o.value: c[o] for o in Outcome}


def report_markdown(results: Sequence[CaseResult]) -> str:
    """The counts per outcome and per group, then every case with its outcome and message."""
    lines = ["# Hostile inputs", "", f"{len(results)} cases.", "", "| outcome | cases |", "| --- | ---: |"]
    lines += [f"| {k} | {v} |" for k, v in counts(results).items()]
    groups = sorted({r.case.group for r in results})
    lines += ["", "| group | cases | clear error | correct result | other |", "| --- | ---: | ---: | ---: | ---: |"]
    for g in groups:
        rs = [r for r in results if r.case.group == g]
        n_err = sum(r.outcome is Outcome.CLEAR_ERROR for r in rs)
        n_ok = sum(r.outcome is Outcome.CORRECT for r in rs)
        lines.append(f"| {g} | {len(rs)} | {n_err} | {n_ok} | {len(rs) - n_err - n_ok} |")
    lines += ["", "| group | case | outcome | message |", "| --- | --- | --- | --- |"]
    for r in results:
        msg = r.message.replace("|", "\\|").replace("\n", " ")[:240]
        lines.append(f"| {r.case.group} | {r.case.name} | {r.outcome.value} | {msg} |")
    return "\n".join(lines) + "\n"
