"""How much memory a request may take: check before allocating, refuse with the number."""

from __future__ import annotations

import os
from collections.abc import Callable

from .errors import InputError

__all__ = ["available_memory", "check_memory", "format_bytes", "stream_limit", "STREAM_ABOVE"]

#: Fraction of the available memory one request may claim.
MEMORY_FRACTION = 0.5
#: An in-memory fit whose estimated peak exceeds this [bytes] (or `stream_limit`'s share of the
#: available memory) reads its record block by block instead, when it can (``--stream auto``).
STREAM_ABOVE = 2 * 2**30


def available_memory() -> int:
    """Memory available to a new allocation now [bytes].

    Linux ``MemAvailable`` (free memory plus the page cache the kernel can drop), else the free
    physical pages (``sysconf``, macOS), else 4 GiB assumed.

    Returns
    -------
    int
        Bytes.
    """
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        pages = os.sysconf("SC_AVPHYS_PAGES")
        size = os.sysconf("SC_PAGE_SIZE")
        if pages > 0 and size > 0:
            return int(pages) * int(size)
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        pass
    return 4 * 1024**3  # pragma: no cover


def format_bytes(n: float) -> str:
    """``1.5 GB`` style (decimal units).

    Parameters
    ----------
    n : float
        Bytes.

    Returns
    -------
    str
    """
    for unit in ("B", "kB", "MB", "GB", "TB", "PB", "EB"):
        if abs(n) < 1000 or unit == "EB":
            return f"{n:.3g} {unit}"
        n /= 1000.0
    return f"{n:.3g} EB"  # pragma: no cover


def check_memory(
    nbytes: float,
    *,
    what: str,
    fix: str,
    available: int | None = None,
    message: Callable[[float, int], str] | None = None,
) -> None:
    """Refuse a request whose arrays would take more than half the available memory.

    The one memory check of physid (design-input, sweeps): estimate the peak from the request's
    sizes, call this before allocating anything of that size.

    Parameters
    ----------
    nbytes : float
        Peak memory the request needs [bytes], estimated from its sizes before allocating.
    what : str
        The request in words (``"design_input with samples=100000000"``).
    fix : str
        What to change (``"lower samples"``).
    available : int, optional
        Available memory [bytes]; default `available_memory`.
    message : callable ``(nbytes, available) -> str``, optional
        Builds the whole message instead of the default wording, for a caller that can say more
        (the sweep names its largest feasible trial count); `what` and `fix` are then unused.

    Raises
    ------
    InputError
        With the estimate and the available memory, e.g. "needs about 26.4 GB of memory
        (available: 3.1 GB)".
    """
    avail = available_memory() if available is None else int(available)
    if nbytes > MEMORY_FRACTION * avail:
        if message is not None:
            raise InputError(message(nbytes, avail))
        raise InputError(
            f"{what} needs about {format_bytes(nbytes)} of memory, more than half of the "
            f"{format_bytes(avail)} available; {fix}."
        )


def stream_limit(workers: int = 1) -> int:
    """The in-memory peak [bytes] above which a fit streams its record by default.

    `STREAM_ABOVE`, or a quarter of the available memory shared by ``workers`` processes when
    that is less: the one rule of ``identify --stream auto``, ``estimate --stream auto`` and a
    fleet's long logs.

    Parameters
    ----------
    workers : int
        Processes fitting at the same time on this machine.

    Returns
    -------
    int
    """
    return int(min(STREAM_ABOVE, available_memory() // (4 * max(int(workers), 1))))
