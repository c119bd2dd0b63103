"""Checks on a recording file before it is read: its suffix, that it is a readable regular file,
and the sample rate of a file without time (shared by `load_recording` and `open_blocks`)."""

from __future__ import annotations

import stat
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ...errors import DataFileError, InputError
from .options import _check_csv_options, _check_load_options, parse_channel_map
from .timebase import check_rate


def _reading_options(
    resample, uniform_rtol, channels, channel_defaults, channel_defaults_source, rate, decimal,
    delimiter,
):  # fmt: skip
    """The reading options `load_recording` and `open_blocks` share, checked and parsed:
    ``(resample, uniform_rtol, channels, defaults, rate, rate_source, decimal, delimiter)``."""
    resample, uniform_rtol = _check_load_options(resample, uniform_rtol)
    channels = parse_channel_map(channels)
    defaults = parse_channel_map(channel_defaults) or {}
    rate, rate_source = _rate_of(rate, defaults, channel_defaults_source)
    decimal, delimiter = _check_csv_options(decimal, delimiter)
    return resample, uniform_rtol, channels, defaults, rate, rate_source, decimal, delimiter


def _check_csv_only(path, fmt: str, decimal: str, delimiter) -> None:
    """Refuse ``decimal=``/``delimiter=`` set for a file that is not CSV."""
    if fmt != "csv" and (decimal, delimiter) != (".", None):
        raise InputError(
            f"decimal= and delimiter= apply to CSV files only; {path} is {fmt.upper()}. Drop them."
        )


def _rate_of(rate, defaults: dict, source) -> tuple[float | None, str]:
    """The sample rate [Hz] (``rate=``, else a ``"rate"`` entry of the defaults) and its origin."""
    table_rate = defaults.pop("rate", None)
    if rate is not None:
        return check_rate(rate), "rate="
    if table_rate is None:
        return None, "rate="
    try:
        value = float(table_rate)
    except ValueError:
        value = float("nan")
    if not (np.isfinite(value) and value > 0):
        raise InputError(
            f"{source or 'channel_defaults='}: rate must be the sample rate in Hz, a number > 0 "
            f"(e.g. rate = 5000); got {table_rate!r}."
        )
    return value, f"{source or 'channel_defaults='} (rate = {value:g})"


_SPECIAL_KINDS = (
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def _check_readable(path: Path, opener=open) -> None:
    """Refuse a path that is missing, a folder, a special file or unreadable, before reading.

    A special file (FIFO, device, socket) is refused from its ``stat`` alone: opening a FIFO
    would block until a writer comes, and a device may never end.
    """
    try:
        mode = path.stat().st_mode
    except OSError:
        mode = None
    for test, kind in _SPECIAL_KINDS:
        if mode is not None and test(mode):
            raise DataFileError(
                f"{path}: is {kind}, not a recording file; physid reads recordings from "
                "regular files (save the stream to a file first)."
            )
    if not path.is_file():
        raise DataFileError(
            f"{path}: no such file{' (it is a directory)' if path.is_dir() else ''}; "
            "check the path."
        )
    try:
        with opener(path, "rb") as fh:
            fh.read(1)
    except PermissionError:
        raise DataFileError(
            f"{path}: permission denied: the file cannot be read by this user; make it "
            f"readable (chmod u+r {path}) or copy it somewhere you can read."
        ) from None
    except OSError as exc:
        raise DataFileError(f"{path}: cannot be read ({exc.strerror or exc}).") from None


def _format_of(path: Path, table: Mapping[str, str], action: str) -> str:
    suffix = path.suffix.lower()
    if suffix not in table:
        raise DataFileError(
            f"{path}: cannot {action} files with suffix {suffix or '(none)'!r}; supported: "
            f"{sorted(table)}. Rename the file or convert it."
        )
    return table[suffix]
