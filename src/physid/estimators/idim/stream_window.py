"""Streamed IDIM, the windows of the main pass: the rows of the in-memory fit, window by window.

The full-rate rows ``[W | τ]`` of a record are computed for one *owned* range of full-rate
samples ``[a, b)`` at a time, from the raw samples around it with margins:

* the physid FIR state filter needs its half-width M of raw samples on each side (exact);
* the parallel Chebyshev filter (zero phase, every candidate nd) needs no left margin: its
  forward pass continues from the state the previous window left at its first decimated row
  (`stream_filter.decimated_window`, the same kernel as the in-memory
  `decimation.parallel_decimate`; lifted, the blocks it computed over the previous window's
  right margin are carried too, not computed again), and only its backward
  pass starts inside the record, at the end of a right margin over which its free response
  decays below `PARALLEL_DECAY` of the impulse response's peak (`stream_plan.decay_length`);
* the Butterworth state filter (zero phase) needs the length after which its impulse response
  stays below `stream_plan.DECAY` on each side;
* a window that holds the record's first or last sample uses there exactly the padding the
  in-memory code uses (``padlen = min(n − 1, edge)``), so the end effects are the same;
* the stiction masks are moving windows (at most `STILL_SECONDS` plus the filters' main lobes).

Columns of ``[W | τ]`` that are exactly zero in a window, and whose carried forward state is
zero, are not filtered (a zero-phase filter of zero is zero): a 7-DOF base regressor has about
40 % of them.
"""

from __future__ import annotations

import time

import numpy as np
from scipy import signal

from ...filters.lifted import lifting_pays
from .._stiction import (
    STICK_AUTO,
    STILL_MIN_SAMPLES,
    contamination_reach,
    dilate,
    reversal_samples,
    sticking_mask,
)
from .base_parameters import base_regressor, write_in_place
from .decimation import _decimation_sos, decimation_edge
from .filtering import consistent_bank
from .stream_filter import decimated_window
from .stream_plan import StreamPlan, decay_length, still_windows

__all__ = ["Margins", "margins", "RawReader", "windows", "window_rows", "COLUMNS", "PARALLEL_DECAY"]

#: Columns of the full-rate rows run through the parallel filter at a time (the lifted filter's
#: block-rate recursions cost the same per step for 1 or 96 columns: chunks this wide keep them
#: few; the time-last copy of a chunk is the window's samples × 96 floats).
COLUMNS = 96
#: The parallel filter's right margin: where its impulse response stays below this (relative).
#: Only the backward pass starts inside the record, from ``z_i · f`` at the margin's end; the
#: free response it leaves at the owned range is ~100× this threshold relative to the signal
#: (white noise through the windows against one `scipy.signal.sosfiltfilt`: 1.4e-14 at nd = 5,
#: below the whole-record call's own rounding from nd ≈ 50 on, which is 2e-13 at nd = 300).
#: Streamed against in-memory estimate (largest relative difference, the tests' 2-link arm, 4
#: settings / the 7-DOF benchmark, normwise) for thresholds 1e-17, 1e-14, 1e-12, 1e-10, 1e-8:
#: ≤ 2.5e-12 / 4.5e-12, ≤ 6.4e-12 / 1.1e-11, ≤ 5.4e-12 / 1.3e-11, ≤ 4.7e-12 / 6.3e-12, then
#: 6.7e-11: rounding, not the transient, sets the difference down to 1e-10, which the transient
#: reaches at 1e-8. 1e-12 keeps two decades of threshold before that onset and a 20× margin
#: below the tests' 1e-10, with a margin of ~95·nd samples (1e-17: ~135·nd).
PARALLEL_DECAY = 1e-12
#: From this nd on the lifted parallel filter reads every column of a window in place: its
#: temporaries (~25/nd of the window's rows) are then below the copy of the live columns it saves.
IN_PLACE_ND = 40


class Margins:
    """Margins of the main pass's windows (all in samples)."""

    def __init__(self, plan: StreamPlan):
        nds = [nd for nd in plan.candidates if nd > 1]
        #: nd -> samples after the owned range the parallel filter of nd needs (its backward
        #: pass's transient)
        self.right = {nd: decay_length(_decimation_sos(nd), PARALLEL_DECAY) for nd in nds}
        par = max(self.right.values(), default=0)
        reach = max(contamination_reach(plan.cutoff, nd) for nd in plan.candidates)
        edge = max(decimation_edge(nd) for nd in plan.candidates)
        #: full-rate samples after the owned range fed to the parallel filter (its backward
        #: pass's transient, the masks' reach)
        self.parallel = max(par, edge + 1, reach + 2)
        #: full-rate samples before the owned range: the masks' reach and the parallel
        #: filter's end padding (its last ``edge + 1`` samples), not the filter's transient
        self.left = max(edge + 1, reach + 2)
        self.butter = 0
        if plan.settings["differentiation"] == "butterworth":
            self.butter = decay_length(_butter(plan.cutoff))
        widths = [int(round(float(np.max(still_windows(s)[1])))) for s in plan.sources]
        #: raw samples on each side of the owned rows for the sticking mask
        self.stick = max(widths) + reach + 2 if plan.stick == STICK_AUTO else 0
        self.reach = reach


def margins(plan: StreamPlan) -> Margins:
    """The `Margins` of a plan."""
    return Margins(plan)


def _butter(cutoff: float):
    return signal.butter(4, cutoff / np.pi, output="sos")


class RawReader:
    """Raw samples ``[r0, r1)`` of a block source on request (r0 never decreases)."""

    def __init__(self, source, channels, size: int, timings: dict | None = None):
        self._it = source.blocks(size, channels)
        self._channels = list(channels)
        self.start = 0
        self.x = np.empty((0, len(channels)))
        self.t = np.empty(0)
        self.timings = timings

    def get(self, r0: int, r1: int):
        """``(t, x)`` of samples ``r0 .. r1 − 1``."""
        tic = time.perf_counter()
        if r0 > self.start:
            drop = min(r0 - self.start, self.x.shape[0])
            self.x, self.t = self.x[drop:], self.t[drop:]
            self.start += drop
        parts, tparts = [self.x], [self.t]
        end = self.start + self.x.shape[0]
        while end < r1:
            blk = next(self._it)
            x = np.asarray(blk.select(self._channels), dtype=float)
            if not np.all(np.isfinite(x)):
                bad = end + int(np.flatnonzero(~np.all(np.isfinite(x), axis=1))[0])
                from ...errors import InputError

                raise InputError(
                    f"the record has a NaN or infinite value at sample {bad}; split it there "
                    "or repair it."
                )
            parts.append(x)
            tparts.append(np.asarray(blk.t, dtype=float))
            end += x.shape[0]
        if len(parts) > 1:
            self.x, self.t = np.concatenate(parts), np.concatenate(tparts)
        if self.timings is not None:
            self.timings["read"] = self.timings.get("read", 0.0) + time.perf_counter() - tic
        i0, i1 = r0 - self.start, r1 - self.start
        return self.t[i0:i1], self.x[i0:i1]


def windows(plan: StreamPlan, k: int, mg: Margins):
    """``(a, b, c0, c1, r0, r1)`` per window of source ``k``: owned full-rate range, the
    full-rate range filtered, the raw range read."""
    n, n_full, off = plan.sources[k].n, plan.n_stacked(k), plan.offset()
    step = plan.block_samples
    for a in range(0, n_full, step):
        b = n_full if n_full - a < step + step // 2 else a + step
        c0, c1 = max(0, a - mg.left), min(n_full, b + mg.parallel)
        if plan.settings["differentiation"] == "physid":
            r0, r1 = c0, c1 + 2 * plan.half_width
        else:
            r0, r1 = c0 + plan.half_width - mg.butter, c1 + plan.half_width + 2 + mg.butter
        if mg.stick:
            r0, r1 = min(r0, a + off - mg.stick), max(r1, b + off + mg.stick)
        yield a, b, c0, c1, max(r0, 0), min(r1, n)
        if b == n_full:
            return


def _states(plan: StreamPlan, q, r0: int, c0: int, c1: int):
    """q^f, q̇^f, q̈^f at full-rate samples ``[c0, c1)`` from raw samples starting at ``r0``."""
    m, dt = plan.half_width, plan.dt
    if plan.settings["differentiation"] == "physid":
        bank = consistent_bank(m, float(plan.cutoff), dt)
        qs = q[c0 - r0 : c1 + 2 * m - r0]
        return tuple(f.apply(qs) for f in bank)
    qf = signal.sosfiltfilt(_butter(plan.cutoff), q, axis=0, padlen=min(q.shape[0] - 1, m))
    i = np.arange(c0, c1) + 1 + m - r0
    qd = (qf[i + 1] - qf[i - 1]) / (2.0 * dt)
    qdd = (qf[i + 1] - 2.0 * qf[i] + qf[i - 1]) / dt**2
    return qf[i], qd, qdd


def _tick(timings, key, tic):
    if timings is not None:
        timings[key] = timings.get(key, 0.0) + time.perf_counter() - tic
    return time.perf_counter()


def window_rows(
    model, columns, plan: StreamPlan, k: int, raw, win, mg: Margins, timings=None, cache=None
):
    """The decimated rows of one window for every candidate nd.

    Parameters
    ----------
    model : ChainModel
    columns : ndarray of int
        The base regressor's kept columns.
    plan : StreamPlan
    k : int
        The source.
    raw : tuple
        ``(t, x)`` of raw samples ``r0 .. r1 − 1`` (x: q1..qn then tau1..taun).
    win : tuple
        `windows`' ``(a, b, c0, c1, r0, r1)``.
    mg : Margins
    timings : dict, optional
    cache : dict, optional
        Carried from one window to the next of the same source (see `_reuse`, `_nonzero`,
        `_parallel`): the buffers of full-rate rows, allocated once for the longest window,
        each window at their front, where the previous window's overlap with this one is
        moved instead of computed again; the columns found non-zero so far (once non-zero, a
        column is filtered in every later window); per nd, the parallel filter's forward state
        (required for every window but the first) and, lifted, its blocks over the previous
        window's right margin.

    Returns
    -------
    dict
        nd -> ``(W, tau, samples, t, stuck, reversal)`` of the rows in the owned range:
        (r, n_joints, p), (r, n_joints), raw sample index (r,), time [s] (r,), masks
        (r, n_joints) of bool or None.
    """
    a, b, c0, c1, r0, r1 = win
    t_raw, x = raw
    nj, off = plan.n_joints, plan.offset()
    q, tau = x[:, :nj], x[:, nj:]
    tic = time.perf_counter()
    p = plan.n_base
    # buffers of the longest window: a step and the margins, or the last window (up to 1.5
    # steps and the left margin; see `_reuse`)
    step = plan.block_samples
    longest = max(step + mg.left + mg.parallel, -(-3 * step // 2) + mg.left)
    capacity = min(longest, plan.n_stacked(k))
    stacked, qdf, start = _reuse(cache, c0, c1, nj * p + nj, nj, capacity)
    if c1 > start:
        qf, qdf_new, qddf = _states(plan, q, r0, start, c1)
        qdf[start - c0 :] = qdf_new
    else:
        qf = qdf_new = qddf = np.empty((0, nj))
    tic = _tick(timings, "state filter", tic)
    for i in range(0, c1 - start, 8192):  # blocks of samples: one full regressor block at a time
        sl = slice(i, i + 8192)
        dest = stacked[start - c0 + i : start - c0 + i + qf[sl].shape[0], : nj * p]
        # the regressor written into the window's rows in place (their leading columns)
        write_in_place(dest, nj, p, lambda out, sl=sl: base_regressor(
            model, columns, qf[sl], qdf_new[sl], qddf[sl], block=8192, out=out
        ))  # fmt: skip
    stacked[:, nj * p :] = tau[c0 + off - r0 : c1 + off - r0]
    if cache is not None:
        cache["rows"] = (c0, c1)
    tic = _tick(timings, "regressor", tic)
    nonzero = _nonzero(stacked, start - c0, cache)
    n_full = plan.n_stacked(k)
    stick_raw = _sticking(plan, k, q, r0, mg)
    states = cache.setdefault("forward", {}) if cache is not None else {}
    out = {}
    for nd in plan.candidates:
        edge = decimation_edge(nd)
        s = np.arange(a, b)
        if nd > 1:
            s = s[(s >= edge) & (s < n_full - edge) & ((s - edge) % nd == 0)]
            dec = _parallel(stacked, nonzero, s, win, n_full, nd, states, mg.right[nd])
        else:
            dec = stacked[s - c0].copy()
        Wk = dec[:, : nj * p].reshape(-1, nj, p)
        tk = dec[:, nj * p :]
        stuck, rev = _masks(plan, k, nd, s, stick_raw, qdf, c0, r0)
        if stuck is not None:
            Wk[stuck] = 0.0
            tk[stuck] = 0.0
        out[nd] = (Wk, tk, s + off, t_raw[s + off - r0], stuck, rev)
    _tick(timings, "parallel filter", tic)
    return out


def _parallel(stacked, nonzero, s, win, n_full: int, nd: int, states: dict, right: int):
    """The parallel filter of ``stacked`` (full-rate rows ``[c0, c1)``) at the samples ``s`` of
    the owned range, by `stream_filter.decimated_window`.

    Below `IN_PLACE_ND` (or where lifting does not pay) the live columns are copied and
    filtered in chunks of `COLUMNS`, each lifted or not by `lifting_pays`, as the in-memory
    `decimation.parallel_decimate` does (its chunks: 256 columns); from it on, one lifted call
    reads the columns from the first live one to the last in place. ``states`` carries, from
    one window to the next: ``states[nd] = (live, pos, z)``, the columns filtered so far, the
    sample the forward state is at, the state (n_sections, live.size, 2); and, in place,
    ``states[("lifted", nd)]``, the lifted blocks past the previous window's last row
    (`physid.filters.lifted.decimated_filtfilt`'s ``carry``) with ``"span"``: the row they
    start at and the first and last live column; they are dropped when this window starts
    elsewhere or its columns differ (a column that turned non-zero)."""
    a, b, c0, c1 = win[:4]
    c1 = min(c1, b + right)  # a smaller nd's transient is shorter than the window's margin
    sos, edge = _decimation_sos(nd), decimation_edge(nd)
    padlen = min(n_full - 1, edge)
    if a > 0 and nd not in states:
        raise ValueError("the parallel filter's state of the previous window is missing")
    was, pos, z = states.get(nd, (np.zeros(0, dtype=np.intp), 0, None))
    # a column is filtered once it has held a non-zero value (its forward pass never returns
    # to exactly zero); one that has not is zero after the filter
    live = np.union1d(np.flatnonzero(nonzero), was)
    where = np.searchsorted(live, was)  # where the carried columns sit among the live ones
    nxt = edge + max(0, -(-(b - edge) // nd)) * nd  # the first decimated row from b on
    dec = np.zeros((s.size, stacked.shape[1]))
    if s.size == 0 and nxt <= pos:  # nothing to compute, the state stays where it is
        new_z = np.zeros((sos.shape[0], live.size, 2))
        if z is not None:
            new_z[:, where] = z
        states[nd] = (live, pos, None if z is None else new_z)
        return dec
    stop = s[0] if s.size else nxt  # the forward state is wanted at stop + s.size · nd
    # the samples read: from the state's on (and the end padding's when the record ends here)
    r0 = max(c0, min(pos, n_full - 1 - padlen) if c1 == n_full else pos)
    new_z = np.zeros((sos.shape[0], live.size, 2))
    # lifted from IN_PLACE_ND on: the columns from the first live one to the last read in
    # place, no copy (a zero one stays zero); judged on the stretch filtered (the last window's
    # too, which ends at b). Slices of live columns apart would filter fewer zero columns, but
    # no faster (measured: the filter reads the rows' memory either way) and not bit for bit.
    in_place = nd >= IN_PLACE_ND and lifting_pays(nd, c1 - stop, live.size)
    carry = None
    if in_place:
        chunks = [(0, live.size)]
        # the lifted blocks of the previous window past its last row (its right margin) are
        # this window's first ones when it starts at that row with the same columns
        carry = states.setdefault(("lifted", nd), {})
        if a == 0 or pos != stop or carry.get("span") != (stop, live[0], live[-1]):
            carry.clear()
    else:  # columns in chunks: bounded temporaries
        chunks = [(i, min(i + COLUMNS, live.size)) for i in range(0, live.size, COLUMNS)]
    for i, j in chunks:
        cols = live[i:j]
        # the columns' places among those read: a slice of stacked in place, or a copy
        place = cols - cols[0] if in_place else np.arange(cols.size)
        state = None
        if a > 0:  # the carried state of these columns (zero for those not filtered before)
            state = np.zeros((sos.shape[0], int(place[-1]) + 1, 2))
            inside = (where >= i) & (where < j)
            state[:, place[where[inside] - i]] = z[:, inside]
        if in_place:
            rows = stacked[r0 - c0 : c1 - c0, cols[0] : cols[-1] + 1]
        else:
            rows = stacked[r0 - c0 : c1 - c0, cols]
        lift = True if in_place else None
        y, zc = decimated_window(
            sos, rows, r0, c1, pos, stop, s.size, nd, state, n_full, padlen, lift, carry
        )
        dec[:, cols] = y[place].T
        if zc is not None:
            new_z[:, i:j] = zc[:, place]
    if carry is not None:
        carry["span"] = (stop + s.size * nd, live[0], live[-1])  # its next row, its columns
    states[nd] = (live, stop + s.size * nd, new_z)
    return dec


def _nonzero(stacked, new: int, cache) -> np.ndarray:
    """Columns of ``stacked`` with a non-zero value: those of its rows from ``new`` on (the
    rows computed for this window), or'ed with the previous window's (kept in ``cache``).

    The previous window's rows hold the ones reused here (``stacked[:new]``), so the result
    can hold more columns than the window's own, but only columns the previous window already
    fed to the parallel filter: `_parallel` adds those (its carried ``live``) in any case, and
    its set of filtered columns is the same as with the window's own test.
    """
    out = np.zeros(stacked.shape[1], dtype=bool)
    for i in range(new, stacked.shape[0], 8192):  # in slices: a bounded boolean temporary
        out |= np.any(stacked[i : i + 8192] != 0.0, axis=0)
    if cache is not None:
        if new > 0:
            out |= cache["nonzero"]
        cache["nonzero"] = out
    return out


def _reuse(cache, c0: int, c1: int, n_cols: int, nj: int, capacity: int):
    """``(stacked, qdf, start)``: the window's full-rate buffers, views holding first the rows
    the previous window already computed (its right margin); rows from ``start`` on remain to
    be computed.

    The buffers live in ``cache`` from one window to the next and hold ``capacity`` rows, the
    longest window's (`window_rows` passes the larger of a step with both margins and the
    last window, up to 1.5 steps with the left margin): allocated once per source. Each window
    starts at the buffers' front, the reused rows moved there first. Buffers of two windows,
    each window placed behind its predecessor and the rows moved every other window only,
    were measured: about 3 % more throughput (10-minute 7-DOF record, one core, five runs
    alternated, median 244 000 against 238 000 samples/s), for 0.15 GiB more peak memory
    (0.68 against 0.53 GiB): not taken. Which rows of the buffer a window occupies changes
    nothing computed on them.
    """
    n = c1 - c0
    if cache is None:
        return np.empty((n, n_cols)), np.empty((n, nj)), c0
    prev = cache.get("rows")
    buf, qbuf = cache.get("buf"), cache.get("qdf")
    if buf is None:  # the source's first window
        buf, qbuf = np.empty((capacity, n_cols)), np.empty((capacity, nj))
        cache["buf"], cache["qdf"] = buf, qbuf
    if n > buf.shape[0]:  # `windows` makes none longer than `window_rows`' capacity
        raise RuntimeError(f"a window of {n} rows does not fit the buffers' {buf.shape[0]}")
    start = c0
    if prev is not None and prev[0] <= c0 < prev[1]:
        start = min(prev[1], c1)
        offset = c0 - prev[0]  # where the reused rows lie: the previous window began at 0
        count = start - c0
        for i in range(0, count, max(offset, 1)):  # forward, in chunks that never overlap
            j = min(i + offset, count)
            buf[i:j] = buf[offset + i : offset + j]
            qbuf[i:j] = qbuf[offset + i : offset + j]
    return buf[:n], qbuf[:n], start


def _sticking(plan: StreamPlan, k: int, q, r0: int, mg: Margins):
    """The sticking mask of the raw samples read (auto rule), or None."""
    if plan.stick != STICK_AUTO:
        return None
    st = plan.sources[k]
    if st.n < 4 * STILL_MIN_SAMPLES:
        return np.zeros(q.shape, dtype=bool)
    band, widths = still_windows(st)
    return sticking_mask(q, plan.coulomb, band, widths, start=r0, n_total=st.n)


def _masks(plan: StreamPlan, k: int, nd: int, s, stick_raw, qdf, c0: int, r0: int):
    """Stuck and reversal masks of the rows at full-rate samples ``s`` (None, None when the
    rule keeps every equation)."""
    if plan.stick is None:
        return None, None
    off = plan.offset()
    if plan.stick == STICK_AUTO:
        reach = contamination_reach(plan.cutoff, nd)
        stuck = dilate(stick_raw, reach)[s + off - r0]
        speed = np.sqrt(plan.sources[k].mean_vel2)  # the whole record's, from the survey
        rev = reversal_samples(qdf, plan.coulomb, reach, speed)[s - c0] & ~stuck
        return stuck, rev
    rms = np.asarray(plan.qd_rms)[k]
    near = (np.abs(qdf) < float(plan.stick) * np.where(rms > 0, rms, 1.0)) & plan.coulomb[None, :]
    return dilate(near, decimation_edge(nd))[s - c0], None
