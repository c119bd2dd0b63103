"""`Recording`: a time vector, named channels with units, and metadata, validated on creation."""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np

from .._validate import as_1d, as_2d, check_finite, check_time, sample_period
from ..errors import InputError, MissingDependencyError, SamplingError, ShapeError

__all__ = ["Recording"]


def _frozen(arr: np.ndarray) -> np.ndarray:
    arr.setflags(write=False)
    return arr


def _pandas(what: str):
    try:
        import pandas as pd
    except ImportError:
        raise MissingDependencyError(
            f'{what} needs pandas, which is not installed; run pip install "physid[pandas]" '
            "(or pip install pandas)."
        ) from None
    return pd


def _numeric_column(values, what: str) -> np.ndarray:
    arr = np.asarray(values)
    if arr.dtype.kind not in "biuf":
        raise InputError(
            f"column {what} holds {arr.dtype} values, not real numbers; convert it "
            "(e.g. df[col].astype(float)) or drop it."
        )
    return arr.astype(float)


@dataclass(frozen=True, eq=False)
class Recording:
    """Sampled signals of one experiment.

    Parameters
    ----------
    t : array_like, shape (n_samples,) [s]
        Sample times, strictly increasing.
    data : array_like, shape (n_samples, n_channels)
        Channel values, time on axis 0. A 1-D array is one channel.
    names : sequence of str, length n_channels
        Unique channel names, e.g. ``("q1", "q2", "tau1", "tau2")``.
    units : sequence of str or mapping name -> unit, optional
        SI unit of each channel (``""`` when unknown or dimensionless).
    metadata : mapping, optional
        Free-form JSON-serialisable information (source file, simulation settings, seed ...).

    Notes
    -----
    The arrays are copied on creation and made read-only, so a recording never mutates what it was
    given and cannot be changed behind its back. Sampling need not be uniform to build a recording;
    methods that need a uniform grid call `dt`, which checks it once and says how to fix it.

    Examples
    --------
    >>> rec = Recording([0.0, 0.1, 0.2], [[1.0], [2.0], [3.0]], ["x"], units=["m"])
    >>> rec["x"].tolist(), rec.dt, rec.unit("x")
    ([1.0, 2.0, 3.0], 0.1, 'm')
    """

    t: np.ndarray
    data: np.ndarray
    names: tuple[str, ...]
    units: tuple[str, ...] = ()
    metadata: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        t = check_time(self.t, "t", min_samples=1)
        names = tuple(str(n) for n in self.names)
        data = as_2d(self.data, "data")
        if data.shape[0] != t.size:
            raise ShapeError(
                f"data has {data.shape[0]} rows but t has {t.size} samples; they must be equal "
                "(time runs along axis 0 of data)."
            )
        if len(names) != data.shape[1]:
            raise ShapeError(
                f"got {len(names)} channel name(s) {names} for {data.shape[1]} data column(s); "
                "give exactly one name per column."
            )
        seen: set[str] = set()
        for n in names:
            if not n or n.strip() != n:
                raise InputError(
                    f"channel name {n!r} is empty or has surrounding spaces; rename it."
                )
            if n == "t":
                raise InputError("'t' is reserved for the time vector; rename the channel.")
            if n in seen:
                raise InputError(f"duplicate channel name {n!r}; channel names must be unique.")
            seen.add(n)
        check_finite(data, "data", names)
        units = self.units
        if isinstance(units, Mapping):
            unknown = set(units) - set(names)
            if unknown:
                raise InputError(
                    f"units given for unknown channel(s) {sorted(unknown)}; known: {names}."
                )
            units = tuple(str(units.get(n, "")) for n in names)
        elif len(units) == 0:
            units = ("",) * len(names)
        else:
            units = tuple(str(u) for u in units)
            if len(units) != len(names):
                raise ShapeError(
                    f"got {len(units)} unit(s) for {len(names)} channel(s); give one per channel."
                )
        object.__setattr__(self, "t", _frozen(t))
        object.__setattr__(self, "data", _frozen(data))
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "units", units)
        object.__setattr__(self, "metadata", MappingProxyType(dict(self.metadata)))

    # ---------------------------------------------------------------- construction helpers
    @classmethod
    def from_columns(
        cls,
        t,
        columns: Mapping[str, Any],
        units: Mapping[str, str] | None = None,
        metadata: Mapping[str, Any] | None = None,
    ) -> Recording:
        """Build a recording from ``{name: 1-D array}`` (``(n, k)`` arrays become ``name1..namek``).

        Parameters
        ----------
        t : array_like, shape (n_samples,) [s]
            Sample times, strictly increasing.
        columns : mapping of str to array_like, each of shape (n_samples,) or (n_samples, k)
            Channel values; a 2-D value under key ``"q"`` becomes channels ``q1 .. qk``.
        units : mapping of str to str, optional
            Unit per channel name; a unit given for ``"q"`` applies to ``q1 .. qk``.
        metadata : mapping, optional
            JSON-serialisable information.

        Returns
        -------
        Recording
            Channels in the order of ``columns``.

        Raises
        ------
        ShapeError
            Columns of different lengths, or not matching ``t``.

        Examples
        --------
        >>> import numpy as np
        >>> rec = Recording.from_columns(
        ...     [0.0, 0.1], {"q": np.zeros((2, 2)), "tau": [1.0, 2.0]}, units={"q": "rad"}
        ... )
        >>> rec.names, rec.units
        (('q1', 'q2', 'tau'), ('rad', 'rad', ''))
        """
        names: list[str] = []
        cols: list[np.ndarray] = []
        for key, value in columns.items():
            arr = np.asarray(value, dtype=float)
            if arr.ndim == 2:
                for j in range(arr.shape[1]):
                    names.append(f"{key}{j + 1}")
                    cols.append(arr[:, j])
            else:
                names.append(key)
                cols.append(as_1d(arr, f"column {key!r}"))
        lengths = {c.size for c in cols}
        if len(lengths) > 1:
            raise ShapeError(
                f"columns have different lengths {sorted(lengths)}; they must all match t."
            )
        data = np.column_stack(cols) if cols else np.empty((np.size(t), 0))
        unit_map = {}
        for name in names:
            if units and name in units:
                unit_map[name] = units[name]
            elif units:
                stem = name.rstrip("0123456789")
                unit_map[name] = units.get(stem, "")
        return cls(t, data, tuple(names), unit_map or (), metadata or {})

    # ---------------------------------------------------------------- access
    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return int(self.t.size)

    @property
    def n_channels(self) -> int:
        """Number of channels."""
        return len(self.names)

    @property
    def dt(self) -> float:
        """Sample period [s]; raises `SamplingError` if the sampling is not uniform."""
        return sample_period(self.t, "the recording's time vector")

    @property
    def duration(self) -> float:
        """Time from the first to the last sample [s]."""
        return float(self.t[-1] - self.t[0])

    def __contains__(self, name: object) -> bool:
        return name in self.names

    def __getitem__(self, name: str) -> np.ndarray:
        """Return one channel as a read-only 1-D array of shape (n_samples,)."""
        return self.data[:, self._index(name)]

    def unit(self, name: str) -> str:
        """Unit of channel ``name`` (``""`` if unknown); `InputError` if there is no such one."""
        return self.units[self._index(name)]

    def _index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise InputError(
                f"the recording has no channel {name!r}; it has {list(self.names)}."
            ) from None

    def select(self, names: Iterable[str]) -> np.ndarray:
        """Return the named channels as a new array of shape (n_samples, len(names)).

        Parameters
        ----------
        names : iterable of str
            Channel names, in the column order wanted.

        Returns
        -------
        ndarray, shape (n_samples, len(names)) [units of the channels]
            A writable copy.

        Raises
        ------
        InputError
            A name is not a channel of the recording (the message lists the channels).

        Examples
        --------
        >>> rec = Recording([0.0, 1.0], [[1.0, 2.0], [3.0, 4.0]], ["a", "b"])
        >>> rec.select(["b", "a"]).tolist()
        [[2.0, 1.0], [4.0, 3.0]]
        """
        names = list(names)
        missing = [n for n in names if n not in self.names]
        if missing:
            raise InputError(
                f"the recording lacks channel(s) {missing}; it has {list(self.names)}."
            )
        return self.data[:, [self.names.index(n) for n in names]].copy()

    def channels(self, prefix: str) -> list[str]:
        """Names ``prefix1, prefix2, ...`` present in order (e.g. ``channels("q")`` -> q1..qn).

        Parameters
        ----------
        prefix : str
            Channel-name stem, e.g. ``"q"`` or ``"tau"``.

        Returns
        -------
        list of str
            ``prefix1 .. prefixk`` for the longest unbroken run starting at 1 (empty if
            ``prefix1`` is missing).

        Examples
        --------
        >>> rec = Recording([0.0, 1.0], [[0, 0, 0]] * 2, ["q1", "q2", "q4"])
        >>> rec.channels("q")
        ['q1', 'q2']
        """
        out = []
        k = 1
        while f"{prefix}{k}" in self.names:
            out.append(f"{prefix}{k}")
            k += 1
        return out

    # ---------------------------------------------------------------- derived recordings
    def with_channels(
        self, columns: Mapping[str, Any], units: Mapping[str, str] | None = None
    ) -> Recording:
        """Return a new recording with channels added or replaced.

        Parameters
        ----------
        columns : mapping of str to array_like (n_samples,)
            New channels (appended) or replacements of existing ones (same position).
        units : mapping of str to str, optional
            Units of the given columns; a replaced channel keeps its unit when none is given.

        Returns
        -------
        Recording
            Same time vector and metadata; this recording is unchanged.

        Raises
        ------
        ShapeError
            A column does not have one value per sample.
        """
        names = list(self.names)
        data = [self.data[:, i] for i in range(self.n_channels)]
        unit_list = list(self.units)
        for key, value in columns.items():
            col = as_1d(value, f"column {key!r}")
            if col.size != self.n_samples:
                raise ShapeError(
                    f"column {key!r} has {col.size} samples; the recording has {self.n_samples}."
                )
            unit = (units or {}).get(key, "")
            if key in names:
                i = names.index(key)
                data[i] = col
                unit_list[i] = unit or unit_list[i]
            else:
                names.append(key)
                data.append(col)
                unit_list.append(unit)
        return Recording(
            self.t, np.column_stack(data), tuple(names), tuple(unit_list), dict(self.metadata)
        )

    def slice_time(self, start: float | None = None, stop: float | None = None) -> Recording:
        """Return the samples with ``start <= t <= stop`` [s].

        Parameters
        ----------
        start, stop : float or None [s]
            Inclusive bounds; None means unbounded on that side.

        Returns
        -------
        Recording
            The kept samples with all channels, units and metadata.

        Raises
        ------
        SamplingError
            No sample lies in the interval.

        Examples
        --------
        >>> rec = Recording([0.0, 0.5, 1.0, 1.5], [1.0, 2.0, 3.0, 4.0], ["x"])
        >>> rec.slice_time(0.5, 1.0).t.tolist()
        [0.5, 1.0]
        """
        keep = np.ones(self.n_samples, dtype=bool)
        if start is not None:
            keep &= self.t >= start
        if stop is not None:
            keep &= self.t <= stop
        if not keep.any():
            raise SamplingError(
                f"no sample lies in [{start}, {stop}] s; "
                f"the record spans [{self.t[0]}, {self.t[-1]}] s."
            )
        return Recording(self.t[keep], self.data[keep], self.names, self.units, dict(self.metadata))

    def resample(self, dt: float | None = None) -> Recording:
        """Linearly interpolate onto a uniform grid of period ``dt`` [s] (default: mean period).

        Parameters
        ----------
        dt : float or None [s]
            Period of the new grid ``t0 + k·dt``, k = 0 .. floor(duration/dt); None: the mean
            period ``duration / (n_samples - 1)`` (same first and last time, same length).

        Returns
        -------
        Recording
            With ``metadata["resampled_from"]`` = {"n_samples", "dt"}.

        Raises
        ------
        InputError
            ``dt`` is not a finite number > 0.
        SamplingError
            The recording has fewer than 2 samples.

        Examples
        --------
        Interpolation is exact on linear data:

        >>> rec = Recording([0.0, 0.1, 0.3, 0.4], [0.0, 1.0, 3.0, 4.0], ["x"])
        >>> out = rec.resample()
        >>> out.dt, out["x"].round(12).tolist()
        (0.13333333333333333, [0.0, 1.333333333333, 2.666666666667, 4.0])
        """
        if self.n_samples < 2:
            raise SamplingError(
                f"resampling needs at least 2 samples; the recording has {self.n_samples}."
            )
        if dt is None:
            dt = self.duration / (self.n_samples - 1)
        if (
            isinstance(dt, (bool, np.bool_))
            or not isinstance(dt, (int, float, np.integer, np.floating))
            or not (np.isfinite(dt) and dt > 0)
        ):
            raise InputError(
                f"dt must be a finite number > 0 [s] or None (the mean period); got {dt!r}."
            )
        n = int(np.floor(self.duration / dt + 1e-9)) + 1
        t_new = self.t[0] + dt * np.arange(n)
        data = np.column_stack(
            [np.interp(t_new, self.t, self.data[:, i]) for i in range(self.n_channels)]
        )
        meta = dict(self.metadata)
        meta["resampled_from"] = {"n_samples": self.n_samples, "dt": float(dt)}
        return Recording(t_new, data, self.names, self.units, meta)

    def detrend(self, names: Iterable[str] | None = None, kind: str = "constant") -> Recording:
        """Return a recording with the mean (or the least-squares line) of channels removed.

        The explicit alternative to estimating an offset (``output_offset`` in a linear-ODE
        model file): ``kind="constant"`` removes a sensor bias together with the input's mean,
        like MATLAB's ``detrend(data, 0)`` on input and output; ``"linear"`` also removes a
        drift. Removing the mean of the input and the output of a linear ODE keeps the
        equation true when the record starts and ends at rest; otherwise the remaining DC
        mismatch biases the static gain (estimate the offset instead).

        Parameters
        ----------
        names : iterable of str or None
            Channels to detrend (default: all).
        kind : {"constant", "linear"}

        Returns
        -------
        Recording
            With ``metadata["detrended"] = {name: removed mean [unit]}`` (the mean of the
            removed line for ``"linear"``).

        Raises
        ------
        InputError
            An unknown channel or kind.

        Examples
        --------
        >>> rec = Recording([0.0, 1.0, 2.0], [[1.0, 5.0], [2.0, 5.0], [3.0, 5.0]], ["x", "u"])
        >>> rec.detrend(["x"])["x"].tolist()
        [-1.0, 0.0, 1.0]
        """
        if kind not in ("constant", "linear"):
            raise InputError(f"kind must be 'constant' or 'linear'; got {kind!r}.")
        names = list(self.names) if names is None else list(names)
        missing = [n for n in names if n not in self.names]
        if missing or not names:
            raise InputError(
                f"detrend: the recording has no channel(s) {missing or names}; it has "
                f"{list(self.names)}."
            )
        idx = [self.names.index(n) for n in names]
        data = np.array(self.data, copy=True)
        block = data[:, idx]
        if kind == "constant":
            trend = np.broadcast_to(block.mean(axis=0), block.shape)
        else:  # least-squares line per channel: [1, t - t̄] @ coef, centred for conditioning
            tc = self.t - self.t.mean()
            basis = np.column_stack([np.ones_like(tc), tc])
            coef, *_ = np.linalg.lstsq(basis, block, rcond=None)
            trend = basis @ coef
        data[:, idx] = block - trend
        meta = dict(self.metadata)
        meta["detrended"] = {
            n: float(m) for n, m in zip(names, np.mean(trend, axis=0).tolist(), strict=True)
        }
        meta["detrend_kind"] = kind
        return Recording(self.t, data, self.names, self.units, meta)

    # ---------------------------------------------------------------- pandas
    @classmethod
    def from_dataframe(
        cls,
        df,
        time: str | None = None,
        *,
        units: Mapping[str, str] | None = None,
        metadata: Mapping[str, Any] | None = None,
    ) -> Recording:
        """Build a recording from a pandas DataFrame (pandas is optional).

        Parameters
        ----------
        df : pandas.DataFrame
            One column per channel; a unit may follow a column name in brackets
            (``"pos [mm]"``) and is converted to SI like a file header.
        time : str or None
            The time column [s] (its unit, if written ``"time [ms]"``, is converted). None: the
            index, which may be a numeric index [s] or a TimedeltaIndex / DatetimeIndex
            (seconds from the first row).
        units : mapping of str to str, optional
            Units of columns (override bracketed units).
        metadata : mapping, optional

        Returns
        -------
        Recording
            Channels in SI units (``metadata["original_units"]`` lists the converted ones).

        Raises
        ------
        MissingDependencyError
            pandas is not installed (``pip install "physid[pandas]"``).
        InputError
            ``time`` is not a column, a column is not numeric, a unit is unknown.

        Examples
        --------
        >>> import pandas as pd  # doctest: +SKIP
        >>> df = pd.DataFrame({"t": [0.0, 0.1], "pos [mm]": [1.0, 2.0]})  # doctest: +SKIP
        >>> Recording.from_dataframe(df, time="t")["pos"].tolist()  # doctest: +SKIP
        [0.001, 0.002]
        """
        pd = _pandas("Recording.from_dataframe")
        from ..units import parse_unit

        if not isinstance(df, pd.DataFrame):
            raise InputError(f"df must be a pandas DataFrame; got {type(df).__name__}.")
        columns = [str(c) for c in df.columns]
        units = dict(units or {})

        def split(label: str) -> tuple[str, str]:
            from .writers import _split_header_cell

            name, unit = _split_header_cell(label)
            return name, units.get(name, units.get(label, unit))

        if time is None:
            index = df.index
            if isinstance(index, pd.DatetimeIndex | pd.TimedeltaIndex):
                t = np.asarray((index - index[0]) / pd.Timedelta(seconds=1), dtype=float)
            else:
                t = _numeric_column(index.to_numpy(), "the index")
            labels = columns
        else:
            if str(time) not in columns:
                raise InputError(
                    f"time={time!r} is not a column of the DataFrame; its columns are {columns}; "
                    "pass time=None to use the index."
                )
            label = str(time)
            _, t_unit = split(label)
            t = _numeric_column(df[df.columns[columns.index(label)]].to_numpy(), repr(label))
            u = parse_unit(t_unit)
            if u.si and u.dimension != (0, 0, 1, 0, 0):
                raise InputError(f"the time column {label!r} has unit {t_unit!r}, not a time.")
            t = t * u.scale
            labels = [c for c in columns if c != label]
        names, cols, si_units, original = [], [], [], {}
        for label in labels:
            name, unit = split(label)
            values = _numeric_column(df[df.columns[columns.index(label)]].to_numpy(), repr(label))
            u = parse_unit(unit)
            names.append(name)
            cols.append(values * u.scale if u.scale != 1.0 else values)
            si_units.append(u.si)
            if u.si != unit:
                original[name] = unit
        meta = dict(metadata or {})
        if original:
            meta["original_units"] = original
        data = np.column_stack(cols) if cols else np.empty((t.size, 0))
        return cls(t, data, tuple(names), tuple(si_units), meta)

    def to_dataframe(self, *, units_in_names: bool = False):
        """The channels as a pandas DataFrame indexed by time ``t`` [s] (pandas is optional).

        Parameters
        ----------
        units_in_names : bool
            Name the columns ``"q1 [rad]"`` instead of ``"q1"`` (`from_dataframe` reads both).

        Returns
        -------
        pandas.DataFrame
            Index ``t`` [s]; ``df.attrs`` holds ``units`` and ``metadata``.

        Raises
        ------
        MissingDependencyError
            pandas is not installed (``pip install "physid[pandas]"``).
        """
        pd = _pandas("Recording.to_dataframe")
        cols = [
            f"{n} [{u}]" if units_in_names and u else n
            for n, u in zip(self.names, self.units, strict=True)
        ]
        df = pd.DataFrame(
            np.array(self.data), columns=cols, index=pd.Index(self.t.copy(), name="t")
        )
        df.attrs["units"] = dict(zip(self.names, self.units, strict=True))
        df.attrs["metadata"] = dict(self.metadata)
        return df

    # ---------------------------------------------------------------- export
    def to_dict(self) -> dict[str, Any]:
        """Columns as lists, plus units and metadata (JSON-ready)."""
        return {
            "t": self.t.tolist(),
            "channels": {n: self[n].tolist() for n in self.names},
            "units": dict(zip(self.names, self.units, strict=True)),
            "metadata": json.loads(json.dumps(dict(self.metadata), default=str)),
        }

    def __repr__(self) -> str:
        pairs = zip(self.names, self.units, strict=True)
        chans = ", ".join(f"{n} [{u}]" if u else n for n, u in pairs)
        span = f"{self.t[0]:.6g}..{self.t[-1]:.6g} s" if self.n_samples else "empty"
        return f"Recording({self.n_samples} samples, {span}{self._rate_text()}; {chans})"

    def _rate_text(self) -> str:
        if self.n_samples < 2:
            return ""
        rate = (self.n_samples - 1) / float(self.t[-1] - self.t[0])
        return f" at {rate / 1000:.4g} kHz" if rate >= 1000 else f" at {rate:.4g} Hz"

    def _repr_html_(self) -> str:
        """A notebook table: each channel's unit and range; samples, duration and rate."""
        import html

        rows = "".join(
            f"<tr><td>{html.escape(n)}</td><td>{html.escape(u)}</td>"
            f"<td style='text-align:right'>{np.nanmin(self[n]):.4g}</td>"
            f"<td style='text-align:right'>{np.nanmax(self[n]):.4g}</td></tr>"
            for n, u in zip(self.names, self.units, strict=True)
        )
        span = f"{self.duration:.6g} s" if self.n_samples else "empty"
        return (
            f"<div><p style='margin:0.2em 0'><b>Recording</b> {self.n_samples} samples, {span}"
            f"{self._rate_text()}, {self.n_channels} channels</p><table><thead><tr>"
            "<th>channel</th><th>unit</th><th>min</th><th>max</th></tr></thead>"
            f"<tbody>{rows}</tbody></table></div>"
        )

    def save(self, path, **kwargs) -> None:
        """Write to CSV or NPZ (chosen by the suffix); see `physid.signals.io.save_recording`."""
        from .writers import write_recording

        write_recording(self, path, **kwargs)

    def plot(self, names: Sequence[str] | None = None, ax=None):
        """Plot channels against time; returns the matplotlib Figure (see `physid.report`)."""
        from ..report.figures import plot_recording

        return plot_recording(self, names=names, ax=ax)
