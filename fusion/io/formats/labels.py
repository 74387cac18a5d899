"""Labels of a data set written inside exported skeleton files (:mod:`fusion.io.export`).

A label is a ``name -> text`` pair that describes the whole file (who, which group, which scores).
Names are lower-case identifiers; texts hold no tab, newline, comma or quote, so that every format
can carry them unescaped:

- C3D: one parameter per label in the :data:`LABEL_GROUP` parameter group, its value a one-string list;
- TRC: tab-separated ``name=text`` fields after the file name on the first line (``PathFileType``);
  OpenSim reads the file as usual (its ``DataRate`` line takes no extra columns);
- CSV: leading columns repeated on every row.
"""

from __future__ import annotations

import re
from collections.abc import Mapping

from fusion.errors import BadInputError

LABEL_GROUP = "MOCAP_BENCH"
"""The C3D parameter group that holds the labels."""

_NAME = re.compile(r"[a-z][a-z0-9_]{0,59}")
_BAD_TEXT = re.compile(r"[\t\r\n,\"']")


def check_labels(labels: Mapping[str, str] | None) -> dict[str, str]:
    """``labels`` as a plain dict (empty for None), each name and text checked.

    Raises
    ------
    BadInputError
        A name that is not a lower-case identifier of at most 60 characters, a text that is not a
        string or holds a tab, newline, comma or quote.
    """
    out = dict(labels or {})
    for name, text in out.items():
        if not isinstance(name, str) or not _NAME.fullmatch(name):
            raise BadInputError(f"label name {name!r} must be a lower-case identifier (a-z, 0-9, _), at most 60 characters")
        if not isinstance(text, str) or _BAD_TEXT.search(text):
            raise BadInputError(f"label {name}: {text!r} must be text without tabs, newlines, commas or quotes")
    return out
