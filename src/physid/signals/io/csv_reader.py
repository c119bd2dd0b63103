"""The CSV reader: header (names and units), separator, decimal mark, metadata comment, and the
numbers (numpy's parser, with a slow pass that names the first bad row or cell)."""

from __future__ import annotations

import csv
import io
import json
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import DataFileError
from ..writers import _split_header_cell
from .variables import _add_metadata_scalars, _check_header_names, _Source, _Var


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


def _read_text(path: Path) -> str:
    """The file as text with ``\\n`` line ends (numpy's parser ends a line at \\n, \\r\\n and \\r)."""
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise DataFileError(
            f"{path}: is not UTF-8 text (byte {exc.start}); save it as UTF-8 CSV."
        ) from None
    except OSError as exc:
        raise DataFileError(f"{path}: cannot be read ({exc.strerror or exc}).") from None
    # one newline convention, the one numpy's parser uses (\n, \r\n and \r end a line)
    return text.replace("\r\n", "\n").replace("\r", "\n")


def _header_row(text: str) -> tuple[dict[str, Any], str | None, int, int]:
    """The metadata comment, the header row (None if there is none), the line number of the
    header's last line and the position after it."""
    metadata: dict[str, Any] = {}
    pos, number, header, header_number = 0, 0, None, 0
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
    return metadata, header, header_number, pos


def _read_csv(path: Path, *, decimal: str = ".", delimiter: str | None = None) -> _Source:
    text = _read_text(path)
    metadata, names, units, delimiter, header_number, pos = _csv_header(
        path, text, decimal, delimiter
    )
    body = text[pos:]
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

    return _csv_source(body, table, names, units, delimiter, metadata, row_label)


def _csv_header(path, text: str, decimal: str, delimiter: str | None):
    """The metadata comment, the channel names and units, the separator, the line number of the
    header's last line and the position after it, from the file's text (or its beginning, up
    to its first data row)."""
    metadata, header, header_number, pos = _header_row(text)
    if header is None:
        raise DataFileError(
            f"{path}: the file is empty (no header row); expected a header such as "
            "'t [s],q1 [rad]' followed by rows of numbers."
        )
    first_row = next((c for _, c in _data_lines(text[pos:], 0)), None)
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
    return metadata, names, units, delimiter, header_number, pos


def _csv_source(body, table, names, units, delimiter, metadata, row_label) -> _Source:
    """The variables of parsed rows (the whole file, or a block of its rows): one per column,
    and the metadata's numbers as scalars for channel maps."""
    variables = {
        name: _Var(name, _exact_integers(body, table, j, delimiter), units[j], column=True)
        for j, name in enumerate(names)
    }  # fmt: skip
    _add_metadata_scalars(variables, metadata)
    return _Source(variables, metadata, row_label)


def _exact_integers(body: str, table: np.ndarray, j: int, delimiter: str) -> np.ndarray:
    """Column ``j``; beyond 2**53 (epoch nanoseconds) re-read as int64, which holds it exactly.

    A float64 keeps integers exactly only up to 2**53 ≈ 9.0e15: epoch stamps in ns (≈1.7e18)
    read as floats lose ~256 ns each, which at 500 Hz is a jitter of 1e-4 of the period.
    """
    column = table[:, j]
    if not np.any(np.abs(column) >= 2.0**53):  # NaN compares False: no all-NaN warning
        return column
    try:
        exact = np.loadtxt(
            io.StringIO(body), delimiter=delimiter, usecols=[j], dtype=np.int64, comments="#",
            quotechar='"', ndmin=1,
        )  # fmt: skip
    except (ValueError, TypeError, IndexError, OverflowError):
        return column  # not plain integers (1.7e18, 1.5): the floats as read
    return exact if exact.shape == column.shape else column


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
