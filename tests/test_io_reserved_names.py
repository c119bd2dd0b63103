"""Channels named like the NPZ layout's keys (``data``, ``names``, ``units``, ``metadata``) are
channels: written by `save_recording` and read back by `load_recording` (whole or block by block)
in every format it writes, and in Parquet and `map_recording`; a layout key that is not listed
as a channel is still not one."""

from __future__ import annotations

import json

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest

from physid.signals import Recording, load_recording, save_recording
from physid.signals.io import map_recording, open_blocks

RESERVED = ["data", "names", "units", "metadata"]


def _recording(names):
    k = len(names)
    data = np.arange(5.0 * k).reshape(5, k) * 0.37 - 1.1
    units = ["m", "N", "rad", "V", "A"][:k]
    return Recording(1e-3 * np.arange(5), data, names, units, metadata={"note": "kept"})


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
@pytest.mark.parametrize("name", RESERVED)
def test_a_reserved_channel_name_round_trips(tmp_path, name, suffix):
    rec = _recording(["x", name])
    back = load_recording(save_recording(rec, tmp_path / f"r{suffix}"))
    assert back.names == ("x", name) and back.units == ("m", "N")
    assert back.data.tobytes() == rec.data.tobytes()
    assert back.metadata["note"] == "kept"  # the metadata still reads as metadata
    # block by block, as `open_blocks` reads it
    with open_blocks(tmp_path / f"r{suffix}") as src:
        assert src.names == ("x", name)
        got = np.concatenate([b[name] for b in src.blocks(2)])
    np.testing.assert_array_equal(got, rec[name])


@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_all_reserved_names_together_and_alone(tmp_path, suffix):
    rec = _recording(RESERVED)
    back = load_recording(save_recording(rec, tmp_path / f"all{suffix}"))
    assert back.names == tuple(RESERVED) and back.units == ("m", "N", "rad", "V")
    assert back.data.tobytes() == rec.data.tobytes()
    alone = _recording(["data"])
    back = load_recording(save_recording(alone, tmp_path / f"alone{suffix}"))
    assert back.names == ("data",) and back.data.tobytes() == alone.data.tobytes()


def test_an_npz_written_by_numpy_in_the_layout_reads_its_reserved_channels(tmp_path):
    # the layout save_recording has always written: files of older versions read the same way
    path = tmp_path / "old.npz"
    data = np.column_stack([np.linspace(0, 1, 4), np.linspace(2, 3, 4)])
    np.savez(path, t=np.arange(4) * 0.01, data=data, names=np.array(["units", "q1"]),
             units=np.array(["N", "rad"]), metadata=np.array(json.dumps({"a": 1})))  # fmt: skip
    back = load_recording(path)
    assert back.names == ("units", "q1") and back.units == ("N", "rad")
    np.testing.assert_array_equal(back["units"], data[:, 0])
    assert back.metadata["a"] == 1


def test_a_layout_key_that_is_not_a_listed_channel_is_not_a_channel(tmp_path):
    path = tmp_path / "plain.npz"
    np.savez(path, t=np.arange(4) * 0.01, x=np.ones(4), units=np.array(["m"]))
    assert load_recording(path).names == ("x",)


def test_a_parquet_column_named_data_is_a_channel(tmp_path):
    path = tmp_path / "r.parquet"
    pq.write_table(pa.table({"t [s]": [0.0, 0.1, 0.2], "data [m]": [1.0, 2.0, 3.0]}), path)
    back = load_recording(path)
    assert back.names == ("data",) and back.units == ("m",)
    np.testing.assert_array_equal(back["data"], [1.0, 2.0, 3.0])


def test_map_recording_keeps_a_channel_named_names():
    rec = _recording(["names", "x"])
    out = map_recording(rec, {"q1": "names", "y": "2*x"})
    assert out.names == ("q1", "y")
    np.testing.assert_array_equal(out["q1"], rec["names"])
