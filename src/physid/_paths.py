"""Where physid keeps files between runs, and how it writes them (atomically)."""

from __future__ import annotations

import errno
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .errors import OutputError, PhysidError

__all__ = ["cache_dir", "atomic_write"]


def cache_dir() -> Path:
    """The on-disk cache folder (derived models, compiled right-hand sides).

    ``$PHYSID_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/physid`` or ``~/.cache/physid``. It is
    created on first write; a folder that cannot be written only costs a re-derivation.
    """
    env = os.environ.get("PHYSID_CACHE_DIR")
    if env:
        return Path(env)
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "physid"


def _current_umask() -> int:
    """The process umask (os.umask can only be read by setting it; set it straight back)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def atomic_write(path, write: Callable[[Any], None], *, binary: bool = False) -> Path:
    """Write a file atomically: ``write(handle)`` fills a temporary file that replaces ``path``.

    The temporary file lives in the same folder (so the final `os.replace` is an atomic rename on
    POSIX and Windows); it is flushed and fsync'ed first and given the permissions a plain
    ``open()`` would give (``0o666`` less the umask; `tempfile.mkstemp` alone makes it private). If
    ``write`` raises, the temporary file is removed, an existing ``path`` is left untouched, and the
    exception propagates. A reader never sees half a file.

    Parameters
    ----------
    path : str or Path
        Destination file; its folder is created if missing.
    write : callable
        Receives the open temporary file (text, UTF-8, or binary with ``binary=True``).
    binary : bool

    Returns
    -------
    Path

    Raises
    ------
    OutputError
        ``path`` is a folder, its folder cannot be created (a file is in the way) or written
        (permissions, read-only file system, disk full); the message names ``path``.
    """
    path = Path(path)
    _check_writable(path)
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    except OSError as exc:
        raise _output_error(path, exc) from None
    try:
        with os.fdopen(
            fd, "wb" if binary else "w", **({} if binary else {"encoding": "utf-8", "newline": ""})
        ) as fh:
            write(fh)
            fh.flush()
            os.fsync(fh.fileno())
        # mkstemp creates the file -rw------- ; give it the permissions open() would (0o666 less
        # the umask), so the outputs are as readable as any other file the user writes
        os.chmod(tmp, 0o666 & ~_current_umask())
        os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(exc, OSError) and not isinstance(exc, PhysidError):
            # a failure of the file system (disk full, folder replaced meanwhile): name the
            # user's path, not the temporary file
            raise _output_error(path, exc) from None
        raise
    return path


def _output_error(path: Path, exc: OSError) -> OutputError:
    """An `OutputError` naming ``path`` (the user's), with the cause and the fix."""
    reason = exc.strerror or type(exc).__name__
    if isinstance(exc, PermissionError) or exc.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        fix = (
            f"the folder {str(path.parent)!r} is not writable ({reason}); choose an output in a "
            "folder you can write, or change the folder's permissions"
        )
    elif exc.errno == errno.ENOSPC:
        fix = f"the disk is full ({reason}); free space or write elsewhere"
    else:
        fix = f"{reason}; check the path"
    return OutputError(f"cannot write {str(path)!r}: {fix}.")


def _check_writable(path: Path) -> None:
    """Refuse an output path that is a folder, or whose folder cannot be made, naming it."""
    if path.is_dir():
        raise OutputError(
            f"cannot write {str(path)!r}: it is a folder; give a file name, e.g. "
            f"{str(path / 'out.csv')!r}."
        )
    parent = path.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise OutputError(
            f"cannot write {str(path)!r}: {str(_first_file(parent))!r} is a file, not a folder; "
            "choose another output path."
        ) from None
    except NotADirectoryError:
        raise OutputError(
            f"cannot write {str(path)!r}: {str(_first_file(parent))!r} is a file, not a folder; "
            "choose another output path."
        ) from None
    except OSError as exc:
        raise _output_error(path, exc) from None


def _first_file(folder: Path) -> Path:
    """The first existing non-folder on the way to ``folder`` (what blocks making it)."""
    for p in [*reversed(folder.parents), folder]:
        if p.exists() and not p.is_dir():
            return p
    return folder
