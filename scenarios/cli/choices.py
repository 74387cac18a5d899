"""Choices of the command-line options, taken from the library's Enums: one spelling everywhere."""

from __future__ import annotations

import enum


def values(kind: type[enum.Enum], *members: enum.Enum) -> list[str]:
    """The values of ``members`` of ``kind`` (default: all of them), as argparse ``choices``."""
    return [m.value for m in (members or kind)]
