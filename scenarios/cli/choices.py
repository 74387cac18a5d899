"""Choices of the command-line options, taken from the library's Enums (one spelling everywhere) and
imported only when they are needed: showing a command's help or checking a value. Building the parser
imports no library, so ``mocap-bench --help`` and every command start fast."""

from __future__ import annotations

import argparse
import enum
import importlib
from collections.abc import Sequence


class LazyChoices(Sequence[str]):
    """The values of an Enum's members (or a mapping's keys), loaded on first use.

    Parameters
    ----------
    path : dotted path of the Enum class or mapping, e.g. ``"fusion.merge.fuse.Fit"``.
    members : member names to keep (default all), in their Enum order.
    where : name of a boolean property a member must have to be kept.
    """

    def __init__(self, path: str, *members: str, where: str | None = None) -> None:
        self._path, self._members, self._where = path, members, where
        self._values: list[str] | None = None

    def _load(self) -> list[str]:
        if self._values is None:
            module, _, name = self._path.rpartition(".")
            kind = getattr(importlib.import_module(module), name)
            if isinstance(kind, type) and issubclass(kind, enum.Enum):
                items = [kind[m] for m in self._members] if self._members else list(kind)
                if self._where is not None:
                    items = [m for m in items if getattr(m, self._where)]
                self._values = [m.value for m in items]
            else:
                self._values = [k for k in kind if not self._members or k in self._members]
        return self._values

    def __getitem__(self, index):  # noqa: ANN001, ANN204 - Sequence protocol
        return self._load()[index]

    def __len__(self) -> int:
        return len(self._load())

    def __contains__(self, value: object) -> bool:
        return value in self._load()

    def __repr__(self) -> str:
        return f"LazyChoices({self._path!r})"


def add_choice(parser: argparse.ArgumentParser, *flags: str, path: str, help: str, members: Sequence[str] = (),
               where: str | None = None, metavar: str | None = None, **kwargs: object) -> None:
    """Add an option (or positional) whose choices are the values at ``path`` (see :class:`LazyChoices`),
    listed in its help when the help is shown."""
    name = flags[0].lstrip("-").replace("-", "_").upper()
    parser.add_argument(*flags, choices=LazyChoices(path, *members, where=where), metavar=metavar or name,
                        help=f"{help}; one of %(choices)s", **kwargs)
