"""From a file's variables to a `Recording`: the time, the channel defaults, the channel map, the
file's own channels and their units, in that order (every format goes through `_assemble`)."""

from __future__ import annotations

import contextlib
import re
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...errors import DataFileError, PhysidError
from ..recording import Recording
from .build import _build
from .channel_map import _default_entry, _expression_names, _expression_values
from .conversion import (
    _check_kind,
    _check_magnitude,
    _convert,
    _find_time,
    _map_unit,
    _split_map_unit,
    _time_values,
)
from .timebase import rate_time, samples_of, time_to_seconds, unit_hint
from .variables import _READ_CHANNEL, _RESERVED, DataFileWarning, _as_channel, _Source, _Var


def _assemble(
    path, source: _Source, channels, *, resample, uniform_rtol, defaults=None, defaults_source="",
    rate=None, rate_source="rate=",
) -> Recording:  # fmt: skip
    """Time, channels, units and the channel map → a checked `Recording` (errors name the file)."""
    variables: dict[str, _Var] = source.variables
    metadata = dict(source.metadata)
    mapping = dict(channels or {})
    # the file's variables for messages: a column named like a layout key is one, time is not
    listed = [v for v, var in variables.items() if v not in _RESERVED or var.column and v != "t"]
    found = _Defaults(
        path,
        defaults_source,
        {k: v for k, v in (defaults or {}).items() if k not in mapping},
        listed[:30] + (["..."] if len(listed) > 30 else []),
    )
    if "t" in found.pending:
        _place_time_default(found, mapping, variables)
    with _blame_table(found, "t"):
        t, t_name, origin = _time(path, variables, mapping.pop("t", None), rate, rate_source)
    if origin:
        metadata["time_origin"] = origin
    if rate is not None and t_name == "":  # the time of a file without one
        metadata["rate"] = rate
    n = t.size
    if found.pending:  # the model file's entries: used where the file has their sources
        _place_defaults(found, mapping, variables, n, t_name)
    if found.unused:
        metadata["channel_defaults_unused"] = found.unused
    exprs, used = _parse_map(mapping, variables, t_name)
    table = _file_channels(variables, t_name, n, used)
    out = _Output(path, source.row_label, exprs)
    if not exprs:
        _add_file_channels(path, table, out)
    else:
        for target, (body, unit) in exprs.items():
            with _blame_table(found, target):
                _add_mapped(path, target, body, unit, variables, t_name, table, out, n)
        _add_unmapped(table, used, out)
        metadata["channel_map"] = {**found.applied, **dict(channels or {})}
    if table.ignored:
        metadata["ignored_variables"] = sorted(set(table.ignored))
        _report_skipped(path, variables, table, metadata)
    if out.original_units:
        metadata["original_units"] = out.original_units
    if out.unconverted:
        metadata["unconverted_units"] = out.unconverted
    if not out.names:
        ignored = table.ignored
        raise DataFileError(
            f"{path}: the file has a time column 't' but no channels"
            f"{f' (ignored non-channel variables {sorted(set(ignored))})' if ignored else ''}."
        )
    data = np.column_stack(out.values)
    return _build(
        path, t, data, out.names, out.units, metadata, source.row_label,
        resample=resample, uniform_rtol=uniform_rtol,
    )  # fmt: skip


# =============================================================================== channel defaults
@dataclass
class _Defaults:
    """The ``channel_defaults`` entries still to place, and which were applied or dropped."""

    path: Any
    source: str  # what the defaults are, for messages
    pending: dict[str, str]
    shown: list  # the file's variables, for messages
    applied: dict[str, str] = field(default_factory=dict)
    unused: dict[str, str] = field(default_factory=dict)

    def place(self, mapping, target, text, available, has_target) -> None:
        """Add the entry to ``mapping`` if the file has its sources, else note it unused."""
        if _default_entry(self.path, target, text, available, has_target, self.source, self.shown):
            mapping[target] = self.applied[target] = text
        else:
            self.unused[target] = text


@contextlib.contextmanager
def _blame_table(found: _Defaults, target: str):
    """Errors of an entry placed from the defaults name the defaults (the model file's
    ``[recording]`` table), not ``channels[...]``, which the caller never wrote."""
    try:
        yield
    except PhysidError as exc:
        if target not in found.applied or not found.source:
            raise
        text = str(exc).replace(f"channels[{target!r}]", f"{found.source} entry {target}")
        if text == str(exc):
            raise
        try:
            new = type(exc)(text)
        except TypeError:  # an error class with required keywords: keep it as it is
            raise exc from None
        for key, value in vars(exc).items():
            if key not in ("template", "arguments"):
                setattr(new, key, value)
        raise new from None


def _place_time_default(found: _Defaults, mapping, variables) -> None:
    try:
        _find_time(found.path, variables)
        has_time = True
    except DataFileError:
        has_time = False
    found.place(mapping, "t", found.pending.pop("t"), variables, has_time)


def _place_defaults(found: _Defaults, mapping, variables, n, t_name) -> None:
    available = set(variables)
    for var in variables.values():
        expanded = _as_channel(var, n)
        if isinstance(expanded, dict):
            available.update(expanded)
    for target, text in found.pending.items():
        has = target in available and target != t_name
        found.place(mapping, target, text, available, has)


# =============================================================================== time
def _time(path, variables, t_text, rate=None, rate_source="rate="):
    """The time in s, the variable it came from (None: an expression; "": from ``rate``) and
    the integer origin subtracted (`time_to_seconds`), or None."""
    if rate is not None:
        t_name = _rate_conflict(path, variables, t_text, rate_source)
        if t_name is None:
            n = samples_of(variables)
            if n == 0:
                raise DataFileError(f"{path}: the file holds no channels with samples.")
            return rate_time(n, rate), "", None
    if t_text is None:
        t_name = _find_time(path, variables)
        t_var = variables[t_name]
        t_raw = _time_values(path, t_var)
        t_unit = t_var.unit
    else:
        t_text, t_unit_given = _split_map_unit(t_text)
        if t_text in variables:
            t_name, t_var = t_text, variables[t_text]
            t_raw = _time_values(path, t_var)
            t_unit = t_unit_given if t_unit_given is not None else t_var.unit
        else:
            t_name, t_var = None, None
            values = _expression_values(path, variables, 0, "t", t_text)
            t_raw = np.asarray(values, dtype=float).reshape(-1)
            t_unit = t_unit_given or ""
    t, origin = time_to_seconds(path, t_raw, t_unit, t_var.origin if t_name else None)
    unit_hint(path, t_name if t_name is not None else t_text, t, t_unit)
    return t, t_name, origin


def _rate_conflict(path, variables, t_text, rate_source) -> str | None:
    """With a rate: None when the file has no time; its time's name when the rate comes from a
    model's table (the file's own time wins); an error for a rate given with a time."""
    if t_text is not None:
        name = t_text
    else:
        try:
            name = _find_time(path, variables)
        except DataFileError:
            return None
    if rate_source != "rate=":
        return name  # a table's default: the file's own time wins
    raise DataFileError(
        f"{path}: rate= gives the sample rate of a file without a time column, but this file "
        f"has its time in {name!r}; drop rate= (the time column is used), or, to ignore that "
        "column, remove it from the file."
    )


# =============================================================================== the file's channels
def _parse_map(mapping, variables, t_name):
    """Each map entry as (body, unit), and the variables the map uses (the time's included)."""
    used: set[str] = set() if t_name is None else {t_name}
    exprs: dict[str, tuple[str, str | None]] = {}
    for target, text in mapping.items():
        body, unit = _split_map_unit(text)
        exprs[target] = (body, unit)
        if body in variables:
            used.add(body)
        else:
            used.update(_expression_names(body, variables))
    return exprs, used


@dataclass
class _FileChannels:
    """The file's variables sorted out: channels, scalars, and those left out or refused."""

    columns: dict[str, tuple[np.ndarray | None, str]]  # None: the 2-D whole (expanded)
    scalars: dict[str, float]
    ignored: list[str]
    refused: dict[str, str]  # name -> why it cannot be a channel


def _file_channels(variables, t_name, n, used) -> _FileChannels:
    """The file's channels (name -> (values (n,), unit)); non-channels are ignored."""
    table = _FileChannels({}, {}, [], {})
    columns, refused = table.columns, table.refused
    for name, var in variables.items():
        if name == t_name or name in _RESERVED and (name == "t" or not var.column):
            continue  # a channel named like a layout key (data, names, units, metadata) stays
        value = _as_channel(var, n)
        if isinstance(value, float):
            table.scalars[name] = value
        elif isinstance(value, dict):
            for sub, col in value.items():
                columns.setdefault(sub, (col, var.unit))
            columns.setdefault(name, (None, var.unit))  # marker: the 2-D whole (expanded)
        elif value is not None:
            columns[name] = (value, var.unit)
        elif var.kind == "numeric":
            refused[name] = (
                f"variable {name!r} has shape {var.value.shape}; channels must have one value "
                f"per time sample ({n}), i.e. shape ({n},) or ({n}, k)"
            )
        elif var.kind == "skipped" or var.kind in ("text", "cell") and 0 <= var.size != n:
            table.ignored.append(name)  # a description, a date, a list of labels: not a channel
        else:
            refused[name] = (
                f"variable {name!r} holds {var.detail}, not real numbers; physid reads real "
                "floating-point channels only"
            )
    for name in table.scalars:
        if name not in used:
            table.ignored.append(name)
    return table


def _report_skipped(path, variables, table: _FileChannels, metadata) -> None:
    """Name the variables left out because they hold no real numbers (never silently)."""
    skipped = {}
    for name in sorted(set(table.ignored)):
        var = variables.get(name)
        if var is not None and var.value is None:
            skipped[name] = var.detail
    if not skipped:
        return
    metadata["skipped_variables"] = skipped
    shown = "; ".join(f"{k!r}: {v}" for k, v in list(skipped.items())[:8])
    more = f"; and {len(skipped) - 8} more" if len(skipped) > 8 else ""
    warnings.warn(
        f"{path}: {len(skipped)} variable(s) not read as channels, they hold no real numbers: "
        f"{shown}{more}. If you need one, convert it to a numeric array in the file (MATLAB: "
        "cell2mat, full, double).",
        DataFileWarning,
        stacklevel=4,
    )


# =============================================================================== the recording's channels
@dataclass
class _Output:
    """The recording's channels as they are added: values in SI and their units."""

    path: Any
    row_label: Any
    mapped: dict  # the channel map's targets
    names: list[str] = field(default_factory=list)
    values: list[np.ndarray] = field(default_factory=list)
    units: list[str] = field(default_factory=list)
    original_units: dict[str, str] = field(default_factory=dict)
    unconverted: dict[str, str] = field(default_factory=dict)

    def add(self, target, values, unit_text, *, strict, column=None) -> None:
        """Check and convert one channel to SI, then append it."""
        path = self.path
        values = np.asarray(values, dtype=float)
        _check_magnitude(path, target, values, self.row_label)
        si_values, si_unit = _convert(
            path, target, values, unit_text, strict=strict, column=column, row_label=self.row_label
        )
        if si_unit is None:
            self.unconverted[target] = unit_text
            si_unit = unit_text
        elif si_unit != unit_text:
            self.original_units[target] = unit_text
        _check_kind(path, target, si_unit, mapped=target in self.mapped)
        self.names.append(target)
        self.values.append(si_values)
        self.units.append(si_unit)


def _add_file_channels(path, table: _FileChannels, out: _Output) -> None:
    """No channel map: every channel of the file, as it is named there."""
    if table.refused:
        name, why = next(iter(table.refused.items()))
        raise DataFileError(
            f"{path}: {why}. Drop or convert it, or map the channels you need "
            f"with channels={{...}}."
        )
    for name, (values, unit) in table.columns.items():
        if values is None:
            continue
        out.add(name, values, unit, strict=bool(_READ_CHANNEL.match(name)), column=name)


def _add_mapped(path, target, body, unit, variables, t_name, table, out, n) -> None:
    """One channel-map entry: a variable of the file, or an expression over them."""
    columns, scalars, refused = table.columns, table.scalars, table.refused
    if body in variables and variables[body].value is None:
        var = variables[body]
        raise DataFileError(
            f"{path}: channels[{target!r}] = {body!r} holds {var.detail}, not real "
            "numbers; map a numeric variable."
        )
    if body == t_name:
        raise DataFileError(
            f"{path}: channels[{target!r}] = {body!r} is the file's time column, which "
            f"is the recording's time t, not a channel; map {target} from another "
            f"variable (the time is found by name or mapped as channels={{'t': {body!r}}})."
        )
    if body in variables or body in columns:
        if body in refused:
            raise DataFileError(f"{path}: channels[{target!r}] = {body!r}: {refused[body]}.")
        if body in scalars:
            raise DataFileError(
                f"{path}: channels[{target!r}] = {body!r} is a scalar "
                f"({scalars[body]:g}), not a channel with one value per sample; use it "
                f"in an expression, e.g. channels={{{target!r}: '{body}*SIGNAL'}}."
            )
        values, file_unit = columns.get(body, (None, ""))
        if values is None:
            k = len([c for c in columns if re.fullmatch(re.escape(body) + r"\d+", c)])
            raise DataFileError(
                f"{path}: channels[{target!r}] = {body!r} is a 2-D variable with {k} "
                f"columns; map one column, e.g. channels={{{target!r}: '{body}1'}}."
            )
        out.add(
            target, values, _map_unit(path, target, body, unit, file_unit),
            strict=True, column=body if unit is None else None,
        )  # fmt: skip
        return
    for name in _expression_names(body, variables):
        if name in refused:
            raise DataFileError(f"{path}: channels[{target!r}] = {body!r} uses {refused[name]}.")
    values = _expression_values(
        path, variables, n, target, body, columns, scalars, row_label=out.row_label
    )
    out.add(target, values, unit or "", strict=True)


def _add_unmapped(table: _FileChannels, used, out: _Output) -> None:
    """With a channel map: the file's other channels, kept unless a map entry took their name
    or used them; one that does not load is left out (listed as ignored)."""
    taken = set(out.names)
    for name, (values, unit) in table.columns.items():
        if values is None or name in used or name in taken:
            if values is not None and name not in used:
                table.ignored.append(name)
            continue
        try:
            out.add(name, values, unit, strict=bool(_READ_CHANNEL.match(name)), column=name)
        except DataFileError:
            table.ignored.append(name)  # an unused channel that does not load: left out
    table.ignored.extend(sorted(set(table.refused) - used))
