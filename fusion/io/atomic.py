"""Atomic file and directory writes: a reader sees the old content or the new, never a mix.

An operating-system error a user can act on (no space, no permission, read-only file system, quota)
becomes a :class:`~fusion.errors.BadInputError` naming the target and what to do; the temporary file
or folder is removed and an existing target is left untouched.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

from fusion.errors import BadInputError

_FREE = "free some space or choose a folder on another disk"
_WRITABLE = "choose a writable folder"
_CAUSES = {  # errno -> (cause in words, what to do)
    errno.ENOSPC: ("no space left on the device", _FREE),
    errno.EROFS: ("the file system is read-only", _WRITABLE),
    errno.EACCES: ("permission denied", _WRITABLE),
    errno.EPERM: ("operation not permitted", _WRITABLE),
}
if hasattr(errno, "EDQUOT"):
    _CAUSES[errno.EDQUOT] = ("the disk quota is exceeded", _FREE)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_error(path: str | os.PathLike, exc: OSError) -> BadInputError | None:
    """The :class:`BadInputError` saying why ``path`` cannot be written, or None for another ``exc``."""
    if exc.errno not in _CAUSES:
        return None
    cause, remedy = _CAUSES[exc.errno]
    return BadInputError(f"cannot write {path}: {cause}; {remedy}")


@contextlib.contextmanager
def _write_errors(path: Path, inside: Path | None = None) -> Iterator[None]:
    """Raise the OSErrors of :func:`write_error` in the block as BadInputError about ``path``.

    With ``inside``, permission errors count only for files under ``inside`` (or none named), so
    that an unreadable input is not reported as an unwritable output.
    """
    try:
        yield
    except OSError as exc:
        err = write_error(path, exc)
        if err is None:
            raise
        name = exc.filename
        if inside is not None and exc.errno in (errno.EACCES, errno.EPERM) and isinstance(name, (str, bytes)):
            if not Path(os.path.abspath(os.fsdecode(name))).is_relative_to(os.path.abspath(inside)):
                raise
        raise err from exc


def write_bytes_atomic(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary sibling file and an atomic rename.

    Raises
    ------
    BadInputError
        No space, no permission or a read-only file system; ``path`` is untouched.
    """
    path = Path(path)
    with _write_errors(path):
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        try:
            try:
                view = memoryview(data)
                while view:
                    view = view[os.write(fd, view):]
                os.fsync(fd)
            finally:
                os.close(fd)
            os.chmod(tmp, 0o666 & ~_umask())  # mkstemp creates owner-only files
            os.replace(tmp, path)
        except BaseException:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
            raise


def write_text_atomic(path: str | os.PathLike, text: str) -> None:
    """Write UTF-8 ``text`` to ``path`` atomically (see :func:`write_bytes_atomic`)."""
    write_bytes_atomic(path, text.encode("utf-8"))


def write_file_atomic(path: str | os.PathLike, write: Callable[[str], object], *,
                      check: Callable[[Path], None] | None = None) -> None:
    """Let ``write(tmp)`` create a file in a hidden sibling temporary folder, then rename it onto ``path``.

    For writers that take a file name (ezc3d, ...). ``check(tmp)``, if given, verifies the written file
    before the rename and raises :class:`BadInputError` if it is incomplete.

    Raises
    ------
    BadInputError
        ``write`` created no file, ``check`` failed, or no space / no permission / a read-only file
        system; the temporary folder is removed and ``path`` is untouched.
    """
    path = Path(path)
    with _write_errors(path):
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp_dir = tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
        try:
            tmp = Path(tmp_dir) / path.name
            write(str(tmp))
            if not tmp.is_file():
                raise BadInputError(f"cannot write {path}: no file was written; {_FREE}, or {_WRITABLE}")
            if check is not None:
                check(tmp)
            os.replace(tmp, path)
        finally:
            shutil.rmtree(tmp_dir, ignore_errors=True)


@contextlib.contextmanager
def atomic_directory(path: str | os.PathLike, *, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary directory that replaces ``path`` when the block succeeds.

    On an exception (SIGTERM included, when the command line turns it into one) the temporary
    directory is removed and ``path`` is untouched.

    Raises
    ------
    BadInputError
        ``path`` exists, is not empty and ``overwrite`` is False, or is a file; or writing failed for
        lack of space or permission, or on a read-only file system.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise BadInputError(f"{path} exists and is not a directory")
    if path.exists() and any(path.iterdir()) and not overwrite:
        raise BadInputError(f"{path} already exists and is not empty; choose another path or allow overwriting")
    with _write_errors(path):
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp"))
    old = None
    try:
        with _write_errors(path, inside=tmp):
            yield tmp
            os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp creates an owner-only directory
            if path.exists():
                old = Path(tempfile.mkdtemp(dir=path.parent, prefix=f".{path.name}.", suffix=".old"))
                os.replace(path, old / "content")
            try:
                os.replace(tmp, path)
            except BaseException:
                if old is not None:
                    os.replace(old / "content", path)
                raise
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    finally:
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)


def check_output_file(path: str | os.PathLike, *, overwrite: bool = False) -> Path:
    """``path`` as a file that may be written: not a directory, and not existing unless ``overwrite``.

    Raises
    ------
    BadInputError
        ``path`` is a directory, or an existing file while ``overwrite`` is False.
    """
    path = Path(path)
    if path.is_dir():
        raise BadInputError(f"{path} is a directory; give the path of a file to write")
    if path.exists() and not overwrite:
        raise BadInputError(f"{path} already exists; choose another path or pass --overwrite")
    return path
