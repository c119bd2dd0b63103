"""How much memory a request may take: check before allocating, refuse with the number."""

from __future__ import annotations

import os

from .errors import InputError

__all__ = ["available_memory", "check_memory", "format_bytes"]

#: Fraction of the available memory one request may claim.
MEMORY_FRACTION = 0.5


def available_memory() -> int:
    """Physical memory available now [bytes] (Linux/macOS ``sysconf``), else 4 GiB assumed.

    Returns
    -------
    int
        Bytes.
    """
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
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if abs(n) < 1000 or unit == "PB":
            return f"{n:.3g} {unit}"
        n /= 1000.0
    return f"{n:.3g} PB"  # pragma: no cover


def check_memory(nbytes: float, *, what: str, fix: str, available: int | None = None) -> None:
    """Refuse a request whose arrays would take more than half the available memory.

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

    Raises
    ------
    InputError
        With the estimate and the available memory, e.g. "needs about 26.4 GB of memory
        (available: 3.1 GB)".
    """
    avail = available_memory() if available is None else int(available)
    if nbytes > MEMORY_FRACTION * avail:
        raise InputError(
            f"{what} needs about {format_bytes(nbytes)} of memory, more than half of the "
            f"{format_bytes(avail)} available; {fix}."
        )
