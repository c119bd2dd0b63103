"""Several files, one run: the columns of recordings of the same experiment, joined onto one
uniform time grid (positions in one file, currents in another, as robots log them).

Files sampled at a rate (no time column) are joined column by column, sample by sample; files
with time stamps are aligned on their stamps (integer epoch stamps keep their common origin,
`Recording.metadata["time_origin"]`), cut to the time all of them cover, and interpolated
linearly onto one uniform grid. A gap longer than ``gap`` periods in any file splits the run into
segments (separate experiments for an estimator); it is never bridged by interpolation.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import DataFileError, InputError
from ..units import parse_unit
from .recording import Recording

__all__ = ["JoinedRun", "join_recordings", "DEFAULT_GAP"]

#: A sample interval longer than this many periods (the file's median) is a gap.
DEFAULT_GAP = 5.0

#: Segments shorter than this many samples are dropped (with a note): too short to filter.
MIN_SEGMENT_SAMPLES = 10


@dataclass(frozen=True)
class JoinedRun:
    """Recordings joined into one run (see `join_recordings`).

    Attributes
    ----------
    segments : tuple of Recording
        The run on a uniform grid, one recording per stretch without gaps.
    period : float [s]
        Period of the grid.
    jitter : float
        Largest deviation of a file's sample interval from its median interval, relative to
        that median (0 for files sampled at a rate).
    gaps : tuple of (float, float, str)
        Start and end [s, on the joined time axis] of each gap that split the run, and the file.
    notes : tuple of str
        What was done, in words (the grid, the jitter, the gaps, dropped segments).
    """

    segments: tuple
    period: float
    jitter: float = 0.0
    gaps: tuple = ()
    notes: tuple = field(default_factory=tuple)

    def summary(self) -> str:
        """The notes, one per line.

        Returns
        -------
        str
        """
        return "\n".join(self.notes)


def join_recordings(
    recordings: Sequence[Recording], labels: Sequence[str] | None = None, *, gap=DEFAULT_GAP
) -> JoinedRun:
    """Join the channels of several recordings of one run onto one uniform grid.

    Parameters
    ----------
    recordings : sequence of Recording, at least 2
        The files of one run. Either all sampled at one rate (``metadata["rate"]``, as
        `physid.load_recording` with ``rate=`` makes them; same number of samples), or all with
        time stamps (any sampling, jitter allowed).
    labels : sequence of str, optional
        One name per recording (the file stems): a channel name found in several recordings
        becomes ``LABEL.NAME`` (``pos.Joint_1``); errors name them. Default ``rec1, rec2, ...``.
    gap : float > 1
        A sample interval longer than ``gap`` times the file's median interval splits the run.

    Returns
    -------
    JoinedRun
        ``segments`` on the grid ``t0 + k·period`` (the grid's period is the largest of the
        files' median periods: no file is sampled faster than it was logged), with
        ``metadata["joined_from"]``.

    Raises
    ------
    InputError
        Fewer than 2 recordings, labels of another length, a bad ``gap``.
    DataFileError
        Files sampled at a rate with different rates or lengths, a mix of rate and time, time
        ranges that do not overlap (both files named), stamps without a common origin.

    Examples
    --------
    >>> k = np.arange(20.0)
    >>> a = Recording(0.1 * k, k, ["q1"])                # positions from 0 to 1.9 s
    >>> b = Recording(0.1 * k + 0.05, 10 * k, ["tau1"])  # torques from 0.05 to 1.95 s
    >>> run = join_recordings([a, b], ["pos", "cur"])
    >>> seg = run.segments[0]
    >>> seg.names, seg.n_samples, seg.t[:2].round(6).tolist(), seg["tau1"][:2].round(6).tolist()
    (('q1', 'tau1'), 19, [0.05, 0.15], [0.0, 10.0])
    """
    recordings = list(recordings)
    if len(recordings) < 2 or not all(isinstance(r, Recording) for r in recordings):
        raise InputError(
            f"join_recordings needs at least 2 Recordings (the files of one run); got "
            f"{len(recordings)}."
        )
    labels = [f"rec{i + 1}" for i in range(len(recordings))] if labels is None else list(labels)
    if len(labels) != len(recordings):
        raise InputError(
            f"labels must name each recording; got {len(labels)} for {len(recordings)}."
        )
    if isinstance(gap, bool) or not isinstance(gap, (int, float)) or not (gap > 1 and gap < 1e9):
        raise InputError(f"gap must be a number of periods > 1 (e.g. 5); got {gap!r}.")
    names = _joined_names(recordings, labels)
    rated = ["rate" in r.metadata for r in recordings]
    if all(rated):
        return _join_rated(recordings, labels, names)
    if any(rated):
        which = [lb for lb, r in zip(labels, rated, strict=True) if r]
        others = [lb for lb, r in zip(labels, rated, strict=True) if not r]
        raise DataFileError(
            f"{which} have no time column (sampled at a rate) but {others} have time stamps; "
            "the files of one run must all have time stamps or all be sampled at one rate."
        )
    return _join_stamped(recordings, labels, names, float(gap))


def _joined_names(recordings, labels) -> list[list[str]]:
    """Each recording's channel names in the joined run (``LABEL.NAME`` where names collide)."""
    count: dict[str, int] = {}
    for rec in recordings:
        for n in rec.names:
            count[n] = count.get(n, 0) + 1
    out = [
        [f"{lb}.{n}" if count[n] > 1 else n for n in rec.names]
        for rec, lb in zip(recordings, labels, strict=True)
    ]
    flat = [n for names in out for n in names]
    dup = sorted({n for n in flat if flat.count(n) > 1})
    if dup:
        raise DataFileError(
            f"joining gives the channel name(s) {dup} twice (two files with the same stem?); "
            "rename the files or the columns."
        )
    return out


def _merged_metadata(recordings, labels, **extra) -> dict:
    units = {}
    for rec in recordings:
        units.update(rec.metadata.get("original_units") or {})
    meta = {
        "source": " + ".join(
            str(r.metadata.get("source", lb)) for r, lb in zip(recordings, labels, strict=True)
        ),
        "joined_from": [
            str(r.metadata.get("source", lb)) for r, lb in zip(recordings, labels, strict=True)
        ],
        **extra,
    }
    if units:
        meta["original_units"] = units
    return meta


def _join_rated(recordings, labels, names) -> JoinedRun:
    """Files without time: the same rate and length, joined column by column (no interpolation)."""
    rates = {lb: float(r.metadata["rate"]) for r, lb in zip(recordings, labels, strict=True)}
    lengths = {lb: r.n_samples for r, lb in zip(recordings, labels, strict=True)}
    if len(set(rates.values())) > 1:
        raise DataFileError(
            f"the files have different rates {rates} Hz; one run is sampled at one rate."
        )
    if len(set(lengths.values())) > 1:
        raise DataFileError(
            f"the files sampled at {next(iter(rates.values())):g} Hz have different numbers of "
            f"samples {lengths}; the files of one run need one row per sample each (trim them "
            "to the same rows)."
        )
    first = recordings[0]
    data = np.column_stack([r.data for r in recordings])
    joined_names = [n for ns in names for n in ns]
    units = [u for r in recordings for u in r.units]
    rate = next(iter(rates.values()))
    meta = _merged_metadata(recordings, labels, rate=rate)
    rec = Recording(first.t, data, tuple(joined_names), tuple(units), meta)
    note = (
        f"joined {len(recordings)} files ({', '.join(labels)}) sample by sample at {rate:g} Hz "
        f"({rec.n_samples} samples, channels {', '.join(joined_names)})"
    )
    return JoinedRun((rec,), 1.0 / rate, 0.0, (), (note,))


def _offsets(recordings, labels) -> list[float]:
    """Each file's time offset [s] on the common axis, from its integer origin (exact)."""
    origins = [r.metadata.get("time_origin") for r in recordings]
    if all(o is None for o in origins):
        return [0.0] * len(recordings)
    if any(o is None for o in origins):
        which = [lb for lb, o in zip(labels, origins, strict=True) if o is None]
        raise DataFileError(
            f"{which} have times that start near 0 while the others have epoch stamps; the "
            "files cannot be aligned. Export every file with the same clock."
        )
    scales = [parse_unit(o["unit"] if o["unit"] != "s" else "s").scale for o in origins]
    firsts = [int(o["first_stamp"]) for o in origins]
    # a common integer origin in each file's unit: differences of integers are exact
    if len(set(scales)) == 1:
        base = [min(firsts)] * len(firsts)
    else:  # stamps in different units: the common origin to a fraction of the finest unit
        base_seconds = min(f * s for f, s in zip(firsts, scales, strict=True))
        base = [int(round(base_seconds / s)) for s in scales]
    return [float(f - b) * s for f, b, s in zip(firsts, base, scales, strict=True)]


def _join_stamped(recordings, labels, names, gap) -> JoinedRun:
    """Files with time stamps: overlap, grid, gaps, interpolation per segment."""
    offsets = _offsets(recordings, labels)
    times = [r.t + off for r, off in zip(recordings, offsets, strict=True)]
    starts = [float(t[0]) for t in times]
    ends = [float(t[-1]) for t in times]
    start, end = max(starts), min(ends)
    if not end > start:
        late, early = int(np.argmax(starts)), int(np.argmin(ends))
        raise DataFileError(
            f"the time ranges of {labels[late]} ({starts[late]:.6g} to {ends[late]:.6g} s) and "
            f"{labels[early]} ({starts[early]:.6g} to {ends[early]:.6g} s) do not overlap; "
            "joining is for files recorded at the same time (one run). Give the files of one "
            "run, or fit separate runs as separate recordings."
        )
    steps = [np.diff(t) for t in times]
    medians = [float(np.median(s)) for s in steps]
    period = max(medians)
    jitter = max(float(np.max(np.abs(s - m))) / m for s, m in zip(steps, medians, strict=True))
    gaps = []
    for t, s, m, lb in zip(times, steps, medians, labels, strict=True):
        for i in np.flatnonzero(s > gap * m):
            a, b = float(t[i]), float(t[i + 1])
            if b > start and a < end:
                gaps.append((a, b, lb))
    gaps.sort()
    segments, dropped = [], []
    lo = start
    for a, b, _ in [*gaps, (end, end, "")]:
        if a > lo:
            grid = lo + period * np.arange(int(np.floor((min(a, end) - lo) / period + 1e-9)) + 1)
            if grid.size >= MIN_SEGMENT_SAMPLES:
                segments.append(_on_grid(recordings, labels, names, times, grid))
            else:
                dropped.append((lo, min(a, end)))
        lo = max(lo, b)
    if not segments:
        raise DataFileError(
            f"joining {', '.join(labels)} leaves no stretch of {MIN_SEGMENT_SAMPLES} samples "
            "without a gap; check the files' time stamps."
        )
    notes = [
        f"joined {len(recordings)} files ({', '.join(labels)}) on their time stamps onto a "
        f"uniform grid of {period * 1e3:.6g} ms ({1 / period:.6g} Hz) over {start:.6g} to "
        f"{end:.6g} s (the time all files cover), by linear interpolation; jitter up to "
        f"{100 * jitter:.3g} % of a file's median period"
    ]
    if gaps:
        where = "; ".join(f"{a:.6g} to {b:.6g} s in {lb}" for a, b, lb in gaps)
        notes.append(
            f"{len(gaps)} gap(s) longer than {gap:g} periods ({where}) split the run into "
            f"{len(segments)} segment(s), fitted as separate experiments (gaps are not bridged)"
        )
    if dropped:
        notes.append(
            f"{len(dropped)} stretch(es) shorter than {MIN_SEGMENT_SAMPLES} samples between gaps "
            "left out"
        )
    meta = {"period": period, "jitter": jitter, "gaps": [list(g) for g in gaps]}
    segments = [
        Recording(s.t, s.data, s.names, s.units, {**s.metadata, "join": {**meta, "segment": k}})
        for k, s in enumerate(segments)
    ]
    return JoinedRun(tuple(segments), period, jitter, tuple(gaps), tuple(notes))


def _on_grid(recordings, labels, names, times, grid) -> Recording:
    """Every channel of every file interpolated onto ``grid`` (one np.interp per channel)."""
    columns, joined, units = [], [], []
    for rec, t, ns in zip(recordings, times, names, strict=True):
        for j, name in enumerate(ns):
            columns.append(np.interp(grid, t, rec.data[:, j]))
            joined.append(name)
            units.append(rec.units[j])
    meta = _merged_metadata(recordings, labels)
    return Recording(grid, np.column_stack(columns), tuple(joined), tuple(units), meta)
