"""IDIM stage 3: parallel filtering and decimation of the regression's columns.

Arrays in, arrays out: ``parallel_decimate(x, nd)`` low-passes every column of ``x`` (time on
axis 0) and keeps one row in ``nd``; `decimated_noise_correlation` is what that filter does to
white noise (the correlation the ``stderr="filtered"`` covariance uses).

The parallel filter (`scipy.signal.cheby1`, order 8, cut-off 0.8·π/nd rad/sample, 0.001 dB
ripple, run forwards and backwards, as `scipy.signal.decimate` does with 0.05 dB) removes what lies above the band of the motion:
torque ripple, noise and the state filter's residual; decimation keeps the rows that carry
independent information. Because the same linear time-invariant filter is applied to every column
of W and to τ, ``τ = W β`` still holds exactly after it.

Only the kept rows are computed: from nd = `physid.filters.lifted.LIFT_MIN_ND` on (and enough
columns to pay for it) the forward-backward filter is lifted to the block rate
(`physid.filters.lifted.sosfiltfilt_decimated`), the same rows as ``sosfiltfilt`` to rounding;
the streamed fit uses the same kernel under the same rule (`stream_filter.decimated_window`).
"""

from __future__ import annotations

import functools

import numpy as np
from scipy import signal

from ...filters.lifted import lifting_pays, sosfiltfilt_decimated

__all__ = ["parallel_decimate", "decimation_edge", "decimated_noise_correlation", "parallel_filter"]

#: Pass-band ripple of the parallel filter [dB]. Run forwards and backwards its gain varies by
#: twice this in the band of the motion; the fit does not care (the same filter is on both sides
#: of ``τ = W β``), but a prediction carries it: 0.05 dB (`scipy.signal.decimate`'s) put 1.1 %
#: of error into every held-out torque prediction; 0.001 dB puts 0.02 %.
RIPPLE_DB = 0.001


def _decimation_sos(nd: int) -> np.ndarray:
    """The parallel filter: Chebyshev I, order 8, `RIPPLE_DB` ripple, cut-off 0.8/nd of Nyquist."""
    return signal.cheby1(8, RIPPLE_DB, 0.8 / nd, output="sos")


@functools.lru_cache(maxsize=32)
def decimated_noise_correlation(nd: int, lags: int = 8) -> np.ndarray:
    """Autocorrelation ``ρ_0..ρ_lags`` (ρ_0 = 1) of white noise after `parallel_decimate`: the
    zero-phase filter's autocorrelation sampled every ``nd`` samples (1, 0 … for nd = 1)."""
    out = np.zeros(lags + 1)
    out[0] = 1.0
    if nd <= 1:
        return out
    half = 40 * nd
    delta = np.zeros(2 * half + 1)
    delta[half] = 1.0
    g = signal.sosfiltfilt(_decimation_sos(nd), delta)
    r = np.correlate(g, g, "full")[g.size - 1 :]
    out[1:] = r[nd * np.arange(1, lags + 1)] / r[0]
    return out


#: Rows dropped at each end of a record after the parallel filter, in periods of nd samples
#: (the padding is as long: ``padlen = edge``). The end rows are exact equations for any edge
#: (the filter is linear); a prediction's end rows are not (the filter is not the identity
#: there: a sinusoid at 0.05–0.5 of the cut-off is off by 1–11 % at the first row at edge 0,
#: up to 1.2 % at 3 periods, 0.3 % at 6, 0.17 % at 12). Measured on the zoo
#: (benchmarks/zoo/README.md), 0, 3 or 6 periods change the automatic nd of one case and
#: worsen others: 12 stays.
EDGE_PERIODS = 12


def decimation_edge(nd: int) -> int:
    """Samples dropped at each end after the parallel filter (its transient has died out)."""
    return 0 if nd <= 1 else int(EDGE_PERIODS * nd)


def parallel_decimate(x, nd: int, *, block_columns: int = 256) -> tuple[np.ndarray, np.ndarray]:
    """Low-pass every column of ``x`` (zero phase) and keep one row in ``nd``.

    Parameters
    ----------
    x : array_like, shape (n_samples, ...)
        Time on axis 0; any trailing shape (e.g. (n_joints, p) for a regressor).
    nd : int
        Decimation factor (1: no filter, no decimation).
    block_columns : int
        Columns filtered at a time (bounds the temporaries of `scipy.signal.sosfiltfilt`).

    Returns
    -------
    y : ndarray, shape (n_kept, ...)
        Filtered rows ``edge, edge + nd, ...``: ``edge = EDGE_PERIODS · nd`` samples (12 nd)
        of transient are dropped at each end.
    kept : ndarray of int, shape (n_kept,)
        The input rows the output rows belong to.

    Notes
    -----
    The filter is Chebyshev type I of order 8 with cut-off ``0.8 π / nd`` rad/sample (the
    anti-aliasing filter of `scipy.signal.decimate`, with a flatter pass band: `RIPPLE_DB`), in second-order sections, run forwards and
    backwards (zero phase; gain squared). Columns that are zero at every sample are not filtered
    (their output is exactly zero). Peak memory: one float64 copy of ``x`` plus a few copies of
    one block (``n_samples × block_columns``).
    """
    arr = np.asarray(x, dtype=float)
    n = arr.shape[0]
    nd = int(nd)
    if nd <= 1:
        return arr, np.arange(n)
    edge = decimation_edge(nd)
    kept = np.arange(edge, n - edge, nd)
    flat = arr.reshape(n, -1)
    out = np.zeros((kept.size, flat.shape[1]))
    sos = _decimation_sos(nd)
    padlen = min(n - 1, edge)
    # a column that is zero at every sample stays exactly zero (a 7-DOF base regressor has ~40 %
    # of them: joint j's equation holds no parameter of the links before it); filter the others
    live = np.flatnonzero(np.any(flat != 0.0, axis=0))
    for start in range(0, live.size, block_columns):
        cols = live[start : start + block_columns]
        if lifting_pays(
            nd, n - edge, cols.size
        ):  # only at the rows kept (`physid.filters.lifted`): the same rows to rounding;
            # it reads the samples in place, time on axis 0 (a slice when the columns are)
            run = cols.size and cols[-1] - cols[0] + 1 == cols.size
            block = flat[:, cols[0] : cols[-1] + 1] if run else flat[:, cols]
            out[:, cols] = sosfiltfilt_decimated(
                sos, block, nd, edge, kept.size, axis=0, padlen=padlen, lift=True
            )
            continue
        # time on the last, contiguous axis: scipy's sosfilt copies its input with time last,
        # which for axis=0 is a slow transposing copy (most of the cost); the filtering itself
        # is the same, sample by sample (bit-identical results)
        block = np.ascontiguousarray(flat[:, cols].T)
        out[:, cols] = signal.sosfiltfilt(sos, block, axis=-1, padlen=padlen)[:, kept].T
    return out.reshape((kept.size,) + arr.shape[1:]), kept


def parallel_filter(x, nd: int) -> np.ndarray:
    """The parallel filter of `parallel_decimate` on every row, without decimation.

    Parameters
    ----------
    x : array_like, shape (n_samples, k)
        Time on axis 0.
    nd : int
        Decimation factor whose filter to apply (1: ``x`` itself).

    Returns
    -------
    ndarray, shape (n_samples, k)
    """
    arr = np.asarray(x, dtype=float)
    if int(nd) <= 1:
        return arr.copy()
    padlen = min(arr.shape[0] - 1, decimation_edge(int(nd)))
    return signal.sosfiltfilt(_decimation_sos(int(nd)), arr, axis=0, padlen=padlen)
