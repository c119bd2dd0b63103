"""Units and time of a file's channels: the unit rule of every format (convert to SI, refuse an
unknown unit or one of the wrong kind on a channel physid reads), and finding the time."""

from __future__ import annotations

import re
from collections.abc import Mapping

import numpy as np

from ...errors import DataFileError, InputError
from ...units import dimension_name, expected_dimensions, parse_unit
from .variables import _RESERVED, MAX_ABS_VALUE, _Var

_MAP_UNIT = re.compile(r"^(?P<expr>.*?)\s*\[(?P<unit>[^\[\]]*)\]\s*$", re.S)


def _map_unit(path, target: str, body: str, map_unit: str | None, file_unit: str) -> str:
    """The unit of a bare mapped column: the file's, or the map's when the file has none.

    A unit in the map tags the raw values; when the file already says the column's unit, the two
    must agree (same scale and dimension), else the map would silently relabel, e.g., degrees as
    radians without converting them. Expressions are different: they see SI values, and their unit
    says what the result is.
    """
    if map_unit is None or not file_unit:
        return map_unit if map_unit is not None else file_unit
    try:
        a, b = parse_unit(map_unit), parse_unit(file_unit)
    except InputError:
        agree = map_unit.strip() == file_unit.strip()
    else:
        agree = a.dimension == b.dimension and abs(a.scale - b.scale) <= 1e-12 * abs(b.scale)
    if agree:
        return file_unit
    raise DataFileError(
        f"{path}: channels[{target!r}] = '{body} [{map_unit}]', but the file says {body!r} is in "
        f"[{file_unit}]. Leave the unit out of the map: physid converts [{file_unit}] to SI "
        "itself (a unit in the map is for a column whose header has none)."
    )


def _split_map_unit(text: str) -> tuple[str, str | None]:
    match = _MAP_UNIT.match(text)
    if match and match["expr"].strip():
        return match["expr"].strip(), match["unit"].strip()
    return text.strip(), None


_TIME_NAMES = ("time", "t")


def _find_time(path, variables: Mapping[str, _Var]) -> str:
    if "t" in variables:
        return "t"
    found = [name for name in variables if name.lower() in _TIME_NAMES]
    if not found:  # a struct field: data.time, log.t
        found = [name for name in variables if name.rsplit(".", 1)[-1].lower() in _TIME_NAMES]
    if not found:  # a ROS export: header.stamp, /joint_states.header.stamp
        found = [name for name in variables if name.lower().endswith("header.stamp")]
    if len(found) == 1:
        return found[0]
    if len(found) > 1:
        raise DataFileError(
            f"{path}: several variables could be the time: {found}; say which one with "
            f"channels={{'t': {found[0]!r}}}."
        )
    names = [n for n in variables if n not in _RESERVED or n == "data"]
    shown = names[:20] + (["..."] if len(names) > 20 else [])
    raise DataFileError(
        f"{path}: no time column or variable: physid looks for one named 't' or 'time' (any "
        f"case, e.g. 't [s]' or 'Time [ms]'), else one named 'header.stamp' "
        f"('header.stamp [ns]'); the file has {shown}. Rename it, map it with "
        "channels={'t': 'NAME'}, or give the sample rate of a file without time (rate=)."
    )


def _time_values(path, var: _Var) -> np.ndarray:
    """The time variable as a vector; integer stamps stay integers (converted exactly later)."""
    if var.value is None:
        raise DataFileError(
            f"{path}: the time {var.name!r} holds {var.detail}, not real numbers; store the "
            "sample times in s as floating-point numbers."
        )
    arr = var.value
    if arr.ndim > 1 and sum(d > 1 for d in arr.shape) > 1:
        raise DataFileError(
            f"{path}: the time {var.name!r} has shape {arr.shape}; it must be a vector of sample "
            "times (n_samples,). Store one time per sample."
        )
    flat = arr.reshape(-1)
    return flat.astype(np.int64) if flat.dtype.kind in "iu" else flat.astype(float)


#: the generic fix `physid.units.parse_unit` ends an unknown unit's message with
_UNITS_FIX = " Convert the values to SI, or scale them by their gain to SI."


def _unknown_unit_fix(name: str, unit_text: str, column: str | None) -> str:
    """How to read a channel whose unit physid does not know: a map with the gain to SI."""
    if column is None:  # a unit given in the map: it says what the mapped value is
        return "give the mapped value's unit in SI, e.g. [rad], [m] or [N]"
    kinds = expected_dimensions(name)
    if kinds and kinds[0][1] == "rad":
        example = f"2*pi/4096*{column} [rad]"
        why = (
            f" (an encoder of 4096 counts per turn; a linear axis: GAIN*{column} [m], GAIN in "
            f"m per {unit_text})"
        )
    else:
        si = kinds[0][1] if kinds else "SI_UNIT"
        example = f"GAIN*{column} [{si}]"
        why = f" (GAIN in {si} per {unit_text}; in the expression {column} is the raw number)"
    return (
        f"map it with its gain to SI, channels={{{name!r}: {example!r}}}{why}, or convert "
        "the column to SI before loading"
    )


def _convert(path, name, values, unit_text, *, strict, column=None, row_label=None):
    """Values in SI and the SI unit; (values, None) for an unknown unit when not ``strict``."""
    try:
        u = parse_unit(unit_text)
    except InputError as exc:
        if not strict:
            return values, None
        reason = str(exc).removesuffix(_UNITS_FIX)
        raise DataFileError(
            f"{path}: channel {name!r} has unit {unit_text!r}, which physid cannot convert: "
            f"{reason} To read it, {_unknown_unit_fix(name, unit_text, column)}."
        ) from None
    if u.scale == 1.0:
        return values, u.si
    with np.errstate(over="ignore"):
        converted = values * u.scale
    if not np.all(np.isfinite(converted)):
        i = int(np.argmax(~np.isfinite(converted)))
        raise DataFileError(
            f"{path}: channel {name!r}: the value {float(values[i])!r} {unit_text} at "
            f"{row_label(i) if row_label else f'sample {i}'} "
            "overflows when converted to SI; check the value or the unit."
        )
    return converted, u.si


def _check_kind(path, name, si_unit, *, mapped) -> None:
    """A channel of physid's naming convention must carry a unit of its kind (or none)."""
    kinds = expected_dimensions(name)
    if kinds is None or not si_unit:
        return
    dim = parse_unit(si_unit).dimension
    if any(dim == d for d, _ in kinds):
        return
    wanted = " or ".join(f"{dimension_name(d)} [{u}]" for d, u in kinds)
    fix = (
        f"if it is a gain times this signal (a drive: force = gain × voltage), map it with the "
        f"gain, e.g. channels={{{name!r}: '35.15*{name}'}} (35.15 standing for your drive's "
        f"gain in {kinds[0][1]}/{si_unit} or {kinds[-1][1]}/{si_unit})"
        if not mapped
        else "give the unit of the mapped value in brackets, e.g. "
        f"channels={{{name!r}: '35.15*vir [N]'}}, or correct the source's unit"
    )
    raise DataFileError(
        f"{path}: channel {name!r} is in {si_unit} ({dimension_name(dim)}), but {name} must be "
        f"{wanted}; {fix}."
    )


def _check_magnitude(path, name, values, row_label) -> None:
    with np.errstate(invalid="ignore"):
        big = np.isfinite(values) & (np.abs(values) > MAX_ABS_VALUE)
    if not big.any():
        return
    i = int(np.argmax(big))
    where = row_label(i) if row_label else f"sample {i}"
    raise DataFileError(
        f"{path}: channel {name!r} holds {float(values[i])!r} at {where} ({int(big.sum())} value(s) "
        f"beyond ±{MAX_ABS_VALUE:g} in all); values that large overflow in the products physid "
        "computes (squares, filters). It is probably a fill value for a missing sample: remove "
        "those rows or interpolate them, or rescale the channel."
    )
