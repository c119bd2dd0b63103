"""The last step of every load: check the assembled columns and make the `Recording`."""

from __future__ import annotations

import warnings

import numpy as np

from ..._validate import UNIFORM_RTOL
from ...errors import DataFileError, PhysidError, PhysidWarning, arg
from ..recording import Recording
from .conversion import _check_magnitude
from .variables import DEFAULT_UNIFORM_RTOL


def _build(
    path, t, data, names, units, metadata, row_label, *, resample, uniform_rtol
) -> Recording:
    """Check the parsed columns and make the `Recording` (errors name the file)."""
    t = np.asarray(t, dtype=float).reshape(-1)
    data = np.asarray(data, dtype=float)
    if data.ndim == 1:
        data = data[:, None]
    names = [str(n) for n in names]
    _check_names(path, names)
    if t.size == 0:
        raise DataFileError(f"{path}: the file holds no samples; it needs at least 2 rows of data.")
    if t.size < 2:
        raise DataFileError(f"{path}: the file holds only 1 sample; it needs at least 2 rows.")
    if data.shape[1] == 0:
        raise DataFileError(f"{path}: the file has a time column 't' but no channels.")
    if data.shape[0] != t.size:
        raise DataFileError(
            f"{path}: t has {t.size} samples but the channels have {data.shape[0]}; "
            "every channel needs one value per time sample."
        )
    if row_label is None:

        def row_label(i: int) -> str:
            return f"sample {i}"

    _check_finite(path, "time column", t[:, None], ["t"], row_label)
    _check_finite(path, "channel", data, names, row_label)
    _check_magnitude(path, "t", t, row_label)
    steps = np.diff(t)
    if np.any(steps <= 0):
        i = int(np.argmax(steps <= 0))
        raise DataFileError(
            f"{path}: time is not strictly increasing: t = {float(t[i + 1])!r} at "
            f"{row_label(i + 1)} follows t = {float(t[i])!r} at {row_label(i)}. Sort the rows by "
            "time and remove duplicates."
        )
    period = (t[-1] - t[0]) / (t.size - 1)
    deviation = np.abs(steps - period)
    worst = float(deviation.max()) / period
    tolerance = DEFAULT_UNIFORM_RTOL if uniform_rtol is None else float(uniform_rtol)
    needs_resampling = False
    if worst > tolerance:
        i = int(deviation.argmax())
        if resample:
            needs_resampling = True
            metadata["max_sampling_deviation"] = worst
            _warn_gap(path, steps, t, row_label)
        elif uniform_rtol is not None:
            raise DataFileError(
                f"{path}: time is not uniformly sampled: the interval from {row_label(i)} to "
                f"{row_label(i + 1)} is {steps[i]:.6g} s against a mean period of "
                f"{period:.6g} s (worst relative deviation {worst:.3g}, tolerance "
                f"{uniform_rtol:g}). Pass {arg('resample', 'True', cli='')} to interpolate onto a "
                "uniform grid with the mean period (or uniform_rtol=None to keep the time "
                "vector as it is)."
            )
    elif uniform_rtol is not None and worst > UNIFORM_RTOL:
        # within the file tolerance but beyond Recording.dt's: snap onto the exact grid t0 + kΔ
        t = t[0] + period * np.arange(t.size)
        metadata["max_sampling_deviation"] = worst
    try:
        rec = Recording(t, data, tuple(names), tuple(units), metadata)
    except PhysidError as exc:  # e.g. a reserved or badly spaced channel name
        raise DataFileError(f"{path}: {exc}") from None
    if needs_resampling:
        rec = rec.resample()
    return rec


def _warn_gap(path, steps, t, row_label) -> None:
    """Say so when resampling interpolates across a gap of more than 5 median periods."""
    median = float(np.median(steps))
    gaps = np.flatnonzero(steps > 5.0 * median)
    if not gaps.size:
        return
    i = int(gaps[np.argmax(steps[gaps])])
    warnings.warn(
        PhysidWarning(
            f"{path}: {gaps.size} gap(s) longer than 5 periods; the longest, {steps[i]:.6g} s "
            f"from {row_label(i)} (t = {float(t[i]):.6g} s) to {row_label(i + 1)}, is bridged "
            f"by the linear interpolation of {arg('resample', 'True', cli='')} (a median period "
            f"of {median:.6g} s). To fit the stretches apart, split the file (or read it with "
            "physid.signals.join_recordings, which splits at gaps)."
        ),
        stacklevel=4,
    )


def _check_names(path, names) -> None:
    seen: dict[str, int] = {}
    for i, name in enumerate(names):
        if not name:
            raise DataFileError(
                f"{path}: channel {i + 1} has an empty name; give every column a name."
            )
        if name == "t":
            raise DataFileError(f"{path}: 't' appears twice; the time column must be unique.")
        if name in seen:
            raise DataFileError(
                f"{path}: duplicate channel name {name!r} (channels {seen[name] + 1} and {i + 1}); "
                "channel names must be unique, rename one of them."
            )
        seen[name] = i


def _check_finite(path, what, arr, names, row_label) -> None:
    bad = ~np.isfinite(arr)
    if not bad.any():
        return
    rows, cols = np.nonzero(bad)
    row, col = int(rows[0]), int(cols[0])
    label = row_label(row) if row_label else f"sample {row}"
    raise DataFileError(
        f"{path}: {what} {names[col]!r} holds {arr[row, col]} at {label} "
        f"({int(bad.sum())} non-finite value(s) in all). Remove those rows or fill the gaps "
        "(e.g. by interpolation) before loading."
    )
