"""Where physid keeps files between runs, how it trusts them, and how it writes them.

The cache (derived models, compiled right-hand sides) holds code that physid runs, so it is used
only when nobody else can change it: the rule of ssh's ``StrictModes`` and pip's cache. The cache
folder must be owned by the current user and not writable by the group or others; every entry
must be a regular file with the same owner and no group/other write permission; and every entry
carries an HMAC-SHA256 keyed with a per-user secret, ``secret.key`` in the folder (32 random
bytes, mode 0600, created atomically on first use), so an entry is accepted only if it was
written by someone who can read that key. A folder or key file that breaks the rule is not used
at all (`CacheWarning` names it and the fix); the work is then done in memory, or in a private
temporary folder, every time.

Outputs are written by `atomic_write` only: a temporary file in the destination's folder replaces
the destination, which must be absent or a regular file (a device, FIFO, socket or symbolic link
is refused, never replaced).
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from .errors import InputError, OutputError, PhysidError, PhysidWarning

__all__ = ["cache_dir", "atomic_write", "trusted_cache", "CacheWarning"]

#: Name of the secret key file in the cache folder.
KEY_NAME = "secret.key"
#: Bytes of the secret key.
KEY_BYTES = 32
#: Permission checks apply where files have POSIX owners and modes.
_POSIX = os.name == "posix" and hasattr(os, "geteuid")


class CacheWarning(PhysidWarning):
    """The cache folder (or its key file) may be changed by someone else: it is not used.

    Parameters
    ----------
    message : str
        Names the folder or file, what is wrong and the fix.
    """


def cache_dir() -> Path:
    """The on-disk cache folder (derived models, compiled right-hand sides).

    ``$PHYSID_CACHE_DIR`` if set (an absolute path; ``~`` is expanded), else
    ``$XDG_CACHE_HOME/physid`` or ``~/.cache/physid``. It is created (mode 0700) on first write;
    a folder that cannot be written only costs a re-derivation. Whether it is used at all is
    decided by `trusted_cache`.

    Returns
    -------
    Path

    Raises
    ------
    InputError
        ``$PHYSID_CACHE_DIR`` is a relative path (it would name a different folder in every
        working directory, possibly one that others can write).
    """
    env = os.environ.get("PHYSID_CACHE_DIR")
    if env:
        path = Path(env).expanduser()
        if not path.is_absolute():
            raise InputError(
                f"the environment variable PHYSID_CACHE_DIR is a relative path ({env!r}); the "
                "cache folder must be an absolute path, e.g. PHYSID_CACHE_DIR="
                f"{str(Path.home() / '.cache' / 'physid')!r}, or unset it."
            )
        return path
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "physid"


def _trust_problem(st: os.stat_result, *, folder: bool = False, private: bool = False) -> str:
    """What makes a file or folder untrustworthy ("" if nothing): type, owner, permissions."""
    if folder and not stat.S_ISDIR(st.st_mode):
        return "is not a folder"
    if not folder and not stat.S_ISREG(st.st_mode):
        return "is not a regular file"
    if not _POSIX:  # no POSIX owners and modes (Windows): the user's profile folder protects it
        return ""
    euid = os.geteuid()
    if st.st_uid != euid:
        return f"is owned by user id {st.st_uid}, not by you (user id {euid})"
    mask = 0o077 if private else 0o022
    if st.st_mode & mask:
        who = "read or written by" if private else "written by"
        return f"can be {who} other users (mode {stat.S_IMODE(st.st_mode):04o})"
    return ""


_WARNED: set[str] = set()


def _warn_untrusted(what: str, path: Path, problem: str, fix: str) -> None:
    """One `CacheWarning` per message and process: what is wrong, that the cache is unused, fix."""
    import warnings

    text = (
        f"the cache {what} {str(path)!r} "
        f"{problem}, so physid does not use the cache (models are derived in memory and C code "
        f"is built in a private temporary folder, every time). Fix: {fix}."
    )
    if text in _WARNED:
        return
    _WARNED.add(text)
    warnings.warn(CacheWarning(text), stacklevel=3)


def _folder_fix(folder: Path) -> str:
    return (
        f"chmod 700 {str(folder)!r} (and chown it to yourself if it is someone else's), or set "
        "PHYSID_CACHE_DIR to the absolute path of a private folder"
    )


def read_private(path: Path) -> bytes | None:
    """The bytes of a cache file, or None unless it is a regular file only its owner can write.

    Opened without following a symbolic link and without blocking (a FIFO is refused, not
    waited on); the owner and mode are those of the opened file (`os.fstat`), so what is checked
    is what is read.

    Parameters
    ----------
    path : Path

    Returns
    -------
    bytes or None
        None: absent, unreadable, or untrusted (another owner, group/other-writable, not a
        regular file, a symbolic link).
    """
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    flags |= getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(path, flags)
    except OSError:
        return None
    try:
        if _trust_problem(os.fstat(fd)):
            return None
        with os.fdopen(fd, "rb") as fh:
            fd = -1
            return fh.read()
    except OSError:
        return None
    finally:
        if fd >= 0:
            os.close(fd)


def _create_key(folder: Path) -> None:
    """Write a fresh secret key, atomically: of two racing processes the first one wins."""
    import secrets

    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".secret.", suffix=".tmp")  # mode 0600
    try:
        try:
            os.write(fd, secrets.token_bytes(KEY_BYTES))
            os.fsync(fd)
        finally:
            os.close(fd)
        try:
            os.link(tmp, folder / KEY_NAME)  # never replaces an existing key
        except FileExistsError:
            pass
        except OSError:  # no hard links here: a lost race only makes the other's entries miss
            os.replace(tmp, folder / KEY_NAME)
    finally:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass


def _read_key(folder: Path, create: bool) -> bytes | None:
    """The folder's secret key (created with ``create``), or None (absent, or untrusted: warned)."""
    path = folder / KEY_NAME
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    flags |= getattr(os, "O_BINARY", 0)
    fix = f"delete {str(path)!r} (physid makes a new one; cached entries are then rebuilt)"
    for _ in range(2):
        try:
            fd = os.open(path, flags)
        except FileNotFoundError:
            if not create:
                return None
            try:
                _create_key(folder)
            except OSError:
                return None  # the folder cannot be written: no cache, as for a missing one
            continue
        except OSError as exc:
            if exc.errno == errno.ELOOP:
                _warn_untrusted("key file", path, "is a symbolic link", fix)
            return None
        with os.fdopen(fd, "rb") as fh:
            problem = _trust_problem(os.fstat(fh.fileno()), private=True)
            if problem:
                _warn_untrusted("key file", path, problem, f"chmod 600 {str(path)!r}, or {fix}")
                return None
            key = fh.read(KEY_BYTES + 1)
        if len(key) != KEY_BYTES:
            _warn_untrusted("key file", path, f"holds {len(key)} bytes instead of {KEY_BYTES}", fix)
            return None
        return key
    return None


def trusted_cache(*, create: bool = False) -> tuple[Path, bytes] | None:
    """The cache folder and its secret key, if the folder may be trusted; else None.

    Trusted: the folder is owned by the current user (`os.geteuid`) and not writable by the
    group or others, and its key file ``secret.key`` is a regular file owned by the user with
    no permissions for the group or others (mode 0600). A folder or key that breaks the rule
    gives one `CacheWarning` (naming it and the fix: ``chmod``/``chown``, or ``PHYSID_CACHE_DIR``
    set to a private folder) and None. On systems without POSIX owners (Windows) only the file
    types are checked.

    Parameters
    ----------
    create : bool
        Create a missing folder (mode 0700) and key file (for a write); without it, a missing
        folder or key gives None silently (nothing is cached yet).

    Returns
    -------
    (Path, bytes) or None
        The folder and the key to sign and check entries with (`cache_mac`).

    Raises
    ------
    InputError
        ``$PHYSID_CACHE_DIR`` is relative (`cache_dir`).
    """
    folder = cache_dir()
    if create:
        try:
            folder.mkdir(mode=0o700, parents=True, exist_ok=True)
        except OSError:
            return None
    try:
        st = os.stat(folder)  # a symbolic link to the folder is judged by its target
    except OSError:
        return None
    problem = _trust_problem(st, folder=True)
    if problem:
        _warn_untrusted("folder", folder, problem, _folder_fix(folder))
        return None
    key = _read_key(folder, create)
    return None if key is None else (folder, key)


def cache_mac(key: bytes, *parts: bytes) -> str:
    """HMAC-SHA256 (hex) of ``parts`` (each length-prefixed, so their boundaries count).

    Parameters
    ----------
    key : bytes
        The cache folder's secret key (`trusted_cache`).
    *parts : bytes

    Returns
    -------
    str
    """
    import hashlib
    import hmac

    mac = hmac.new(key, digestmod=hashlib.sha256)
    for part in parts:
        mac.update(len(part).to_bytes(8, "big"))
        mac.update(part)
    return mac.hexdigest()


def same_mac(a: str, b) -> bool:
    """Constant-time comparison of two MACs (False unless ``b`` is a string equal to ``a``)."""
    import hmac

    return isinstance(b, str) and hmac.compare_digest(a.encode(), b.encode())


def _current_umask() -> int:
    """The process umask: read from ``/proc/self/status`` where Linux shows it, else by setting it
    and straight back (`os.umask` can only be read that way, which is not thread-safe)."""
    try:
        with open("/proc/self/status", encoding="ascii", errors="replace") as fh:
            for line in fh:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def _kept_mode(path: Path) -> int | None:
    """The permission bits of an existing regular file at ``path`` (kept when it is replaced)."""
    try:
        st = os.lstat(path)
    except OSError:
        return None
    return stat.S_IMODE(st.st_mode) if stat.S_ISREG(st.st_mode) else None


def atomic_write(
    path,
    write: Callable[[Any], None],
    *,
    binary: bool = False,
    mode: int | None = None,
    exclusive: bool = False,
) -> Path:
    """Write a file atomically: ``write(handle)`` fills a temporary file that replaces ``path``.

    The temporary file lives in the same folder (so the final `os.replace` is an atomic rename on
    POSIX and Windows); it is flushed and fsync'ed first. A file that replaces an existing regular
    file keeps that file's permissions (a private ``0o600`` output stays private); a new file gets
    those a plain ``open()`` would give (``0o666`` less the umask; `tempfile.mkstemp` alone makes
    it private). If ``write`` raises, the temporary file is removed, an existing ``path`` is left
    untouched, and the exception propagates. A reader never sees half a file.

    The destination must be absent or a regular file: a symbolic link, a device, a FIFO or a
    socket is refused (replacing it would destroy it instead of writing to it), checked before
    writing and again just before the rename.

    Parameters
    ----------
    path : str or Path
        Destination file; its folder is created if missing.
    write : callable
        Receives the open temporary file (text, UTF-8, or binary with ``binary=True``).
    binary : bool
    mode : int, optional
        Permissions of the written file (e.g. ``0o600`` for a private one); default those of the
        file replaced, or of a plain ``open()`` for a new one.
    exclusive : bool
        Never replace: the file is put in place with `os.link`, which fails atomically when
        ``path`` exists (even one created while the data were written).

    Returns
    -------
    Path

    Raises
    ------
    FileExistsError
        ``exclusive=True`` and ``path`` exists (the caller words the refusal).
    OutputError
        ``path`` is a folder, a symbolic link, a device, FIFO or socket; its folder cannot be
        created (a file is in the way) or written (permissions, read-only file system, disk
        full, no hard links with ``exclusive=True``); the message names ``path``.
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
        # mkstemp creates the file -rw------- ; give it the permissions of the file it replaces,
        # or those open() would give (0o666 less the umask), so the outputs are as readable as
        # any other file the user writes and a private file stays private
        if mode is None:
            mode = _kept_mode(path)
        os.chmod(tmp, 0o666 & ~_current_umask() if mode is None else mode)
        _check_not_special(path)  # again: it may have appeared while the data were written
        if exclusive:
            os.link(tmp, path)  # FileExistsError, atomically, if anything is there now
            os.unlink(tmp)
        else:
            os.replace(tmp, path)
    except BaseException as exc:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        if isinstance(exc, FileExistsError) and exclusive:
            raise
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


_KINDS = (
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISSOCK, "a socket"),
)


def _check_not_special(path: Path) -> None:
    """Refuse a destination that exists and is a symbolic link or not a regular file."""
    try:
        st = os.lstat(path)
    except OSError:
        return  # absent (or its folder is not searchable: reported when writing)
    if stat.S_ISLNK(st.st_mode):
        raise OutputError(
            f"cannot write {str(path)!r}: it is a symbolic link (to "
            f"{os.path.realpath(path)!r}); give the target path, physid does not replace links."
        )
    if stat.S_ISDIR(st.st_mode) or stat.S_ISREG(st.st_mode):
        return
    kind = next((name for test, name in _KINDS if test(st.st_mode)), "a special file")
    raise OutputError(
        f"cannot write {str(path)!r}: it is {kind}, not a regular file; physid writes outputs "
        "by replacing a regular file and would destroy it. Give the path of a regular file."
    )


def _check_writable(path: Path) -> None:
    """Refuse a folder, link or special file as output, or one whose folder cannot be made."""
    if path.is_dir() and not path.is_symlink():
        raise OutputError(
            f"cannot write {str(path)!r}: it is a folder; give a file name, e.g. "
            f"{str(path / 'out.csv')!r}."
        )
    _check_not_special(path)
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
