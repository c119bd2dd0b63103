"""Read and write recordings: CSV, NPZ, MATLAB ``.mat`` (v5 and v7.3) and HDF5.

File layouts
------------
CSV
    A header row of channel names, first column ``t`` [s]; a unit may follow a name in brackets,
    ``q1 [rad]``. Separator ``,`` (``;`` and tab are recognised from the header). Lines starting
    with ``#`` are comments; ``# metadata: {json}`` carries the recording's metadata.
NPZ, MAT, HDF5
    A variable/dataset ``t`` (n_samples,) and either ``data`` (n_samples, n_channels) with
    ``names`` (and optionally ``units``) or one variable per channel: 1-D of length n_samples, or
    2-D (n_samples, k) which becomes channels ``name1..namek``. In HDF5 a dataset attribute
    ``unit`` gives the channel's unit. Scalars and text variables (a sampling rate, a
    description) are not channels: they are skipped and listed in
    ``metadata["ignored_variables"]``.

Every problem with a file raises `DataFileError` naming the file, the channel or row, and the
fix; bad keyword values raise `InputError`, and a missing h5py `MissingDependencyError`.
"""

from __future__ import annotations

import csv
import io
import json
import re
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .._paths import atomic_write
from .._validate import UNIFORM_RTOL
from ..errors import DataFileError, InputError, MissingDependencyError, PhysidError, arg
from .recording import Recording

__all__ = ["load_recording", "save_recording", "DEFAULT_UNIFORM_RTOL", "SUPPORTED_SUFFIXES"]

#: Default relative tolerance on the sample intervals for a file to count as uniformly sampled.
#: Times written with ~7 significant digits still pass; larger jitter needs ``resample=True``.
DEFAULT_UNIFORM_RTOL = 1e-3

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
_TIME_UNITS = {"": 1.0, "s": 1.0, "sec": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6}
_HEADER_UNIT = re.compile(r"^(?P<name>.*?)\s*\[(?P<unit>[^\[\]]*)\]$")
_MAT_RESERVED = {"t", "data", "names", "units", "metadata"}


# =============================================================================== public API
def load_recording(
    path,
    *,
    resample: bool = False,
    uniform_rtol: float | None = DEFAULT_UNIFORM_RTOL,
) -> Recording:
    """Read a recording from CSV, NPZ, MATLAB ``.mat`` or HDF5 (chosen by the file suffix).

    Parameters
    ----------
    path : str or os.PathLike
        The file. Suffixes: ``.csv``/``.txt``, ``.npz``, ``.mat``, ``.h5``/``.hdf5``.
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

    Returns
    -------
    Recording
        With ``metadata["source"]`` (the path) and ``metadata["format"]``.

    Raises
    ------
    InputError
        ``resample`` is not a bool, or ``uniform_rtol`` is neither None nor a finite number ≥ 0.
    DataFileError
        Unknown suffix, missing file, empty file, no ``t``, non-numeric cells, NaN/inf,
        duplicate channel names, time not strictly increasing, non-uniform sampling.
    MissingDependencyError
        An HDF5 or MATLAB v7.3 file and h5py is not installed (``pip install "physid[io]"``).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "r.csv"
    >>> _ = p.write_text("t [s],x [m]\\n0,1\\n0.5,2\\n1.0,4\\n")
    >>> rec = load_recording(p)
    >>> rec.names, rec.units, rec.dt
    (('x',), ('m',), 0.5)
    """
    resample, uniform_rtol = _check_load_options(resample, uniform_rtol)
    path = Path(path)
    fmt = _format_of(path, SUPPORTED_SUFFIXES, "read")
    if not path.is_file():
        raise DataFileError(
            f"{path}: no such file{' (it is a directory)' if path.is_dir() else ''}; "
            "check the path."
        )
    reader = {"csv": _read_csv, "npz": _read_npz, "mat": _read_mat, "hdf5": _read_hdf5}[fmt]
    t, data, names, units, metadata, row_label = reader(path)
    metadata = {**metadata, "source": str(path), "format": fmt}
    return _build(
        path,
        t,
        data,
        names,
        units,
        metadata,
        row_label,
        resample=resample,
        uniform_rtol=uniform_rtol,
    )


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

    Notes
    -----
    CSV values are written with Python's shortest round-trip representation, so
    ``load_recording(save_recording(rec, p))`` returns the same numbers bit for bit.
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
        header = ",".join(
            [_header_cell("t", "s")]
            + [_header_cell(n, u) for n, u in zip(rec.names, rec.units, strict=True)]
        )
        # str() of a list of lists writes every float in its shortest round-trip form (repr) at
        # C speed; reshape "[[a, b], [c, d]]" into "a,b\nc,d"
        table = str(np.column_stack([rec.t, rec.data]).tolist())
        body = table[2:-2].replace("], [", "\n").replace(", ", ",")
        text = f"# metadata: {meta}\n{header}\n{body}\n"
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
                "uniform grid with the mean period, or uniform_rtol=None to keep the time "
                "vector as it is."
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


def _format_of(path: Path, table: Mapping[str, str], action: str) -> str:
    suffix = path.suffix.lower()
    if suffix not in table:
        raise DataFileError(
            f"{path}: cannot {action} files with suffix {suffix or '(none)'!r}; supported: "
            f"{sorted(table)}. Rename the file or convert it."
        )
    return table[suffix]


def _split_header_cell(cell: str) -> tuple[str, str]:
    cell = cell.strip().strip('"').strip("'").strip()
    match = _HEADER_UNIT.match(cell)
    if match:
        return match["name"].strip(), match["unit"].strip()
    return cell, ""


def _header_cell(name: str, unit: str) -> str:
    return f"{name} [{unit}]" if unit else name


def _time_scale(path, unit: str) -> float:
    try:
        return _TIME_UNITS[unit]
    except KeyError:
        raise DataFileError(
            f"{path}: the time column has unit {unit!r}; physid reads time in s (ms and us are "
            "converted). Convert the column to seconds."
        ) from None


# =============================================================================== CSV
def _read_csv(path: Path):
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise DataFileError(
            f"{path}: is not UTF-8 text (byte {exc.start}); save it as UTF-8 CSV."
        ) from None
    # one newline convention, the one numpy's parser uses (\n, \r\n and \r end a line)
    text = text.replace("\r\n", "\n").replace("\r", "\n")
    metadata: dict[str, Any] = {}
    pos, number, header = 0, 0, None
    while pos < len(text):  # comments and blank lines before the header
        end = text.find("\n", pos)
        end = len(text) if end < 0 else end
        line = text[pos:end]
        pos, number = end + 1, number + 1
        stripped = line.strip()
        if stripped.startswith("#"):
            body = stripped.lstrip("#").strip()
            if body.startswith("metadata:"):
                try:
                    loaded = json.loads(body[len("metadata:") :])
                except ValueError:
                    loaded = None
                if isinstance(loaded, dict):
                    metadata.update(loaded)
        elif stripped:
            header = line
            break
    if header is None:
        raise DataFileError(
            f"{path}: the file is empty (no header row); expected a header such as "
            "'t [s],q1 [rad]' followed by rows of numbers."
        )
    header_number = number  # 1-based line number of the header
    delimiter = next((d for d in (",", ";", "\t") if d in header), ",")
    try:
        raw_cells = next(csv.reader([header], delimiter=delimiter))
    except csv.Error as exc:
        raise DataFileError(f"{path}: cannot read the header row ({exc}).") from None
    cells = [_split_header_cell(c) for c in raw_cells]
    names = [c[0] for c in cells]
    units = [c[1] for c in cells]
    if "t" not in names:
        raise DataFileError(
            f"{path}: no time column 't' in the header {header.strip()!r} "
            f"(line {header_number}); the first column must be the time in s, named 't' "
            "(e.g. 't [s],q1 [rad]')."
        )
    t_col = names.index("t")
    body = text[pos:]
    table, line_numbers = _parse_numbers(path, body, header_number, len(names), delimiter, names)
    if table.shape[0] == 0:
        raise DataFileError(
            f"{path}: the header is there but there are no data rows; the file needs at least 2."
        )

    def row_label(i: int) -> str:
        numbers = line_numbers() if callable(line_numbers) else line_numbers
        return f"data row {i + 1} (line {numbers[i]})"

    t = table[:, t_col] * _time_scale(path, units[t_col])
    keep = [j for j in range(len(names)) if j != t_col]
    names_out = [names[j] for j in keep]
    units_out = [units[j] for j in keep]
    return t, table[:, keep], names_out, units_out, metadata, row_label


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
                f"{n_cols} column(s); every row needs one value per column."
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
                    "cell below the header must be a number (with '.' as the decimal point)."
                )


# =============================================================================== NPZ / MAT / HDF5
def _columns_from_mapping(path, items: Mapping[str, np.ndarray], units_by_name=None):
    """t, data, names, units from {name: array} with either data+names or one array per channel."""
    units_by_name = dict(units_by_name or {})
    if "t" not in items:
        raise DataFileError(
            f"{path}: no variable 't' (time in s); found {sorted(items)}. Store the sample times "
            "under the name 't'."
        )
    t = _numeric(path, "t", items["t"]).reshape(-1) if np.size(items["t"]) else np.empty(0)
    n = t.size
    if "data" in items and "names" in items:
        data = _numeric(path, "data", items["data"])
        names = [str(s).strip() for s in np.asarray(items["names"]).reshape(-1)]
        if data.ndim == 1:
            data = data[:, None]
        if data.ndim == 2 and data.shape[0] != n and data.shape[1] == n:
            data = data.T  # stored channel-major (MATLAB/HDF5 column order)
        if data.ndim != 2 or data.shape[1] != len(names):
            raise DataFileError(
                f"{path}: 'data' has shape {data.shape} but 'names' lists {len(names)} channel(s); "
                f"'data' must be (n_samples={n}, n_channels)."
            )
        units = [str(s).strip() for s in np.asarray(items.get("units", [])).reshape(-1)]
        if len(units) != len(names):
            units = [units_by_name.get(nm, "") for nm in names]
        return t, data, names, units, []
    names, columns, units, ignored = [], [], [], []
    for key, value in items.items():
        if key in _MAT_RESERVED:
            continue
        raw = np.asarray(value)
        if raw.dtype.kind not in "biuf" or (raw.size == 1 and n > 1):
            ignored.append(key)  # text or a scalar setting (e.g. fs): not a channel
            continue
        arr = _numeric(path, key, raw)
        if arr.ndim == 2 and 1 in arr.shape and arr.size == n:
            arr = arr.reshape(-1)
        if arr.ndim == 2 and arr.shape[0] != n and arr.shape[1] == n:
            arr = arr.T
        if arr.ndim == 1 and arr.size == n:
            names.append(key)
            columns.append(arr)
            units.append(units_by_name.get(key, ""))
        elif arr.ndim == 2 and arr.shape[0] == n:
            for j in range(arr.shape[1]):
                names.append(f"{key}{j + 1}")
                columns.append(arr[:, j])
                units.append(units_by_name.get(key, ""))
        else:
            raise DataFileError(
                f"{path}: variable {key!r} has shape {arr.shape}; channels must have one value per "
                f"time sample ({n}), i.e. shape ({n},) or ({n}, k)."
            )
    if not names:
        raise DataFileError(
            f"{path}: the file has a time vector 't' but no channels"
            f"{f' (ignored non-channel variables {ignored})' if ignored else ''}."
        )
    return t, np.column_stack(columns), names, units, ignored


def _ignored(metadata: dict, ignored: list[str]) -> dict:
    if ignored:
        metadata = {**metadata, "ignored_variables": ignored}
    return metadata


def _numeric(path, key, value) -> np.ndarray:
    arr = np.asarray(value)
    if arr.dtype.kind not in "biuf":
        raise DataFileError(
            f"{path}: variable {key!r} is not numeric (dtype {arr.dtype}); store numbers only."
        )
    return arr.astype(float)


def _read_npz(path: Path):
    try:
        with np.load(path, allow_pickle=False) as z:
            items = {k: z[k] for k in z.files}
    except (ValueError, OSError, EOFError) as exc:
        raise DataFileError(f"{path}: not a readable NPZ file ({exc}).") from None
    metadata = {}
    if "metadata" in items:
        try:
            loaded = json.loads(str(items["metadata"]))
            metadata = loaded if isinstance(loaded, dict) else {}
        except ValueError:
            metadata = {}
    t, data, names, units, ignored = _columns_from_mapping(path, items)
    return t, data, names, units, _ignored(metadata, ignored), None


def _read_mat(path: Path):
    from scipy import io as sio

    try:
        raw = sio.loadmat(path, squeeze_me=False, chars_as_strings=True)
    except NotImplementedError:  # MATLAB v7.3 is HDF5 underneath
        return _read_hdf5(path, matlab=True)
    except Exception as exc:  # scipy raises many types (IndexError, MatReadError...) on bad files
        raise DataFileError(
            f"{path}: not a readable MATLAB file ({type(exc).__name__}: {exc}); save it from "
            "MATLAB with save(..., '-v7') or as CSV."
        ) from None
    items = {k: v for k, v in raw.items() if not k.startswith("__")}
    for key in ("names", "units"):
        if key in items:
            items[key] = np.array([_mat_string(s) for s in np.asarray(items[key]).reshape(-1)])
    t, data, names, units, ignored = _columns_from_mapping(path, items)
    return t, data, names, units, _ignored({}, ignored), None


def _mat_string(value) -> str:
    arr = np.asarray(value)
    if arr.dtype.kind in "US":
        return "".join(str(s) for s in arr.reshape(-1)).strip()
    if arr.dtype == object and arr.size == 1:
        return _mat_string(arr.reshape(-1)[0])
    return str(value).strip()


def _read_hdf5(path: Path, *, matlab: bool = False):
    try:
        import h5py
    except ImportError:
        kind = "MATLAB v7.3 files" if matlab else "HDF5 files"
        raise MissingDependencyError(
            f"{path}: reading {kind} needs h5py, which is not installed; run "
            'pip install "physid[io]" (or pip install h5py), or save the file as MATLAB v7 '
            "(save -v7) or CSV."
        ) from None
    items: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    try:
        with h5py.File(path, "r") as f:
            for key, obj in f.items():
                if not isinstance(obj, h5py.Dataset) or key.startswith("#"):
                    continue
                value = obj[()]
                if key in ("names", "units"):
                    items[key] = np.array([_h5_string(v, f) for v in np.asarray(value).reshape(-1)])
                    continue
                items[key] = np.asarray(value)
                unit = obj.attrs.get("unit", obj.attrs.get("units", ""))
                if isinstance(unit, bytes):
                    unit = unit.decode("utf-8", "replace")
                units[key] = str(unit)
    except OSError as exc:
        raise DataFileError(f"{path}: not a readable HDF5 file ({exc}).") from None
    if matlab:  # MATLAB stores column-major: a (n, k) matrix comes back as (k, n)
        items = {
            k: (v.T if v.ndim == 2 and k not in ("names", "units") else v) for k, v in items.items()
        }
    t, data, names, units_list, ignored = _columns_from_mapping(path, items, units)
    return t, data, names, units_list, _ignored({}, ignored), None


def _h5_string(value, f) -> str:
    import h5py

    if isinstance(value, h5py.Reference):  # MATLAB v7.3 cell array of char
        chars = np.asarray(f[value][()]).reshape(-1)
        return "".join(chr(int(c)) for c in chars)
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    return str(value)
