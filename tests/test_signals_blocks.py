"""The block-source protocol: partition of a record into blocks, the in-memory adaptor, and
per-sample transforms applied block by block."""

import numpy as np
import pytest

from physid.errors import InputError
from physid.signals import Recording
from physid.signals.blocks import (
    BlockSource,
    RecordingBlocks,
    TransformedBlocks,
    as_block_source,
    block_starts,
)


@pytest.mark.parametrize("n", [1, 2, 3, 7, 8, 9, 100, 101])
@pytest.mark.parametrize("size", [2, 3, 8, 50])
def test_block_starts_partition_every_sample_once(n, size):
    starts = block_starts(n, size)
    lengths = np.diff(starts)
    assert starts[0] == 0 and starts[-1] == n
    assert np.all(lengths >= 1)
    # every block but the last has exactly `size`; the last has size..2*size-1 (or all of n)
    assert np.all(lengths[:-1] == size)
    assert lengths[-1] == n if n < size else size <= lengths[-1] <= 2 * size - 1


def _rec(n=103, dt=0.01):
    rng = np.random.default_rng(0)
    t = 2.0 + dt * np.arange(n)
    return Recording(t, rng.normal(size=(n, 3)), ["q1", "tau1", "x"], ["rad", "N*m", "m"])


def test_recording_blocks_concatenate_to_the_recording():
    rec = _rec()
    src = RecordingBlocks(rec)
    assert isinstance(src, BlockSource)
    assert (src.n_samples, src.t0) == (103, 2.0)
    assert src.dt == pytest.approx(0.01, rel=1e-12)
    blocks = list(src.blocks(10))
    assert [b.n_samples for b in blocks] == [10] * 9 + [13]
    np.testing.assert_array_equal(np.concatenate([b.data for b in blocks]), rec.data)
    np.testing.assert_array_equal(np.concatenate([b.t for b in blocks]), rec.t)
    # a second pass starts again at the first sample
    again = next(iter(src.blocks(10)))
    np.testing.assert_array_equal(again.data, rec.data[:10])


def test_recording_blocks_hand_out_the_channels_asked_for():
    rec = _rec()
    block = next(iter(RecordingBlocks(rec).blocks(5, channels=["tau1", "q1"])))
    assert block.names == ("tau1", "q1") and block.units == ("N*m", "rad")
    np.testing.assert_array_equal(block.data, rec.select(["tau1", "q1"])[:5])


def test_transformed_blocks_apply_a_per_sample_map():
    rec = _rec()

    def gear(r):
        return r.with_channels({"q1": r["q1"] / 50.0})

    src = TransformedBlocks(RecordingBlocks(rec), gear)
    out = np.concatenate([b["q1"] for b in src.blocks(16)])
    np.testing.assert_array_equal(out, rec["q1"] / 50.0)
    assert src.names == rec.names


def test_transformed_blocks_refuse_a_transform_that_drops_samples():
    src = TransformedBlocks(RecordingBlocks(_rec()), lambda r: r)
    src.transform = lambda r: Recording(r.t[:1], r.data[:1], r.names, r.units)
    with pytest.raises(InputError, match="keep the number of samples"):
        list(src.blocks(10))


def test_as_block_source_wraps_a_recording_and_refuses_other_things():
    rec = _rec()
    assert isinstance(as_block_source(rec), RecordingBlocks)
    src = RecordingBlocks(rec)
    assert as_block_source(src) is src
    with pytest.raises(InputError, match="expected a Recording or a block source"):
        as_block_source(np.zeros((3, 2)))
