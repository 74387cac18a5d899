"""Griffe extension: numpydoc items written ``name : what it is.`` read as descriptions, not types.

The docstrings follow numpydoc, and many short items put their description on the name line
(``max_gap_s : consecutive skeletons further apart than this [s] are not compared.``) where numpydoc
expects a type. Parsed as written, that sentence would show as the item's type. This extension,
run by mkdocstrings when it loads a package, moves such text into the item's description; real
types (``np.ndarray``, ``tuple of str``, ``mapping group -> float``, ``str or None``) stay types.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Iterator
from typing import Any

import griffe

_SECTIONS = {
    griffe.DocstringSectionKind.parameters, griffe.DocstringSectionKind.other_parameters,
    griffe.DocstringSectionKind.attributes, griffe.DocstringSectionKind.returns,
    griffe.DocstringSectionKind.yields, griffe.DocstringSectionKind.receives,
}
# Lower-case words that occur in the types the docstrings write.
_TYPE_WORDS = {
    "or", "of", "optional", "mapping", "sequence", "iterable", "tuple", "list", "dict", "set", "callable",
    "path", "like", "array", "array_like", "str", "int", "float", "bool", "none", "bytes", "np", "numpy",
    "ndarray", "int8", "uint8", "uint16", "float64", "int64", "mujoco", "group", "name", "names", "default",
    "generator", "random", "object", "objects", "any", "type", "function", "scalar", "arrays", "ints",
    "floats", "paths", "pathlib",
}


def _is_prose(text: str) -> bool:
    """Whether the text on the name line reads as a sentence rather than a type."""
    text = text.strip()
    if not text:
        return False
    if text.endswith((".", ";", ":", ",")) or "``" in text or "`" in text:
        return True
    words = re.findall(r"[A-Za-z_][A-Za-z_0-9]*", text)
    prose = [w for w in words if w.lower() not in _TYPE_WORDS and not w[0].isupper()]
    return len(prose) >= 2 or (len(prose) == 1 and "[" in text and "->" not in text and "]" in text
                                and not re.search(r"\w\[", text))


def _fix(sections: list[griffe.DocstringSection]) -> list[griffe.DocstringSection]:
    for section in sections:
        if section.kind not in _SECTIONS:
            continue
        for item in section.value:
            annotation = item.annotation
            if annotation is None or not isinstance(annotation, (str, griffe.Expr)):
                continue
            text = str(annotation)
            if not _is_prose(text):
                continue
            item.annotation = None
            item.description = f"{text} {item.description}".strip() if item.description else text
    return sections


class _Docstring(griffe.Docstring):
    """A docstring whose items are corrected when it is parsed (only the rendered ones are parsed, so
    griffe's warnings stay those of the pages)."""

    @functools.cached_property
    def parsed(self) -> list[griffe.DocstringSection]:
        return _fix(self.parse())


def _walk(obj: griffe.Object) -> Iterator[griffe.Object]:
    yield obj
    for member in obj.members.values():
        if not member.is_alias:
            yield from _walk(member)


class DocstringItems(griffe.Extension):
    """Move sentences written on an item's name line into its description."""

    def on_package(self, *, pkg: griffe.Module, **kwargs: Any) -> None:  # noqa: ARG002
        for obj in _walk(pkg):
            if obj.docstring is not None and type(obj.docstring) is griffe.Docstring:
                obj.docstring.__class__ = _Docstring
