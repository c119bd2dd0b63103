"""The MATLAB ``.mat`` reader (v5 through scipy; v7.3 is HDF5 and goes to the HDF5 reader)."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import DataFileError
from .hdf5_reader import _read_hdf5
from .variables import _MAX_DEPTH, _finish, _from_mapping, _Source


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
