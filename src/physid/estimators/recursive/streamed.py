"""`fit_blocks`: the recursive estimator on a record read block by block, in constant memory.

Three passes over the block source, each holding one block:

1. the online estimator (`StreamingRecursiveEstimator`: the state-variable filter's state and the
   recursion carried across blocks) gives the histories, thinned to ``keep`` samples, and the
   rows' moments ``Σ x xᵀ``, ``Σ x Y``, ``Σ Y²`` for the whole-record excitation check
   (`check_excitation_moments`); the running statistics of u and y stand in for the in-memory
   fit's checks of the whole channels (magnitude, input ≠ output, an output that never changes);
2. the same rows again (a fresh filter: the same bits) give the weighted sums of the final
   estimate and of its uncertainty: ``S = Σ w x xᵀ``, ``Σ w² x xᵀ``, ``b = Σ w x Y``, the
   residual sums about the pass-1 estimate (so Σ w e² at any θ has no cancellation), the Gram
   matrices ``Σ_k C_j,k C_l,kᵀ`` of the regressors convolved with each SVF impulse response
   (overlap-add across blocks: ``κ = Σ_j a_j h_j``, so ``Cᵀ C`` follows for any θ, the
   bias-compensated one included) and the row-pair counts of the noise × noise term;
3. the identified model simulated block by block gives the training fit and the gate's segment
   correlations from per-segment Gram matrices (`PredictionStats`).

The final estimate solves the accumulated normal equations exactly as the in-memory fit solves
its running sums, so it equals `RecursiveLeastSquares.fit` of the same record to rounding; so do
its standard errors. Memory: one block, the SVF impulse response (``n_imp`` samples × the
model's order, ≤ 200 000) and p × p sums — independent of the record's length.
"""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np

from ..._validate import check_positive
from ...errors import EstimationError, InputError, arg
from ...models.linear_ode import as_linear_ode_model
from .._linear_stream import (
    PredictionStats,
    RecordStats,
    Thinned,
    UniformTimes,
    open_source,
    pairs,
    progress_bar,
    refuse,
)
from .._regression import check_excitation_moments
from ..plausibility import gate
from .batch import _check_forgetting, _check_init_samples, _packed_solve
from .estimator import RecursiveLeastSquares, _metadata, _nominal_of, _offset_to_si, _verdict
from .regression import _offset_to_value
from .result import RecursiveResult
from .streamed_moments import RowMoments, uncertainty_from_moments

__all__ = ["fit_blocks"]


def fit_blocks(
    estimator: RecursiveLeastSquares,
    source,
    *,
    block_samples: int = 65536,
    keep: int = 20000,
    progress: bool = True,
) -> RecursiveResult:
    """`RecursiveLeastSquares.fit` of a record read block by block, in constant memory.

    Parameters
    ----------
    estimator : RecursiveLeastSquares
        The settings (its ``prefilter`` must be ``"butterworth"``, the causal filter).
    source : BlockSource or Recording
        The record (`physid.signals.io.open_blocks`, `physid.signals.blocks.RecordingBlocks`);
        its channels are the model's input and output, as for ``fit``.
    block_samples : int, default 65536
        Samples read at a time.
    keep : int, default 20000
        Most samples kept of each per-sample history (every k-th sample; the result's
        ``metadata["notes"]`` says so).
    progress : bool, default True
        A progress line on stderr (`physid._progress.Progress`: silent off a terminal).

    Returns
    -------
    RecursiveResult
        As ``fit``'s: the final estimate, its standard errors and covariance, verdict and
        training fit equal those of ``fit`` on the same record (to rounding); ``t``,
        ``estimates``, ``covariance`` hold the thinned history; ``valid_fraction`` counts every
        sample.

    Raises
    ------
    InputError
        ``prefilter="differential"`` (non-causal: it cannot stream), bad settings.
    EstimationError, IdentifiabilityError
        As ``fit`` (too few rows, no excitation, input equal to the output).

    Notes
    -----
    The record is read three times (rows and history; weighted sums; the model's prediction).
    Memory holds one block, the pre-filter's impulse response and O(p²) sums. With
    ``forgetting < 1`` the final estimate uses the last row; where the weighted information of
    the last row is singular (no excitation at the end of the record) the fit refuses, where
    ``fit`` would fall back to the last row with information.

    Examples
    --------
    >>> from scipy import signal
    >>> from physid import Recording
    >>> t = np.arange(4000) * 1e-3
    >>> u = np.sin(10 * t)
    >>> x = signal.lsim(([1.0], [1.0, 2.0, 100.0]), u, t)[1]
    >>> rec = Recording(t, np.c_[u, x], ["u", "x"])
    >>> est = RecursiveLeastSquares("msd")
    >>> streamed = fit_blocks(est, rec, block_samples=999, progress=False)
    >>> batch = est.fit(rec).result_
    >>> bool(np.isclose(streamed.parameters["theta2"], batch.parameters["theta2"], rtol=1e-9))
    True
    """
    est = estimator
    if not isinstance(est, RecursiveLeastSquares):
        raise InputError(
            f"{arg('estimator')} must be a RecursiveLeastSquares; got {type(est).__name__}."
        )
    lam = _check_forgetting(est.forgetting)
    r = check_positive(est.weight, "weight")
    if est.covariance not in ("full", "diagonal"):
        raise InputError(f"covariance must be 'full' or 'diagonal'; got {est.covariance!r}.")
    if est.prefilter != "butterworth":
        raise refuse(
            "prefilter",
            est.prefilter,
            "butterworth",
            "the differential FIR filters are non-causal (each derivative needs the samples "
            "after it)",
        )
    spec = as_linear_ode_model(est.model)
    src, in_name, out_name, size, keep = open_source(source, spec, est.known, block_samples, keep)
    channels = (in_name, out_name)
    bar = progress_bar(progress, 3 * src.n_samples, "rls, streamed (3 passes)")
    try:
        survey = _survey(est, spec, src, channels, size, keep, bar)
        moments = _moments(est, spec, src, channels, size, survey, bar)
        return _conclude(est, spec, src, channels, size, survey, moments, (lam, r), bar)
    finally:
        bar.close()


def _survey(est, spec, src, channels, size, keep, bar) -> SimpleNamespace:
    """Pass 1: the online estimator's histories (thinned), the rows' moments and the record's
    statistics; then the in-memory fit's checks on them."""
    online = est.stream(src.dt, t_start=src.t0)
    names = online.names
    p = len(names)
    stats = RecordStats(channels)
    thin = Thinned(src.n_samples, keep)
    S, xy, yy, n_rows, valid = np.zeros((p, p)), np.zeros(p), 0.0, 0, 0
    for start, block, u, y in pairs(src, *channels, size, bar):
        if start == 0:
            spec.check_units(block)  # a force [N] for the normalised msd is an error
        stats.add(u, y)
        _, kept, X, Y = online._rows(u, y)
        theta = np.full((u.size, p), np.nan)
        P = np.full((u.size, p, p), np.nan)
        if Y.size:
            theta[kept], P[kept] = online._rls.update(X, Y, return_covariance=True)
            S += X.T @ X
            xy += X.T @ Y
            yy += float(Y @ Y)
            n_rows += Y.size
        valid += int(np.count_nonzero(np.isfinite(theta).all(axis=1)))
        pick = thin.pick(start, u.size)
        P = P[pick] if est.covariance == "full" else np.diagonal(P[pick], axis1=1, axis2=2)
        thin.add(t=np.asarray(block.t)[pick], theta=theta[pick], P=P)
    stats.check_distinct()
    init = _check_init_samples(est.init_samples, p)
    if n_rows < max(init, p):
        raise EstimationError(
            f"the regression has {n_rows} rows after the {online.discarded}-sample pre-filter "
            f"transient but needs at least {max(init, p)} ({arg('init_samples')}, >= {p} "
            f"unknowns). Use a longer record, fewer {arg('init_samples')} (>= {p}) or a higher "
            f"{arg('prefilter_cutoff')} [Hz] (a shorter transient)."
        )
    least_squares = lambda: np.linalg.lstsq(S, xy, rcond=None)[0]  # noqa: E731
    check_excitation_moments(S, n_rows, names, (xy, yy, least_squares), _nominal_of(spec, names))
    if online._rls.init_end is None:  # pragma: no cover - the excitation check catches this
        raise EstimationError("the regressors never determine all unknowns.")
    return SimpleNamespace(
        online=online,
        names=names,
        stats=stats,
        thin=thin,
        n_rows=n_rows,
        valid=valid,
        init_end=int(online._rls.init_end),
        theta=online._rls.theta,
    )


def _moments(est, spec, src, channels, size, survey, bar) -> RowMoments:
    """Pass 2: the weighted sums of the final estimate and its uncertainty (the same rows)."""
    online = est.stream(src.dt, t_start=src.t0)  # a fresh filter: the rows of pass 1 again
    acc = RowMoments(
        spec,
        online,
        lam=_check_forgetting(est.forgetting),
        init_end=survey.init_end,
        last=survey.n_rows - 1,
        theta0=survey.theta,
        prefilter_order=est.prefilter_order,
    )
    row = 0
    for _, _, u, y in pairs(src, *channels, size, bar):
        _, _, X, Y = online._rows(u, y)
        acc.add(row, X, Y)
        row += Y.size
    acc.finish()
    return acc


def _conclude(est, spec, src, channels, size, survey, acc, rates, bar) -> RecursiveResult:
    """The final estimate, its uncertainty and verdict (pass 3 simulates the model)."""
    lam, r = rates
    names = survey.names
    p = len(names)
    iu = np.triu_indices(p)
    theta, _, ok = _packed_solve((acc.S / r)[iu][None], (acc.b / r)[None], p)  # as the batch
    if not ok[0]:
        raise EstimationError(
            "the weighted information of the record's last rows is singular (with "
            f"{arg('forgetting')} < 1 the end of the record carries no excitation); raise "
            f"{arg('forgetting')} or fit the record in memory."
        )
    theta = theta[0]
    values = dict(spec.parameters)
    values.update(est.known or {})
    sigma2, white_cov = acc.white_covariance(theta)
    theta_final, cov_final, stderr, stderr_reason, method = uncertainty_from_moments(
        acc, spec, names, theta, values, bias_compensation=est.bias_compensation
    )
    theta_final, stderr, cov_final = _offset_to_si(spec, names, theta_final, stderr, cov_final)
    fitted = {nm: float(theta_final[i]) for i, nm in enumerate(names)}
    known_values = {k: float(v) for k, v in values.items() if k not in names}
    known_values = {k: v for k, v in known_values.items() if k in spec.coefficient_names}
    every = {**known_values, **fitted}
    prediction = PredictionStats(spec, every, src.n_samples)
    finite = all(np.isfinite(v) for v in every.values())
    if finite:
        for _, block, u, y in pairs(src, *channels, size, bar):
            prediction.add(np.asarray(block.t, dtype=float), u, y)
    times = UniformTimes(src.t0, src.dt)
    problem = survey.stats.unchanging(channels[1])
    fit, problems = prediction.verdict(times, channels[1], problem) if finite else (np.nan, [])
    success, message, fit = _verdict(spec, every, names, None, channels, 0, fit_of=lambda: fit)
    if success:
        success, message = gate(success, message, problems)
    if not success:
        stderr, stderr_reason = None, "no trustworthy estimate"
    cov_final = None if stderr is None else np.array(cov_final, dtype=float)
    thin = survey.thin
    theta_hist = thin.get("theta", np.empty((0, p)))
    P_shape = (0, p, p) if est.covariance == "full" else (0, p)
    online = survey.online
    result = est._result(
        SimpleNamespace(t=thin.get("t", np.empty(0)), dt=src.dt),
        spec,
        SimpleNamespace(names=names, cutoff=online.prefilter_cutoff, discarded=online.discarded),
        estimates=_offset_to_value(spec, names, theta_hist),
        cov=thin.get("P", np.empty(P_shape)),
        values=values,
        fitted=fitted,
        known_values=known_values,
        uncertainty=(stderr, stderr_reason, cov_final),
        verdict=(success, message, fit),
        init_end=int(online.discarded + survey.init_end),
        rates=(lam, r),
        metadata=_metadata(_shape_only(survey.n_rows, p, names), sigma2, white_cov, method),
    )
    notes = [f"streamed: read in blocks of {size} samples ({src.n_samples} samples, three passes)"]
    notes += [n for n in [thin.note(src.n_samples)] if n]
    return dataclasses.replace(
        result,
        valid_fraction=survey.valid / src.n_samples,
        metadata={**result.metadata, "streamed": True, "notes": notes},
    )


def _shape_only(n_rows: int, p: int, names) -> SimpleNamespace:
    """What `_metadata` reads of a regression (its row count and names), without the rows."""
    return SimpleNamespace(X=SimpleNamespace(shape=(n_rows, p)), names=names)
