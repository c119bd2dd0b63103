"""The Parquet reader (needs pyarrow, the ``parquet`` extra): one column per channel.

A column's unit is its field metadata ``unit`` (or ``units``), else a ``[unit]`` at the end of
its name (``q1 [rad]``, as in a CSV header). A timestamp column becomes integer stamps in its
own unit (``ns``, ``us``, ``ms``, ``s``), kept exact like any integer time. The schema metadata
``physid`` or ``metadata`` (JSON) is the recording's metadata; its numbers can be used in channel
maps, as a CSV file's ``# metadata:`` comment.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import DataFileError, MissingDependencyError
from ..writers import _split_header_cell
from .variables import _add_metadata_scalars, _check_header_names, _classify, _Source, _Var

_TIMESTAMP_UNITS = {"s": "s", "ms": "ms", "us": "us", "ns": "ns"}


def _pyarrow(path):
    """``pyarrow.parquet``, or a `MissingDependencyError` that says how to install it."""
    try:
        import pyarrow.parquet as pq
    except ImportError:
        raise MissingDependencyError(
            f"{path}: reading Parquet files needs pyarrow, which is not installed; run "
            'pip install "physid[parquet]" (or pip install pyarrow), or save the data as CSV, '
            "NPZ or HDF5."
        ) from None
    return pq


def _open_parquet(path: Path, *, streaming: bool = False):
    """The `pyarrow.parquet.ParquetFile` (a damaged file is a `DataFileError`); ``streaming``:
    column chunks read through a 1 MiB buffer, not whole (a block read stays small)."""
    pq = _pyarrow(path)
    kwargs = {"buffer_size": 1 << 20, "pre_buffer": False} if streaming else {}
    try:
        return pq.ParquetFile(path, **kwargs)
    except Exception as exc:  # pyarrow raises ArrowInvalid, OSError ... on damaged files
        raise DataFileError(
            f"{path}: not a readable Parquet file ({type(exc).__name__}: {exc}); write it again "
            "(pandas: df.to_parquet(path)) or save the data as CSV."
        ) from None


def _parquet_layout(path: Path, schema) -> tuple[list[tuple[str, str, str]], dict[str, Any]]:
    """``[(column, channel name, unit)]`` and the metadata, from the file's schema only."""
    columns = []
    for field in schema:
        meta = {k.decode("utf-8", "replace"): v for k, v in (field.metadata or {}).items()}
        unit_bytes = meta.get("unit", meta.get("units"))
        name, unit = field.name, ""
        if unit_bytes is not None:
            unit = unit_bytes.decode("utf-8", "replace").strip()
        else:
            name, unit = _split_header_cell(field.name)
        if _timestamp_unit(field.type) and not unit:
            unit = _timestamp_unit(field.type)
        columns.append((field.name, name, unit))
    _check_header_names(path, [c[1] for c in columns])
    metadata: dict[str, Any] = {}
    raw = schema.metadata or {}
    for key in (b"physid", b"metadata"):
        if key in raw:
            try:
                loaded = json.loads(raw[key])
            except (ValueError, RecursionError):
                loaded = None
            if isinstance(loaded, dict):
                metadata.update(loaded)
    return columns, metadata


def _timestamp_unit(arrow_type) -> str:
    import pyarrow as pa

    if pa.types.is_timestamp(arrow_type) or pa.types.is_duration(arrow_type):
        return _TIMESTAMP_UNITS.get(arrow_type.unit, "")
    return ""


def _column_values(column) -> np.ndarray:
    """A pyarrow column (chunked array) as numpy: nulls become NaN (refused at load with the
    row), timestamps their integer stamps, anything else as pyarrow converts it."""
    import pyarrow as pa

    if _timestamp_unit(column.type):
        column = column.cast(pa.int64())
    if column.null_count:
        if pa.types.is_integer(column.type) or pa.types.is_floating(column.type):
            column = column.cast(pa.float64())
        return np.asarray(column.to_numpy(zero_copy_only=False), dtype=float)
    values = column.to_numpy()
    return values if isinstance(values, np.ndarray) else np.asarray(values)


def _source_from_table(table, columns, metadata) -> _Source:
    """The variables of a table (the whole file, or one block of its rows)."""
    variables: dict[str, _Var] = {}
    for column, name, unit in columns:
        values = table.column(column)
        if _timestamp_unit(values.type):  # stamps: int64 kept exact (time_to_seconds)
            array = _column_values(values)
            variables[name] = _Var(name, array, unit, size=int(array.size))
        else:
            variables[name] = _classify(name, _column_values(values), unit)
        variables[name].column = True  # a column named "data" or "names" is a channel too
    _add_metadata_scalars(variables, metadata)
    return _Source(variables, dict(metadata))


def _read_parquet(path: Path) -> _Source:
    """The whole file, column by column (the same variables a block of it gives)."""
    pf = _open_parquet(path)
    columns, metadata = _parquet_layout(path, pf.schema_arrow)
    try:
        table = pf.read()
    except Exception as exc:  # a damaged page
        raise DataFileError(
            f"{path}: its data cannot be read ({type(exc).__name__}: {exc}); the file is "
            "damaged or truncated. Write it again or save the data as CSV."
        ) from None
    return _source_from_table(table, columns, metadata)
