"""A file's variables as the readers hand them over (`_Var`, `_Source`), the limits every format
shares, and the ``data`` + ``names`` layout of NPZ, MAT and HDF5 files (`_from_mapping`)."""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import DataFileError, PhysidWarning

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
    ".parquet": "parquet",
}
_RESERVED = {"t", "data", "names", "units", "metadata"}
#: channels physid itself reads: their units must be known (and of the right kind)
_READ_CHANNEL = re.compile(r"^(t|u|x|y|(q|qd|qdd|tau|r)\d+)$")
_MAX_DEPTH = 8  # nesting of MATLAB structs / HDF5 groups that is followed
#: Largest integer float64 holds exactly; integer channels beyond it would be rounded silently.
_MAX_EXACT_INT = 2**53


class DataFileWarning(PhysidWarning):
    """A data file's variables that were not read as channels (a MATLAB cell array, a sparse
    matrix, text, a dangling HDF5 link, ...), named with the reason; the recording's
    ``metadata["skipped_variables"]`` lists them too."""


@dataclass
class _Var:
    """One variable of a file: numbers (any shape) or a reason it is not numeric."""

    name: str
    value: np.ndarray | None
    unit: str = ""
    kind: str = "numeric"  # numeric | complex | text | cell | other | skipped (not a channel)
    detail: str = ""  # the type in words, for messages
    size: int = 0  # number of elements (-1: unknown)
    origin: int | None = None  # integer stamps: the record's first stamp (a block of a file)
    column: bool = False  # a named column of the table: a channel even if named like a layout key


@dataclass
class _Source:
    variables: dict
    metadata: dict
    row_label: Any = None  # callable(i) -> "data row i (line k)" for CSV


def _add_metadata_scalars(variables: dict, metadata: Mapping) -> None:
    """The numbers of a table file's metadata (CSV, Parquet) as scalar variables, in place,
    for channel maps (``tau1 = "g*cur"``); a column of the same name keeps its place."""
    for key, value in metadata.items():  # numbers in the metadata: scalars for channel maps
        if (
            isinstance(key, str)
            and key not in variables
            and isinstance(value, (int, float))
            and not isinstance(value, bool)
        ):
            variables[key] = _Var(key, np.array([float(value)]))


def _classify(name: str, value, unit: str = "") -> _Var:
    arr = np.asarray(value) if not isinstance(value, np.ndarray) else value
    kind, size = arr.dtype.kind, int(arr.size)
    if kind in "iu" and size and arr.dtype.itemsize >= 8:
        worst = max(abs(int(arr.min())), abs(int(arr.max())))
        if worst > _MAX_EXACT_INT:
            return _Var(
                name, None, unit, "other",
                f"integers up to {worst} (dtype {arr.dtype}), beyond 2**53, which float64 "
                "cannot hold exactly", size,
            )  # fmt: skip
    if kind in "biuf" and arr.dtype.itemsize <= 8:
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
            variables[name] = _Var(name, data[:, j], units[j], size=data.shape[0], column=True)
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
