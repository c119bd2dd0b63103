"""The HDF5 reader, also for MATLAB v7.3 files (needs h5py, the ``io`` extra).

One rule for what a data file may make physid read: the file itself, nothing else. Links are
inspected before anything is opened through them (``getlink=True``): an external link, a
dataset stored in external raw-data files or a virtual dataset (its values come from other
datasets, usually other files) is refused with the dataset's name, never followed; a soft link
is followed inside the file by hand, one path component at a time, so that it cannot leave the
file through an external link on the way; a dangling link is reported. Every dataset's declared
shape and type are checked before its values are read: numbers only (odd types are kept as
non-channel variables that say what they hold), and the total size within `check_memory`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..._resources import check_memory, format_bytes
from ...errors import DataFileError, InputError, MissingDependencyError
from .variables import _MAX_DEPTH, _finish, _from_mapping, _Source, _Var

#: Links (datasets and groups) one file may hold before it is refused: a crafted file of hard
#: links to its own groups would otherwise be walked exponentially.
MAX_HDF5_LINKS = 10_000
#: Elements of a text dataset (``names``, ``units``, MATLAB ``char``) that are read.
_MAX_TEXT = 100_000
#: Text elements and characters one file may make physid read in all, references followed
#: included: 100 000 references to 100 000 characters each would be 10**10.
MAX_HDF5_TEXT = 1_000_000
_MAX_SOFT_HOPS = 16  # a soft link to a soft link to …: deeper is a loop
#: Steps (path components) all soft links of one file may take to resolve, together: links whose
#: targets run through other soft links would otherwise multiply the work exponentially.
MAX_HDF5_LINK_STEPS = MAX_HDF5_LINKS


def _read_hdf5(path: Path, *, matlab: bool = False) -> _Source:
    try:
        import h5py  # noqa: F401
    except ImportError:
        kind = "MATLAB v7.3 files" if matlab else "HDF5 files"
        raise MissingDependencyError(
            f"{path}: reading {kind} needs h5py, which is not installed; run "
            'pip install "physid[io]" (or pip install h5py), or save the file as MATLAB v7 '
            "(save -v7) or CSV."
        ) from None
    import h5py

    walk = _Walk(path, matlab)
    try:
        with h5py.File(path, "r") as f:
            walk.f = f
            walk.group(f, "", 0)
            walk.check_size()
            walk.read()
    except (DataFileError, MissingDependencyError):
        raise
    except (OSError, ValueError, KeyError, RuntimeError, TypeError) as exc:
        raise DataFileError(f"{path}: not a readable HDF5 file ({exc}).") from None
    source = _from_mapping(path, walk.items, walk.units)
    for name, var in walk.unread.items():
        source.variables.setdefault(name, var)
    return _finish(source, {})


@dataclass
class _Walk:
    """The links of one file, sorted into datasets to read and variables not read (and why)."""

    path: Path
    matlab: bool
    f: Any = None
    pending: dict = field(default_factory=dict)  # name -> dataset (numbers, checked, unread)
    items: dict = field(default_factory=dict)  # name -> values read
    units: dict = field(default_factory=dict)
    unread: dict = field(default_factory=dict)  # name -> _Var without values (kind, why)
    links: int = 0
    link_steps: int = 0  # path components followed through soft links, all links together
    text_read: int = 0  # text elements and characters read, references followed included
    seen_groups: set = field(default_factory=set)

    # ------------------------------------------------------------------ links
    def group(self, group, prefix: str, depth: int) -> None:
        import h5py

        for key in list(group.keys()):  # link names only: nothing is followed yet
            if key.startswith("#"):  # MATLAB's #refs#, #subsystem#
                continue
            name = f"{prefix}{key}"
            self.links += 1
            if self.links > MAX_HDF5_LINKS:
                raise DataFileError(
                    f"{self.path}: holds more than {MAX_HDF5_LINKS} datasets and groups; physid "
                    "reads recordings of a few channels. Copy the channels you need into a "
                    "smaller file."
                )
            obj = self.resolve(group, key, name, 0)
            if obj is None:
                continue
            if isinstance(obj, h5py.Group):
                self.subgroup(obj, name, depth)
            elif isinstance(obj, h5py.Dataset):
                self.dataset(obj, name)

    def subgroup(self, obj, name: str, depth: int) -> None:
        mclass = _attr_text(obj, "MATLAB_class")
        if mclass not in ("", "struct"):  # sparse, function_handle, an object of a class
            self.skip(name, f"a MATLAB {mclass} (not an array of numbers)")
            return
        if depth + 1 > _MAX_DEPTH:
            self.skip(name, f"a group nested deeper than {_MAX_DEPTH} levels (not read)")
            return
        address = _address(obj)
        if address is not None and address in self.seen_groups:
            self.skip(name, "a second link to a group already read (not read twice)")
            return
        self.seen_groups.add(address)
        self.group(obj, f"{name}.", depth + 1)

    def resolve(self, group, key: str, name: str, hops: int):
        """The object behind link ``key`` of ``group``, followed inside the file only; None for a
        dangling link or a loop of soft links (recorded as skipped under ``name``)."""
        try:
            return self._follow(group, key, name, hops)
        except _Dangling as exc:
            self.skip(name, str(exc))
            return None

    def _follow(self, group, key: str, name: str, hops: int):
        import h5py

        link = group.get(key, getlink=True)  # the link itself: nothing opened through it
        if link is None:
            raise _Dangling("")
        if isinstance(link, h5py.HardLink):
            return group[key]
        if isinstance(link, h5py.ExternalLink):
            raise DataFileError(
                f"{self.path}: {name!r} is an external link to {link.path!r} in the file "
                f"{link.filename!r}; physid reads only the file it is given and never follows "
                "a data file's links to other files. Copy the data into this file (h5py: "
                f"f[{name.replace('.', '/')!r}] = other[{link.path!r}][()]) and load it again."
            )
        if not isinstance(link, h5py.SoftLink):
            raise DataFileError(
                f"{self.path}: {name!r} is a user-defined link ({type(link).__name__}), which "
                "physid never follows; store the values in the file as a dataset."
            )
        if hops >= _MAX_SOFT_HOPS:
            raise _Dangling(f"a chain of more than {_MAX_SOFT_HOPS} soft links (a loop)")
        # the target path, one component at a time, each link checked as above
        cur = self.f if link.path.startswith("/") else group
        for part in (p for p in link.path.split("/") if p and p != "."):
            self.link_steps += 1
            if self.link_steps > MAX_HDF5_LINK_STEPS:
                raise DataFileError(
                    f"{self.path}: resolving the soft link {name!r} took the file's soft links "
                    f"past {MAX_HDF5_LINK_STEPS} steps in all; links whose "
                    "targets run through other soft links are crafted to multiply the work. "
                    "Store the channels as datasets (or hard links) and load the file again."
                )
            if not isinstance(cur, h5py.Group):
                cur = None
                break
            try:
                cur = self._follow(cur, part, name, hops + 1)
            except _Dangling as exc:
                if str(exc):
                    raise
                cur = None
                break
        if cur is None:
            raise _Dangling(
                f"a soft link to {link.path!r}, which is not in the file (a dangling link)"
            )
        return cur

    # ------------------------------------------------------------------ datasets
    def dataset(self, ds, name: str) -> None:
        """Check one dataset's storage, type and size; queue it for reading or record why not."""
        _check_storage(self.path, ds, name)
        shape = ds.shape
        if shape is None:
            self.skip(name, "an empty (null) HDF5 dataspace")
            return
        n = int(np.prod(shape, dtype=object)) if shape else 1
        mclass = _attr_text(ds, "MATLAB_class")
        if self.matlab and _attr_text(ds, "MATLAB_empty") not in ("", "0"):
            self.skip(name, "an empty MATLAB array")
            return
        if name in ("names", "units") or mclass == "char":
            self.text(ds, name, n, mclass)
            return
        why = _not_numbers(ds.dtype, mclass)
        if why is not None:
            kind, detail = why
            self.unread[name] = _Var(name, None, _unit_of(ds), kind, f"{detail} (shape {shape})", n)
            return
        self.pending[name] = ds

    def text(self, ds, name: str, n: int, mclass: str) -> None:
        import h5py

        if n > _MAX_TEXT:
            self.unread[name] = _Var(name, None, "", "text", f"text of {n} elements", n)
            return
        self.count_text(n, name)
        if mclass == "char" and ds.dtype.kind in "iu":  # MATLAB v7.3 char: UTF-16 code units
            codes = np.asarray(ds[()]).reshape(-1)
            self.items[name] = np.array("".join(chr(int(c)) for c in codes if 0 <= c < 0x110000))
            return
        dt = ds.dtype
        if not (h5py.check_string_dtype(dt) or h5py.check_ref_dtype(dt) or dt.kind in "SU"):
            why = _not_numbers(dt, mclass)
            if why is None:  # numbers under a text name: an ordinary variable
                self.pending[name] = ds
                return
            self.unread[name] = _Var(name, None, "", why[0], why[1], n)
            return
        values = np.asarray(ds[()]).reshape(-1)
        self.items[name] = np.array([self.string(v, name) for v in values])

    def string(self, value, name: str) -> str:
        """One element of a text dataset; a reference (a MATLAB cell of char) is followed
        within the file under the same checks as any dataset."""
        import h5py

        if isinstance(value, h5py.Reference):
            if not value:
                return ""
            target = self.f[value]
            if target.file.filename != self.f.filename or not isinstance(target, h5py.Dataset):
                return ""
            _check_storage(self.path, target, f"{name} (a referenced element)")
            if target.shape is None or int(np.prod(target.shape)) > _MAX_TEXT:
                return ""
            if target.dtype.kind not in "iuSU" and not h5py.check_string_dtype(target.dtype):
                return ""
            self.count_text(int(np.prod(target.shape)), name)
            chars = np.asarray(target[()]).reshape(-1)
            if chars.dtype.kind in "iu":
                return "".join(chr(int(c)) for c in chars if 0 <= c < 0x110000)
            return "".join(_decode(c) for c in chars)
        return _decode(value)

    def count_text(self, n: int, name: str) -> None:
        """Add ``n`` text elements to the file's total; refuse past `MAX_HDF5_TEXT`."""
        self.text_read += n
        if self.text_read > MAX_HDF5_TEXT:
            raise DataFileError(
                f"{self.path}: its text ({name!r} and the text before it, references followed) "
                f"holds more than {MAX_HDF5_TEXT} elements and characters (at least "
                f"{self.text_read}); physid reads names and units of a few channels. The file is "
                "damaged or crafted: keep the text short, or save the channels without it."
            )

    def skip(self, name: str, why: str) -> None:
        self.unread[name] = _Var(name, None, "", "skipped", why, -1)

    # ------------------------------------------------------------------ reading
    def check_size(self) -> None:
        """Refuse before reading when the declared sizes exceed the memory check."""
        sizes = {}
        for name, ds in self.pending.items():
            n = int(np.prod(ds.shape, dtype=object)) if ds.shape else 1
            sizes[name] = n * (ds.dtype.itemsize + 8)  # the values, then as float64
        total = sum(sizes.values())
        if not sizes:
            return
        big = max(sizes, key=sizes.get)
        ds = self.pending[big]

        def message(nbytes, available):
            return (
                f"{self.path}: its datasets declare {format_bytes(nbytes)} of values to read "
                f"(the largest, {big!r}: shape {ds.shape}, {ds.dtype}), more than half of the "
                f"{format_bytes(available)} of memory available; the file is damaged or "
                "crafted, or too large for one recording: copy a slice of it into a smaller "
                f"file (h5py: small[{big.replace('.', '/')!r}] = f[...][:n])."
            )

        try:
            check_memory(total, what="", fix="", message=message)
        except InputError as exc:
            raise DataFileError(str(exc)) from None

    def read(self) -> None:
        for name, ds in self.pending.items():
            arr = np.asarray(ds[()])
            if self.matlab and arr.ndim == 2:  # MATLAB is column-major: (n, k) reads as (k, n)
                arr = arr.T
            self.items[name] = arr
            self.units[name] = _unit_of(ds)


class _Dangling(Exception):
    """A link whose target is not in the file (the message says why; empty: not there)."""


def _check_storage(path, ds, name: str) -> None:
    """Refuse a dataset whose values live outside the file (external raw data, virtual)."""
    dcpl = ds.id.get_create_plist()
    if dcpl.get_external_count() > 0:
        where = dcpl.get_external(0)[0]
        where = where.decode("utf-8", "replace") if isinstance(where, bytes) else str(where)
        raise DataFileError(
            f"{path}: dataset {name!r} keeps its values in the external file {where!r} "
            "(HDF5 external storage); physid reads only the file it is given and never "
            "follows a data file to other files. Store the values in the dataset itself "
            "(h5py: create_dataset without external=)."
        )
    if ds.is_virtual:
        sources = sorted({s.file_name for s in ds.virtual_sources()})[:3]
        raise DataFileError(
            f"{path}: dataset {name!r} is a virtual dataset (its values are read from "
            f"{sources}); physid reads only the file it is given and never follows a data "
            "file to other files or datasets. Store the values in the dataset itself "
            "(h5py: f2[name] = f[name][()])."
        )


def _not_numbers(dt, mclass: str) -> tuple[str, str] | None:
    """(kind, detail) of a dataset type physid does not read as numbers; None for numbers."""
    import h5py

    if h5py.check_string_dtype(dt) is not None or dt.kind in "SU":
        return "text", "text"
    if h5py.check_ref_dtype(dt) is not None:
        what = "a MATLAB cell array" if mclass == "cell" else "object references"
        return "cell", f"{what} (HDF5 references)"
    if dt.names is not None:
        if set(dt.names) == {"real", "imag"}:
            return "complex", f"complex numbers (dtype {dt['real']} pairs)"
        return "other", f"compound records (fields {list(dt.names)[:6]})"
    if dt.kind == "c":
        return "complex", f"complex numbers (dtype {dt})"
    if dt.kind in "biu" and dt.itemsize <= 8 or dt.kind == "f" and dt.itemsize <= 8:
        return None
    return "other", f"values of HDF5 type {dt}"


def _attr_text(obj, key: str) -> str:
    """A short text attribute (``MATLAB_class``, ``unit``), or "" when absent or not text."""
    import h5py

    if key not in obj.attrs:
        return ""
    try:
        aid = h5py.h5a.open(obj.id, key.encode())
        shape, dt = aid.shape, aid.dtype
    except (KeyError, OSError, RuntimeError, ValueError, TypeError):
        return ""
    size = int(np.prod(shape)) if shape else 1
    if shape is None or size > 64:
        return ""
    if dt.kind in "iu":  # MATLAB_empty = 1
        return str(int(np.asarray(obj.attrs[key]).reshape(-1)[0])) if size else ""
    if not (h5py.check_string_dtype(dt) is not None or dt.kind in "SU"):
        return ""
    value = np.asarray(obj.attrs[key]).reshape(-1)
    return _decode(value[0]) if value.size else ""


def _unit_of(ds) -> str:
    return _attr_text(ds, "unit") or _attr_text(ds, "units")


def _decode(value) -> str:
    if isinstance(value, bytes):
        return value.decode("utf-8", "replace")
    return str(value)


def _address(obj):
    """The object's address in the file (to meet a group twice only once), or None."""
    import h5py

    try:
        info = h5py.h5o.get_info(obj.id)
    except (RuntimeError, ValueError, TypeError, OSError):
        return None
    return getattr(info, "addr", None) or getattr(info, "token", None)
