"""MkDocs hook: the Python API pages list every module of their package, found at build time.

An API page holds marker lines such as ``<!-- api: fusion.calibrate first: pipeline, options -->``;
this hook replaces each with mkdocstrings directives (``::: module``): the package's own docstring,
then every module and sub-package in it, recursively, the ones named after ``first:`` leading in
that order and the rest alphabetically. ``flat`` after the package name keeps to the modules
directly in it (no sub-packages). A module added or renamed in the code is picked up without
editing the page.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
MARKER = re.compile(r"^<!-- api: (?P<package>[\w.]+)(?P<flat> flat)?(?: first: (?P<first>[\w., ]+))? -->$",
                    re.MULTILINE)


def _members(package: str, flat: bool) -> list[tuple[str, bool]]:
    """``(dotted name, is a package)`` of what is in ``package``, sorted by name."""
    folder = ROOT.joinpath(*package.split("."))
    out = []
    for path in sorted(folder.iterdir()):
        if path.suffix == ".py" and path.stem not in ("__init__", "__main__"):
            out.append((f"{package}.{path.stem}", False))
        elif not flat and path.is_dir() and (path / "__init__.py").is_file():
            out.append((f"{package}.{path.name}", True))
    return out


def _directives(package: str, flat: bool, first: list[str]) -> list[str]:
    lines = [f"::: {package}", "    options:", "      members: false", ""]
    members = _members(package, flat)
    rank = {name: i for i, name in enumerate(first)}
    members.sort(key=lambda m: (rank.get(m[0].rsplit(".", 1)[1], len(rank)), m[0]))
    for name, is_package in members:
        if is_package:
            lines += _directives(name, False, [])
        else:
            lines += [f"::: {name}", ""]
    return lines


def _expand(match: re.Match[str]) -> str:
    package = match["package"]
    if not ROOT.joinpath(*package.split("."), "__init__.py").is_file():
        raise ValueError(f"API marker names {package!r}, which is not a package of this repository")
    first = [n.strip() for n in (match["first"] or "").split(",") if n.strip()]
    return "\n".join(_directives(package, bool(match["flat"]), first))


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ANN001, ARG001
    """Replace every API marker of the page with the directives of its package."""
    return MARKER.sub(_expand, markdown)
