"""Fuzz the HDF5 and MATLAB v7.3 readers with generated file structures: groups, soft, external
and dangling links, external storage, virtual datasets, declared shapes up to 1e12 elements, odd
types and MATLAB class attributes. `load_recording` returns a valid `Recording` or raises a
`PhysidError` — never another exception, and never a value of another file (the other files hold
a marker value that must never come out).

``make fuzz`` runs it at 20 000 examples (profile ``fuzz`` in tests/conftest.py); the default
profile runs a few dozen.
"""

from __future__ import annotations

import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from physid.errors import PhysidError
from physid.signals import Recording, load_recording

h5py = pytest.importorskip("h5py")

_SETTINGS = settings(deadline=None, suppress_health_check=list(HealthCheck))
_MARKER = 271828.125  # every value of the other files: it must never reach a recording
_N = 8
_NAMES = st.sampled_from(["t", "x", "u", "q1", "tau1", "g", "data", "names", "units", "#refs#"])
_DTYPES = st.sampled_from(
    ["f8", "f4", "f2", "i8", "u8", "i2", "u1", "?", "c16", "S3", "str", "ref", "compound",
     "longdouble", "enum", "vlen"]
)  # fmt: skip
_SHAPES = st.sampled_from(
    [(_N,), (1, _N), (_N, 2), (), (0,), (_N + 1,), (10**12,), (10**6, 10**6), None]
)
_CLASSES = st.sampled_from([None, "double", "char", "cell", "struct", "sparse", "logical", "x"])


def _others(folder: Path) -> dict:
    """The other files a crafted file may point at, every value the marker."""
    raw = folder / "other.bin"
    raw.write_bytes(np.full(_N, _MARKER).tobytes())
    h5 = folder / "other.h5"
    with h5py.File(h5, "w") as f:
        f["x"] = np.full(_N, _MARKER)
        f["g/x"] = np.full(_N, _MARKER)
    return {"bin": raw, "h5": h5}


def _dtype(name):
    return {
        "str": h5py.string_dtype(), "ref": h5py.ref_dtype,
        "compound": np.dtype([("a", "f8"), ("b", "i4")]), "longdouble": np.longdouble,
        "enum": h5py.enum_dtype({"a": 0, "b": 1}, basetype="i1"),
        "vlen": h5py.vlen_dtype(np.float64),
    }.get(name, name)  # fmt: skip


def _dataset(group, key, draw, others):
    kind = draw(st.sampled_from(["data", "data", "data", "external", "virtual", "declared"]))
    shape = draw(_SHAPES)
    if kind == "external":
        group.create_dataset(
            key, shape=(_N,), dtype="f8", external=[(str(others["bin"]), 0, 8 * _N)]
        )
        return
    if kind == "virtual":
        layout = h5py.VirtualLayout(shape=(_N,), dtype="f8")
        source = draw(st.sampled_from([str(others["h5"]), "."]))
        layout[:] = h5py.VirtualSource(source, "x", shape=(_N,))
        group.create_virtual_dataset(key, layout, fillvalue=_MARKER)
        return
    dtype = _dtype(draw(_DTYPES))
    if shape is None:
        ds = group.create_dataset(key, data=h5py.Empty("f8"))
    elif kind == "declared" or np.prod(shape) > 10**4:  # declared, never written (chunked)
        chunks = tuple(min(s, 64) for s in shape) if shape and all(shape) else None
        ds = group.create_dataset(key, shape=shape, dtype=dtype, chunks=chunks or None)
    else:
        try:
            values = np.arange(int(np.prod(shape)), dtype=float).reshape(shape) * 1e-3
            ds = group.create_dataset(key, data=values.astype(dtype) if dtype not in (
                h5py.string_dtype(), h5py.ref_dtype, h5py.vlen_dtype(np.float64)) else None,
                shape=shape, dtype=dtype)  # fmt: skip
        except (TypeError, ValueError):
            ds = group.create_dataset(key, shape=shape, dtype=dtype)
    mclass = draw(_CLASSES)
    if mclass:
        ds.attrs["MATLAB_class"] = np.bytes_(mclass)
    if draw(st.booleans()):
        ds.attrs["unit"] = draw(st.sampled_from(["ms", "mm", "deg", "V", "furlong", ""]))


def _build(f, draw, others, depth=0):
    for _ in range(draw(st.integers(min_value=0, max_value=4 if depth else 6))):
        key = draw(_NAMES)
        if key in f:
            continue
        what = draw(st.sampled_from(
            ["dataset", "dataset", "group", "soft", "dangling", "external", "hard", "loop"]
        ))  # fmt: skip
        if what == "dataset":
            try:
                _dataset(f, key, draw, others)
            except (TypeError, ValueError):  # h5py cannot write that: not the reader's case
                continue
        elif what == "group" and depth < 3:
            g = f.create_group(key)
            if draw(st.booleans()):
                g.attrs["MATLAB_class"] = np.bytes_(draw(st.sampled_from(["struct", "sparse"])))
            _build(g, draw, others, depth + 1)
        elif what == "soft":
            f[key] = h5py.SoftLink(draw(st.sampled_from(["/t", "/g/x", "/ext/x", "x", "/", "."])))
        elif what == "dangling":
            f[key] = h5py.SoftLink("/nothing/here")
        elif what == "external":
            f[key] = h5py.ExternalLink(str(others["h5"]), draw(st.sampled_from(["/x", "/g", "/"])))
        elif what == "hard" and depth:
            f[key] = f.file["/"]  # a hard link back to the root: a cycle
        elif what == "loop":
            f[key] = h5py.SoftLink(f"{f.name.rstrip('/')}/{key}")


@st.composite
def _file(draw):
    folder = Path(tempfile.mkdtemp(prefix="physid-fuzz-"))
    others = _others(folder)
    matlab = draw(st.booleans())
    path = folder / ("f.mat" if matlab else "f.h5")
    with h5py.File(path, "w", userblock_size=512 if matlab else 0) as f:
        if draw(st.booleans()):
            f["t"] = 1e-3 * np.arange(_N)  # a valid time, so that channels are reached
        _build(f, draw, others)
    if matlab:
        with open(path, "r+b") as fh:
            fh.write(b"MATLAB 7.3 MAT-file, fuzz".ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02IM")
    return path


@_SETTINGS
@given(path=_file(), channels=st.one_of(st.none(), st.sampled_from(
    [{"x": "g.x"}, {"x": "ext.x"}, {"u": "x", "x": "u"}, {"x": "names"}])))  # fmt: skip
def test_hdf5_structure_loads_or_raises_physid_error(path, channels):
    from physid.errors import PhysidWarning

    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a warning escaping the loader is a defect too...
        warnings.simplefilter("ignore", PhysidWarning)  # ...except physid's own notes to the user
        try:
            rec = load_recording(path, channels=channels)
        except PhysidError:
            return
    assert isinstance(rec, Recording)
    assert rec.n_samples >= 2 and np.all(np.diff(rec.t) > 0)
    assert np.all(np.isfinite(rec.data))
    assert not np.any(np.isclose(rec.data, _MARKER)), "a value of another file was read"
