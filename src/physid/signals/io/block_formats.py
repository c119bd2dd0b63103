"""The formats `open_blocks` reads a block at a time: each gives the `_Source` of rows ``a:b``.

Every reader here learns the file's layout (names, shapes, types, units, scalars) once without
reading its samples, and then, for one pass over the record, hands out the variables of a range
of rows as the whole-file reader would have them (`_from_mapping`, `_csv_source`,
`_source_from_table`), so that `_assemble` makes of them what `load_recording` makes of the file.

HDF5 / MATLAB v7.3
    h5py dataset slices (MATLAB's column-major storage transposed back); the links and storage
    of every dataset are checked by the whole-file reader's walk, on every pass.
NPZ
    An uncompressed member is read at its offset inside the zip (one read per block); a
    compressed one is decompressed forward only, one block of rows after the other (a pass
    restarts the stream).
CSV
    A first scan counts the data rows without holding them; a pass parses the data lines in
    chunks with the whole-file parser (decimal commas, separators, exact integer stamps).
Parquet
    ``iter_batches`` (row groups in order), batches joined or cut to the block's rows.
"""

from __future__ import annotations

import contextlib
import struct
import zipfile
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import DataFileError, MissingDependencyError
from .conversion import _find_time, _split_map_unit
from .csv_reader import _csv_header, _csv_source, _diagnose, _parse_numbers
from .npz_reader import _npz_error
from .variables import _finish, _from_mapping, _Source, _Var

#: Non-per-sample variables up to this many elements are read (scalars, short vectors); larger
#: ones are never channels, and only their shape is kept.
_SMALL = 4096
#: Bytes a CSV file's beginning is read in, looking for its header and first data row.
_CSV_PREFIX = 1 << 16
#: Bytes skipped at once in a compressed NPZ member that is read forward.
_SKIP_BYTES = 1 << 22


def _read_slice(ds, axis: int, a: int, b: int, transposed: bool) -> np.ndarray:
    """Rows ``a:b`` of a dataset or memory map, sample-major: shape (b-a,) or (b-a, k).

    ``axis`` is the sample axis of the variable as the whole-file reader sees it;
    ``transposed``: the storage is that variable transposed (MATLAB v7.3).
    """
    ndim = len(ds.shape)
    stored_axis = 1 - axis if transposed and ndim == 2 else axis
    index = (slice(a, b),) if stored_axis == 0 else (slice(None), slice(a, b))
    out = np.array(ds[index])
    if transposed and ndim == 2:
        out = out.T
    return out.T if axis == 1 else out


# =============================================================================== variables by name
@dataclass
class _Column:
    """A variable with one value (row) per sample, read by slices."""

    shape: tuple  # as the whole-file reader sees it (MATLAB transposed back)
    axis: int  # its sample axis
    dtype: Any


@dataclass
class _Mapping:
    """A file of named arrays (NPZ, HDF5, MATLAB v7.3): what is read by slices, what is not."""

    path: Path
    order: list  # variable names in the whole-file reader's order
    fixed: dict  # name -> value (text, scalars, short arrays, the shapes of the others)
    columns: dict  # name -> _Column
    units: dict
    unread: dict  # name -> _Var without values
    metadata: dict
    n: int = 0
    misfit: dict = field(default_factory=dict)  # name -> (shape, dtype) of a large non-channel
    replace_unread: bool = False  # NPZ: an unread variable replaces the one of the same name

    def source(self, arrays: dict) -> _Source:
        """The `_Source` of one range of rows (``arrays``: its slice of every column)."""
        items = {}
        for k in self.order:
            if k in self.columns:
                items[k] = arrays[k]
            elif k in self.misfit:  # its shape only, no memory (and nothing to pickle)
                items[k] = np.broadcast_to(np.zeros((), self.misfit[k][1]), self.misfit[k][0])
            else:
                items[k] = self.fixed[k]
        source = _from_mapping(self.path, items, self.units)
        for name, (shape, _) in self.misfit.items():
            if name in source.variables:
                source.variables[name] = _Var(
                    name, None, self.units.get(name, ""), "other",
                    f"an array of shape {shape}, not one value per sample ({self.n} samples)",
                    int(np.prod(shape, dtype=object)),
                )  # fmt: skip
        for name, var in self.unread.items():
            if self.replace_unread:
                source.variables[name] = var
            else:
                source.variables.setdefault(name, var)
        return _finish(source, dict(self.metadata))

    def sort(self, shapes: dict, dtypes: dict, load, channels, defaults) -> None:
        """Split the variables into columns (read by slices) and the rest (``load(name)``)."""
        self.n = _record_length(self.path, shapes, self.fixed, channels, defaults)
        n = self.n
        for name in self.order:
            if name in self.fixed or name in self.misfit:
                continue
            shape = shapes[name]
            axis = _sample_axis(shape, n)
            if axis is not None:
                self.columns[name] = _Column(shape, axis, dtypes[name])
                continue
            size = int(np.prod(shape, dtype=object)) if shape else 1
            if size <= _SMALL:
                self.fixed[name] = load(name)
            else:  # never a channel: only its shape matters (refused or ignored as whole)
                self.misfit[name] = (shape, dtypes[name])

    def row_bytes(self) -> int:
        """Bytes one sample takes across the columns, read and then as float64."""
        total = 0
        for col in self.columns.values():
            k = int(np.prod(col.shape, dtype=object)) // max(col.shape[col.axis], 1)
            total += k * (np.dtype(col.dtype).itemsize + 8)
        return total


def _sample_axis(shape: tuple, n: int) -> int | None:
    if len(shape) == 1 and shape[0] == n:
        return 0
    if len(shape) == 2 and n > 1:
        if shape[0] == n:
            return 0
        if shape[1] == n:
            return 1
    return None


def _record_length(path, shapes: dict, fixed: dict, channels, defaults) -> int:
    """Samples of the record, from shapes only: the time's length (as `_assemble` finds the
    time), else the rows of ``data``, else the most common length (as `samples_of`)."""

    def length(name):
        shape = shapes.get(name)
        if shape is None:
            return None
        if len(shape) == 1:
            return shape[0]
        if len(shape) == 2 and 1 in shape:
            return max(shape)
        return None

    names = []
    for text in ((channels or {}).get("t"), (defaults or {}).get("t")):
        if text:
            names.append(_split_map_unit(text)[0])
    names.append("t")
    with contextlib.suppress(DataFileError):
        names.append(_find_time(path, dict.fromkeys([*shapes, *fixed])))
    for name in names:
        found = length(name)
        if found and found >= 1:
            return int(found)
    if "data" in shapes and "names" in fixed and len(shapes["data"]) == 2:
        k = np.size(fixed["names"])
        rows, cols = shapes["data"]
        return int(cols if rows == k and cols != k else rows)
    counts: dict[int, int] = {}
    for shape in shapes.values():
        size = int(np.prod(shape, dtype=object)) if shape else 1
        if size <= 1 or len(shape) not in (1, 2):
            continue
        m = size if len(shape) == 1 or 1 in shape else shape[0]
        counts[m] = counts.get(m, 0) + 1
    return max(counts, key=lambda m: (counts[m], m)) if counts else 0


# =============================================================================== HDF5, MATLAB v7.3
class _Hdf5Blocks:
    """HDF5 (and MATLAB v7.3) by dataset slices; the file is opened for each pass."""

    how = "by dataset slices (h5py)"

    def __init__(self, path: Path, channels, defaults, *, matlab: bool = False):
        self.path, self.matlab = path, matlab
        with self._walk() as walk:
            pending = walk.pending
            self.layout = _Mapping(
                path, list(walk.items) + list(pending), dict(walk.items), {}, {}, walk.unread, {}
            )
            shapes = {k: self._shape(ds) for k, ds in pending.items()}
            dtypes = {k: ds.dtype for k, ds in pending.items()}
            for name, ds in pending.items():
                self.layout.units[name] = _unit_of(ds)

            def load(name):
                arr = np.asarray(pending[name][()])
                return arr.T if matlab and arr.ndim == 2 else arr

            self.layout.sort(shapes, dtypes, load, channels, defaults)
            self.stored = {k: ds.shape for k, ds in pending.items()}
        self.n = self.layout.n

    def _shape(self, ds) -> tuple:
        shape = tuple(int(s) for s in ds.shape)
        return shape[::-1] if self.matlab and len(shape) == 2 else shape

    @contextlib.contextmanager
    def _walk(self):
        """The file open, walked by the whole-file reader (links and storage checked)."""
        try:
            import h5py
        except ImportError:
            kind = "MATLAB v7.3 files" if self.matlab else "HDF5 files"
            raise MissingDependencyError(
                f"{self.path}: reading {kind} needs h5py, which is not installed; run "
                'pip install "physid[io]" (or pip install h5py), or save the file as CSV.'
            ) from None
        from .hdf5_reader import _Walk

        walk = _Walk(self.path, self.matlab)
        try:
            with h5py.File(self.path, "r") as f:
                walk.f = f
                walk.group(f, "", 0)
                yield walk
        except (DataFileError, MissingDependencyError):
            raise
        except (OSError, ValueError, KeyError, RuntimeError, TypeError) as exc:
            raise DataFileError(f"{self.path}: not a readable HDF5 file ({exc}).") from None

    @contextlib.contextmanager
    def reading(self) -> Iterator:
        """One pass: ``read(a, b)`` gives the `_Source` of rows ``a:b``."""
        with self._walk() as walk:
            now = {k: walk.pending[k].shape for k in self.stored if k in walk.pending}
            if now != self.stored:
                raise _changed(self.path, "its datasets changed shape")
            layout = self.layout

            def read(a, b):
                arrays = {
                    k: _read_slice(walk.pending[k], col.axis, a, b, self.matlab)
                    for k, col in layout.columns.items()
                }
                return layout.source(arrays)

            yield read


def _unit_of(ds) -> str:
    from .hdf5_reader import _unit_of as unit_of

    return unit_of(ds)


def _changed(path, what: str) -> DataFileError:
    return DataFileError(
        f"{path}: the file changed while it was read in blocks ({what}); a file that is still "
        "being written cannot be read in blocks. Wait until it is complete (or copy it) and "
        "open it again."
    )


# =============================================================================== NPZ
@dataclass
class _Member:
    info: Any  # zipfile.ZipInfo
    shape: tuple
    fortran: bool
    dtype: Any
    header: int  # bytes of the .npy header inside the member


class _NpzBlocks:
    """NPZ by slices: stored members read at their offset, compressed ones decompressed forward."""

    how = "by slices (uncompressed members at their offset, compressed ones streamed forward)"

    def __init__(self, path: Path, channels, defaults):
        self.path = path
        members, fixed, unread = {}, {}, {}
        try:
            with zipfile.ZipFile(path) as zf:
                for info in zf.infolist():
                    key = info.filename.removesuffix(".npy")
                    member = _npy_member(zf, info)
                    if member.dtype.hasobject:
                        why = "a Python object array (physid never unpickles data)"
                        unread[key] = _Var(key, None, "", "cell", why, -1)
                        fixed[key] = np.zeros(0)
                        continue
                    members[key] = member
                    if key in ("names", "units", "metadata") or member.dtype.kind in "USV":
                        fixed[key] = _load_member(zf, info, key, path)
        except DataFileError:
            raise
        except Exception as exc:  # zipfile.BadZipFile, zlib.error, struct.error, ValueError ...
            raise DataFileError(_npz_error(path, exc)) from None
        self.members = members
        order = [k for k in list(members) + list(unread) if k not in ()]
        metadata = _npz_metadata(fixed.get("metadata"))
        self.layout = _Mapping(path, order, fixed, {}, {}, unread, metadata, replace_unread=True)
        shapes = {k: m.shape for k, m in members.items()}
        dtypes = {k: m.dtype for k, m in members.items()}

        def load(name):
            with zipfile.ZipFile(path) as zf:
                return _load_member(zf, members[name].info, name, path)

        self.layout.sort(shapes, dtypes, load, channels, defaults)
        self.n = self.layout.n
        for key, col in self.layout.columns.items():
            m = members[key]
            if m.info.compress_type != zipfile.ZIP_STORED and not _rows_contiguous(m, col):
                raise DataFileError(
                    f"{path}: member {key!r} is compressed and stored channel by channel (shape "
                    f"{m.shape}, {'Fortran' if m.fortran else 'C'} order), so its samples cannot "
                    "be read a block at a time; save it uncompressed (numpy.savez) or as "
                    "(n_samples, k) in C order, or load the file whole with load_recording."
                )

    @contextlib.contextmanager
    def reading(self) -> Iterator:
        """One pass: ``read(a, b)`` gives the `_Source` of rows ``a:b`` (forward for the
        compressed members)."""
        layout = self.layout
        with open(self.path, "rb") as raw, zipfile.ZipFile(raw) as zf:
            readers = {}
            for key, col in layout.columns.items():
                m = self.members[key]
                if m.info.compress_type == zipfile.ZIP_STORED:
                    readers[key] = _StoredMember(self.path, raw, m, col)
                else:
                    readers[key] = _StreamedMember(self.path, zf, m, col)

            def read(a, b):
                try:
                    arrays = {k: r.read(a, b) for k, r in readers.items()}
                except DataFileError:
                    raise
                except Exception as exc:  # a damaged member (zlib.error, EOFError ...)
                    raise DataFileError(_npz_error(self.path, exc)) from None
                return layout.source(arrays)

            try:
                yield read
            finally:
                for r in readers.values():
                    r.close()


def _npy_member(zf, info) -> _Member:
    """Shape, order and type of one ``.npy`` member, from its header alone."""
    with zf.open(info) as fh:
        version = np.lib.format.read_magic(fh)
        if version == (1, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_1_0(fh)
        else:
            shape, fortran, dtype = np.lib.format.read_array_header_2_0(fh)
        header = fh.tell()
    return _Member(info, tuple(int(s) for s in shape), bool(fortran), dtype, header)


def _load_member(zf, info, key, path) -> np.ndarray:
    with zf.open(info) as fh:
        try:
            return np.lib.format.read_array(fh, allow_pickle=False)
        except ValueError as exc:
            raise DataFileError(_npz_error(path, exc)) from None


def _npz_metadata(value) -> dict:
    import json

    if value is None:
        return {}
    try:
        loaded = json.loads(str(value))
    except (ValueError, RecursionError):
        return {}
    return loaded if isinstance(loaded, dict) else {}


def _rows_contiguous(m: _Member, col: _Column) -> bool:
    """Whether a sample's elements lie together, one sample after the other, in storage."""
    if len(m.shape) == 1 or min(m.shape) == 1:
        return True
    return (col.axis == 0) != m.fortran


class _StoredMember:
    """An uncompressed member read at its offset in the zip: a block's rows are one read, or
    one per column when the member is stored channel-major (nothing mapped, nothing kept)."""

    def __init__(self, path, raw, m: _Member, col: _Column):
        raw.seek(m.info.header_offset)
        local = raw.read(30)
        if len(local) < 30 or local[:4] != b"PK\x03\x04":
            raise DataFileError(_npz_error(path, ValueError("a damaged local header")))
        name_len, extra_len = struct.unpack("<HH", local[26:30])
        self.offset = m.info.header_offset + 30 + name_len + extra_len + m.header
        self.path, self.m, self.raw = path, m, raw
        self.n = m.shape[col.axis]
        self.row = int(np.prod(m.shape, dtype=object)) // max(self.n, 1)
        self.together = _rows_contiguous(m, col)

    def _bytes(self, start: int, count: int) -> np.ndarray:
        item = self.m.dtype.itemsize
        self.raw.seek(self.offset + start * item)
        buf = self.raw.read(count * item)
        if len(buf) != count * item:
            raise _changed(self.path, f"member {self.m.info.filename!r} ended early")
        return np.frombuffer(buf, dtype=self.m.dtype)

    def read(self, a, b):
        m = b - a
        if self.together:
            arr = self._bytes(a * self.row, m * self.row)
            return arr if len(self.m.shape) == 1 else arr.reshape(m, self.row)
        columns = [self._bytes(j * self.n + a, m) for j in range(self.row)]  # one per channel
        return np.column_stack(columns)

    def close(self):
        self.raw = None


class _StreamedMember:
    """A compressed member read forward: rows ``a:b`` after rows ``..a`` (each pass reopens)."""

    def __init__(self, path, zf, m: _Member, col: _Column):
        self.path, self.m = path, m
        self.fh = zf.open(m.info)
        self.fh.read(m.header)
        self.pos = 0
        self.row = int(np.prod(m.shape, dtype=object)) // max(m.shape[col.axis], 1)
        self.itemsize = m.dtype.itemsize

    def read(self, a, b):
        if a < self.pos:
            raise DataFileError(f"{self.path}: rows {a}..{b} asked after row {self.pos}.")
        skip = (a - self.pos) * self.row * self.itemsize
        while skip > 0:
            chunk = self.fh.read(min(skip, _SKIP_BYTES))
            if not chunk:
                raise _changed(self.path, f"member {self.m.info.filename!r} ended early")
            skip -= len(chunk)
        want = (b - a) * self.row * self.itemsize
        buf = bytearray()
        while len(buf) < want:
            chunk = self.fh.read(want - len(buf))
            if not chunk:
                raise _changed(self.path, f"member {self.m.info.filename!r} ended early")
            buf += chunk
        self.pos = b
        arr = np.frombuffer(bytes(buf), dtype=self.m.dtype)
        return arr.reshape(b - a, self.row) if len(self.m.shape) == 2 else arr

    def close(self):
        self.fh.close()


# =============================================================================== CSV
class _CsvBlocks:
    """CSV in chunks of data lines, parsed by the whole-file parser; a first scan counts them."""

    how = "in chunks of lines (a first scan counts the rows)"

    def __init__(self, path: Path, decimal: str, delimiter: str | None):
        self.path, self.decimal = path, decimal
        prefix = self._prefix()
        meta, names, units, delimiter, header_number, pos = _csv_header(
            path, prefix, decimal, delimiter
        )
        self.metadata, self.names, self.units, self.delimiter = meta, names, units, delimiter
        self.header_number, self.skip = header_number, pos
        head: list = []
        tail: deque = deque(maxlen=2)
        n = 0
        with self._lines() as lines:
            for row in lines:
                if n < 2:
                    head.append(row)
                tail.append(row)
                n += 1
        if n == 0:
            raise DataFileError(
                f"{path}: the header is there but there are no data rows; the file needs at "
                "least 2."
            )
        self.n, self.head, self.tail = n, head, list(tail)

    def _prefix(self) -> str:
        """The file's beginning, up to its first data row (or all of it)."""
        size = _CSV_PREFIX
        while True:
            with self._text() as fh:
                text = fh.read(size)
                more = fh.read(1) != ""
            if not more or text.count("\n") >= 2 and _has_data_after_header(text):
                return text
            size *= 4

    @contextlib.contextmanager
    def _text(self):
        try:
            with open(self.path, encoding="utf-8-sig", newline=None) as fh:
                yield fh
        except UnicodeDecodeError as exc:
            raise DataFileError(
                f"{self.path}: is not UTF-8 text (byte {exc.start} of a read); save it as "
                "UTF-8 CSV."
            ) from None
        except OSError as exc:
            raise DataFileError(f"{self.path}: cannot be read ({exc.strerror or exc}).") from None

    @contextlib.contextmanager
    def _lines(self):
        """(line number, content) of the data lines, comments and blanks dropped."""
        with self._text() as fh:
            fh.read(self.skip)

            def lines():
                number = self.header_number
                for line in fh:
                    number += 1
                    content = line.split("#", 1)[0].rstrip("\n")
                    if content.strip():
                        yield number, content

            yield lines()

    def parse(self, a: int, rows: list) -> _Source:
        """The `_Source` of data rows ``a .. a+len(rows)`` from their (line number, content)."""
        body = "\n".join(c for _, c in rows)
        if self.decimal == ",":
            body = body.replace(",", ".")
        names, delimiter = self.names, self.delimiter
        try:
            table, _ = _parse_numbers(self.path, body, 0, len(names), delimiter, names)
        except DataFileError:
            fixed = [(k, c.replace(",", ".") if self.decimal == "," else c) for k, c in rows]
            _diagnose(self.path, fixed, len(names), delimiter, names)
            raise
        if table.shape[0] != len(rows):
            raise DataFileError(
                f"{self.path}: read {table.shape[0]} rows from lines {rows[0][0]}.."
                f"{rows[-1][0]}, expected {len(rows)}; check the separator."
            )
        numbers = [k for k, _ in rows]

        def row_label(i: int) -> str:
            return f"data row {a + i + 1} (line {numbers[i]})"

        return _csv_source(body, table, names, self.units, delimiter, self.metadata, row_label)

    def probe(self, a: int, b: int) -> _Source:
        """The first or the last rows (up to 2), kept by the scan."""
        rows = self.head[:b] if a == 0 else self.tail[len(self.tail) - (b - a) :]
        return self.parse(a, rows)

    @contextlib.contextmanager
    def reading(self) -> Iterator:
        """One pass, forward: ``read(a, b)`` gives the `_Source` of data rows ``a:b``."""
        with self._lines() as lines:
            state = {"pos": 0}

            def read(a, b):
                rows = []
                for number, content in lines:
                    if state["pos"] >= a:
                        rows.append((number, content))
                    state["pos"] += 1
                    if state["pos"] == b:
                        break
                if len(rows) != b - a:
                    raise _changed(self.path, f"it has fewer than the {self.n} rows counted")
                return self.parse(a, rows)

            yield read
            if state["pos"] == self.n and next(lines, None) is not None:
                raise _changed(self.path, f"it has more than the {self.n} rows counted")


def _has_data_after_header(text: str) -> bool:
    """Whether ``text`` holds the header and a complete first data line after it."""
    from .csv_reader import _data_lines, _header_row

    _, header, _, pos = _header_row(text)
    if header is None:
        return False
    tail = text[pos:]
    cut = tail.rfind("\n")
    return cut >= 0 and any(True for _ in _data_lines(tail[:cut], 0))


# =============================================================================== Parquet
class _ParquetBlocks:
    """Parquet by record batches (row groups in order), joined or cut to each block's rows."""

    how = "by row batches (pyarrow iter_batches)"

    def __init__(self, path: Path):
        from .parquet_reader import _open_parquet, _parquet_layout

        self.path = path
        pf = _open_parquet(path)
        self.columns, self.metadata = _parquet_layout(path, pf.schema_arrow)
        self.n = int(pf.metadata.num_rows)
        self.groups = [pf.metadata.row_group(i).num_rows for i in range(pf.num_row_groups)]

    def _table(self, batches):
        import pyarrow as pa

        from .parquet_reader import _source_from_table

        return _source_from_table(pa.Table.from_batches(batches), self.columns, self.metadata)

    @contextlib.contextmanager
    def reading(self) -> Iterator:
        """One pass, forward: ``read(a, b)`` gives the `_Source` of rows ``a:b``."""
        import pyarrow as pa

        from .parquet_reader import _open_parquet

        pf = _open_parquet(self.path, streaming=True)
        if int(pf.metadata.num_rows) != self.n:
            raise _changed(self.path, f"it has {pf.metadata.num_rows} rows, not {self.n}")
        batches = pf.iter_batches(batch_size=65536, use_threads=False)
        state = {"pos": 0, "carry": None}

        def read(a, b):
            parts, have = [], 0
            carry = state["carry"]
            while True:
                if carry is None:
                    try:
                        carry = pa.Table.from_batches([next(batches)])
                    except StopIteration:
                        raise _changed(self.path, "it ended early") from None
                start = max(a - state["pos"], 0)
                if start >= carry.num_rows:
                    state["pos"] += carry.num_rows
                    carry = None
                    continue
                take = min(carry.num_rows - start, b - a - have)
                parts.append(carry.slice(start, take))
                have += take
                rest = carry.slice(start + take)
                state["pos"] += start + take
                carry = rest if rest.num_rows else None
                if have == b - a:
                    break
            state["carry"] = carry
            return self._table([x for p in parts for x in p.to_batches()])

        try:
            yield read
        finally:
            if hasattr(pf, "close"):
                pf.close()

    def probe(self, a: int, b: int) -> _Source:
        """The first rows, or the last ones (the last row group streamed, its tail kept)."""
        import pyarrow as pa

        from .parquet_reader import _open_parquet

        pf = _open_parquet(self.path, streaming=True)
        if a == 0:
            batch = next(pf.iter_batches(batch_size=b, use_threads=False))
            return self._table([batch])
        last = len(self.groups) - 1
        while last > 0 and self.groups[last] < b - a:  # the last rows may span row groups
            last -= 1
        tail: deque = deque()
        groups = range(last, len(self.groups))
        for batch in pf.iter_batches(batch_size=65536, row_groups=groups, use_threads=False):
            tail.append(batch)
            while sum(x.num_rows for x in tail) - tail[0].num_rows >= b - a:
                tail.popleft()
        table = pa.Table.from_batches(list(tail))
        return self._table(table.slice(table.num_rows - (b - a)).to_batches())
