"""Read and write recordings: CSV, NPZ, MATLAB ``.mat`` (v5 and v7.3) and HDF5.

File layouts
------------
CSV
    A header row of channel names; a unit may follow a name in brackets, ``q1 [rad]``. The
    separator is ``,``, ``;`` or tab (recognised from the header and the first data row, or given
    with ``delimiter=``); ``decimal=","`` reads decimal commas. Lines starting with ``#`` are
    comments; ``# metadata: {json}`` carries the recording's metadata (its numbers can be used in
    channel maps, like the scalars of a ``.mat`` file).
NPZ, MAT, HDF5
    Either ``data`` (n_samples, n_channels) with ``names`` (and optionally ``units``), or one
    variable per channel: 1-D of length n_samples, or 2-D (n_samples, k) which becomes channels
    ``name1..namek``. MATLAB structs and HDF5 groups are reached with dots (``data.pos``). A
    dataset attribute ``unit`` (or ``units``) gives the channel's unit (HDF5, MATLAB v7.3).
    Scalars (a drive gain, a sampling rate) are not channels but may be used in channel maps.

Time
    The column or variable named ``t``, else one named ``time`` in any case (``Time``,
    ``time [ms]``), else the one mapped with ``channels={"t": ...}``.

Units (one rule for every format)
    A unit in a header, an attribute or a channel map is converted to SI with the table of
    `physid.units` at load; the recording keeps the SI unit. A unit the table does not
    know is refused on the channels physid reads (``t``, ``q1``, ``qd1``, ``tau1``, ``r1``,
    ``u``, ``x``, ``y`` and every mapped channel); a unit of the wrong kind for such a channel
    (``[V]`` on ``tau1``) is refused with the map that fixes it. Other channels keep their values
    and unit as they are (listed in ``metadata["unconverted_units"]``).

Channel maps
    ``channels={"t": "time", "q1": "qm", "tau1": "gtau*vir"}``: each recording channel from a
    variable name or arithmetic over variables and scalars of the file (parsed by
    `physid.expressions`, never evaluated as Python; the variables are in SI units). A trailing
    ``[unit]`` gives the unit of an expression's value (``"35.15*vir [N]"``). Unmapped channels
    of the file are kept unless a mapped channel takes their name or a map uses them.

Every problem with a file raises `DataFileError` naming the file, the channel or row, and the
fix; bad keyword values raise `InputError`, an expression physid refuses `ExpressionError`, and
a missing h5py `MissingDependencyError`. Messages name Python keywords (``resample=True``); the
command line shows its own flags instead (``--resample``).
"""

from __future__ import annotations

import csv
import io
import json
import re
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._paths import atomic_write
from .._validate import UNIFORM_RTOL
from ..errors import DataFileError, InputError, MissingDependencyError, PhysidError, arg
from ..units import dimension_name, expected_dimensions, parse_unit
from .recording import Recording

__all__ = [
    "load_recording",
    "save_recording",
    "parse_channel_map",
    "DEFAULT_UNIFORM_RTOL",
    "SUPPORTED_SUFFIXES",
    "MAX_ABS_VALUE",
]

#: Default relative tolerance on the sample intervals for a file to count as uniformly sampled.
#: Times written with ~7 significant digits still pass; larger jitter needs ``resample=True``.
DEFAULT_UNIFORM_RTOL = 1e-3

#: Largest magnitude accepted in a file. Squares of larger values overflow float64 (≈1.8e308),
#: so a value such as 1e308 (a logger's fill value) would surface later as a NaN in a filter or
#: an estimator; it is refused at load, where the row can be named.
MAX_ABS_VALUE = 1e150

SUPPORTED_SUFFIXES = {
    ".csv": "csv",
    ".txt": "csv",
    ".npz": "npz",
    ".mat": "mat",
    ".h5": "hdf5",
    ".hdf5": "hdf5",
    ".hdf": "hdf5",
}
_SAVE_SUFFIXES = (".csv", ".npz")
_HEADER_UNIT = re.compile(r"^(?P<name>.*?)\s*\[(?P<unit>[^\[\]]*)\]$", re.S)
_MAP_UNIT = re.compile(r"^(?P<expr>.*?)\s*\[(?P<unit>[^\[\]]*)\]\s*$", re.S)
_RESERVED = {"t", "data", "names", "units", "metadata"}
#: channels physid itself reads: their units must be known (and of the right kind)
_READ_CHANNEL = re.compile(r"^(t|u|x|y|(q|qd|qdd|tau|r)\d+)$")
_MAX_DEPTH = 8  # nesting of MATLAB structs / HDF5 groups that is followed
_open = open  # opens a file for the readability check (tests replace it to simulate chmod 000)


# =============================================================================== public API
def load_recording(
    path,
    channels: Mapping[str, str] | None = None,
    *,
    resample: bool = False,
    uniform_rtol: float | None = DEFAULT_UNIFORM_RTOL,
    decimal: str = ".",
    delimiter: str | None = None,
    channel_defaults: Mapping[str, str] | None = None,
    channel_defaults_source: str | None = None,
) -> Recording:
    """Read a recording from CSV, NPZ, MATLAB ``.mat`` or HDF5 (chosen by the file suffix).

    Parameters
    ----------
    path : str or os.PathLike
        The file. Suffixes: ``.csv``/``.txt``, ``.npz``, ``.mat``, ``.h5``/``.hdf5``.
    channels : mapping of str to str, optional
        Channel map: recording channel name → a variable of the file (``"qm"``, a struct field
        ``"data.pos"``) or arithmetic over variables and scalars (``"gtau*vir"``), optionally
        followed by the value's unit in brackets (``"35.15*vir [N]"``). ``"t"`` maps the time.
        The variables are in SI units when the expression is evaluated. CLI: ``--map
        t=time,q1=qm,tau1=gtau*vir``. A string ``"t=time,q1=qm"`` is accepted too.
    resample : bool
        If the sampling is not uniform within ``uniform_rtol``, interpolate linearly onto a uniform
        grid with the mean period (`Recording.resample`) instead of raising (CLI: ``--resample``).
        Must be a real bool (a string such as ``'no'`` is refused, not read as truthy).
    uniform_rtol : float ≥ 0 or None
        Largest accepted deviation of a sample interval from the mean period, relative to it
        (finite; NaN or inf are refused).
        Within it the time vector is snapped onto the exact grid ``t0 + k·Δ`` (so that
        ``rec.dt`` works downstream; the worst deviation is kept in ``metadata``). ``None``
        keeps the time vector as it is, uniform or not.
    decimal : {".", ","}
        Decimal mark of a CSV file (CLI: ``--decimal ,``). With ``","`` the separator is ``;``
        or tab.
    delimiter : {",", ";", "\\t"} or None
        Separator of a CSV file; None recognises it from the header and first data row.
    channel_defaults : mapping of str to str, optional
        A channel map from elsewhere, e.g. a model file's ``[recording]`` table; ``channels``
        entries override it. Its entries apply as ``channels``' do, except one whose source
        names the file lacks while the file already has the target channel (physid's own
        recordings, which call it ``q1`` already): that entry is dropped and the file's channel
        is used, listed in ``metadata["channel_defaults_unused"]`` (target → entry).
    channel_defaults_source : str, optional
        What ``channel_defaults`` is, for messages (e.g. ``"the [recording] table of
        axis.toml"``); default ``"channel_defaults="``.

    Returns
    -------
    Recording
        Channels in SI units, with ``metadata["source"]`` (the path) and ``metadata["format"]``;
        ``metadata["channel_map"]`` when a map was given, ``metadata["original_units"]`` for
        converted channels.

    Raises
    ------
    InputError
        A keyword with a bad value.
    DataFileError
        Unknown suffix, missing or unreadable file, empty file, no time, non-numeric cells,
        NaN/inf or values beyond ±`MAX_ABS_VALUE`, duplicate channel names, time not strictly
        increasing, non-uniform sampling, a complex/text/cell channel, a unit that cannot be
        converted or does not fit the channel, a mapped name or struct path that is not there.
    ExpressionError
        A channel-map expression that uses an unknown name or a forbidden construct.
    MissingDependencyError
        An HDF5 or MATLAB v7.3 file and h5py is not installed (``pip install "physid[io]"``).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "r.csv"
    >>> _ = p.write_text("time [ms],pos [mm],F [N]\\n0,1,0\\n500,2,1\\n1000,4,0\\n")
    >>> rec = load_recording(p, {"x": "pos", "u": "F"})
    >>> rec.names, rec.units, rec.dt, rec["x"].tolist()
    (('x', 'u'), ('m', 'N'), 0.5, [0.001, 0.002, 0.004])
    """
    resample, uniform_rtol = _check_load_options(resample, uniform_rtol)
    channels = parse_channel_map(channels)
    defaults = parse_channel_map(channel_defaults) or {}
    decimal, delimiter = _check_csv_options(decimal, delimiter)
    path = Path(path)
    fmt = _format_of(path, SUPPORTED_SUFFIXES, "read")
    _check_readable(path)
    if fmt == "csv":
        source = _read_csv(path, decimal=decimal, delimiter=delimiter)
    else:
        if (decimal, delimiter) != (".", None):
            raise InputError(
                f"decimal= and delimiter= apply to CSV files only; {path} is {fmt.upper()}. "
                "Drop them."
            )
        source = {"npz": _read_npz, "mat": _read_mat, "hdf5": _read_hdf5}[fmt](path)
    source.metadata = {**source.metadata, "source": str(path), "format": fmt}
    return _assemble(
        path, source, channels, resample=resample, uniform_rtol=uniform_rtol,
        defaults=defaults, defaults_source=channel_defaults_source or "channel_defaults=",
    )  # fmt: skip


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


def save_recording(rec: Recording, path, *, overwrite: bool = True) -> Path:
    """Write a recording to CSV (units in the header) or NPZ, chosen by the suffix.

    Parameters
    ----------
    rec : Recording
    path : str or os.PathLike
        ``.csv`` or ``.npz``.
    overwrite : bool
        If False, refuse to replace an existing file.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    DataFileError
        Not a Recording, a bad suffix, an existing file with ``overwrite=False``, a missing
        folder, a unit that holds ``[`` or ``]`` (it could not be read back from a header).

    Notes
    -----
    CSV header cells are quoted where needed (names with commas, quotes or newlines), a name
    that looks like ``name [unit]`` is written with an empty unit ``[]`` after it, and values
    are written with Python's shortest round-trip representation, so
    ``load_recording(save_recording(rec, p))`` returns the same names, units and numbers bit
    for bit whenever the units are SI (non-SI units are converted to SI when read back).
    """
    if not isinstance(rec, Recording):
        raise DataFileError(f"save_recording expects a Recording; got {type(rec).__name__}.")
    path = Path(path)
    if path.suffix.lower() not in _SAVE_SUFFIXES:
        raise DataFileError(
            f"{path}: cannot save to suffix {path.suffix!r}; use one of {list(_SAVE_SUFFIXES)} "
            "(.mat and HDF5 are read-only in physid)."
        )
    if path.exists() and not overwrite:
        raise DataFileError(f"{path} exists; pass overwrite=True or choose another name.")
    if path.parent and not path.parent.exists():
        raise DataFileError(f"{path}: the folder {path.parent} does not exist; create it first.")
    meta = json.dumps(dict(rec.metadata), default=str)
    if path.suffix.lower() == ".csv":
        cells = [_header_cell("t", "s")] + [
            _header_cell(n, u) for n, u in zip(rec.names, rec.units, strict=True)
        ]
        buffer = io.StringIO()
        csv.writer(buffer, lineterminator="\n").writerow(cells)
        header = buffer.getvalue()
        # str() of a list of lists writes every float in its shortest round-trip form (repr) at
        # C speed; reshape "[[a, b], [c, d]]" into "a,b\nc,d"
        table = str(np.column_stack([rec.t, rec.data]).tolist())
        body = table[2:-2].replace("], [", "\n").replace(", ", ",")
        text = f"# metadata: {meta}\n{header}{body}\n"
        atomic_write(path, lambda fh: fh.write(text))
    else:
        arrays = {
            "t": rec.t,
            "data": rec.data,
            "names": np.array(rec.names, dtype=str),
            "units": np.array(rec.units, dtype=str),
            "metadata": np.array(meta),
        }
        atomic_write(path, lambda fh: np.savez(fh, **arrays), binary=True)
    return path


# =============================================================================== validation
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


def _check_readable(path: Path) -> None:
    if not path.is_file():
        raise DataFileError(
            f"{path}: no such file{' (it is a directory)' if path.is_dir() else ''}; "
            "check the path."
        )
    try:
        with _open(path, "rb") as fh:
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


# =============================================================================== variables
@dataclass
class _Var:
    """One variable of a file: numbers (any shape) or a reason it is not numeric."""

    name: str
    value: np.ndarray | None
    unit: str = ""
    kind: str = "numeric"  # numeric | complex | text | cell | other
    detail: str = ""  # the type in words, for messages
    size: int = 0  # number of elements (-1: unknown)


@dataclass
class _Source:
    variables: dict
    metadata: dict
    row_label: Any = None  # callable(i) -> "data row i (line k)" for CSV


def _classify(name: str, value, unit: str = "") -> _Var:
    arr = np.asarray(value) if not isinstance(value, np.ndarray) else value
    kind, size = arr.dtype.kind, int(arr.size)
    if kind in "biuf":
        return _Var(name, arr, unit, size=size)
    if kind == "c":
        return _Var(name, None, unit, "complex", f"complex numbers (dtype {arr.dtype})", size)
    if kind in "US":
        return _Var(name, None, unit, "text", f"text (shape {arr.shape})", size)
    if kind == "O":
        return _Var(name, None, unit, "cell", f"a cell/object array of shape {arr.shape}", size)
    return _Var(name, None, unit, "other", f"values of dtype {arr.dtype}", size)


def _shape_of(var: _Var) -> tuple:
    return var.value.shape if var.value is not None else ()


def _as_channel(var: _Var, n: int):
    """The variable as 1-D (n,), a scalar float, a dict of (n, k) columns, or None."""
    arr = var.value
    if arr is None:
        return None
    if arr.size == 1 and n != 1:
        return float(arr.reshape(-1)[0])
    if arr.ndim == 1 and arr.size == n:
        return arr.astype(float)
    if arr.ndim == 2 and 1 in arr.shape and arr.size == n:
        return arr.reshape(-1).astype(float)
    if arr.ndim == 2 and (arr.shape[0] == n or arr.shape[1] == n):
        cols = arr if arr.shape[0] == n else arr.T
        return {f"{var.name}{j + 1}": cols[:, j].astype(float) for j in range(cols.shape[1])}
    return None


# =============================================================================== assembly
def _missing_names(body: str, available) -> list[str]:
    """The names an expression (or a bare variable) uses that are not in ``available``."""
    body, _ = _split_map_unit(body)
    if body in available:
        return []
    from ..expressions import expression_names

    try:
        names, _ = expression_names(body)
    except PhysidError:
        return []  # a dotted struct path or a syntax error: the normal path explains it
    return [name for name in names if name not in available and name != "pi"]


def _default_entry(path, target, text, available, has_target, source, shown):
    """Whether a channel-defaults entry applies (True) or is dropped (False); or raise."""
    missing = _missing_names(text, available)
    if not missing:
        return True
    if has_target:
        return False
    raise DataFileError(
        f"{path}: {source} maps {target} = {text!r}, but the file has no variable "
        f"{', '.join(repr(m) for m in missing)} and no channel {target!r}; its variables are "
        f"{shown}. Correct that entry, or map the channel from the file's variables with "
        f"channels={{{target!r}: 'NAME'}}."
    )


def _assemble(
    path, source: _Source, channels, *, resample, uniform_rtol, defaults=None, defaults_source=""
) -> Recording:
    """Time, channels, units and the channel map → a checked `Recording` (errors name the file)."""
    variables: dict[str, _Var] = source.variables
    metadata = dict(source.metadata)
    mapping = dict(channels or {})
    defaults = {k: v for k, v in (defaults or {}).items() if k not in mapping}
    unused_defaults: dict[str, str] = {}
    applied: dict[str, str] = {}  # the defaults entries used
    listed = [v for v in variables if v not in _RESERVED]
    shown_vars = listed[:30] + (["..."] if len(listed) > 30 else [])
    if "t" in defaults:
        try:
            _find_time(path, variables)
            has_time = True
        except DataFileError:
            has_time = False
        text = defaults.pop("t")
        if _default_entry(path, "t", text, variables, has_time, defaults_source, shown_vars):
            mapping["t"] = applied["t"] = text
        else:
            unused_defaults["t"] = text
    # ---- time
    t_text = mapping.pop("t", None)
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
            t_name = None
            values = _expression_values(path, variables, 0, "t", t_text)
            t_raw = np.asarray(values, dtype=float).reshape(-1)
            t_unit = t_unit_given or ""
    t = _time_to_seconds(path, t_raw, t_unit)
    n = t.size
    if defaults:  # the model file's entries: used where the file has their sources
        available = set(variables)
        for var in variables.values():
            expanded = _as_channel(var, n)
            if isinstance(expanded, dict):
                available.update(expanded)
        for target, text in defaults.items():
            has = target in available and target != t_name
            if _default_entry(path, target, text, available, has, defaults_source, shown_vars):
                mapping[target] = applied[target] = text
            else:
                unused_defaults[target] = text
    if unused_defaults:
        metadata["channel_defaults_unused"] = unused_defaults
    # ---- which variables the map uses
    used: set[str] = set() if t_name is None else {t_name}
    exprs: dict[str, tuple[str, str | None]] = {}
    for target, text in mapping.items():
        body, unit = _split_map_unit(text)
        exprs[target] = (body, unit)
        if body in variables:
            used.add(body)
        else:
            used.update(_expression_names(body, variables))
    # ---- the file's channels (name -> (values (n,), unit)); non-channels are ignored
    columns: dict[str, tuple[np.ndarray, str]] = {}
    scalars: dict[str, float] = {}
    ignored: list[str] = []
    refused: dict[str, str] = {}
    for name, var in variables.items():
        if name == t_name or name in _RESERVED:
            continue
        value = _as_channel(var, n)
        if isinstance(value, float):
            scalars[name] = value
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
        elif var.kind in ("text", "cell") and 0 <= var.size != n:
            ignored.append(name)  # a description, a date, a list of labels: not a channel
        else:
            refused[name] = (
                f"variable {name!r} holds {var.detail}, not real numbers; physid reads real "
                "floating-point channels only"
            )
    for name in scalars:
        if name not in used:
            ignored.append(name)
    # ---- the recording's channels
    out_names: list[str] = []
    out_values: list[np.ndarray] = []
    out_units: list[str] = []
    original_units: dict[str, str] = {}
    unconverted: dict[str, str] = {}
    row_label = source.row_label

    def add(target, values, unit_text, *, strict, column=None):
        values = np.asarray(values, dtype=float)
        _check_magnitude(path, target, values, row_label)
        si_values, si_unit = _convert(path, target, values, unit_text, strict=strict, column=column)
        if si_unit is None:
            unconverted[target] = unit_text
            si_unit = unit_text
        elif si_unit != unit_text:
            original_units[target] = unit_text
        _check_kind(path, target, si_unit, mapped=target in exprs)
        out_names.append(target)
        out_values.append(si_values)
        out_units.append(si_unit)

    if not exprs:
        if refused:
            name, why = next(iter(refused.items()))
            raise DataFileError(
                f"{path}: {why}. Drop or convert it, or map the channels you need "
                f"with channels={{...}}."
            )
        for name, (values, unit) in columns.items():
            if values is None:
                continue
            add(name, values, unit, strict=bool(_READ_CHANNEL.match(name)), column=name)
    else:
        for target, (body, unit) in exprs.items():
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
                    raise DataFileError(
                        f"{path}: channels[{target!r}] = {body!r}: {refused[body]}."
                    )
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
                add(
                    target, values, _map_unit(path, target, body, unit, file_unit),
                    strict=True, column=body if unit is None else None,
                )  # fmt: skip
                continue
            for name in _expression_names(body, variables):
                if name in refused:
                    raise DataFileError(
                        f"{path}: channels[{target!r}] = {body!r} uses {refused[name]}."
                    )
            values = _expression_values(path, variables, n, target, body, columns, scalars)
            add(target, values, unit or "", strict=True)
        taken = set(out_names)
        for name, (values, unit) in columns.items():
            if values is None or name in used or name in taken:
                if values is not None and name not in used:
                    ignored.append(name)
                continue
            try:
                add(name, values, unit, strict=bool(_READ_CHANNEL.match(name)), column=name)
            except DataFileError:
                ignored.append(name)  # an unused channel that does not load: left out
        ignored.extend(sorted(set(refused) - used))
        metadata["channel_map"] = {**applied, **dict(channels or {})}
    if ignored:
        metadata["ignored_variables"] = sorted(set(ignored))
    if original_units:
        metadata["original_units"] = original_units
    if unconverted:
        metadata["unconverted_units"] = unconverted
    if not out_names:
        raise DataFileError(
            f"{path}: the file has a time column 't' but no channels"
            f"{f' (ignored non-channel variables {sorted(set(ignored))})' if ignored else ''}."
        )
    data = np.column_stack(out_values)
    return _build(
        path, t, data, out_names, out_units, metadata, row_label,
        resample=resample, uniform_rtol=uniform_rtol,
    )  # fmt: skip


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
        f"case, e.g. 't [s]' or 'Time [ms]'); the file has {shown}. Rename it, or map it with "
        "channels={'t': 'NAME'}."
    )


def _time_values(path, var: _Var) -> np.ndarray:
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
    return arr.reshape(-1).astype(float)


def _time_to_seconds(path, t: np.ndarray, unit: str) -> np.ndarray:
    try:
        u = parse_unit(unit)
    except InputError as exc:
        raise DataFileError(f"{path}: the time column has unit {unit!r}: {exc}") from None
    if u.si == "" and u.scale == 1.0:
        return t
    if u.dimension != (0, 0, 1, 0, 0):
        raise DataFileError(
            f"{path}: the time column has unit {unit!r} ({u.words}), not a time; physid reads "
            "time in s (ms, us, min and h are converted). Convert the column to seconds."
        )
    return t * u.scale if u.scale != 1.0 else t


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


def _convert(path, name, values, unit_text, *, strict, column=None):
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
            f"{path}: channel {name!r}: the value {float(values[i])!r} {unit_text} at sample {i} "
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


def _expression_names(body: str, variables) -> tuple[str, ...]:
    """The variables (dotted struct paths included) that an expression mentions."""
    return tuple(
        name
        for name in variables
        if name in body and re.search(rf"(?<![\w.]){re.escape(name)}(?![\w.])", body)
    )


def _expression_values(path, variables, n, target, body, columns=None, scalars=None):
    """Evaluate a channel-map expression over the file's channels (in SI) and scalars."""
    from ..expressions import evaluate_expression

    if columns is None:  # time: over the raw numeric vectors and scalars
        table = {}
        for name, var in variables.items():
            if var.value is not None and var.value.size == 1:
                table[name] = float(var.value.reshape(-1)[0])
            elif var.value is not None and var.value.ndim == 1:
                table[name] = var.value.astype(float)
    else:
        table = dict(scalars or {})
        for name, (values, unit) in columns.items():
            if values is None:
                continue
            try:
                table[name] = parse_unit(unit).scale * values if unit else values
            except InputError:
                table[name] = values  # an unknown unit: the expression sees the raw numbers
    from ..errors import ExpressionError

    try:
        with np.errstate(all="ignore"):
            value = evaluate_expression(body, table, source=f"{path}: channels[{target!r}]")
    except ExpressionError as exc:
        if exc.reason != "unknown_name":
            raise
        arrays = [k for k, v in table.items() if np.ndim(v) > 0]
        numbers = [k for k, v in table.items() if np.ndim(v) == 0]
        shown = arrays[:30] + (["..."] if len(arrays) > 30 else [])
        raise ExpressionError(
            f"{path}: channels[{target!r}] = {body!r}: the file has no variable "
            f"{', '.join(repr(n) for n in exc.names)}; its channels are {shown}"
            + (f" and its scalars {numbers[:20]}" if numbers else "")
            + ". Check the spelling (MATLAB struct fields are written data.pos).",
            reason="unknown_name",
            names=exc.names,
            text=body,
            source=str(path),
        ) from None
    value = np.asarray(value, dtype=float)
    if value.ndim == 0 or value.size == 1 and n != 1:
        raise DataFileError(
            f"{path}: channels[{target!r}] = {body!r} is a constant ({float(value):g}); a "
            "channel needs one value per sample: use at least one channel of the file in it."
        )
    value = value.reshape(-1) if value.ndim > 1 and 1 in value.shape else value
    if value.ndim != 1 or (n and value.size != n):
        raise DataFileError(
            f"{path}: channels[{target!r}] = {body!r} has shape {value.shape}, not one value "
            f"per time sample ({n},)."
        )
    bad = ~np.isfinite(value)
    if bad.any():
        i = int(np.argmax(bad))
        raise DataFileError(
            f"{path}: channels[{target!r}] = {body!r} is {value[i]} at sample {i} "
            f"({int(bad.sum())} non-finite value(s)); check for a division by zero or a "
            "logarithm of a negative value."
        )
    return value


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


# =============================================================================== CSV
def _split_header_cell(cell: str) -> tuple[str, str]:
    cell = cell.strip()
    match = _HEADER_UNIT.match(cell)
    if match:
        return match["name"].strip(), match["unit"].strip()
    return cell, ""


def _header_cell(name: str, unit: str) -> str:
    """``name [unit]`` (or ``name`` alone) such that `_split_header_cell` gives both back."""
    if "\r" in name or "\r" in unit:
        raise DataFileError(
            f"channel {name!r}: a carriage return in a name or unit cannot be stored in a CSV "
            "header (readers turn it into a newline); rename the channel."
        )
    if "[" in unit or "]" in unit:
        raise DataFileError(
            f"channel {name!r}: the unit {unit!r} holds a bracket, which a CSV header cannot "
            "carry ('name [unit]'); rename the unit."
        )
    cell = f"{name} [{unit}]" if unit else name
    if _split_header_cell(cell) != (name, unit):
        cell = f"{name} [{unit}]"  # e.g. a name 'pos [deg]' without unit: 'pos [deg] []'
    return cell


def _header_end(text: str, start: int) -> int:
    """Index of the newline that ends the (possibly quoted, multi-line) header row."""
    quoted = False
    i = start
    while i < len(text):
        ch = text[i]
        if ch == '"':
            quoted = not quoted
        elif ch == "\n" and not quoted:
            return i
        i += 1
    return len(text)


def _guess_delimiter(header: str, first_row: str | None, decimal: str) -> str:
    candidates = (";", "\t") if decimal == "," else (",", ";", "\t")
    best = None
    for d in candidates:
        try:
            n_head = len(next(csv.reader([header], delimiter=d)))
            n_row = len(next(csv.reader([first_row], delimiter=d))) if first_row else n_head
        except (csv.Error, StopIteration):
            continue
        if n_head > 1 and n_head == n_row:
            return d
        if best is None and d in header:
            best = d
    return best or candidates[0]


def _read_csv(path: Path, *, decimal: str = ".", delimiter: str | None = None) -> _Source:
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise DataFileError(
            f"{path}: is not UTF-8 text (byte {exc.start}); save it as UTF-8 CSV."
        ) from None
    except OSError as exc:
        raise DataFileError(f"{path}: cannot be read ({exc.strerror or exc}).") from None
    # one newline convention, the one numpy's parser uses (\n, \r\n and \r end a line)
    text = text.replace("\r\n", "\n").replace("\r", "\n")
    metadata: dict[str, Any] = {}
    pos, number, header = 0, 0, None
    while pos < len(text):  # comments and blank lines before the header
        end = text.find("\n", pos)
        end = len(text) if end < 0 else end
        line = text[pos:end]
        stripped = line.strip()
        if stripped.startswith("#"):
            pos, number = end + 1, number + 1
            body = stripped.lstrip("#").strip()
            if body.startswith("metadata:"):
                try:
                    loaded = json.loads(body[len("metadata:") :])
                except (ValueError, RecursionError):
                    loaded = None
                if isinstance(loaded, dict):
                    metadata.update(loaded)
        elif stripped:
            end = _header_end(text, pos)
            header = text[pos:end]
            number += 1
            header_number = number + header.count("\n")  # line of the header's last line
            pos = end + 1
            break
        else:
            pos, number = end + 1, number + 1
    if header is None:
        raise DataFileError(
            f"{path}: the file is empty (no header row); expected a header such as "
            "'t [s],q1 [rad]' followed by rows of numbers."
        )
    body = text[pos:]
    first_row = next((c for _, c in _data_lines(body, 0)), None)
    if delimiter is None:
        delimiter = _guess_delimiter(header, first_row, decimal)
    try:
        raw_cells = next(csv.reader(io.StringIO(header), delimiter=delimiter))
    except (csv.Error, StopIteration) as exc:
        raise DataFileError(f"{path}: cannot read the header row ({exc}).") from None
    cells = [_split_header_cell(c) for c in raw_cells]
    names = [c[0] for c in cells]
    units = [c[1] for c in cells]
    _check_header_names(path, names)
    if decimal == ",":
        body = body.replace(",", ".")
    table, line_numbers = _parse_numbers(path, body, header_number, len(names), delimiter, names)
    if table.shape[0] == 0:
        raise DataFileError(
            f"{path}: the header is there but there are no data rows; the file needs at least 2."
        )

    def row_label(i: int) -> str:
        numbers = line_numbers() if callable(line_numbers) else line_numbers
        return f"data row {i + 1} (line {numbers[i]})"

    variables = {
        name: _Var(name, table[:, j], units[j]) for j, name in enumerate(names)
    }  # fmt: skip
    for key, value in metadata.items():  # numbers in the metadata: scalars for channel maps
        if (
            isinstance(key, str)
            and key not in variables
            and isinstance(value, (int, float))
            and not isinstance(value, bool)
        ):
            variables[key] = _Var(key, np.array([float(value)]))
    return _Source(variables, metadata, row_label)


def _check_header_names(path, names) -> None:
    seen: dict[str, int] = {}
    for i, name in enumerate(names):
        if not name:
            raise DataFileError(
                f"{path}: channel {i + 1} has an empty name; give every column a name."
            )
        if name in seen:
            which = "'t' appears twice; the time column must be unique" if name == "t" else (
                f"duplicate channel name {name!r} (channels {seen[name]} and {i}); channel names "
                "must be unique, rename one of them"
            )  # fmt: skip
            raise DataFileError(f"{path}: {which}.")
        seen[name] = i


def _data_lines(body: str, first_number: int) -> list[tuple[int, str]]:
    """(1-based line number, content) of the lines holding data: comments and blanks dropped."""
    out = []
    for k, line in enumerate(body.split("\n")):
        content = line.split("#", 1)[0]
        if content.strip():
            out.append((first_number + k, content))
    return out


def _parse_numbers(path, body, header_number, n_cols, delimiter, names):
    """Fast path: numpy's C parser on the whole body; on failure a slow pass names the bad cell.

    Returns the table and the line numbers of its rows (computed lazily on the fast path, since
    they are needed only for error messages).
    """
    kwargs = dict(delimiter=delimiter, ndmin=2, dtype=float, comments="#", quotechar='"')
    try:
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", "loadtxt: input contained no data", UserWarning)
            table = np.loadtxt(io.StringIO(body), **kwargs)
        if table.size and table.shape[1] == n_cols:
            return table, lambda: [n for n, _ in _data_lines(body, header_number + 1)]
    except (ValueError, TypeError, IndexError, OverflowError):
        pass
    # slow path: drop blank and comment lines the way a person would, check every cell, retry
    lines = _data_lines(body, header_number + 1)
    if not lines:
        return np.empty((0, n_cols)), []
    _diagnose(path, lines, n_cols, delimiter, names)
    try:
        table = np.loadtxt(io.StringIO("\n".join(c for _, c in lines)), **kwargs)
    except (ValueError, TypeError, IndexError, OverflowError) as exc:
        raise DataFileError(
            f"{path}: could not read the numbers ({exc}); check the separator and the cells."
        ) from None
    if table.shape != (len(lines), n_cols):
        raise DataFileError(
            f"{path}: read a table of shape {table.shape} but expected {len(lines)} rows of "
            f"{n_cols} columns; check the separator."
        )
    return table, [n for n, _ in lines]


def _diagnose(path, data_lines, n_cols, delimiter, names) -> None:
    """Raise a `DataFileError` at the first row or cell the fast parser could not read."""
    for line_number, line in data_lines:
        try:
            cells = next(csv.reader([line], delimiter=delimiter), [])
        except csv.Error as exc:
            raise DataFileError(f"{path}: cannot read line {line_number} ({exc}).") from None
        if len(cells) != n_cols:
            raise DataFileError(
                f"{path}: line {line_number} has {len(cells)} cell(s) but the header has "
                f"{n_cols} column(s); every row needs one value per column (if the file uses "
                "decimal commas, pass decimal=',')."
            )
        for j, cell in enumerate(cells):
            try:
                float(cell)
                ok = cell.strip() != "" and "_" not in cell
            except ValueError:
                ok = False
            if not ok:
                what = "empty cell" if not cell.strip() else f"non-numeric cell {cell.strip()!r}"
                raise DataFileError(
                    f"{path}: {what} in column {names[j]!r} at line {line_number}; every "
                    "cell below the header must be a number (with '.' as the decimal point, or "
                    "pass decimal=',')."
                )


# =============================================================================== NPZ / MAT / HDF5
def _from_mapping(path, items: Mapping[str, Any], units_by_name=None) -> _Source:
    """Variables from ``{name: array}``: ``data`` + ``names`` expanded, the rest one each."""
    units_by_name = dict(units_by_name or {})
    variables: dict[str, _Var] = {}
    if "data" in items and "names" in items:
        data_var = _classify("data", items["data"])
        if data_var.value is None:
            raise DataFileError(
                f"{path}: variable 'data' holds {data_var.detail}, not real numbers; store "
                "numbers only."
            )
        data = data_var.value
        names = [str(s).strip() for s in np.asarray(items["names"]).reshape(-1)]
        t_size = np.size(items["t"]) if "t" in items else None
        if data.ndim == 1:
            data = data[:, None]
        if data.ndim == 2 and t_size and data.shape[0] != t_size and data.shape[1] == t_size:
            data = data.T  # stored channel-major (MATLAB/HDF5 column order)
        if data.ndim != 2 or data.shape[1] != len(names):
            raise DataFileError(
                f"{path}: 'data' has shape {data.shape} but 'names' lists {len(names)} channel(s); "
                f"'data' must be (n_samples, n_channels={len(names)})."
            )
        units = [str(s).strip() for s in np.asarray(items.get("units", [])).reshape(-1)]
        if len(units) != len(names):
            units = [units_by_name.get(nm, "") for nm in names]
        _check_header_names(path, ["t", *names] if "t" in items else names)
        if "t" in items:
            variables["t"] = _classify("t", items["t"], units_by_name.get("t", ""))
        for j, name in enumerate(names):
            variables[name] = _Var(name, data[:, j], units[j], size=data.shape[0])
        for key, value in items.items():  # scalars next to data (a gain) stay usable
            if key not in _RESERVED and key not in variables:
                var = _classify(key, value, units_by_name.get(key, ""))
                if var.value is not None and var.value.size == 1:
                    variables[key] = var
        return _Source(variables, {})
    for key, value in items.items():
        if key not in ("names", "units", "metadata"):
            variables[key] = _classify(key, value, units_by_name.get(key, ""))
    return _Source(variables, {})


def _finish(source: _Source, metadata: dict) -> _Source:
    source.metadata = {**metadata, **source.metadata}
    return source


def _read_npz(path: Path) -> _Source:
    # never allow_pickle: an object array in a .npz can run code when unpickled
    with open(path, "rb") as fh:
        magic = fh.read(6)
    if magic.startswith(b"\x93NUMPY"):
        raise DataFileError(
            f"{path}: holds a single .npy array, not an NPZ archive of named variables; save it "
            "with numpy.savez(path, t=..., x=...)."
        )
    if not magic.startswith((b"PK\x03\x04", b"PK\x05\x06")):
        raise DataFileError(
            f"{path}: not an NPZ file: it is not a zip archive (it starts with {magic!r}); the "
            "file is damaged or of another format. Write it with numpy.savez(path, t=..., "
            "x=...) or save the data as CSV."
        )
    try:  # the file object is ours, so a damaged archive cannot leak an open handle
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
            items, refused = {}, {}
            for k in z.files:
                try:
                    items[k] = z[k]
                except ValueError as exc:
                    if "allow_pickle" in str(exc) or "Object arrays" in str(exc):
                        refused[k] = "a Python object array (physid never unpickles data)"
                    else:
                        raise
    except DataFileError:
        raise
    except (ValueError, OSError, EOFError, KeyError, RuntimeError, NotImplementedError) as exc:
        raise DataFileError(_npz_error(path, exc)) from None
    except Exception as exc:  # zipfile.BadZipFile, zlib.error, struct.error ... on damaged files
        raise DataFileError(_npz_error(path, exc)) from None
    metadata: dict = {}
    if "metadata" in items:
        try:
            loaded = json.loads(str(items["metadata"]))
            metadata = loaded if isinstance(loaded, dict) else {}
        except (ValueError, RecursionError):
            metadata = {}
    source = _from_mapping(path, items)
    for key, why in refused.items():
        source.variables[key] = _Var(key, None, "", "cell", why, -1)
    return _finish(source, metadata)


def _npz_error(path, exc) -> str:
    kind = type(exc).__name__
    detail = str(exc)
    if "pickle" in detail.lower():
        detail = "its content is not numeric arrays"
    return (
        f"{path}: not a readable NPZ file ({kind}: {detail}); the file is damaged, truncated or "
        "not made by numpy.savez. Write it again with numpy.savez(path, t=..., x=...) or save "
        "the data as CSV."
    )


def _read_mat(path: Path) -> _Source:
    from scipy import io as sio

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            raw = sio.loadmat(path, simplify_cells=True, chars_as_strings=True)
    except NotImplementedError:  # MATLAB v7.3 is HDF5 underneath
        return _read_hdf5(path, matlab=True)
    except Exception as exc:  # scipy raises many types (IndexError, MatReadError...) on bad files
        raise DataFileError(
            f"{path}: not a readable MATLAB file ({type(exc).__name__}: {exc}); save it from "
            "MATLAB with save(..., '-v7') or as CSV."
        ) from None
    items: dict[str, Any] = {}
    for key, value in raw.items():
        if not key.startswith("__"):
            _flatten_mat(key, value, items, 0)
    for key in ("names", "units"):
        if key in items:
            items[key] = np.array([_mat_string(s) for s in np.asarray(items[key]).reshape(-1)])
    return _finish(_from_mapping(path, items), {})


def _flatten_mat(key: str, value, out: dict, depth: int) -> None:
    """Structs (dicts after ``simplify_cells``) become dotted names; strings become text."""
    if isinstance(value, dict):
        if depth >= _MAX_DEPTH:
            return
        for sub, v in value.items():
            _flatten_mat(f"{key}.{sub}", v, out, depth + 1)
        return
    if isinstance(value, str):
        out[key] = np.array(value)
        return
    if isinstance(value, list):  # a cell array
        out[key] = np.array(value, dtype=object) if value else np.array([], dtype=object)
        return
    if isinstance(value, (int, float, complex, np.number, bool, np.bool_)):
        out[key] = np.asarray(value)
        return
    arr = np.asarray(value)
    if arr.dtype == object and arr.size and all(isinstance(v, str) for v in arr.reshape(-1)):
        out[key] = arr.astype(str)
        return
    out[key] = arr


def _mat_string(value) -> str:
    arr = np.asarray(value)
    if arr.dtype.kind in "US":
        return "".join(str(s) for s in arr.reshape(-1)).strip()
    if arr.dtype == object and arr.size == 1:
        return _mat_string(arr.reshape(-1)[0])
    return str(value).strip()


def _read_hdf5(path: Path, *, matlab: bool = False) -> _Source:
    try:
        import h5py
    except ImportError:
        kind = "MATLAB v7.3 files" if matlab else "HDF5 files"
        raise MissingDependencyError(
            f"{path}: reading {kind} needs h5py, which is not installed; run "
            'pip install "physid[io]" (or pip install h5py), or save the file as MATLAB v7 '
            "(save -v7) or CSV."
        ) from None
    items: dict[str, Any] = {}
    units: dict[str, str] = {}
    try:
        with h5py.File(path, "r") as f:
            _walk_hdf5(f, "", f, items, units, matlab, 0)
    except (OSError, ValueError, KeyError, RuntimeError, TypeError) as exc:
        raise DataFileError(f"{path}: not a readable HDF5 file ({exc}).") from None
    return _finish(_from_mapping(path, items, units), {})


def _walk_hdf5(group, prefix, f, items, units, matlab, depth) -> None:
    import h5py

    if depth > _MAX_DEPTH:
        return
    for key, obj in group.items():
        if key.startswith("#"):
            continue
        name = f"{prefix}{key}"
        if isinstance(obj, h5py.Group):
            _walk_hdf5(obj, f"{name}.", f, items, units, matlab, depth + 1)
            continue
        if not isinstance(obj, h5py.Dataset):
            continue
        value = obj[()]
        mclass = obj.attrs.get("MATLAB_class", b"")
        mclass = mclass.decode("ascii", "replace") if isinstance(mclass, bytes) else str(mclass)
        if name in ("names", "units"):
            items[name] = np.array([_h5_string(v, f) for v in np.asarray(value).reshape(-1)])
            continue
        if mclass == "char":
            items[name] = np.array("".join(chr(int(c)) for c in np.asarray(value).reshape(-1)))
            continue
        arr = np.asarray(value)
        if arr.dtype.kind == "V" and arr.dtype.names and {"real", "imag"} <= set(arr.dtype.names):
            arr = arr["real"] + 1j * arr["imag"]  # MATLAB v7.3 complex
        elif arr.dtype.kind == "O" or arr.dtype.kind == "V":
            arr = np.array(arr, dtype=object)
        if matlab and arr.ndim == 2:  # MATLAB stores column-major: (n, k) comes back as (k, n)
            arr = arr.T
        items[name] = arr
        unit = obj.attrs.get("unit", obj.attrs.get("units", ""))
        if isinstance(unit, bytes):
            unit = unit.decode("utf-8", "replace")
        if isinstance(unit, np.ndarray):
            unit = _h5_string(unit.reshape(-1)[0], f) if unit.size else ""
        units[name] = str(unit)


def _h5_string(value, f) -> str:
    import h5py

    if isinstance(value, h5py.Reference):  # MATLAB v7.3 cell array of char
        chars = np.asarray(f[value][()]).reshape(-1)
        return "".join(chr(int(c)) for c in chars)
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    return str(value)
