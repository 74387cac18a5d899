"""Checks that a command's outputs may be written: existing outputs are kept unless ``--overwrite``."""

from __future__ import annotations

import os
from pathlib import Path

from fusion.errors import BadInputError


def check_output_dir(path: str | os.PathLike, *, overwrite: bool = False) -> Path:
    """``path`` as a directory that may be written: not a file, and empty or absent unless ``overwrite``.

    Raises
    ------
    BadInputError
        ``path`` is a file, or a non-empty directory while ``overwrite`` is False.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise BadInputError(f"{path} exists and is not a directory; give the path of a directory to write")
    if path.is_dir() and any(path.iterdir()) and not overwrite:
        raise BadInputError(f"{path} already exists and is not empty; choose another path or pass --overwrite")
    return path
