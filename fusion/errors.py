"""Exception hierarchy shared by every package of mocap-bench."""

from __future__ import annotations

from collections.abc import Iterable


class BenchError(Exception):
    """Base class of every error mocap-bench raises on purpose."""


class BadInputError(BenchError, ValueError):
    """An argument has the wrong shape, type, unit or value."""


class RecordingError(BadInputError):
    """A recording on disk is missing, truncated, corrupt or of an unknown version (bad input read from disk)."""


class ScenarioError(BenchError):
    """A scenario file is malformed or names an unknown key or value."""


class CalibrationError(BenchError):
    """The data cannot determine a camera pose (static person, no overlap, ...)."""


class StaticPersonError(CalibrationError):
    """The person hardly moves in a camera's view: the body gives a calibration nothing to work with."""


class UnknownNameError(BenchError, KeyError):
    """A joint, camera or coordinate name that does not exist.

    The message lists the names that do exist.
    """

    def __init__(self, kind: str, name: str, available: Iterable[str]):
        self.kind = kind
        self.name = name
        self.available = tuple(available)
        super().__init__(
            f"unknown {kind} {name!r}; available: {', '.join(self.available)}"
        )

    def __str__(self) -> str:  # KeyError would quote the whole message
        return self.args[0]
