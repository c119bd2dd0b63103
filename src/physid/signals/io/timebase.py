"""The time of a recording: stamps to seconds (integer stamps kept exact), a unit hint for
stamps that look like ms/µs/ns read as seconds, and the time of a file without one (a rate)."""

from __future__ import annotations

import math
import warnings

import numpy as np

from ...errors import DataFileError, InputError, PhysidWarning
from ...units import parse_unit

#: Integer stamps at or beyond this magnitude are shifted to start at 0, in integer arithmetic,
#: before they become float seconds: epoch (or boot-time) stamps in s, ms, µs or ns. A float64
#: holds integers exactly only up to 2**53 ≈ 9.0e15, so epoch nanoseconds (≈1.7e18) would lose
#: ~256 ns per stamp, and even epoch milliseconds times 1e-3 keep only ~2e-7 s of resolution.
INTEGER_ORIGIN_MIN = 10**9

#: A time column without a unit whose mean period exceeds this [s] gets a hint naming the unit
#: the stamps are probably in (a 500 Hz log in ns read as s has a period of 2e6 s).
SUSPICIOUS_PERIOD = 5.0

_TIME_UNITS = (("ms", 1e-3), ("us", 1e-6), ("ns", 1e-9))


def _integer_stamps(t: np.ndarray) -> np.ndarray | None:
    """The stamps as int64 when they are integers (an integer dtype, or integral floats)."""
    if t.dtype.kind in "iu":
        return t.astype(np.int64)
    if t.dtype.kind != "f" or not np.all(np.isfinite(t)) or np.max(np.abs(t)) >= 2.0**63:
        return None
    if np.all(t == np.round(t)):
        return t.astype(np.int64)
    return None


def time_to_seconds(
    path, t: np.ndarray, unit: str, origin: int | None = None
) -> tuple[np.ndarray, dict | None]:
    """Stamps in ``unit`` → seconds; integer stamps beyond `INTEGER_ORIGIN_MIN` start at 0.

    Parameters
    ----------
    path : str or Path
        The file, for messages.
    t : ndarray, shape (n_samples,)
        The raw stamps (integers are kept as such by the readers).
    unit : str
        Their unit (``""``: seconds).
    origin : int, optional
        Integer stamps: the stamp to subtract (a block of a record: the record's first stamp,
        0 for none), instead of deciding from ``t[0]``.

    Returns
    -------
    t : ndarray of float, shape (n_samples,) [s]
    origin : dict or None
        ``{"first_stamp": int, "unit": unit}`` when the stamps were shifted (the first stamp
        subtracted in integers, exactly, then converted: ``t = (stamp - first) · scale``).

    Raises
    ------
    DataFileError
        A unit that is not a time or that physid does not know.
    """
    try:
        u = parse_unit(unit)
    except InputError as exc:
        raise DataFileError(f"{path}: the time column has unit {unit!r}: {exc}") from None
    if not (u.si == "" and u.scale == 1.0) and u.dimension != (0, 0, 1, 0, 0):
        raise DataFileError(
            f"{path}: the time column has unit {unit!r} ({u.words}), not a time; physid reads "
            "time in s (ms, us, ns, min and h are converted). Convert the column to seconds."
        )
    stamps = _integer_stamps(t) if t.size else None
    if stamps is not None and origin is None and abs(int(stamps[0])) >= INTEGER_ORIGIN_MIN:
        origin = int(stamps[0])
    if stamps is not None and origin is not None:
        # subtract in int64 (exact), then convert: the differences are small enough for a float
        relative = (stamps - np.int64(origin)).astype(float)
        seconds = relative * u.scale if u.scale != 1.0 else relative
        return seconds, {"first_stamp": int(origin), "unit": unit or "s"} if origin else None
    t = t.astype(float)
    return (t * u.scale if u.scale != 1.0 else t), None


def unit_hint(path, name: str | None, t: np.ndarray, unit: str) -> None:
    """Warn when a time column without a unit has a mean period that looks like ms/µs/ns.

    The likely unit is the one that brings the mean period closest to 1 ms (robot logs run at
    100 Hz to 10 kHz): 2e6 "s" → ns (2 ms), 2000 → µs, 2 → ms.
    """
    if unit or t.size < 2:
        return
    period = float(t[-1] - t[0]) / (t.size - 1)
    if not period > SUSPICIOUS_PERIOD:
        return
    likely, scale = min(_TIME_UNITS, key=lambda us: abs(math.log10(period * us[1] / 1e-3)))
    column = name or "t"
    warnings.warn(
        PhysidWarning(
            f"{path}: the time {column!r} has no unit and its mean period is {period:.4g} s "
            f"({1 / period:.3g} Hz); if the stamps are in {likely} (a period of "
            f"{period * scale * 1e3:.4g} ms), say so: channels={{'t': '{column} [{likely}]'}}, "
            f"or name the column '{column} [{likely}]'."
        ),
        stacklevel=3,
    )


def check_rate(rate) -> float | None:
    """Validate ``rate`` [Hz]: None, or a finite number > 0."""
    if rate is None:
        return None
    if (
        isinstance(rate, (bool, np.bool_))
        or not isinstance(rate, (int, float, np.integer, np.floating))
        or not (math.isfinite(float(rate)) and float(rate) > 0)
    ):
        raise InputError(
            f"rate must be the sample rate in Hz, a finite number > 0 (e.g. rate=5000), or None "
            f"when the file has a time column; got {rate!r}."
        )
    return float(rate)


def samples_of(variables) -> int:
    """Number of samples of a file without time: the most common length of its vectors."""
    lengths: dict[int, int] = {}
    for var in variables.values():
        arr = var.value
        if arr is None or arr.size <= 1:
            continue
        if arr.ndim == 1 or (arr.ndim == 2 and 1 in arr.shape):
            n = arr.size
        elif arr.ndim == 2:
            n = arr.shape[0]
        else:
            continue
        lengths[n] = lengths.get(n, 0) + 1
    if not lengths:
        return 0
    return max(lengths, key=lambda n: (lengths[n], n))


def rate_time(n: int, rate: float) -> np.ndarray:
    """``t = k / rate`` [s], k = 0 .. n-1 (the same numbers for every file of the same length)."""
    return np.arange(n) / rate
