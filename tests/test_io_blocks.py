"""Files read block by block (physid.signals.io.open_blocks): the blocks, concatenated, are what
load_recording returns for the same file and options; bad input is refused at its sample."""

from __future__ import annotations

import json
import os
import sys

import h5py
import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

import physid.signals.io.block_formats as block_formats
import physid.signals.io.block_readers as block_readers
from physid.errors import DataFileError, InputError, MissingDependencyError
from physid.signals.blocks import BlockSource, block_starts
from physid.signals.io import (
    BLOCK_FORMATS,
    in_memory_bytes,
    load_recording,
    open_blocks,
    save_recording,
)

N = 1003
DT = 1e-3
MAP = {"tau1": "g*cur [N*m]"}


def _signals(n=N, jitter=True):
    k = np.arange(n)
    t = 2.0 + k * DT + (1e-7 * ((k % 3) - 1) if jitter else 0.0)  # 1e-4 of a period: snapped
    q = np.column_stack([np.sin(3 * t), 0.5 * np.cos(2 * t)])
    cur = np.cos(5 * t) + 0.1 * k / n
    return t, q, cur


def _write_csv(path, t, q, cur, *, decimal="."):
    sep = ";" if decimal == "," else ","
    lines = ['# metadata: {"g": 2.5}', f"t [s]{sep}q1 [deg]{sep}q2{sep}cur [A]"]
    for i in range(t.size):
        cells = [repr(float(v)) for v in (t[i], q[i, 0], q[i, 1], cur[i])]
        if decimal == ",":
            cells = [c.replace(".", ",") for c in cells]
        lines.append(sep.join(cells))
        if i == 10:
            lines.append("# a comment between rows")
            lines.append("")
    path.write_text("\n".join(lines) + "\n")


def _write_mat73(path, items, units=None):
    with h5py.File(path, "w", userblock_size=512) as f:
        for key, value in items.items():
            value = np.asarray(value)
            f[key] = value.T if value.ndim == 2 else value[None, :] if value.ndim == 1 else value
            f[key].attrs["MATLAB_class"] = np.bytes_("double")
            if units and key in units:
                f[key].attrs["unit"] = units[key]
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: test HDF5 schema 1.00 ."
    with open(path, "r+b") as fh:
        fh.write(header.ljust(116, b" ") + b"\x00" * 8 + b"\x00\x02IM")


def _write(fmt, path, t, q, cur):
    """The same record in each format: q1 in degrees, the gain g a scalar of the file."""
    if fmt == "npz":
        np.savez(path, t=t, q=np.column_stack([np.deg2rad(q[:, 0]), q[:, 1]]), cur=cur, g=2.5)
    elif fmt == "npz_compressed":
        np.savez_compressed(path, t=t, q=q, cur=cur, g=2.5)
    elif fmt == "hdf5":
        with h5py.File(path, "w") as f:
            f["t"], f["q"], f["cur"], f["g"] = t, q, cur, 2.5
            f["q"].attrs["unit"] = "deg"
            f["cur"].attrs["unit"] = "A"
    elif fmt == "mat73":
        _write_mat73(path, {"t": t, "q": q, "cur": cur, "g": np.array([[2.5]])}, {"q": "deg"})
    elif fmt in ("csv", "csv_comma"):
        _write_csv(path, t, q, cur, decimal="," if fmt == "csv_comma" else ".")
    elif fmt == "parquet":
        table = pa.table({"t [s]": t, "q1 [deg]": q[:, 0], "q2": q[:, 1], "cur [A]": cur})
        table = table.replace_schema_metadata({"physid": json.dumps({"g": 2.5})})
        pq.write_table(table, path, row_group_size=300)
    return path


SUFFIX = {"npz": ".npz", "npz_compressed": ".npz", "hdf5": ".h5", "mat73": ".mat",
          "csv": ".csv", "csv_comma": ".csv", "parquet": ".parquet"}  # fmt: skip
FORMATS = list(SUFFIX)


def _options(fmt):
    return {"decimal": ","} if fmt == "csv_comma" else {}


def _concat(blocks):
    blocks = list(blocks)
    return np.concatenate([b.t for b in blocks]), np.vstack([b.data for b in blocks]), blocks


@pytest.mark.parametrize("fmt", FORMATS)
def test_blocks_concatenated_equal_the_whole_load(tmp_path, fmt):
    path = _write(fmt, tmp_path / f"r{SUFFIX[fmt]}", *_signals())
    whole = load_recording(path, MAP, **_options(fmt))
    with open_blocks(path, MAP, **_options(fmt)) as src:
        assert isinstance(src, BlockSource)
        assert (src.n_samples, src.names, src.units) == (N, whole.names, whole.units)
        assert src.dt == whole.dt and src.t0 == whole.t[0]
        assert src.metadata["channel_map"] == whole.metadata["channel_map"]
        for key in ("source", "format"):  # errors and the scale check name the file
            assert src.metadata[key] == whole.metadata[key]
        for size in (7, 250, N):  # 7 and 250 do not divide 1003
            t, data, blocks = _concat(src.blocks(size))
            lengths = [b.n_samples for b in blocks]
            assert lengths[:-1] == [size] * (len(lengths) - 1) and size <= lengths[-1] < 2 * size
            assert np.cumsum([0, *lengths]).tolist() == block_starts(N, size).tolist()
            np.testing.assert_array_equal(data, whole.data)  # bit for bit
            np.testing.assert_array_equal(t, whole.t)  # both on the grid t0 + k·dt
        t2, data2, _ = _concat(src.blocks(7))  # a second pass: the same numbers
        np.testing.assert_array_equal(data2, whole.data)
    cur = _signals()[2]
    np.testing.assert_array_equal(whole["tau1"], 2.5 * cur)  # the map's expression, in N·m


@pytest.mark.parametrize("fmt", ["hdf5", "csv", "parquet"])
def test_channel_selection_and_the_file_times_off_the_grid(tmp_path, fmt):
    path = _write(fmt, tmp_path / f"r{SUFFIX[fmt]}", *_signals(jitter=False))
    whole = load_recording(path, MAP)
    src = open_blocks(path, MAP)
    blocks = list(src.blocks(100, channels=["q2"]))
    assert all(b.names == ("q2",) for b in blocks)
    np.testing.assert_array_equal(np.concatenate([b["q2"] for b in blocks]), whole["q2"])
    t = np.concatenate([b.t for b in blocks])  # the file's own times, uniform to 1e-6
    np.testing.assert_allclose(t, whole.t, rtol=0, atol=1e-12)
    with pytest.raises(InputError, match=r"channels=\['q9'\] not in .*its channels are"):
        src.blocks(100, channels=["q9"])


def test_rate_for_a_file_without_time(tmp_path):
    path = tmp_path / "r.npz"
    np.savez(path, q=np.arange(2 * N, dtype=float).reshape(N, 2), cur=np.ones(N), g=2.0)
    whole = load_recording(path, MAP, rate=500.0)
    src = open_blocks(path, MAP, rate=500.0)
    assert (src.dt, src.t0) == (1 / 500.0, 0.0)
    t, data, _ = _concat(src.blocks(64))
    np.testing.assert_array_equal(data, whole.data)
    np.testing.assert_array_equal(t, whole.t)  # k / rate, the same numbers


def test_channel_defaults_of_a_model_table(tmp_path):
    path = _write("hdf5", tmp_path / "r.h5", *_signals())
    table = {"tau1": "g*cur [N*m]", "cur": "current_a", "rate": "1000"}
    kwargs = dict(channel_defaults=table, channel_defaults_source="the [recording] table of a.toml")
    whole = load_recording(path, **kwargs)
    src = open_blocks(path, **kwargs)
    assert src.names == whole.names and "tau1" in src.names
    assert src.metadata.get("channel_defaults_unused") == whole.metadata.get(
        "channel_defaults_unused"
    )
    np.testing.assert_array_equal(_concat(src.blocks(100))[1], whole.data)


def _csv_stamps(path, stamps, x):
    rows = "".join(f"{int(s)},{float(v)!r}\n" for s, v in zip(stamps, x, strict=True))
    path.write_text("stamp [ns],x [m]\n" + rows)
    return path


@pytest.mark.parametrize("first", [1_700_000_000_000_000_000, 0])
def test_integer_nanosecond_stamps_stay_exact(tmp_path, first):
    # epoch stamps: the first is subtracted in integers; stamps from 0 pass 1e9 ns after 1 s,
    # where a block's first stamp must not be taken for an origin
    k = np.arange(3001, dtype=np.int64)
    stamps = first + k * 1_000_000 + (k % 3)  # 1 kHz, a few ns of jitter
    x = np.sin(k / 100.0)
    csv_path = _csv_stamps(tmp_path / "s.csv", stamps, x)
    pq_path = tmp_path / "s.parquet"
    table = pa.table({"stamp": pa.array(stamps, pa.timestamp("ns")), "x [m]": x})
    pq.write_table(table, pq_path, row_group_size=700)
    for path in (csv_path, pq_path):
        whole = load_recording(path, {"t": "stamp"})
        src = open_blocks(path, {"t": "stamp"})
        assert src.metadata.get("time_origin") == whole.metadata.get("time_origin")
        t, data, _ = _concat(src.blocks(256))
        np.testing.assert_array_equal(data, whole.data)
        np.testing.assert_array_equal(t, whole.t)
        assert src.dt == pytest.approx(1e-3, rel=1e-8)


def test_parquet_load_equals_the_same_record_as_csv(tmp_path):
    t, q, cur = _signals()
    csv_rec = load_recording(_write("csv", tmp_path / "r.csv", t, q, cur), MAP)
    pq_rec = load_recording(_write("parquet", tmp_path / "r.parquet", t, q, cur), MAP)
    assert (pq_rec.names, pq_rec.units) == (csv_rec.names, csv_rec.units)
    np.testing.assert_array_equal(pq_rec.data, csv_rec.data)
    np.testing.assert_array_equal(pq_rec.t, csv_rec.t)
    assert pq_rec.metadata["format"] == "parquet"
    back = load_recording(save_recording(pq_rec, tmp_path / "back.csv"))
    np.testing.assert_array_equal(back.data, pq_rec.data)


def test_parquet_without_pyarrow_says_how_to_install_it(tmp_path, monkeypatch):
    path = _write("parquet", tmp_path / "r.parquet", *_signals())
    monkeypatch.setitem(sys.modules, "pyarrow.parquet", None)
    with pytest.raises(MissingDependencyError, match=r'pip install "physid\[parquet\]"'):
        load_recording(path)
    with pytest.raises(MissingDependencyError, match=r"needs pyarrow"):
        open_blocks(path)


# ----------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("fmt", ["npz", "hdf5", "csv", "parquet"])
def test_a_nan_is_refused_at_its_sample(tmp_path, fmt):
    t, q, cur = _signals()
    cur[537] = np.nan
    path = _write(fmt, tmp_path / f"r{SUFFIX[fmt]}", t, q, cur)
    with pytest.raises(DataFileError, match="data row 538" if fmt == "csv" else "sample 537"):
        load_recording(path, MAP)
    src = open_blocks(path, MAP)
    where = "sample 537, data row 538 .line 542." if fmt == "csv" else "sample 537"
    with pytest.raises(DataFileError, match=rf"r{SUFFIX[fmt]}: .*is nan at {where}, t ≈ 2.537 s"):
        list(src.blocks(100))
    inf_t = t.copy()
    inf_t[640] = np.inf
    path = _write(fmt, tmp_path / f"i{SUFFIX[fmt]}", inf_t, q, np.cos(t))
    with pytest.raises(DataFileError, match=r"time column 't' holds inf at sample 640"):
        list(open_blocks(path, MAP).blocks(100))


@pytest.mark.parametrize("at", [700, 600])  # inside a block of 100, and at a block's edge
def test_a_time_gap_is_refused_with_where_to_split(tmp_path, at):
    t, q, cur = _signals(jitter=False)
    t[at:] += 4 * DT  # five periods from sample at-1 to at
    path = _write("npz", tmp_path / "r.npz", t, q, cur)
    with pytest.raises(DataFileError, match="not uniformly sampled"):
        load_recording(path, MAP)
    src = open_blocks(path, MAP)
    with pytest.raises(
        DataFileError,
        match=rf"r\.npz: time is not uniformly sampled: the interval from sample {at - 1} "
        rf"\(t = .*\) to sample {at} .*Split the file at sample {at}.*join_recordings",
    ):
        list(src.blocks(100))
    assert _concat(open_blocks(path, MAP, uniform_rtol=None).blocks(100))[0][at] == t[at]


def test_time_going_back_at_a_block_edge_or_inside_one(tmp_path):
    t, q, cur = _signals(jitter=False)
    t[600] = t[599]  # at the edge of blocks of 100
    path = _write("hdf5", tmp_path / "r.h5", t, q, cur)
    with pytest.raises(DataFileError, match=r"not strictly increasing: .* at sample 600 follows"):
        list(open_blocks(path, MAP).blocks(100))
    t[600] = t[600] + DT / 2
    t[650] = t[648]  # inside a block
    path = _write("csv", tmp_path / "r.csv", t, q, cur)
    with pytest.raises(DataFileError, match=r"not strictly increasing: .*sample 650, data row 651"):
        list(open_blocks(path, MAP).blocks(100))


@pytest.mark.parametrize("fmt", ["npz", "csv", "hdf5"])
def test_a_file_that_changes_between_passes_is_refused(tmp_path, fmt):
    path = _write(fmt, tmp_path / f"r{SUFFIX[fmt]}", *_signals())
    src = open_blocks(path, MAP)
    assert len(list(src.blocks(500))) == 2
    _write(fmt, path, *_signals(n=N + 40))
    with pytest.raises(DataFileError, match=r"changed since it was opened|file changed"):
        list(src.blocks(500))


def test_a_fifo_is_refused_before_anything_is_opened(tmp_path):
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    with pytest.raises(DataFileError, match=r"pipe\.csv: is a FIFO"):
        open_blocks(fifo)


def test_hdf5_external_links_stay_refused(tmp_path):
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = np.arange(10.0)
    path = tmp_path / "r.h5"
    with h5py.File(path, "w") as f:
        f["t"] = np.arange(10.0)
        f["x"] = h5py.ExternalLink(str(other), "/x")
    with pytest.raises(DataFileError, match=r"'x' is an external link .*never follows"):
        open_blocks(path)


def test_mat_v5_read_whole_under_the_limit_refused_over_it(tmp_path, monkeypatch):
    import scipy.io

    t, q, cur = _signals()
    path = tmp_path / "r.mat"
    scipy.io.savemat(path, {"t": t, "q": q, "cur": cur, "g": 2.5})
    whole = load_recording(path, MAP)
    np.testing.assert_array_equal(_concat(open_blocks(path, MAP).blocks(100))[1], whole.data)
    monkeypatch.setattr(block_readers, "MAX_WHOLE_MAT_BYTES", 1000)
    with pytest.raises(
        DataFileError,
        match=r"r\.mat: a MATLAB v5 .mat file .*cannot be read in slices.*'-v7\.3'.*HDF5 "
        r"\(\.h5\), MATLAB v7\.3 \(\.mat\), NPZ, CSV and Parquet",
    ):
        open_blocks(path, MAP)


def test_a_compressed_channel_major_member_is_refused(tmp_path):
    path = tmp_path / "r.npz"
    t, q, _ = _signals()
    np.savez_compressed(path, t=t, q=np.ascontiguousarray(q.T))  # (2, n), C order
    with pytest.raises(DataFileError, match=r"member 'q' is compressed and stored channel"):
        open_blocks(path)


# ----------------------------------------------------------------------------- memory
@pytest.mark.parametrize("fmt", ["hdf5", "npz", "npz_compressed", "mat73"])
def test_a_block_read_does_not_grow_with_the_file(tmp_path, fmt, monkeypatch):
    largest = {}
    readers = {"hdf5": "_read_slice", "mat73": "_read_slice", "npz": "_StoredMember",
               "npz_compressed": "_StreamedMember"}  # fmt: skip
    if readers[fmt] == "_read_slice":
        original = block_formats._read_slice

        def counting(ds, axis, a, b, transposed):
            out = original(ds, axis, a, b, transposed)
            largest[n] = max(largest.get(n, 0), out.shape[0])
            return out

        monkeypatch.setattr(block_formats, "_read_slice", counting)
    else:
        cls = getattr(block_formats, readers[fmt])
        original = cls.read

        def counting(self, a, b):
            out = original(self, a, b)
            largest[n] = max(largest.get(n, 0), out.shape[0])
            return out

        monkeypatch.setattr(cls, "read", counting)
    for n in (2_099, 20_000):
        path = _write(fmt, tmp_path / f"r{n}{SUFFIX[fmt]}", *_signals(n=n))
        for block in open_blocks(path, MAP).blocks(300):
            assert block.data.shape[0] < 600
    assert largest == {2_099: 599, 20_000: 500}  # the longest block, not the file


def test_parquet_batches_do_not_grow_with_the_file(tmp_path, monkeypatch):
    rows = {}
    original = block_formats._ParquetBlocks._table

    def counting(self, batches):
        rows[self.n] = max(rows.get(self.n, 0), sum(b.num_rows for b in batches))
        return original(self, batches)

    monkeypatch.setattr(block_formats._ParquetBlocks, "_table", counting)
    for n in (2_099, 20_000):
        path = _write("parquet", tmp_path / f"r{n}.parquet", *_signals(n=n))
        list(open_blocks(path, MAP).blocks(300))
    assert rows == {2_099: 599, 20_000: 500}


def test_csv_chunks_do_not_grow_with_the_file(tmp_path, monkeypatch):
    rows = {}
    original = block_formats._CsvBlocks.parse

    def counting(self, a, lines):
        rows[self.n] = max(rows.get(self.n, 0), len(lines))
        return original(self, a, lines)

    monkeypatch.setattr(block_formats._CsvBlocks, "parse", counting)
    for n in (2_099, 20_000):
        path = _write("csv", tmp_path / f"r{n}.csv", *_signals(n=n))
        list(open_blocks(path, MAP).blocks(300))
    assert rows == {2_099: 599, 20_000: 500}


def test_in_memory_bytes_from_shapes_alone(tmp_path):
    t, q, cur = _signals()
    h5 = _write("hdf5", tmp_path / "r.h5", t, q, cur)
    npz = _write("npz", tmp_path / "r.npz", t, q, cur)
    per_sample = 4 * 16  # t, q (2 columns), cur: float64 read, then as float64
    assert in_memory_bytes(h5) == N * per_sample + 16  # and the scalar g
    assert in_memory_bytes(npz) == N * per_sample + 16
    csv = _write("csv", tmp_path / "r.csv", t, q, cur)
    assert in_memory_bytes(csv) == 3 * csv.stat().st_size
    parquet = _write("parquet", tmp_path / "r.parquet", t, q, cur)
    assert in_memory_bytes(parquet) == N * 4 * 16
    assert set(BLOCK_FORMATS) == {"hdf5", "npz", "csv", "parquet", "mat", "rosbag"}


@pytest.mark.parametrize(
    "layout", ["fortran", "channel_major", "compressed_fortran_channel_major", "big_endian"]
)
def test_npz_storage_orders(tmp_path, layout):
    t, q, cur = _signals()
    stored = {
        "fortran": np.asfortranarray(q),  # (n, 2) stored column by column
        "channel_major": np.ascontiguousarray(q.T),  # (2, n): one read per channel
        "compressed_fortran_channel_major": np.asfortranarray(q.T),  # samples together
        "big_endian": q.astype(">f8"),
    }[layout]
    path = tmp_path / "r.npz"
    save = np.savez_compressed if layout.startswith("compressed") else np.savez
    save(path, t=t, q=stored, cur=cur, g=2.5)
    whole = load_recording(path, MAP)
    assert whole.names == ("tau1", "q1", "q2")
    t_b, data, _ = _concat(open_blocks(path, MAP).blocks(97))
    np.testing.assert_array_equal(data, whole.data)
    np.testing.assert_array_equal(t_b, whole.t)


def test_a_block_larger_than_memory_is_refused_before_reading(tmp_path, monkeypatch):
    path = _write("hdf5", tmp_path / "r.h5", *_signals())
    original = block_readers.check_memory

    def small_machine(nbytes, **kwargs):
        return original(nbytes, available=20_000, **kwargs)  # 10 kB may be claimed

    monkeypatch.setattr(block_readers, "check_memory", small_machine)
    src = open_blocks(path, MAP)
    assert len(list(src.blocks(10))) == N // 10  # 10 rows × 4 columns × 16 B × 2: 1.3 kB
    with pytest.raises(DataFileError, match=r"r\.h5: one block of 500 samples .*read smaller"):
        src.blocks(500)


def test_a_table_rate_leaves_a_file_with_its_own_time_alone(tmp_path):
    # a [recording] table's rate applies to files without time only; this file has both a time
    # and a "rate" in its metadata, which must not be taken for a time made from the rate
    t = 5 + np.arange(500) * 0.01
    rows = "".join(f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, np.sin(t), strict=True))
    path = tmp_path / "r.csv"
    path.write_text('# metadata: {"rate": 100.0}\nt,x\n' + rows)
    whole = load_recording(path, channel_defaults={"rate": "100"})
    src = open_blocks(path, channel_defaults={"rate": "100"})
    assert src.t0 == 5.0 and src.dt == pytest.approx(0.01, rel=1e-12)
    np.testing.assert_array_equal(_concat(src.blocks(64))[0], whole.t)
