"""Results of the sensor check: one check, a section of checks, the whole check.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from fusion.errors import BadInputError
from scenarios.runner import VERSION

SECTION_TITLES: Mapping[str, str] = MappingProxyType({
    "projection": "Render-then-measure", "depth_noise": "Depth noise", "back_facing": "Back-facing",
    "occlusion": "Occlusion", "bone_lengths": "Bone lengths", "clocks": "Clocks",
})
"""Section key -> heading, in report order."""


@dataclass(frozen=True, eq=False)
class Check:
    """One measured number and the interval it must lie in.

    Attributes
    ----------
    case : str
        What was set up, e.g. ``"wall 2.5 m, 60 deg"``.
    quantity : str
        What was measured.
    unit : str
        Unit of ``measured``, ``expected``, ``low`` and ``high``.
    measured : float
        The measurement.
    expected : float or None
        The value the sensor facts predict; None when they predict only the interval.
    low, high : float
        Accepted interval, inclusive.
    tolerance : str
        How the interval follows from the expected value, e.g. ``"+-15 %"``.
    extra : Mapping[str, float]
        Further numbers of the measurement, name (with unit) -> value.
    """

    case: str
    quantity: str
    unit: str
    measured: float
    expected: float | None
    low: float
    high: float
    tolerance: str
    extra: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if not self.low <= self.high:
            raise BadInputError(f"check {self.case!r}: accepted interval [{self.low}, {self.high}] is empty")
        object.__setattr__(self, "extra", MappingProxyType({k: float(v) for k, v in self.extra.items()}))
        for name in ("measured", "low", "high"):
            object.__setattr__(self, name, float(getattr(self, name)))

    @property
    def passed(self) -> bool:
        """True when ``measured`` lies in ``[low, high]`` (NaN fails)."""
        return bool(self.low <= self.measured <= self.high)

    def to_dict(self) -> dict:
        """Plain-type dictionary for JSON."""
        d = {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self)}
        return d | {"extra": {k: _plain(v) for k, v in self.extra.items()}, "passed": self.passed}


def _plain(value: object) -> object:
    """``value`` for JSON: non-finite floats become None."""
    return None if isinstance(value, float) and not np.isfinite(value) else value


def around(case: str, quantity: str, unit: str, measured: float, expected: float, tol: float, tolerance: str, *,
            lowest: float = -np.inf, highest: float = np.inf, **extra: float) -> Check:
    """A check accepting ``expected +- tol``, clipped to the quantity's domain ``[lowest, highest]``."""
    return Check(case, quantity, unit, measured, expected, max(expected - tol, lowest), min(expected + tol, highest),
                 tolerance, extra)


def relative(case: str, quantity: str, unit: str, measured: float, expected: float, rel: float,
              **extra: float) -> Check:
    """A check accepting ``expected`` within a relative tolerance ``rel``."""
    return around(case, quantity, unit, measured, expected, rel * expected, f"+-{rel:.0%}", **extra)


@dataclass(frozen=True, eq=False)
class Section:
    """One part of the sensor check.

    Attributes
    ----------
    key : str
        One of :data:`SECTION_TITLES`; also the name of the section's figure, ``<key>.png``, if it has one.
    method : str
        Markdown: the set-up, and where the expected values and tolerances come from.
    checks : tuple of Check
    arrays : Mapping[str, np.ndarray]
        The data behind the section's figure.
    """

    key: str
    method: str
    checks: tuple[Check, ...]
    arrays: Mapping[str, np.ndarray] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.key not in SECTION_TITLES:
            raise BadInputError(f"unknown section {self.key!r}; the sections are {list(SECTION_TITLES)}")

    @property
    def title(self) -> str:
        """Heading."""
        return SECTION_TITLES[self.key]

    @property
    def passed(self) -> bool:
        """True when every check passed."""
        return all(c.passed for c in self.checks)


@dataclass(frozen=True, eq=False)
class SensorCheck:
    """The result of :func:`run_sensor_check`: the seed and the sections in order."""

    seed: int
    sections: tuple[Section, ...]

    @property
    def checks(self) -> tuple[Check, ...]:
        """Every check of every section."""
        return tuple(c for s in self.sections for c in s.checks)

    @property
    def passed(self) -> bool:
        """True when every check passed."""
        return all(s.passed for s in self.sections)

    def to_dict(self) -> dict:
        """Plain-type dictionary for JSON (the figures' arrays are left out)."""
        return {
            "format": "mocap-bench-sensor-check", "version": VERSION, "seed": self.seed, "passed": self.passed,
            "sections": [{"key": s.key, "title": s.title, "passed": s.passed,
                          "checks": [c.to_dict() for c in s.checks]} for s in self.sections],
        }
