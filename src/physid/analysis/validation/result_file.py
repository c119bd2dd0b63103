"""Reading a result file (JSON) safely: a bounded size, a bounded nesting, and every key physid
uses checked for its type and range at the boundary, so that a damaged, truncated or crafted file
is refused with the file and the key named, never a traceback and never a silent default."""

from __future__ import annotations

import json
import math
import os
import stat
from pathlib import Path
from typing import Any

from ..._resources import format_bytes
from ...errors import DataFileError
from ...signals.io import MAX_ABS_VALUE

#: Largest result file read [bytes]; physid's own are a few hundred kB at most.
MAX_RESULT_BYTES = 64 * 2**20
#: Deepest nesting of JSON arrays and objects accepted (physid writes at most 4 levels).
MAX_RESULT_DEPTH = 32

_FIX = (
    "Write it again with physid.estimators.results.save_result (what physid estimate and "
    "physid identify save)."
)


def read_result_json(p: Path) -> dict[str, Any]:
    """The JSON object of result file ``p``, checked (see the module docstring)."""
    try:
        st = os.stat(p)
    except OSError as exc:
        raise DataFileError(
            f"cannot read the result file {str(p)!r}: {exc.strerror or exc}. {_FIX}"
        ) from None
    if not stat.S_ISREG(st.st_mode):
        raise DataFileError(
            f"the result file {str(p)!r} is not a regular file (a folder, a device or a pipe); "
            "give the JSON file written by physid."
        )
    if st.st_size > MAX_RESULT_BYTES:
        raise DataFileError(
            f"the result file {str(p)!r} holds {format_bytes(st.st_size)}, more than the "
            f"{format_bytes(MAX_RESULT_BYTES)} a physid result file can reach; it is not one. "
            f"{_FIX}"
        )
    try:
        with open(p, "rb") as fh:
            raw = fh.read(MAX_RESULT_BYTES + 1)
        data = json.loads(raw.decode("utf-8"))
    except (OSError, UnicodeDecodeError, ValueError, RecursionError) as exc:
        why = "it is nested too deeply" if isinstance(exc, RecursionError) else exc
        if "integer string conversion" in str(exc):  # Python's int_max_str_digits
            why = "it holds an integer of thousands of digits"
        raise DataFileError(f"cannot read the result file {str(p)!r}: {why}. {_FIX}") from None
    if not isinstance(data, dict) or not isinstance(data.get("parameters"), dict):
        raise DataFileError(
            f"{str(p)!r} is not a physid result file (no 'parameters' object); write one with "
            "physid.estimators.results.save_result (the estimate command's save option)."
        )
    _check_depth(p, data)
    for key, check in _KEYS.items():
        if key in data:
            check(p, key, data[key])
    return data


def _check_depth(p, data) -> None:
    stack = [(data, 1, "")]
    while stack:
        value, depth, where = stack.pop()
        if depth > MAX_RESULT_DEPTH:
            raise DataFileError(
                f"{str(p)!r}: key {where!r} is nested more than {MAX_RESULT_DEPTH} levels deep; "
                f"a physid result file is not. {_FIX}"
            )
        if isinstance(value, dict):
            stack.extend(
                (v, depth + 1, f"{where}.{k}" if where else str(k)) for k, v in value.items()
            )
        elif isinstance(value, list):
            stack.extend((v, depth + 1, f"{where}[{i}]") for i, v in enumerate(value))


def _refuse(p, key, what, value) -> DataFileError:
    shown = repr(value)
    shown = shown if len(shown) <= 60 else shown[:57] + "..."
    return DataFileError(
        f"{str(p)!r}: {key!r} must be {what}; the file has {shown} "
        f"({type(value).__name__}). The file is damaged or was edited. {_FIX}"
    )


def _number(p, key, value, *, null=False) -> None:
    """A finite JSON number within ±MAX_ABS_VALUE (not a bool, not a string)."""
    if value is None and null:
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _refuse(p, key, "a number" + (" or null" if null else ""), value)
    if isinstance(value, float) and not math.isfinite(value):
        raise DataFileError(
            f"{str(p)!r}: {key!r} is {value} in the result file (JSON has no NaN or Infinity; "
            "physid writes a value it could not estimate as null). The result file is damaged "
            f"or was edited, not the data. {_FIX}"
        )
    if abs(value) > MAX_ABS_VALUE:
        raise DataFileError(
            f"{str(p)!r}: {key!r} = {value:g} in the result file is beyond ±{MAX_ABS_VALUE:g}, "
            f"where its square overflows; no physical parameter is that large. {_FIX}"
        )


def _numbers(null: bool):
    def check(p, key, value) -> None:
        if not isinstance(value, dict):
            raise _refuse(p, key, "an object of name: number", value)
        for name, v in value.items():
            _number(p, f"{key}.{name}", v, null=null)

    return check


def _parameters(p, key, value) -> None:
    for name, v in value.items():
        if v is None:
            continue  # refused later as a failed fit, with every null named
        _number(p, f"{key}.{name}", v)


def _text(p, key, value) -> None:
    if not isinstance(value, str):
        raise _refuse(p, key, "a string", value)


def _texts(p, key, value) -> None:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise _refuse(p, key, "a list of strings", value)


def _text_map(p, key, value) -> None:
    if not isinstance(value, dict) or not all(isinstance(v, str) for v in value.values()):
        raise _refuse(p, key, "an object of name: string", value)


def _optional(check):
    def optional(p, key, value) -> None:
        if value is not None:
            check(p, key, value)

    return optional


def _object(p, key, value) -> None:
    if not isinstance(value, dict):
        raise _refuse(p, key, "an object", value)


def _stick_threshold(p, key, value) -> None:
    """The fit's stiction rule: ``"auto"`` (sustained sticking), a number (the speed rule) or
    null."""
    if value == "auto":
        return
    if isinstance(value, str):
        raise _refuse(p, key, '"auto", a number or null', value)
    _number(p, key, value, null=True)


def _setting(*, number: bool = False, integer: bool = False, text: bool = True):
    """A fit setting handed to an estimator (which checks the rest): null, a string, or (where
    allowed) a positive number or integer."""
    what = " or ".join(
        [
            *(["a string"] if text else []),
            *(["a positive integer"] if integer else []),
            *(["a number > 0"] if number else []),
        ]
    )

    def check(p, key, value) -> None:
        if value is None or text and isinstance(value, str):
            return
        ok = not isinstance(value, bool) and (
            integer and isinstance(value, int) or number and isinstance(value, (int, float))
        )
        if not ok or not value > 0:
            raise _refuse(p, key, what + " or null", value)
        _number(p, key, value)

    return check


def _settings(p, key, value) -> None:
    if value is None:
        return
    _object(p, key, value)
    if "dt" in value:
        _number(p, f"{key}.dt", value["dt"], null=True)


def _gains(p, key, value) -> None:
    if value is None:
        return
    _object(p, key, value)
    for name, v in value.items():
        if v is None:
            continue
        if not isinstance(v, list):
            raise _refuse(p, f"{key}.{name}", "a list of numbers", v)
        for i, x in enumerate(v):
            _number(p, f"{key}.{name}[{i}]", x)


#: Every key of a result file that `load_result` and `validate` read, and its check.
_KEYS = {
    "format": _text,
    "method": _text,
    "model": _optional(_text),
    "model_name": _optional(_text),
    "model_options": _optional(_object),
    "names": _texts,
    "free": _optional(_texts),
    "columns": _optional(_texts),
    "parameter_set": _optional(_text),
    "parameters": _parameters,
    "known": _optional(_numbers(null=False)),
    "fixed": _optional(_numbers(null=False)),
    "derived": _optional(_numbers(null=True)),
    "stderr": _optional(_numbers(null=True)),
    "units": _optional(_text_map),
    "settings": _settings,
    "dt": lambda p, k, v: _number(p, k, v, null=True),
    "stick_threshold": _stick_threshold,
    "prefilter_cutoff": lambda p, k, v: _number(p, k, v, null=True),
    "gains": _gains,
    "feedforward": _optional(_text),
    "half_width": _setting(integer=True, text=False),
    "decimate": _setting(integer=True),
    "cutoff": _setting(number=True),
    **dict.fromkeys(("torque", "derivatives", "differentiation"), _setting()),
}
