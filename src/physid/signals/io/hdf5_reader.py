"""The HDF5 reader, also for MATLAB v7.3 files (needs h5py, the ``io`` extra)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ...errors import DataFileError, MissingDependencyError
from .variables import _MAX_DEPTH, _finish, _from_mapping, _Source


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
