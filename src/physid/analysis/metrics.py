"""Convergence and accuracy metrics for parameter estimates that evolve in time.

The paper behind this module (Oueslati et al. 2011, section 5) measures "the convergence time for
2 % of estimation error" with one literal rule: the estimation stops the first time the absolute
relative error drops below 2 %. A noisy estimate can cross 2 % once by chance and leave again, so
physid measures the time to 2 % three ways and reports all three side by side:

first hit (`first_hit_time`)
    The paper's literal rule: the time of the first sample whose relative error is below the
    tolerance. Optimistic by construction.
settle (`settle_time`)
    The earliest time after which *every* stretch of 100 ms (sliding, one start per sample) keeps at
    least 95 % of its samples within the tolerance (taken at a sample that is within tolerance).
    An estimate that is briefly right by accident does not settle; one that stays right apart
    from rare spikes does.
shortest window (`shortest_window`)
    For sliding-window estimators (the algebraic one): the shortest window length T for which at
    least 95 % of the full window positions give an estimate within the tolerance. This is the
    "estimation time" a user must budget for when the estimator runs on-line with a fixed window.

All three count a NaN sample as *outside* the tolerance. A sample the estimator flags invalid (the
algebraic estimator's determinant guard) shows, by default, the last valid estimate — what an
on-line user holds while the estimator abstains (`hold_last_valid`); ``invalid="fail"`` counts it
as outside instead. The first hit is the same either way. Times are measured from the start of
the record (``t - t[0]``) unless ``t_start`` is given. A metric that is never reached within the
record is NaN ("did not converge"); summaries treat NaN convergence times as censored
(`censored_median`).

Over Monte-Carlo trials, `trial_statistics` gives the final error, the bias and the spread of the
final estimates.

Every function is vectorised: per-sample tests are array comparisons and the 100 ms stretch counts
are differences of one cumulative sum (no Python loop over samples).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from .._validate import as_1d, check_in_range, check_positive, check_time, sample_period
from ..errors import InputError, ShapeError
from ..estimators.results import ResultMixin

__all__ = [
    "relative_error",
    "within_tolerance",
    "hold_last_valid",
    "first_hit_time",
    "settle_time",
    "convergence_times",
    "recovery_times",
    "shortest_window",
    "WindowSearchResult",
    "estimate_trace",
    "trial_statistics",
    "censored_median",
]

#: Relative error under which an estimate counts as converged (the paper's 2 %).
DEFAULT_TOLERANCE = 0.02
#: Length [s] of the stretches the settle rule inspects.
DEFAULT_STRETCH = 0.1
#: Share of samples (settle) or of window positions (shortest window) that must be within tolerance.
DEFAULT_FRACTION = 0.95


# --------------------------------------------------------------------------- per-sample errors
def _truth_array(truth, n: int, name: str = "truth") -> np.ndarray:
    arr = np.asarray(truth, dtype=float)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    elif arr.shape != (n,):
        raise ShapeError(
            f"{name} must be a scalar or have one value per sample, shape ({n},); "
            f"got shape {arr.shape}."
        )
    if not np.all(np.isfinite(arr)) or np.any(arr == 0):
        raise InputError(
            f"{name} must be finite and non-zero (errors are relative to it); got values in "
            f"[{np.nanmin(arr):g}, {np.nanmax(arr):g}]. Use an absolute error for a zero parameter."
        )
    return arr


def relative_error(estimate, truth) -> np.ndarray:
    """Relative error ``|estimate - truth| / |truth|`` per sample (NaN where the estimate is NaN).

    Parameters
    ----------
    estimate : array_like, shape (n_samples,)
        Estimates (any unit).
    truth : float or array_like, shape (n_samples,)
        True value(s) in the same unit, non-zero; an array for a parameter that changes in time.

    Returns
    -------
    ndarray, shape (n_samples,) [-]

    Examples
    --------
    >>> relative_error([99.0, 101.0, np.nan], 100.0).tolist()
    [0.01, 0.01, nan]
    """
    est = as_1d(estimate, "estimate")
    true = _truth_array(truth, est.size)
    with np.errstate(invalid="ignore"):
        return np.abs(est - true) / np.abs(true)


def hold_last_valid(estimate, valid) -> np.ndarray:
    """The estimate an on-line user sees: each invalid sample replaced by the last valid one.

    Samples before the first valid one are NaN. Vectorised (a running maximum of indices).

    Examples
    --------
    >>> hold_last_valid([1.0, 2.0, 9.0, 4.0], [False, True, False, True]).tolist()
    [nan, 2.0, 2.0, 4.0]
    """
    est = as_1d(estimate, "estimate")
    flags = _valid_array(valid, est.size)
    flags &= np.isfinite(est)
    last = np.maximum.accumulate(np.where(flags, np.arange(est.size), -1))
    return np.where(last >= 0, est[np.maximum(last, 0)], np.nan)


def _valid_array(valid, n: int) -> np.ndarray:
    flags = np.asarray(valid)
    if flags.shape != (n,):
        raise ShapeError(
            f"valid must have one flag per sample, shape ({n},); got shape {flags.shape}."
        )
    return flags.astype(bool)


def within_tolerance(
    estimate,
    truth,
    tolerance: float = DEFAULT_TOLERANCE,
    valid=None,
    *,
    invalid: str = "hold",
) -> np.ndarray:
    """Boolean mask: the (held) estimate is finite and within ``tolerance`` of the truth.

    Parameters
    ----------
    estimate : array_like, shape (n_samples,)
    truth : float or array_like, shape (n_samples,)
    tolerance : float
        Relative tolerance (0.02 = 2 %), strictly positive.
    valid : array_like of bool, shape (n_samples,), optional
        The estimator's own validity flags (e.g. the algebraic estimator's determinant guard).
    invalid : {"hold", "fail"}
        What an invalid sample shows: ``"hold"`` (default) the last valid estimate, as an on-line
        user would (`hold_last_valid`); ``"fail"`` counts it as outside the tolerance.

    Returns
    -------
    ndarray of bool, shape (n_samples,)
    """
    tolerance = check_positive(tolerance, "tolerance")
    if invalid not in ("hold", "fail"):
        raise InputError(f"invalid must be 'hold' or 'fail'; got {invalid!r}.")
    est = as_1d(estimate, "estimate")
    if valid is not None and invalid == "hold":
        est = hold_last_valid(est, valid)
    err = relative_error(est, truth)
    ok = np.zeros(err.shape, dtype=bool)
    np.less(err, tolerance, out=ok, where=np.isfinite(err))
    if valid is not None and invalid == "fail":
        ok &= _valid_array(valid, ok.size)
    return ok


def _prepare(t, estimate, name_t="t"):
    t = check_time(t, name_t)
    est = as_1d(estimate, "estimate")
    if est.size != t.size:
        raise ShapeError(
            f"estimate has {est.size} samples but {name_t} has {t.size}; "
            "give one estimate per time."
        )
    return t, est


# --------------------------------------------------------------------------- the three rules
def first_hit_time(
    t,
    estimate,
    truth,
    tolerance: float = DEFAULT_TOLERANCE,
    *,
    valid=None,
    invalid: str = "hold",
    t_start: float | None = None,
) -> float:
    """Time [s] to the first sample within ``tolerance`` (the paper's literal 2 % rule).

    Parameters
    ----------
    t : array_like, shape (n_samples,) [s]
        Sample times, strictly increasing.
    estimate : array_like, shape (n_samples,)
        The estimate at each time (NaN where none is available yet).
    truth : float or array_like, shape (n_samples,)
        True value(s).
    tolerance : float, default 0.02
        Relative tolerance.
    valid : array_like of bool, optional
        Estimator validity flags; an invalid sample never counts as a hit by itself.
    invalid : {"hold", "fail"}
        See `within_tolerance`.
    t_start : float, optional [s]
        Reference time of the convergence clock; default ``t[0]``.

    Returns
    -------
    float [s]
        ``t[i] - t_start`` for the first hit ``i``, or NaN if the estimate never gets within the
        tolerance.

    Examples
    --------
    >>> first_hit_time([0.0, 0.1, 0.2, 0.3], [2.0, 1.5, 1.01, 3.0], 1.0)
    0.2
    """
    t, est = _prepare(t, estimate)
    ok = within_tolerance(est, truth, tolerance, valid, invalid=invalid)
    ref = float(t[0]) if t_start is None else float(t_start)
    if not ok.any():
        return math.nan
    return float(t[int(np.argmax(ok))] - ref)


def _stretch_samples(t: np.ndarray, stretch: float) -> int:
    dt = sample_period(t, "t")
    return max(1, int(round(stretch / dt)))


def _settle_index(ok: np.ndarray, length: int, fraction: float) -> int | None:
    """Index from which every ``length``-sample stretch has >= ``fraction`` of ``ok`` samples."""
    n = ok.size
    if n < length:
        return None
    needed = math.ceil(fraction * length - 1e-9)
    counts = np.concatenate(([0], np.cumsum(ok, dtype=np.int64)))
    in_stretch = counts[length:] - counts[:-length]  # stretch j covers samples j .. j+length-1
    bad = in_stretch < needed
    if not bad.any():
        return int(np.argmax(ok))
    first_good_start = int(np.flatnonzero(bad)[-1]) + 1
    if first_good_start > n - length:  # the last full stretch is still bad
        return None
    # start the clock at a sample that is itself within tolerance (so settle >= first hit); the
    # stretch starting at first_good_start holds such a sample
    return first_good_start + int(np.argmax(ok[first_good_start:]))


def settle_time(
    t,
    estimate,
    truth,
    tolerance: float = DEFAULT_TOLERANCE,
    *,
    stretch: float = DEFAULT_STRETCH,
    fraction: float = DEFAULT_FRACTION,
    valid=None,
    invalid: str = "hold",
    t_start: float | None = None,
) -> float:
    """Time [s] after which every ``stretch`` keeps ``fraction`` of its samples within tolerance.

    Every stretch of ``L = round(stretch / dt)`` consecutive samples that starts at or after the
    settle time holds at least ``ceil(fraction * L)`` samples within the tolerance (finite, valid
    and with relative error < ``tolerance``). The settle time is the earliest such start that is
    itself within the tolerance, so it is never earlier than the first hit.

    Parameters
    ----------
    t : array_like, shape (n_samples,) [s]
        Uniformly sampled times.
    estimate : array_like, shape (n_samples,)
    truth : float or array_like, shape (n_samples,)
    tolerance : float, default 0.02
    stretch : float, default 0.1 [s]
        Length of the inspected stretches.
    fraction : float, default 0.95
        Share of samples of each stretch that must be within tolerance, in (0, 1].
    valid : array_like of bool, optional
    invalid : {"hold", "fail"}
        See `within_tolerance`.
    t_start : float, optional [s]
        Reference time of the clock; default ``t[0]``.

    Returns
    -------
    float [s]
        The settle time, or NaN when even the last full stretch of the record fails the rule (or the
        record is shorter than one stretch).

    Examples
    --------
    Right at sample 2 by accident, wrong again, then right from sample 5 on (stretch = 3 samples):

    >>> t = np.arange(10) * 0.1
    >>> est = [2, 2, 1, 2, 2, 1, 1, 1, 1, 1]
    >>> round(settle_time(t, est, 1.0, stretch=0.3, fraction=1.0), 12)
    0.5
    """
    t, est = _prepare(t, estimate)
    check_positive(stretch, "stretch")
    fraction = check_in_range(fraction, "fraction", 0.0, 1.0, low_open=True)
    ok = within_tolerance(est, truth, tolerance, valid, invalid=invalid)
    idx = _settle_index(ok, _stretch_samples(t, stretch), fraction)
    ref = float(t[0]) if t_start is None else float(t_start)
    return math.nan if idx is None else float(t[idx] - ref)


def convergence_times(
    t,
    estimate,
    truth,
    tolerance: float = DEFAULT_TOLERANCE,
    *,
    stretch: float = DEFAULT_STRETCH,
    fraction: float = DEFAULT_FRACTION,
    valid=None,
    invalid: str = "hold",
) -> dict[str, float]:
    """The first-hit and settle times [s] and the final relative error of one estimate trace.

    Parameters
    ----------
    t : array_like, shape (n_samples,) [s]
        Uniformly sampled times.
    estimate : array_like, shape (n_samples,)
        The estimate's trace.
    truth : float or array_like, shape (n_samples,)
        The true value.
    tolerance : float, default 0.02
        Relative tolerance.
    stretch, fraction : float
        The settle rule (see `settle_time`).
    valid : array_like of bool, optional
        Which samples hold a valid estimate.
    invalid : {"hold", "fail"}
        See `within_tolerance`.

    Returns
    -------
    dict
        ``{"first_hit": s, "settle": s, "final_error": relative error of the last finite, valid
        sample (NaN if there is none)}``.
    """
    t, est = _prepare(t, estimate)
    err = relative_error(est, truth)
    usable = np.isfinite(err) if valid is None else np.isfinite(err) & np.asarray(valid, bool)
    final = float(err[np.flatnonzero(usable)[-1]]) if usable.any() else math.nan
    return {
        "first_hit": first_hit_time(t, est, truth, tolerance, valid=valid, invalid=invalid),
        "settle": settle_time(
            t,
            est,
            truth,
            tolerance,
            stretch=stretch,
            fraction=fraction,
            valid=valid,
            invalid=invalid,
        ),
        "final_error": final,
    }


def recovery_times(
    t,
    estimate,
    truth,
    change_times: Sequence[float],
    tolerance: float = DEFAULT_TOLERANCE,
    *,
    stretch: float = DEFAULT_STRETCH,
    fraction: float = DEFAULT_FRACTION,
    valid=None,
    invalid: str = "hold",
) -> dict[str, np.ndarray]:
    """First-hit and settle times measured from each change of a time-varying parameter.

    The record is cut at ``change_times``; in each segment the clock starts at the segment's
    start (0 or the change time) and only that segment's samples are inspected, with the truth
    that holds in it.

    Parameters
    ----------
    t : array_like, shape (n_samples,) [s]
    estimate : array_like, shape (n_samples,)
    truth : array_like, shape (n_samples,)
        The true value at each sample (piecewise constant).
    change_times : sequence of float [s]
        Times of the jumps, increasing, inside the record.

    Returns
    -------
    dict of ndarray, each of shape (n_segments,)
        ``segment_start`` [s], ``first_hit`` [s], ``settle`` [s] (NaN where not reached before the
        next change), ``truth`` (the value the segment converges to).
    """
    t, est = _prepare(t, estimate)
    true = _truth_array(truth, t.size)
    valid_arr = None if valid is None else _valid_array(valid, t.size)
    if valid_arr is not None and invalid == "hold":  # hold across segment boundaries, as on-line
        est, valid_arr = hold_last_valid(est, valid_arr), None
    changes = as_1d(change_times, "change_times") if len(change_times) else np.empty(0)
    if changes.size and (
        np.any(np.diff(changes) <= 0) or changes[0] <= t[0] or changes[-1] >= t[-1]
    ):
        raise InputError(
            f"change_times must be increasing and strictly inside the record ({t[0]:g} s, "
            f"{t[-1]:g} s); got {changes.tolist()}."
        )
    starts = np.concatenate(([t[0]], changes))
    bounds = np.searchsorted(t, starts, side="left").tolist() + [t.size]
    first, settle, seg_truth = [], [], []
    for k in range(starts.size):  # one iteration per segment, not per sample
        sl = slice(bounds[k], bounds[k + 1])
        v = None if valid_arr is None else valid_arr[sl]
        if bounds[k + 1] - bounds[k] < 2:
            first.append(math.nan)
            settle.append(math.nan)
        else:
            first.append(
                first_hit_time(
                    t[sl], est[sl], true[sl], tolerance, valid=v, invalid=invalid, t_start=starts[k]
                )
            )
            settle.append(
                settle_time(
                    t[sl],
                    est[sl],
                    true[sl],
                    tolerance,
                    stretch=stretch,
                    fraction=fraction,
                    valid=v,
                    invalid=invalid,
                    t_start=starts[k],
                )
            )
        seg_truth.append(float(true[min(bounds[k], t.size - 1)]))
    return {
        "segment_start": starts,
        "first_hit": np.array(first),
        "settle": np.array(settle),
        "truth": np.array(seg_truth),
    }


# --------------------------------------------------------------------------- shortest window
@dataclass(frozen=True)
class WindowSearchResult(ResultMixin):
    """Share of window positions within tolerance, for each candidate window length.

    Attributes
    ----------
    windows : ndarray, shape (n_windows,) [s]
        Candidate window lengths, increasing.
    fraction_within : ndarray, shape (n_windows,) [-]
        Share of full window positions whose estimate is within the tolerance (NaN where the
        estimator raised for that window; see ``errors``).
    shortest : float [s]
        The shortest window with ``fraction_within >= fraction``; NaN if none qualifies.
    tolerance, fraction : float
        The rule used.
    errors : tuple of str
        One message per window that could not be evaluated ("" where it ran).
    success : bool
    message : str
    """

    windows: np.ndarray
    fraction_within: np.ndarray
    shortest: float
    tolerance: float
    fraction: float
    errors: tuple[str, ...]
    success: bool
    message: str

    @property
    def parameters(self) -> dict[str, float]:
        """``{"shortest_window": s}`` (for `summary`)."""
        return {"shortest_window": self.shortest}


def estimate_trace(result, parameter: str = "natural_frequency"):
    """``(t, values, valid)`` of an estimator result's per-time history of ``parameter``.

    Works with results that offer ``series(name)`` (the algebraic estimator) or a per-time
    attribute of that name (the recursive estimator); ``valid`` is None when the result has no
    validity mask.
    """
    values = None
    series = getattr(result, "series", None)
    if callable(series):  # e.g. AlgebraicResult.series("natural_frequency")
        try:
            values = series(parameter)
        except InputError:
            values = None
    if values is None:
        values = getattr(result, parameter, None)
    if values is None or np.ndim(values) != 1:
        raise InputError(
            f"the estimator's result has no per-time array {parameter!r}; give parameter= the name "
            f"of a 1-D history attribute of its result_ (e.g. 'natural_frequency')."
        )
    valid = getattr(result, "valid", None)
    return (
        np.asarray(result.t, float),
        np.asarray(values, float),
        (None if valid is None else np.asarray(valid, bool)),
    )


def shortest_window(
    estimator_factory: Callable[[float], object],
    record,
    windows: Sequence[float],
    truth: float,
    *,
    parameter: str = "natural_frequency",
    tolerance: float = DEFAULT_TOLERANCE,
    fraction: float = DEFAULT_FRACTION,
    invalid: str = "hold",
) -> WindowSearchResult:
    """The shortest sliding window whose estimates are within tolerance ``fraction`` of the time.

    For each window length T the estimator is built by ``estimator_factory(T)`` and fitted on
    ``record``; the positions whose window is full (``t - t[0] >= T``) are inspected, and a position
    counts as a success when its estimate is within ``tolerance`` (a position the estimator flags
    invalid shows the last valid estimate, or fails with ``invalid="fail"``).

    Parameters
    ----------
    estimator_factory : callable
        ``T [s] -> estimator`` with ``fit(record)`` returning itself and ``result_`` holding ``t``,
        the per-time array named ``parameter`` and optionally a boolean ``valid`` mask.
    record : Recording
        The data (the same record for every window).
    windows : sequence of float [s]
        Candidate window lengths (sorted here).
    truth : float
        True value of the parameter.
    parameter : str, default "natural_frequency"
    tolerance : float, default 0.02
    fraction : float, default 0.95
    invalid : {"hold", "fail"}
        See `within_tolerance`.

    Returns
    -------
    WindowSearchResult
    """
    tolerance = check_positive(tolerance, "tolerance")
    fraction = check_in_range(fraction, "fraction", 0.0, 1.0, low_open=True)
    win = np.sort(as_1d(windows, "windows"))
    if win.size == 0 or np.any(win <= 0) or not np.all(np.isfinite(win)):
        raise InputError(
            f"windows must be a non-empty list of positive lengths [s]; got {list(windows)}."
        )
    shares = np.full(win.size, np.nan)
    errors: list[str] = []
    for k, length in enumerate(win):  # one estimator fit per candidate window
        try:
            result = estimator_factory(float(length)).fit(record).result_
            t, values, valid = estimate_trace(result, parameter)
        except InputError:
            raise
        except Exception as exc:  # a window the estimator rejects is reported, not fatal
            errors.append(f"{type(exc).__name__}: {exc}")
            continue
        errors.append("")
        full = (t - t[0]) >= length - 0.5 * (t[1] - t[0])
        if not full.any():
            shares[k] = 0.0
            continue
        ok = within_tolerance(values, truth, tolerance, valid, invalid=invalid)
        shares[k] = float(ok[full].mean())
    qualifies = np.flatnonzero(np.nan_to_num(shares, nan=-1.0) >= fraction)
    shortest = float(win[qualifies[0]]) if qualifies.size else math.nan
    if qualifies.size:
        message = (
            f"shortest window with {fraction:.0%} of positions within {tolerance:.0%}: "
            f"{shortest:g} s"
        )
    else:
        message = (
            f"no candidate window reached {fraction:.0%} of positions within {tolerance:.0%}; "
            f"try longer windows (largest tried: {win[-1]:g} s)"
        )
    return WindowSearchResult(
        windows=win,
        fraction_within=shares,
        shortest=shortest,
        tolerance=tolerance,
        fraction=fraction,
        errors=tuple(errors),
        success=bool(qualifies.size),
        message=message,
    )


# --------------------------------------------------------------------------- over trials
def trial_statistics(final_estimates, truth: float) -> dict[str, float]:
    """Final error, bias and spread of the final estimates of several Monte-Carlo trials.

    Parameters
    ----------
    final_estimates : array_like, shape (n_trials,)
        One final estimate per trial; NaN (failed trials) are left out and counted.
    truth : float
        The true value (non-zero).

    Returns
    -------
    dict
        ``n`` (finite estimates), ``n_missing``, ``mean``, ``bias`` (mean - truth),
        ``relative_bias``, ``std`` (sample standard deviation, ddof = 1), ``relative_spread``
        (std / |truth|), ``rmse``, ``relative_rmse`` and ``median_relative_error``
        (median |estimate - truth| / |truth|). NaN where undefined (no estimate; std of one).

    Examples
    --------
    >>> s = trial_statistics([9.0, 11.0, np.nan], 10.0)
    >>> s["n"], s["bias"], round(s["std"], 6), s["rmse"], s["median_relative_error"]
    (2, 0.0, 1.414214, 1.0, 0.1)
    """
    est = as_1d(final_estimates, "final_estimates")
    true = float(truth)
    if not math.isfinite(true) or true == 0:
        raise InputError(f"truth must be finite and non-zero; got {truth!r}.")
    finite = est[np.isfinite(est)]
    n = int(finite.size)
    out = {"n": n, "n_missing": int(est.size - n)}
    if n == 0:
        nan = math.nan
        out.update(
            mean=nan,
            bias=nan,
            relative_bias=nan,
            std=nan,
            relative_spread=nan,
            rmse=nan,
            relative_rmse=nan,
            median_relative_error=nan,
        )
        return out
    mean = float(finite.mean())
    std = float(finite.std(ddof=1)) if n > 1 else math.nan
    rmse = float(np.sqrt(np.mean((finite - true) ** 2)))
    out.update(
        mean=mean,
        bias=mean - true,
        relative_bias=(mean - true) / abs(true),
        std=std,
        relative_spread=std / abs(true),
        rmse=rmse,
        relative_rmse=rmse / abs(true),
        median_relative_error=float(np.median(np.abs(finite - true)) / abs(true)),
    )
    return out


def censored_median(times) -> float:
    """Median of convergence times where NaN means "not converged within the record".

    NaN entries count as +infinity (they are slower than any finite time), so the median is finite
    only when more than half the trials converged; NaN is returned otherwise.

    Examples
    --------
    >>> censored_median([0.1, 0.2, np.nan]), censored_median([0.1, np.nan, np.nan])
    (0.2, nan)
    """
    arr = as_1d(times, "times")
    if arr.size == 0:
        return math.nan
    value = float(np.median(np.where(np.isnan(arr), np.inf, arr)))
    return value if math.isfinite(value) else math.nan
