"""The one place for shape, finiteness and uniform-sampling checks.

Every public function validates its user-facing arrays through these helpers so that the messages
are uniform: they name the argument, the rule, what was received and the fix.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .errors import InputError, SamplingError, ShapeError

__all__ = [
    "as_2d",
    "as_1d",
    "check_finite",
    "check_time",
    "sample_period",
    "check_positive",
    "check_in_range",
    "check_length",
    "check_signal_pair",
]

#: Relative tolerance on the spread of sample intervals before sampling counts as non-uniform.
UNIFORM_RTOL = 1e-6


def as_1d(x, name: str, *, dtype=float) -> np.ndarray:
    """Return ``x`` as a new 1-D float array, or raise `ShapeError` naming ``name``."""
    try:
        arr = np.array(x, dtype=dtype, copy=True)
    except (TypeError, ValueError) as exc:
        raise InputError(
            f"{name} must be numeric; could not convert it to numbers ({exc})."
        ) from None
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim != 1:
        raise ShapeError(f"{name} must be one-dimensional; got shape {arr.shape}.")
    return arr


def as_2d(x, name: str, *, n_channels: int | None = None, dtype=float) -> np.ndarray:
    """Return ``x`` as a new array of shape ``(n_samples, n_channels)``.

    A 1-D input is one channel. ``n_channels``, when given, must match.
    """
    try:
        arr = np.array(x, dtype=dtype, copy=True)
    except (TypeError, ValueError) as exc:
        raise InputError(
            f"{name} must be numeric; could not convert it to numbers ({exc})."
        ) from None
    if arr.ndim == 1:
        arr = arr[:, None]
    if arr.ndim != 2:
        raise ShapeError(
            f"{name} must have shape (n_samples, n_channels) or (n_samples,); "
            f"got shape {arr.shape}."
        )
    if n_channels is not None and arr.shape[1] != n_channels:
        raise ShapeError(
            f"{name} must have {n_channels} column(s) (one per channel); got shape {arr.shape}."
        )
    return arr


def check_finite(arr: np.ndarray, name: str, channel_names: Sequence[str] | None = None) -> None:
    """Raise `InputError` naming the first channel and row holding NaN or inf."""
    bad = ~np.isfinite(arr)
    if not bad.any():
        return
    rows, cols = np.nonzero(bad.reshape(arr.shape[0], -1))
    row, col = int(rows[0]), int(cols[0])
    where = f"channel {channel_names[col]!r}" if channel_names is not None else f"column {col}"
    value = arr.reshape(arr.shape[0], -1)[row, col]
    raise InputError(
        f"{name} holds a non-finite value ({value}) in {where}, row {row} "
        f"({int(bad.sum())} non-finite value(s) in all); remove or interpolate those samples first."
    )


def check_time(t, name: str = "t", *, min_samples: int = 2) -> np.ndarray:
    """Validate a time vector [s]: 1-D, finite, strictly increasing, >= ``min_samples`` long."""
    t = as_1d(t, name)
    check_finite(t[:, None], name)
    if t.size < min_samples:
        raise SamplingError(f"{name} must hold at least {min_samples} samples; got {t.size}.")
    dt = np.diff(t)
    if np.any(dt <= 0):
        i = int(np.argmax(dt <= 0))
        raise SamplingError(
            f"{name} must be strictly increasing; {name}[{i + 1}] = {t[i + 1]!r} follows "
            f"{name}[{i}] = {t[i]!r}. Sort the samples and drop duplicates."
        )
    return t


def sample_period(t: np.ndarray, name: str = "t", *, rtol: float = UNIFORM_RTOL) -> float:
    """Return the sample period [s] of a uniform time vector, or raise `SamplingError`.

    The period is the least-squares slope of ``t`` against the sample index, so a grid built by
    accumulation (with rounding drift) still counts as uniform.
    """
    t = np.asarray(t, dtype=float)
    if t.size < 2:
        raise SamplingError(
            f"{name} needs at least 2 samples to define a sample period; got {t.size}."
        )
    n = t.size
    period = (t[-1] - t[0]) / (n - 1)
    deviation = np.abs(np.diff(t) - period)
    worst = float(deviation.max())
    if worst > rtol * period:
        i = int(deviation.argmax())
        raise SamplingError(
            f"{name} is not uniformly sampled: the interval after sample {i} is "
            f"{t[i + 1] - t[i]:.6g} s against a mean period of {period:.6g} s "
            f"(worst relative deviation {worst / period:.3g}, "
            f"tolerance {rtol:g}). Resample onto a uniform grid first (e.g. load_recording(..., "
            f"resample=True) or Recording.resample())."
        )
    return float(period)


def check_positive(value, name: str, *, allow_zero: bool = False) -> float:
    """Return ``value`` as float if it is finite and > 0 (or >= 0), else raise `InputError`."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(
            f"{name} must be a number; got {value!r} of type {type(value).__name__}."
        ) from None
    ok = np.isfinite(v) and (v >= 0 if allow_zero else v > 0)
    if not ok:
        rule = ">= 0" if allow_zero else "> 0"
        raise InputError(f"{name} must be finite and {rule}; got {value!r}.")
    return v


def check_in_range(
    value, name: str, low: float, high: float, *, low_open=False, high_open=False
) -> float:
    """Return ``value`` as float if it lies in the interval, else raise `InputError`."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(
            f"{name} must be a number; got {value!r} of type {type(value).__name__}."
        ) from None
    lo_ok = v > low if low_open else v >= low
    hi_ok = v < high if high_open else v <= high
    if not (np.isfinite(v) and lo_ok and hi_ok):
        interval = f"{'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
        raise InputError(f"{name} must lie in {interval}; got {value!r}.")
    return v


def check_length(n_samples: int, needed: int, what: str, fix: str) -> None:
    """Raise `SamplingError` when a record of ``n_samples`` is shorter than ``needed``."""
    if n_samples < needed:
        raise SamplingError(
            f"{what} needs at least {needed} samples but the record has {n_samples}. {fix}"
        )


def check_signal_pair(u, y, name_u: str = "u", name_y: str = "y") -> tuple[np.ndarray, np.ndarray]:
    """Return input and output samples as new 1-D float arrays of equal length, all finite."""
    u = as_1d(u, name_u)
    y = as_1d(y, name_y)
    if u.size != y.size:
        raise ShapeError(
            f"{name_u} and {name_y} must have the same length; got {u.size} and {y.size}."
        )
    check_finite(u[:, None], name_u)
    check_finite(y[:, None], name_y)
    return u, y
