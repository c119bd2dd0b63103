"""Recording files read block by block (`open_blocks`): a `BlockSource` that never holds a file.

A block is made the way `load_recording` makes a whole file: the format's reader hands over the
variables of the block's rows (`block_formats`), and the same `_assemble` applies the channel
map, the defaults, the units and every check to them, its messages naming the record's own
sample (or data row and line). What only the whole record knows is settled once, when the
file is opened: its length, its first and last time (two rows read at each end), hence its
period ``dt = (t_last − t_first) / (n − 1)``, and the integer stamp subtracted from every
time; the time of each block is then checked against that period, across the edges of blocks
too, so that a gap anywhere is refused at its sample.
"""

from __future__ import annotations

import contextlib
import os
import warnings
import weakref
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..._resources import check_memory, format_bytes
from ..._validate import check_int
from ...errors import DataFileError, InputError
from ..blocks import RecordingBlocks
from ..recording import Recording
from .assemble import _assemble
from .block_formats import _CsvBlocks, _Hdf5Blocks, _NpzBlocks, _ParquetBlocks
from .files import _check_csv_only, _check_readable, _format_of, _reading_options
from .rosbag_reader import is_rosbag
from .timebase import rate_time
from .variables import DEFAULT_UNIFORM_RTOL, SUPPORTED_SUFFIXES

__all__ = [
    "open_blocks",
    "FileBlocks",
    "BLOCK_FORMATS",
    "blocks_obstacle",
    "in_memory_bytes",
    "in_memory_samples",
    "in_memory_extent",
    "MAX_WHOLE_MAT_BYTES",
]

#: How each format is read by `open_blocks` (for messages and the docs).
BLOCK_FORMATS = {
    "hdf5": "by dataset slices (h5py); MATLAB v7.3 files the same",
    "npz": "by slices (uncompressed members at their offset, compressed ones decompressed forward)",
    "csv": "in chunks of lines, after a first scan that counts the rows",
    "parquet": "by row batches (pyarrow)",
    "mat": "MATLAB v7.3 by dataset slices; a v5 file is read whole (up to MAX_WHOLE_MAT_BYTES)",
    "rosbag": "one topic message by message (rosbags), decoded a block at a time",
}

#: Largest MATLAB v5 ``.mat`` file [bytes] `open_blocks` reads whole (a v5 file cannot be read
#: in slices); larger ones are refused with the formats that can be.
MAX_WHOLE_MAT_BYTES = 512 * 2**20


@dataclass
class _Options:
    channels: Any
    defaults: dict
    defaults_source: str
    rate: float | None
    rate_source: str
    uniform_rtol: float | None


def open_blocks(
    path,
    channels: Mapping[str, str] | None = None,
    *,
    rate: float | None = None,
    channel_defaults: Mapping[str, str] | None = None,
    channel_defaults_source: str | None = None,
    uniform_rtol: float | None = DEFAULT_UNIFORM_RTOL,
    decimal: str = ".",
    delimiter: str | None = None,
    topic: str | None = None,
    joint_names: Sequence[str] | None = None,
) -> FileBlocks:
    """Open a recording file to be read in blocks (a `physid.signals.blocks.BlockSource`).

    The keywords are `load_recording`'s and mean the same; the blocks, concatenated, hold what
    ``load_recording(path, ...)`` returns: the same channels, units and values (bit for bit),
    and times ``t0 + k·dt`` (the whole-file load snaps onto that grid; a file within 1e-6 of it
    keeps its own times there, which differ from these by rounding). `BLOCK_FORMATS` says how
    each format is read. Memory: one block read holds O(size × channels) values (the block's
    rows of every variable of the file, then its channels) plus the reader's buffers (an HDF5
    chunk, a Parquet row group's pages, a CSV chunk's lines), whatever the record's length.

    Parameters
    ----------
    path : str or os.PathLike
        ``.h5``/``.hdf5``, ``.mat`` (v7.3; v5 up to `MAX_WHOLE_MAT_BYTES`, read whole),
        ``.npz``, ``.csv``/``.txt``, ``.parquet``, or a ROS bag (``.bag``, ``.mcap``,
        ``.db3`` or a ROS 2 bag folder).
    channels, rate, channel_defaults, channel_defaults_source, uniform_rtol, decimal, delimiter
        As for `load_recording` (``rate`` [Hz], ``uniform_rtol`` relative). ``resample`` has no
        block form: a non-uniform record is refused at the sample where it stops being uniform.
    topic, joint_names
        ROS bags, as for `load_recording` (ignored ``joint_names`` for other files): one topic
        (several, joined on their stamps, are refused: they are read whole), its joints
        matched to ``joint_names`` by name. A block of ``size`` messages holds them raw and
        decoded: about 2 kB per message of a 7-joint JointState, measured (`.rosbag_blocks`).

    Returns
    -------
    FileBlocks
        ``n_samples``, ``dt`` [s], ``t0`` [s], ``names``, ``units``, ``metadata``,
        ``blocks(size, channels=None)``; ``path``, ``format``; a context manager.

    Raises
    ------
    DataFileError
        What `load_recording` refuses; several topics of a ROS bag; a v5 ``.mat`` file too
        large to read whole; and, while blocks are read, a NaN/inf, a time not increasing or a
        gap (at its sample), a file that changed since it was opened.
    InputError, ExpressionError, MissingDependencyError
        As for `load_recording`.

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "r.npz"
    >>> np.savez(p, t=np.arange(10) * 0.1, x=np.arange(10.0))
    >>> with open_blocks(p) as src:
    ...     [b["x"].tolist() for b in src.blocks(4)]
    [[0.0, 1.0, 2.0, 3.0], [4.0, 5.0, 6.0, 7.0, 8.0, 9.0]]
    """
    _, uniform_rtol, channels, defaults, rate, rate_source, decimal, delimiter = _reading_options(
        False, uniform_rtol, channels, channel_defaults, channel_defaults_source, rate, decimal,
        delimiter,
    )  # fmt: skip
    path = Path(path)
    options = _Options(
        channels, defaults, channel_defaults_source or "channel_defaults=", rate, rate_source,
        uniform_rtol,
    )  # fmt: skip
    if is_rosbag(path):
        from .rosbag_blocks import _BagBlocks

        bag = _BagBlocks(path, topic, joint_names, set(channels or {}))
        options.channels = {**bag.joint_map, **(channels or {})} or None  # as load_recording
        return FileBlocks(path, "rosbag", bag, options)
    if topic is not None:
        raise InputError(f"topic= applies to ROS bags only; {path} is not one. Drop it.")
    fmt = _format_of(path, SUPPORTED_SUFFIXES, "read")
    _check_readable(path)
    _check_csv_only(path, fmt, decimal, delimiter)
    if fmt == "mat" and not _is_hdf5(path):
        return _whole_mat(path, options)
    reader = {
        "hdf5": lambda: _Hdf5Blocks(path, channels, defaults),
        "mat": lambda: _Hdf5Blocks(path, channels, defaults, matlab=True),
        "npz": lambda: _NpzBlocks(path, channels, defaults),
        "csv": lambda: _CsvBlocks(path, decimal, delimiter),
        "parquet": lambda: _ParquetBlocks(path),
    }[fmt]()
    return FileBlocks(path, fmt, reader, options)


def _formats_text() -> str:
    return "HDF5 (.h5), MATLAB v7.3 (.mat), NPZ, CSV and Parquet"


def _is_hdf5(path: Path) -> bool:
    """Whether the file is HDF5 (a MATLAB v7.3 file): the signature at 0, 512, 1024 …"""
    with open(path, "rb") as fh:
        for offset in (0, 512, 1024, 2048):
            fh.seek(offset)
            if fh.read(8) == b"\x89HDF\r\n\x1a\n":
                return True
    return False


def _whole_mat(path: Path, options: _Options) -> FileBlocks:
    """A MATLAB v5 file: read whole when it is small enough, refused otherwise."""
    size = path.stat().st_size
    if size > MAX_WHOLE_MAT_BYTES:
        raise DataFileError(
            f"{path}: a MATLAB v5 .mat file of {format_bytes(size)}; v5 files cannot be read in "
            f"slices, and physid reads them whole only up to {format_bytes(MAX_WHOLE_MAT_BYTES)}. "
            "Save it from MATLAB as v7.3 (save(name, '-v7.3'), HDF5 inside, read by slices), "
            f"or in another format read in blocks: {_formats_text()}."
        )
    from .mat_reader import _read_mat

    source = _read_mat(path)
    source.metadata = {**source.metadata, "source": str(path), "format": "mat"}
    rec = _assemble(
        path, source, options.channels, resample=False, uniform_rtol=options.uniform_rtol,
        defaults=options.defaults, defaults_source=options.defaults_source, rate=options.rate,
        rate_source=options.rate_source,
    )  # fmt: skip
    return FileBlocks(path, "mat", _WholeRecording(rec), options)


class _WholeRecording:
    """A recording already loaded (a MATLAB v5 file), handed out as blocks."""

    how = "whole"

    def __init__(self, rec: Recording):
        self.rec = rec
        self.n = rec.n_samples


class FileBlocks:
    """A recording file read block by block (`open_blocks` makes it; a `BlockSource`).

    Attributes
    ----------
    path : pathlib.Path
    format : str
        ``"hdf5"``, ``"mat"``, ``"npz"``, ``"csv"``, ``"parquet"`` or ``"rosbag"``.
    n_samples : int
    dt : float
        Sample period [s] of the whole record.
    t0 : float
        Time of the first sample [s].
    names, units : tuple of str
        The channels (as `load_recording` names them) and their SI units.
    metadata : dict
        As the whole file's (``"source"``, ``"format"``, ``"channel_map"`` …).
    """

    def __init__(self, path: Path, fmt: str, reader, options: _Options):
        self.path, self.format = path, fmt
        self._reader, self._options = reader, options
        self._stat = _stat(path)
        self._passes: weakref.WeakSet = weakref.WeakSet()  # passes not yet ended (close())
        if isinstance(reader, _WholeRecording):
            self._whole = RecordingBlocks(reader.rec)
            rec = reader.rec
            self.n_samples, self.dt, self.t0 = rec.n_samples, self._whole.dt, float(rec.t[0])
            self.names, self.units, self.metadata = rec.names, rec.units, dict(rec.metadata)
            self._origin = None
            return
        self._whole = None
        self.n_samples = n = int(reader.n)
        if n < 2:
            raise DataFileError(
                f"{path}: the file holds {'only 1 sample' if n == 1 else 'no samples'}; it "
                "needs at least 2 rows."
            )
        self._origin = None
        first = self._assemble(self._probe(0, 2), 0, 2, warn=True)
        self._origin = int(first.metadata.get("time_origin", {}).get("first_stamp", 0))
        last = self._assemble(self._probe(n - 2, n), n - 2, n, warn=False)
        rate = options.rate
        # the time of a file without one: k / rate, which a block's own rows start again at 0
        grid = None if rate is None else rate_time(2, rate)
        self._rate_time = grid is not None and all(np.array_equal(r.t, grid) for r in (first, last))
        if self._rate_time:
            self.t0, self.dt = 0.0, 1.0 / rate
        else:
            self.t0 = float(first.t[0])
            self.dt = float((last.t[-1] - first.t[0]) / (n - 1))
            if not self.dt > 0:
                raise DataFileError(
                    f"{path}: time is not increasing: the last sample (t = {last.t[-1]!r}) is "
                    f"not after the first (t = {first.t[0]!r}). Sort the rows by time."
                )
        self.names, self.units = tuple(first.names), tuple(first.units)
        self.metadata = {k: v for k, v in first.metadata.items() if k != "max_sampling_deviation"}
        self.metadata.update(source=str(path), format=fmt)  # as load_recording sets them

    # ------------------------------------------------------------------ reading
    def _probe(self, a: int, b: int):
        probe = getattr(self._reader, "probe", None)
        if probe is not None:
            return probe(a, b)
        with self._reader.reading() as read:
            return read(a, b)

    def _assemble(self, source, a: int, b: int, *, warn: bool) -> Recording:
        """The `Recording` of rows ``a:b`` (errors name the record's sample or row)."""
        if self._origin is not None:
            for var in source.variables.values():
                var.origin = self._origin
        source.row_label = self._labels(source.row_label, a)
        opts = self._options
        with warnings.catch_warnings():
            if not warn:
                warnings.simplefilter("ignore")
            return _assemble(
                self.path, source, opts.channels, resample=False, uniform_rtol=None,
                defaults=opts.defaults, defaults_source=opts.defaults_source,
                rate=opts.rate, rate_source=opts.rate_source,
            )  # fmt: skip

    def _labels(self, own, a: int):
        dt = getattr(self, "dt", None)
        t0 = getattr(self, "t0", 0.0)

        def label(i: int) -> str:
            base = own(i) if own is not None else f"sample {a + i}"
            if own is not None:
                base = f"sample {a + i}, {base}"
            return base if dt is None else f"{base}, t ≈ {t0 + (a + i) * dt:.6g} s"

        return label

    def blocks(self, size: int, channels: Sequence[str] | None = None) -> Iterator[Recording]:
        """Consecutive blocks of ``size`` samples (the last up to ``2·size − 1``).

        Parameters
        ----------
        size : int
            Block length [samples] (≥ 2).
        channels : sequence of str, optional
            Channels to hand out (default all); the block is computed whole, then selected.

        Yields
        ------
        Recording
            Times ``t0 + k·dt`` [s] (the file's own with ``uniform_rtol=None``), SI units.

        Raises
        ------
        DataFileError
            A NaN/inf, a time not increasing or a gap (at its sample: split the file there), a
            file that changed since it was opened.
        """
        size = check_int(size, "size", minimum=2)
        names = self._check_channels(channels)
        if self._whole is not None:
            return self._whole.blocks(size, names)
        self._check_block_memory(size)
        gen = self._blocks(size, names)
        self._passes.add(gen)
        return gen

    def _blocks(self, size: int, names: list) -> Iterator[Recording]:
        self._check_unchanged()
        count = max(self.n_samples // size, 1)  # block_starts' partition, without its array
        prev = None
        with self._reader.reading() as read:
            for j in range(count):
                a, b = j * size, (j + 1) * size if j < count - 1 else self.n_samples
                rec = self._assemble(read(a, b), a, b, warn=False)
                if rec.n_samples != b - a:
                    raise _length_error(self.path, a, b, rec.n_samples)
                try:
                    t = self._block_time(rec, a, b, prev)
                except _Drift as drift:
                    self._locate(read, size, j + 1, count, drift)
                prev = rec.t[-1] if not self._rate_time else None
                units = [rec.unit(n) for n in names]
                yield Recording(t, rec.select(names), names, units, self.metadata)
        self._check_unchanged()

    def _check_channels(self, channels) -> list[str]:
        if channels is None:
            return list(self.names)
        if isinstance(channels, str):
            channels = [channels]
        names = [str(c) for c in channels]
        missing = [c for c in names if c not in self.names]
        if missing:
            raise InputError(
                f"channels={missing} not in {self.path}; its channels are {list(self.names)}."
            )
        return names

    def _check_block_memory(self, size: int) -> None:
        """The declared sizes of one block (a crafted dataset of a billion columns)."""
        layout = getattr(self._reader, "layout", None)
        if layout is None:
            return
        nbytes = 2 * size * layout.row_bytes()

        def message(nbytes, available):
            return (
                f"{self.path}: one block of {size} samples of its datasets would take "
                f"{format_bytes(nbytes)}, more than half of the {format_bytes(available)} of "
                "memory available; read smaller blocks, or save the channels you need in a "
                "smaller file."
            )

        try:
            check_memory(nbytes, what="", fix="", message=message)
        except InputError as exc:
            raise DataFileError(str(exc)) from None

    def _check_unchanged(self) -> None:
        if _stat(self.path) != self._stat:
            raise DataFileError(
                f"{self.path}: the file changed since it was opened (its size or time of "
                "modification); a file that is still being written cannot be read in blocks. "
                "Open it again once it is complete."
            )

    def _block_time(self, rec: Recording, a: int, b: int, prev) -> np.ndarray:
        """The block's times [s], checked against the record's period (edges included)."""
        k = np.arange(a, b)
        if self._rate_time:
            return k / self._options.rate  # as rate_time: k / rate
        t = np.asarray(rec.t)
        rtol = self._options.uniform_rtol
        full = t if prev is None else np.concatenate([[prev], t])
        steps = np.diff(full)
        first = a if prev is None else a - 1  # the sample each step starts at
        if prev is not None and steps[0] <= 0:
            raise self._back(a, float(t[0]), float(prev))
        if rtol is None:
            return t
        deviation = np.abs(steps - self.dt) / self.dt
        if deviation.size and float(deviation.max()) > rtol:
            local = float(np.median(steps))  # the interval here: a gap stands out of it
            off = np.abs(steps - local) / local
            if float(off.max()) > rtol:
                i = int(np.argmax(off > rtol))  # the first irregular interval
                one = _lone(off > rtol, i)
                raise self._gap(first + i, float(full[i]), float(steps[i]), local, rtol, one)
            raise _Drift(local, float(t[-1]))
        return self.t0 + self.dt * k

    def _locate(self, read, size: int, start: int, count: int, drift: _Drift):
        """After a block whose intervals all differ from the record's period: read on to the
        first interval off the block's own (the whole-file load names the worst interval)."""
        rtol, prev = self._options.uniform_rtol, drift.prev
        for j in range(start, count):
            a, b = j * size, (j + 1) * size if j < count - 1 else self.n_samples
            t = np.asarray(self._assemble(read(a, b), a, b, warn=False).t)
            full = np.concatenate([[prev], t])
            steps = np.diff(full)
            if steps[0] <= 0:
                raise self._back(a, float(t[0]), float(prev))
            off = np.abs(steps - drift.local) / drift.local
            if float(off.max()) > rtol:
                i = int(np.argmax(off > rtol))  # the first irregular interval
                one = _lone(off > rtol, i)
                raise self._gap(a - 1 + i, float(full[i]), float(steps[i]), drift.local, rtol, one)
            prev = t[-1]
        fix = self._time_hint() or (
            " Resample it (load_recording(..., resample=True) reads it whole)."
        )
        raise DataFileError(
            f"{self.path}: time is not uniformly sampled: its intervals drift from "
            f"{drift.local:.6g} s to the record's mean period {self.dt:.6g} s "
            f"((t_last − t_first) / (n − 1)) by more than the tolerance {rtol:g}, without one "
            f"gap to split at.{fix} Or pass uniform_rtol=None to keep the times as they are."
        )

    def _back(self, a: int, t_a: float, prev: float) -> DataFileError:
        return DataFileError(
            f"{self.path}: time is not strictly increasing: t = {t_a!r} at sample {a} follows "
            f"t = {prev!r} at sample {a - 1}. Sort the rows by time and remove duplicates (or "
            f"split the file at sample {a})."
        )

    def _gap(self, g: int, t_at: float, step: float, period: float, rtol: float, one=False):
        """The error of the first irregular interval, from sample ``g``: with the format's hint
        on jitter first (a ROS bag's) for a step off by under half a period among others off,
        a gap's otherwise (a lost sample, or ``one``: a lone step, a jump in the time)."""
        interval = (
            f"the interval from sample {g} (t = {t_at:.6g} s) to sample {g + 1} is {step:.6g} s "
            f"against a period of {period:.6g} s (relative deviation "
            f"{abs(step - period) / period:.3g}, tolerance {rtol:g})"
        )
        hint = self._time_hint()
        if hint and not one and abs(step - period) < 0.5 * period:  # jitter: no lost sample
            return DataFileError(
                f"{self.path}: time is not uniformly sampled from sample {g}: its stamps jitter "
                f"({interval}, the first interval this far off); a stream of blocks cannot "
                f"resample.{hint} Or pass uniform_rtol=None to keep the times as they are."
            )
        return DataFileError(
            f"{self.path}: time is not uniformly sampled: {interval}: a gap or a jump in the "
            f"time. Split the file at sample {g + 1} and fit the parts as separate experiments "
            "(physid.signals.join_recordings splits files at gaps), or pass uniform_rtol=None "
            "to keep the times as they are."
        )

    def _time_hint(self) -> str:
        """What the format adds to a time error (a ROS bag: its stamps may jitter)."""
        hint = getattr(self._reader, "time_hint", "")
        return f" {hint}" if hint else ""

    # ------------------------------------------------------------------ the rest
    def close(self) -> None:
        """End the passes not read to their end (a ROS bag's reader, a file they hold open)."""
        for gen in list(self._passes):
            gen.close()
        self._passes.clear()

    def __enter__(self) -> FileBlocks:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        return (
            f"FileBlocks({str(self.path)!r}, {self.format}, {self.n_samples} samples at "
            f"{self.dt:.6g} s, channels {list(self.names)})"
        )


class _Drift(Exception):
    """A block whose intervals all differ from the record's period by the same amount."""

    def __init__(self, local: float, prev: float):
        super().__init__(local, prev)
        self.local, self.prev = local, prev


def _stat(path: Path) -> tuple:
    """Size and time of modification of the file, or of each file of a folder (a ROS 2 bag:
    its metadata.yaml and storage files)."""
    path = Path(path)
    if path.is_dir():
        return tuple(
            (p.name, *_stat(p)) for p in sorted(path.iterdir(), key=lambda p: p.name) if p.is_file()
        )
    st = os.stat(path)
    return (st.st_size, st.st_mtime_ns)


def _length_error(path, a, b, got) -> DataFileError:
    return DataFileError(
        f"{path}: samples {a}..{b - 1} gave {got} time samples, not {b - a}: the time and the "
        "channels have different lengths; every channel needs one value per time sample."
    )


def blocks_obstacle(path, topic=None) -> str | None:
    """Why `open_blocks` cannot read ``path`` in blocks, from its name alone, or None.

    The rule the streamed fits share (``physid identify --stream``, ``physid estimate
    --stream``, fleets): a file of a format in `BLOCK_FORMATS` (a ROS bag, its ``.bag``, its
    ``.mcap``/``.db3`` or its folder, included) streams; several ROS bag topics joined on their
    stamps do not. A file that can be named here may still fail to open (then `open_blocks`
    says why).

    Parameters
    ----------
    path : str or Path
        The record file (or a ROS 2 bag's folder).
    topic : str, optional
        As `open_blocks` (several comma-separated topics are read whole).

    Returns
    -------
    str or None
        The reason, its settings marked with `physid.errors.arg` (the command line shows its
        flags), or None.
    """
    from ...errors import arg

    if is_rosbag(path):
        names = [t for t in topic.split(",") if t.strip()] if isinstance(topic, str) else []
        if len(names) > 1:
            return (
                f"{arg('topic', repr(topic), cli=topic)} joins several topics on their stamps "
                "by interpolation onto one grid of the whole run"
            )
        return None
    fmt = SUPPORTED_SUFFIXES.get(Path(path).suffix.lower())
    if fmt not in BLOCK_FORMATS:
        return (
            f"{path} cannot be read in blocks (formats read in blocks: "
            f"{', '.join(sorted(BLOCK_FORMATS))})"
        )
    return None


def in_memory_samples(path, topic=None) -> int | None:
    """The samples of ``path`` from its index alone, or None where only its size bounds them.

    A ROS bag: its topic's message count (a ROS 1 bag's index, a ROS 2 bag's metadata.yaml),
    no message decoded. The one rule by which ``identify``, ``estimate`` and fleets
    size a bag under ``--stream auto``.

    Parameters
    ----------
    path : str or os.PathLike
    topic : str, optional
        A ROS bag's topic(s), as `open_blocks`.

    Returns
    -------
    int or None

    Raises
    ------
    DataFileError
        A bag that cannot be opened, or without the topic.
    """
    if not is_rosbag(path):
        return None
    from .rosbag_reader import bag_extent

    return bag_extent(Path(path), topic, width=False)[0]


def in_memory_extent(path, topic=None) -> tuple[int, int | None]:
    """`in_memory_bytes` and `in_memory_samples` of ``path`` at once (a ROS bag opened once).

    Parameters
    ----------
    path : str or os.PathLike
    topic : str, optional
        A ROS bag's topic(s), as `open_blocks` (other files: unused).

    Returns
    -------
    nbytes : int
        As `in_memory_bytes` [bytes].
    samples : int or None
        As `in_memory_samples` (None: not a ROS bag).

    Raises
    ------
    DataFileError
        As `in_memory_bytes`.
    """
    if not is_rosbag(path):
        return in_memory_bytes(path, topic), None
    from .rosbag_reader import bag_extent, read_bytes

    count, values = bag_extent(Path(path), topic)
    return read_bytes(count, values), count


def in_memory_bytes(path, topic=None) -> int:
    """Estimated bytes `load_recording` would take for ``path``, from its shapes, types and size.

    No sample is read (of a ROS bag, its first message alone is decoded): HDF5/v7.3 datasets and
    NPZ members by their declared shape and type (the values, then as float64), a v5 ``.mat`` by
    its variables' declared sizes, Parquet by its rows × columns, a CSV file as three times its
    size (the text, its copy parsed, the table), a ROS bag by its index's message count times
    the values of its first message (three float64 copies, as its whole read checks); anything
    else twice its size.

    Parameters
    ----------
    path : str or os.PathLike
    topic : str, optional
        A ROS bag's topic(s), as `open_blocks` (other files: unused).

    Returns
    -------
    int
        Bytes (an estimate of the peak, within a factor of about 2).

    Raises
    ------
    DataFileError
        A missing or unreadable file.
    """
    path = Path(path)
    if is_rosbag(path):
        return in_memory_extent(path, topic)[0]
    _check_readable(path)
    size = path.stat().st_size
    fmt = SUPPORTED_SUFFIXES.get(path.suffix.lower())
    with contextlib.suppress(Exception):
        if fmt in ("hdf5", "mat") and _is_hdf5(path):
            return _hdf5_bytes(path)
        if fmt == "npz":
            return _npz_bytes(path)
        if fmt == "mat":
            from scipy import io as sio

            from .mat_reader import _CLASS_BYTES

            listing = sio.whosmat(path)
            return int(
                sum(
                    int(np.prod(shape, dtype=object)) * (_CLASS_BYTES.get(c, 8) + 8)
                    for _, shape, c in listing
                )
            )
        if fmt == "parquet":
            from .parquet_reader import _open_parquet

            meta = _open_parquet(path).metadata
            return int(meta.num_rows) * int(meta.num_columns) * 16
    return 3 * size if fmt == "csv" else 2 * size


def _hdf5_bytes(path: Path) -> int:
    import h5py

    total = 0

    def visit(_, obj):
        nonlocal total
        if isinstance(obj, h5py.Dataset) and obj.shape is not None:
            total += int(np.prod(obj.shape, dtype=object)) * (obj.dtype.itemsize + 8)

    with h5py.File(path, "r") as f:
        f.visititems(visit)
    return total


def _npz_bytes(path: Path) -> int:
    import zipfile

    from .block_formats import _npy_member

    total = 0
    with zipfile.ZipFile(path) as zf:
        for info in zf.infolist():
            m = _npy_member(zf, info)
            total += int(np.prod(m.shape, dtype=object)) * (m.dtype.itemsize + 8)
    return total


def _lone(irregular: np.ndarray, i: int) -> bool:
    """Whether interval ``i``, the first of ``irregular``, is the only one there (not jitter),
    and not the block's last (the next block may go on jittering)."""
    return bool(i < irregular.size - 1 and np.count_nonzero(irregular) == 1)
