"""The MATLAB ``.mat`` reader (v5 through scipy; v7.3 is HDF5 and goes to the HDF5 reader)."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ..._resources import check_memory, format_bytes
from ...errors import DataFileError, InputError
from .hdf5_reader import _read_hdf5
from .variables import _MAX_DEPTH, _finish, _from_mapping, _Source, _Var

#: Bytes per element of each MATLAB class as scipy returns it (char: numpy's 4-byte unicode);
#: classes not listed (cell, struct, objects) count 8 bytes per element at least.
_CLASS_BYTES = {"double": 8, "single": 4, "int8": 1, "uint8": 1, "int16": 2, "uint16": 2,
                "int32": 4, "uint32": 4, "int64": 8, "uint64": 8, "logical": 1, "char": 4}  # fmt: skip


def _read_mat(path: Path) -> _Source:
    from scipy import io as sio

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            listing = sio.whosmat(path)
            _check_declared_size(path, listing)
            raw = sio.loadmat(path, simplify_cells=True, chars_as_strings=True)
    except NotImplementedError:  # MATLAB v7.3 is HDF5 underneath
        return _read_hdf5(path, matlab=True)
    except DataFileError:
        raise
    except Exception as exc:  # scipy raises many types (IndexError, MatReadError...) on bad files
        raise DataFileError(
            f"{path}: not a readable MATLAB file ({type(exc).__name__}: {exc}); save it from "
            "MATLAB with save(..., '-v7') or as CSV."
        ) from None
    items: dict[str, Any] = {}
    special: dict[str, _Var] = {}
    classes = {name: mclass for name, _, mclass in listing}
    for key, value in raw.items():
        if not key.startswith("__"):
            if classes.get(key) == "cell" and _is_object_array(value) and not _all_text(value):
                why = f"a MATLAB cell array of shape {value.shape} (convert it with cell2mat)"
                special[key] = _skipped(key, why, int(value.size))
                continue
            _flatten_mat(key, value, items, special, 0)
    for key in ("names", "units"):
        if key in items:
            items[key] = np.array([_mat_string(s) for s in np.asarray(items[key]).reshape(-1)])
    source = _from_mapping(path, items)
    for name, var in special.items():
        source.variables.setdefault(name, var)
    return _finish(source, {})


def _check_declared_size(path: Path, listing) -> None:
    """Refuse, before reading, a file whose variables declare more than the memory check."""
    sizes = {}
    for name, shape, mclass in listing:
        n = int(np.prod(shape, dtype=object)) if shape else 1
        if mclass != "sparse":  # kept sparse: its size is that of its stored values
            sizes[name] = n * (_CLASS_BYTES.get(mclass, 8) + 8)  # the values, then as float64
    if not sizes:
        return
    big = max(sizes, key=sizes.get)
    shape = dict((n, s) for n, s, _ in listing)[big]

    def message(nbytes, available):
        return (
            f"{path}: its variables declare {format_bytes(nbytes)} of values to read (the "
            f"largest, {big!r}: shape {shape}), more than half of the {format_bytes(available)} "
            "of memory available; the file is damaged, or too large for one recording: save "
            "the channels you need, or a part of the samples, in a smaller file."
        )

    try:
        check_memory(sum(sizes.values()), what="", fix="", message=message)
    except InputError as exc:
        raise DataFileError(str(exc)) from None


def _flatten_mat(key: str, value, out: dict, special: dict, depth: int) -> None:
    """Structs (dicts after ``simplify_cells``) become dotted names; strings become text; what
    holds no array of numbers (cell and struct arrays, sparse matrices, objects) goes to
    ``special`` as a variable that says what it is (reported, refused if mapped)."""
    if isinstance(value, dict):
        if depth >= _MAX_DEPTH:
            special[key] = _skipped(key, f"a struct nested deeper than {_MAX_DEPTH} levels")
            return
        for sub, v in value.items():
            _flatten_mat(f"{key}.{sub}", v, out, special, depth + 1)
        return
    if isinstance(value, str):
        out[key] = np.array(value)
        return
    if isinstance(value, list):  # a cell array, or a struct array (a list of structs)
        if value and all(isinstance(v, dict) for v in value):
            why = (
                f"a MATLAB struct array of {len(value)} elements (only a 1×1 struct's "
                "fields are read, as name.field)"
            )
        elif value and all(isinstance(v, str) for v in value):
            out[key] = np.array(value)  # a cell array of text: labels
            return
        else:
            why = f"a MATLAB cell array of {len(value)} elements (convert it with cell2mat)"
        special[key] = _skipped(key, why, len(value))
        return
    if _is_sparse(value):
        special[key] = _skipped(
            key,
            f"a MATLAB sparse matrix of shape {value.shape} (convert it with full())",
            int(np.prod(value.shape)),
        )
        return
    if isinstance(value, (int, float, complex, np.number, bool, np.bool_)):
        out[key] = np.asarray(value)
        return
    if not isinstance(value, np.ndarray):
        special[key] = _skipped(key, f"a MATLAB {type(value).__name__} (not an array of numbers)")
        return
    arr = value
    if arr.dtype == object and arr.size and all(isinstance(v, str) for v in arr.reshape(-1)):
        out[key] = arr.astype(str)
        return
    if arr.dtype == object or arr.dtype.names is not None:
        special[key] = _skipped(
            key,
            f"a MATLAB cell or struct array of shape {arr.shape} (not an array of numbers)",
            int(arr.size),
        )
        return
    out[key] = arr


def _skipped(name: str, why: str, size: int = -1) -> _Var:
    """A variable that is not read: as a cell, refused as a channel when it has one element per
    sample, else left out and reported; ``size`` -1 always left out."""
    return _Var(name, None, "", "cell" if size >= 0 else "skipped", why, size)


def _is_object_array(value) -> bool:
    return isinstance(value, np.ndarray) and value.dtype == object


def _all_text(arr) -> bool:
    return bool(arr.size) and all(isinstance(v, str) for v in arr.reshape(-1))


def _is_sparse(value) -> bool:
    return hasattr(value, "tocsc") and hasattr(value, "nnz")


def _mat_string(value) -> str:
    arr = np.asarray(value)
    if arr.dtype.kind in "US":
        return "".join(str(s) for s in arr.reshape(-1)).strip()
    if arr.dtype == object and arr.size == 1:
        return _mat_string(arr.reshape(-1)[0])
    return str(value).strip()
