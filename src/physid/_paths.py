"""Where physid keeps files between runs, and how it writes them (atomically)."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

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
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
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
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    return path
