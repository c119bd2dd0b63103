"""Records read block by block: the protocol streamed estimators consume, and a recording as one.

A record too long for memory is never held whole: a *block source* hands it out as consecutive
`Recording` blocks, and a streamed estimator (`physid.estimators.idim.stream`) keeps only what
its filters need across a block's edge. Every block source has

``n_samples`` : int
    Samples in the whole record.
``dt`` : float [s]
    The record's sample period, ``(t_last − t_first) / (n_samples − 1)`` (or ``1 / rate``):
    one value for the whole record, so that a filter designed for it is the same in every block.
``t0`` : float [s]
    Time of the first sample.
``names``, ``units`` : tuple of str
    The record's channels (without ``t``), SI units.
``metadata`` : mapping
    As `Recording.metadata` (``"source"``: the file, when there is one; PD gains …).
``blocks(size, channels=None)`` : iterator of `Recording`
    Consecutive blocks in time order that together hold samples ``0 .. n_samples − 1`` once
    each: block k starts at sample ``k · size``; every block has ``size`` samples except the
    last, which has ``size`` to ``2 · size − 1`` (a short tail joins the block before it, so no
    block is too short for a difference). ``channels`` restricts the channels read. Each call
    starts again at the first sample (a streamed fit may read the record twice). Times are
    ``t0 + k · dt`` for sample k.

`RecordingBlocks` gives a `Recording` already in memory this protocol (tests compare a streamed
fit with the in-memory one on the same data; a fleet's short logs go through the same code).
File-backed sources come from `physid.signals.io.open_blocks`.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np

from .._validate import check_int
from ..errors import InputError
from .recording import Recording

__all__ = ["BlockSource", "RecordingBlocks", "TransformedBlocks", "as_block_source", "block_starts"]


@runtime_checkable
class BlockSource(Protocol):
    """What a streamed estimator reads: a record handed out in consecutive blocks."""

    n_samples: int
    dt: float
    t0: float
    names: tuple[str, ...]
    units: tuple[str, ...]
    metadata: Mapping[str, Any]

    def blocks(self, size: int, channels: Sequence[str] | None = None) -> Iterator[Recording]:
        """Consecutive `Recording` blocks of ``size`` samples (the last up to ``2·size − 1``)."""
        ...


def block_starts(n_samples: int, size: int) -> np.ndarray:
    """First sample of each block, and ``n_samples`` at the end (the protocol's partition).

    Parameters
    ----------
    n_samples : int
        Samples of the record (≥ 1).
    size : int
        Block length [samples] (≥ 2).

    Returns
    -------
    ndarray of int, shape (n_blocks + 1,)
        ``starts[k]:starts[k+1]`` is block k; a tail shorter than ``size`` joins the last block.

    Examples
    --------
    >>> block_starts(10, 4).tolist(), block_starts(8, 4).tolist(), block_starts(3, 4).tolist()
    ([0, 4, 10], [0, 4, 8], [0, 3])
    """
    n = check_int(n_samples, "n_samples", minimum=1)
    size = check_int(size, "size", minimum=2)
    starts = np.arange(0, n, size)
    if starts.size > 1 and n - starts[-1] < size:
        starts = starts[:-1]
    return np.append(starts, n)


class RecordingBlocks:
    """A `Recording` in memory as a `BlockSource` (blocks are views of its arrays).

    Parameters
    ----------
    recording : Recording
        Uniformly sampled (``recording.dt`` must work).

    Examples
    --------
    >>> rec = Recording(np.arange(5) * 0.1, np.arange(5.0), ["x"], ["m"])
    >>> src = RecordingBlocks(rec)
    >>> [b["x"].tolist() for b in src.blocks(2)]
    [[0.0, 1.0], [2.0, 3.0, 4.0]]
    """

    def __init__(self, recording: Recording):
        if not isinstance(recording, Recording):
            raise InputError(
                f"RecordingBlocks expects a Recording; got {type(recording).__name__}."
            )
        self.recording = recording
        self.n_samples = int(recording.n_samples)
        t = np.asarray(recording.t)
        recording.dt  # noqa: B018 - refuses non-uniform sampling with its own message
        self.dt = float((t[-1] - t[0]) / (t.size - 1)) if t.size > 1 else float("nan")
        self.t0 = float(t[0])
        self.names = tuple(recording.names)
        self.units = tuple(recording.units)
        self.metadata = recording.metadata

    def blocks(self, size: int, channels: Sequence[str] | None = None) -> Iterator[Recording]:
        """Consecutive blocks of ``size`` samples (see the module's protocol).

        Parameters
        ----------
        size : int
            Block length [samples] (≥ 2).
        channels : sequence of str, optional
            Channels to hand out (default all).

        Yields
        ------
        Recording
        """
        rec = self.recording
        names = list(self.names if channels is None else channels)
        data = rec.select(names)
        units = [rec.unit(n) for n in names]
        starts = block_starts(self.n_samples, size)
        for a, b in zip(starts[:-1], starts[1:], strict=True):
            yield Recording(rec.t[a:b], data[a:b], names, units, rec.metadata)

    def __repr__(self) -> str:
        return (
            f"RecordingBlocks({self.n_samples} samples at {self.dt:.6g} s, "
            f"channels {list(self.names)})"
        )


def as_block_source(obj) -> BlockSource:
    """A `BlockSource` for ``obj``: itself when it is one, a `RecordingBlocks` for a `Recording`.

    Parameters
    ----------
    obj : BlockSource or Recording

    Returns
    -------
    BlockSource

    Raises
    ------
    InputError
        Anything else.
    """
    if isinstance(obj, Recording):
        return RecordingBlocks(obj)
    if isinstance(obj, BlockSource):
        return obj
    raise InputError(
        f"expected a Recording or a block source (physid.signals.io.open_blocks); got "
        f"{type(obj).__name__}."
    )


class TransformedBlocks:
    """A block source whose every block passes through ``transform`` (a per-sample map).

    For conversions that act sample by sample, such as motor-side channels through a
    transmission (``q = K⁻¹ θm``): applied block by block they give the blocks of the converted
    record. ``transform`` must keep the time vector and the number of samples.

    Parameters
    ----------
    source : BlockSource
    transform : callable
        ``transform(block: Recording) -> Recording``.

    Examples
    --------
    >>> rec = Recording(np.arange(4) * 0.5, np.arange(4.0), ["x"], ["m"])
    >>> double = TransformedBlocks(
    ...     RecordingBlocks(rec), lambda r: r.with_channels({"y": 2 * r["x"]}, {"y": "m"})
    ... )
    >>> double.names, [b["y"].tolist() for b in double.blocks(2)]
    (('x', 'y'), [[0.0, 2.0], [4.0, 6.0]])
    """

    def __init__(self, source: BlockSource, transform):
        self.source = source
        self.transform = transform
        self.n_samples = source.n_samples
        self.dt = source.dt
        self.t0 = source.t0
        self.metadata = source.metadata
        first = next(iter(source.blocks(2)))
        probe = transform(first)
        self.names = tuple(probe.names)
        self.units = tuple(probe.units)

    def blocks(self, size: int, channels: Sequence[str] | None = None) -> Iterator[Recording]:
        """The source's blocks, transformed (then restricted to ``channels``).

        Parameters
        ----------
        size : int
            Block length [samples].
        channels : sequence of str, optional
            Channels of the transformed blocks to hand out (default all).

        Yields
        ------
        Recording
        """
        for block in self.source.blocks(size):
            out = self.transform(block)
            if out.n_samples != block.n_samples:
                raise InputError(
                    "a block transform must keep the number of samples; it turned "
                    f"{block.n_samples} into {out.n_samples}."
                )
            if channels is not None:
                names = list(channels)
                out = Recording(
                    out.t, out.select(names), names, [out.unit(n) for n in names], out.metadata
                )
            yield out

    def close(self) -> None:
        """Close the source (when it can be closed)."""
        close = getattr(self.source, "close", None)
        if callable(close):
            close()
