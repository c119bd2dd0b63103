"""The keywords of `load_recording`: the channel map, the load and the CSV options."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ...errors import InputError

__all__ = ["parse_channel_map"]


def parse_channel_map(channels) -> dict[str, str] | None:
    """Validate a channel map: a mapping name → text, or the CLI form ``"t=time,q1=qm"``.

    Parameters
    ----------
    channels : mapping of str to str, str, or None

    Returns
    -------
    dict or None
        Target channel → source text (whitespace stripped).

    Raises
    ------
    InputError
        Not a mapping of non-empty strings, an entry without ``=``, a target given twice.

    Examples
    --------
    >>> parse_channel_map("t=time, tau1=gtau*vir")
    {'t': 'time', 'tau1': 'gtau*vir'}
    """
    if channels is None:
        return None
    if isinstance(channels, str):
        out: dict[str, str] = {}
        for item in _split_top_level(channels):
            if not item.strip():
                continue
            name, sep, value = item.partition("=")
            if not sep or not name.strip() or not value.strip():
                raise InputError(
                    f"channels= expects NAME=SOURCE pairs separated by commas, e.g. "
                    f"'t=time,q1=qm,tau1=gtau*vir'; got {item.strip()!r}."
                )
            if name.strip() in out:
                raise InputError(
                    f"channels= maps {name.strip()!r} twice; give each channel one source."
                )
            out[name.strip()] = value.strip()
        channels = out
    if not isinstance(channels, Mapping):
        raise InputError(
            "channels= must be a mapping of recording channel -> file variable or expression, "
            f"e.g. {{'t': 'time', 'q1': 'qm'}}; got {type(channels).__name__}."
        )
    out = {}
    for key, value in channels.items():
        if not isinstance(key, str) or not key.strip() or key.strip() != key:
            raise InputError(
                f"channels= keys must be channel names without surrounding spaces; got {key!r}."
            )
        if not isinstance(value, str) or not value.strip():
            raise InputError(
                f"channels[{key!r}] must be a variable name or an expression (a non-empty "
                f"string); got {value!r}."
            )
        out[key] = value.strip()
    return out


def _check_load_options(resample, uniform_rtol) -> tuple[bool, float | None]:
    """Validate `load_recording`'s keywords (a truthy string or a NaN tolerance would be
    silently misread: ``resample='no'`` is truthy, and ``worst > nan`` is never true, which
    would snap non-uniform times onto a grid without moving the data)."""
    if not isinstance(resample, (bool, np.bool_)):
        raise InputError(
            f"resample must be True or False, got {resample!r} of type "
            f"{type(resample).__name__}; pass resample=True to interpolate onto a uniform grid "
            "or resample=False (the default) to refuse non-uniform sampling."
        )
    if uniform_rtol is None:
        return bool(resample), None
    if isinstance(uniform_rtol, (bool, np.bool_)) or not isinstance(
        uniform_rtol, (int, float, np.integer, np.floating)
    ):
        raise InputError(
            f"uniform_rtol must be None or a finite number >= 0, got {uniform_rtol!r} of type "
            f"{type(uniform_rtol).__name__}; pass e.g. uniform_rtol=1e-3 (the default), or "
            "uniform_rtol=None to keep the time vector as it is."
        )
    value = float(uniform_rtol)
    if not np.isfinite(value) or value < 0:
        raise InputError(
            f"uniform_rtol must be None or a finite number >= 0, got {uniform_rtol!r}; pass e.g. "
            "uniform_rtol=1e-3 (the default), or uniform_rtol=None to keep the time vector as "
            "it is."
        )
    return bool(resample), value


def _check_csv_options(decimal, delimiter) -> tuple[str, str | None]:
    if decimal not in (".", ","):
        raise InputError(f"decimal must be '.' or ','; got {decimal!r}.")
    if delimiter is not None:
        if delimiter in ("tab", "\\t"):
            delimiter = "\t"
        if delimiter not in (",", ";", "\t"):
            raise InputError(
                f"delimiter must be ',', ';', a tab or None (recognised); got {delimiter!r}."
            )
        if delimiter == "," and decimal == ",":
            raise InputError(
                "decimal=',' and delimiter=',' cannot both hold: with decimal commas the "
                "separator is ';' or a tab; pass delimiter=';'."
            )
    return decimal, delimiter


def _split_top_level(text: str) -> list[str]:
    """Split at commas outside parentheses (``atan2(a, b)`` stays whole)."""
    parts, depth, start = [], 0, 0
    for i, ch in enumerate(text):
        if ch in "([":
            depth += 1
        elif ch in ")]":
            depth = max(depth - 1, 0)
        elif ch == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return parts
