"""Write recordings to CSV and NPZ, and the CSV header cell ``name [unit]``.

Below `physid.signals.recording` and the readers of `physid.signals.io`: `Recording.save` and
`Recording.from_dataframe` use it without importing the readers, which import `Recording`.
"""

from __future__ import annotations

import csv
import io
import json
import re
from pathlib import Path

import numpy as np

from .._paths import atomic_write
from ..errors import DataFileError

__all__ = ["write_recording"]

_SAVE_SUFFIXES = (".csv", ".npz")
_HEADER_UNIT = re.compile(r"^(?P<name>.*?)\s*\[(?P<unit>[^\[\]]*)\]$", re.S)


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


def write_recording(rec, path, *, overwrite: bool = True) -> Path:
    """Write a recording to CSV (units in the header) or NPZ, chosen by the suffix.

    `physid.signals.io.save_recording` checks that ``rec`` is a `Recording` and calls this;
    `Recording.save` calls it directly.

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
        A bad suffix, an existing file with ``overwrite=False``, a missing folder, a unit that
        holds ``[`` or ``]`` (it could not be read back from a header).
    """
    path = Path(path)
    if path.suffix.lower() not in _SAVE_SUFFIXES:
        raise DataFileError(
            f"{path}: cannot save to suffix {path.suffix!r}; use one of {list(_SAVE_SUFFIXES)} "
            "(.mat and HDF5 are read-only in physid)."
        )
    exists = DataFileError(f"{path} exists; pass overwrite=True or choose another name.")
    if path.exists() and not overwrite:
        raise exists
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
        write = lambda fh: fh.write(text)  # noqa: E731
        binary = False
    else:
        arrays = {
            "t": rec.t,
            "data": rec.data,
            "names": np.array(rec.names, dtype=str),
            "units": np.array(rec.units, dtype=str),
            "metadata": np.array(meta),
        }
        write = lambda fh: np.savez(fh, **arrays)  # noqa: E731
        binary = True
    try:  # without overwrite, a file that appears meanwhile is never replaced either
        atomic_write(path, write, binary=binary, exclusive=not overwrite)
    except FileExistsError:
        raise exists from None
    return path
