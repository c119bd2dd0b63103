"""Read and write recordings: CSV, NPZ, MATLAB ``.mat`` (v5 and v7.3), HDF5 and Parquet.

File layouts
------------
CSV
    A header row of channel names; a unit may follow a name in brackets, ``q1 [rad]``. The
    separator is ``,``, ``;`` or tab (recognised from the header and the first data row, or given
    with ``delimiter=``); ``decimal=","`` reads decimal commas. Lines starting with ``#`` are
    comments; ``# metadata: {json}`` carries the recording's metadata (its numbers can be used in
    channel maps, like the scalars of a ``.mat`` file).
NPZ, MAT, HDF5
    Either ``data`` (n_samples, n_channels) with ``names`` (and optionally ``units``), or one
    variable per channel: 1-D of length n_samples, or 2-D (n_samples, k) which becomes channels
    ``name1..namek``. MATLAB structs and HDF5 groups are reached with dots (``data.pos``). A
    dataset attribute ``unit`` (or ``units``) gives the channel's unit (HDF5, MATLAB v7.3).
    Scalars (a drive gain, a sampling rate) are not channels but may be used in channel maps.
Parquet
    One column per channel (needs pyarrow: ``pip install "physid[parquet]"``); a unit in the
    column's field metadata ``unit`` or at the end of its name (``q1 [rad]``); the schema
    metadata ``physid`` (JSON) is the recording's metadata.
Long records
    `open_blocks` reads a file block by block instead of whole (`BLOCK_FORMATS` says how each
    format is read); concatenated, the blocks are what `load_recording` returns.

Time
    The column or variable named ``t``, else one named ``time`` in any case (``Time``,
    ``time [ms]``), else the one mapped with ``channels={"t": ...}``.

Units (one rule for every format)
    A unit in a header, an attribute or a channel map is converted to SI with the table of
    `physid.units` at load; the recording keeps the SI unit. A unit the table does not
    know is refused on the channels physid reads (``t``, ``q1``, ``qd1``, ``tau1``, ``r1``,
    ``u``, ``x``, ``y`` and every mapped channel); a unit of the wrong kind for such a channel
    (``[V]`` on ``tau1``) is refused with the map that fixes it. Other channels keep their values
    and unit as they are (listed in ``metadata["unconverted_units"]``).

Channel maps
    ``channels={"t": "time", "q1": "qm", "tau1": "gtau*vir"}``: each recording channel from a
    variable name or arithmetic over variables and scalars of the file (parsed by
    `physid.expressions`, never evaluated as Python; the variables are in SI units). A trailing
    ``[unit]`` gives the unit of an expression's value (``"35.15*vir [N]"``). Unmapped channels
    of the file are kept unless a mapped channel takes their name or a map uses them.

Every problem with a file raises `DataFileError` naming the file, the channel or row, and the
fix; bad keyword values raise `InputError`, an expression physid refuses `ExpressionError`, and
a missing h5py `MissingDependencyError`. Messages name Python keywords (``resample=True``); the
command line shows its own flags instead (``--resample``).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from ...errors import DataFileError, InputError
from ..recording import Recording
from ..writers import _header_cell as _header_cell
from ..writers import _split_header_cell as _split_header_cell
from ..writers import write_recording
from .assemble import _assemble
from .block_readers import (
    BLOCK_FORMATS,
    FileBlocks,
    in_memory_bytes,
    in_memory_extent,
    in_memory_samples,
    open_blocks,
)
from .csv_reader import _read_csv
from .files import _check_csv_only, _check_readable, _format_of, _reading_options
from .hdf5_reader import _read_hdf5
from .mat_reader import _read_mat
from .npz_reader import _read_npz
from .options import parse_channel_map
from .parquet_reader import _read_parquet
from .rosbag_reader import is_rosbag, read_rosbag
from .variables import _READ_CHANNEL as _READ_CHANNEL  # read from here by tests
from .variables import _RESERVED as _RESERVED
from .variables import (
    DEFAULT_UNIFORM_RTOL,
    MAX_ABS_VALUE,
    SUPPORTED_SUFFIXES,
    DataFileWarning,
    _Source,
    _Var,
)

__all__ = [
    "load_recording",
    "open_blocks",
    "FileBlocks",
    "BLOCK_FORMATS",
    "in_memory_bytes",
    "in_memory_samples",
    "in_memory_extent",
    "map_recording",
    "save_recording",
    "parse_channel_map",
    "DEFAULT_UNIFORM_RTOL",
    "SUPPORTED_SUFFIXES",
    "MAX_ABS_VALUE",
    "DataFileWarning",
]

_open = open  # opens a file for the readability check (tests replace it to simulate chmod 000)


def load_recording(
    path,
    channels: Mapping[str, str] | None = None,
    *,
    resample: bool = False,
    uniform_rtol: float | None = DEFAULT_UNIFORM_RTOL,
    decimal: str = ".",
    delimiter: str | None = None,
    channel_defaults: Mapping[str, str] | None = None,
    channel_defaults_source: str | None = None,
    rate: float | None = None,
    topic: str | None = None,
    joint_names=None,
) -> Recording:
    """Read a recording from CSV, NPZ, MATLAB ``.mat``, HDF5, Parquet or a ROS bag (by suffix).

    Long by its docstring: every keyword of every format is documented here.

    Parameters
    ----------
    path : str or os.PathLike
        The file. Suffixes: ``.csv``/``.txt``, ``.npz``, ``.mat``, ``.h5``/``.hdf5``,
        ``.parquet`` (needs ``physid[parquet]``); ROS bags ``.bag`` (ROS 1), ``.mcap``/``.db3``
        or a ROS 2 bag folder (needs ``physid[ros]``).
    channels : mapping of str to str, optional
        Channel map: recording channel name → a variable of the file (``"qm"``, a struct field
        ``"data.pos"``) or arithmetic over variables and scalars (``"gtau*vir"``), optionally
        followed by the value's unit in brackets (``"35.15*vir [N]"``). ``"t"`` maps the time.
        The variables are in SI units when the expression is evaluated. CLI: ``--map
        t=time,q1=qm,tau1=gtau*vir``. A string ``"t=time,q1=qm"`` is accepted too.
    resample : bool
        If the sampling is not uniform within ``uniform_rtol``, interpolate linearly onto a uniform
        grid with the mean period (`Recording.resample`) instead of raising (CLI: ``--resample``).
        Must be a real bool (a string such as ``'no'`` is refused, not read as truthy).
    uniform_rtol : float ≥ 0 or None
        Largest accepted deviation of a sample interval from the mean period, relative to it
        (finite; NaN or inf are refused).
        Within it the time vector is snapped onto the exact grid ``t0 + k·Δ`` (so that
        ``rec.dt`` works downstream; the worst deviation is kept in ``metadata``). ``None``
        keeps the time vector as it is, uniform or not.
    decimal : {".", ","}
        Decimal mark of a CSV file (CLI: ``--decimal ,``). With ``","`` the separator is ``;``
        or tab.
    delimiter : {",", ";", "\\t"} or None
        Separator of a CSV file; None recognises it from the header and first data row.
    channel_defaults : mapping of str to str, optional
        A channel map from elsewhere, e.g. a model file's ``[recording]`` table; ``channels``
        entries override it. Its entries apply as ``channels``' do, except one whose source
        names the file lacks while the file already has the target channel (physid's own
        recordings, which call it ``q1`` already): that entry is dropped and the file's channel
        is used, listed in ``metadata["channel_defaults_unused"]`` (target → entry).
    channel_defaults_source : str, optional
        What ``channel_defaults`` is, for messages (e.g. ``"the [recording] table of
        axis.toml"``); default ``"channel_defaults="``. A ``"rate"`` entry of
        ``channel_defaults`` is the table's sample rate [Hz]: used for a file without a time
        column, ignored for a file with one.
    rate : float, optional
        Sample rate [Hz] of a file without a time column (CLI: ``--rate 5000``): the time is
        ``t = k / rate``, k = 0 .. n-1. A file that has a time column is refused with it.
    topic : str, optional
        ROS bags: the ``sensor_msgs/JointState`` topic to read (CLI: ``--topic
        /joint_states``); default the bag's only one. Also a ``Float64MultiArray`` topic, or
        several separated by commas, joined on their stamps (`.rosbag_reader`).
    joint_names : sequence of str, optional
        ROS bags: the model's joint names; the bag's joints of these names become ``q1..qn``,
        ``qd1..qdn``, ``tau1..taun`` in this order (matched by name, in any order in the bag).

    Returns
    -------
    Recording
        Channels in SI units, with ``metadata["source"]`` (the path) and ``metadata["format"]``;
        ``metadata["channel_map"]`` when a map was given, ``metadata["original_units"]`` for
        converted channels.

    Raises
    ------
    InputError
        A keyword with a bad value.
    DataFileError
        Unknown suffix, missing or unreadable file, empty file, no time, non-numeric cells,
        NaN/inf or values beyond ±`MAX_ABS_VALUE`, duplicate channel names, time not strictly
        increasing, non-uniform sampling, a complex/text/cell channel, a unit that cannot be
        converted or does not fit the channel, a mapped name or struct path that is not there.
    ExpressionError
        A channel-map expression that uses an unknown name or a forbidden construct.
    MissingDependencyError
        An HDF5 or MATLAB v7.3 file and h5py is not installed (``pip install "physid[io]"``),
        a Parquet file and pyarrow is not (``pip install "physid[parquet]"``).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "r.csv"
    >>> _ = p.write_text("time [ms],pos [mm],F [N]\\n0,1,0\\n500,2,1\\n1000,4,0\\n")
    >>> rec = load_recording(p, {"x": "pos", "u": "F"})
    >>> rec.names, rec.units, rec.dt, rec["x"].tolist()
    (('x', 'u'), ('m', 'N'), 0.5, [0.001, 0.002, 0.004])
    """
    resample, uniform_rtol, channels, defaults, rate, rate_source, decimal, delimiter = (
        _reading_options(
            resample, uniform_rtol, channels, channel_defaults, channel_defaults_source, rate,
            decimal, delimiter,
        )
    )  # fmt: skip
    path = Path(path)
    if is_rosbag(path):
        source = read_rosbag(path, topic=topic, joint_names=joint_names, mapped=set(channels or {}))
        channels = {**source.metadata.pop("joint_map", {}), **(channels or {})} or None
        fmt = "rosbag"
    else:
        fmt = _format_of(path, SUPPORTED_SUFFIXES, "read")
        if topic is not None:
            raise InputError(f"topic= applies to ROS bags only; {path} is not one. Drop it.")
        _check_readable(path, _open)
    if fmt == "rosbag":
        pass  # read above
    elif fmt == "csv":
        source = _read_csv(path, decimal=decimal, delimiter=delimiter)
    else:
        _check_csv_only(path, fmt, decimal, delimiter)
        readers = {"npz": _read_npz, "mat": _read_mat, "hdf5": _read_hdf5, "parquet": _read_parquet}
        source = readers[fmt](path)
    source.metadata = {**source.metadata, "source": str(path), "format": fmt}
    return _assemble(
        path, source, channels, resample=resample, uniform_rtol=uniform_rtol,
        defaults=defaults, defaults_source=channel_defaults_source or "channel_defaults=",
        rate=rate, rate_source=rate_source,
    )  # fmt: skip


def map_recording(
    rec: Recording,
    channels: Mapping[str, str] | None = None,
    *,
    channel_defaults: Mapping[str, str] | None = None,
    channel_defaults_source: str | None = None,
) -> Recording:
    """Apply a channel map to a recording already loaded (e.g. files joined into one run).

    The channels of ``rec`` are the variables the map sees, in their (SI) units, exactly as
    `load_recording` applies a map to a file's columns.

    Parameters
    ----------
    rec : Recording
    channels, channel_defaults, channel_defaults_source
        As for `load_recording`.

    Returns
    -------
    Recording
        Same time vector; mapped channels, and the others kept.

    Raises
    ------
    DataFileError, ExpressionError
        As for `load_recording` (named after ``metadata["source"]``).

    Examples
    --------
    >>> rec = Recording([0.0, 0.1], [[1.0, 2.0], [3.0, 4.0]], ["pos.j1", "cur.j1"], ["m", "A"])
    >>> out = map_recording(rec, {"q1": "pos.j1", "tau1": "0.5*cur.j1 [N]"})
    >>> out.names, out["tau1"].tolist()
    (('q1', 'tau1'), [1.0, 2.0])
    """
    if not isinstance(rec, Recording):
        raise InputError(f"map_recording expects a Recording; got {type(rec).__name__}.")
    variables = {"t": _Var("t", np.asarray(rec.t), "s", size=rec.n_samples)}
    for j, name in enumerate(rec.names):
        variables[name] = _Var(
            name, np.asarray(rec.data[:, j]), rec.units[j], size=rec.n_samples, column=True
        )
    source = _Source(variables, dict(rec.metadata))
    defaults = parse_channel_map(channel_defaults) or {}
    defaults.pop("rate", None)  # the time is the recording's
    return _assemble(
        rec.metadata.get("source", "the recording"), source, parse_channel_map(channels),
        resample=False, uniform_rtol=DEFAULT_UNIFORM_RTOL, defaults=defaults,
        defaults_source=channel_defaults_source or "channel_defaults=",
    )  # fmt: skip


def save_recording(rec: Recording, path, *, overwrite: bool = True) -> Path:
    """Write a recording to CSV (units in the header) or NPZ, chosen by the suffix.

    Parameters
    ----------
    rec : Recording
    path : str or os.PathLike
        ``.csv`` or ``.npz``.
    overwrite : bool
        If False, refuse to replace an existing file.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    DataFileError
        Not a Recording, a bad suffix, an existing file with ``overwrite=False``, a missing
        folder, a unit that holds ``[`` or ``]`` (it could not be read back from a header).

    Notes
    -----
    CSV header cells are quoted where needed (names with commas, quotes or newlines), a name
    that looks like ``name [unit]`` is written with an empty unit ``[]`` after it, and values
    are written with Python's shortest round-trip representation, so
    ``load_recording(save_recording(rec, p))`` returns the same names, units and numbers bit
    for bit whenever the units are SI (non-SI units are converted to SI when read back).
    """
    if not isinstance(rec, Recording):
        raise DataFileError(f"save_recording expects a Recording; got {type(rec).__name__}.")
    return write_recording(rec, path, overwrite=overwrite)
