"""`fit_blocks`: the algebraic estimator on a record read block by block, in constant memory.

The per-window estimates come from `StreamingAlgebraicEstimator` (the last ``span`` samples and
the guard's level history carried across blocks: they equal the in-memory ones). The final
estimate that streams is ``final="bias-compensated"``: pooled least squares over every full
window of the trailing ``final_fraction`` — sums of the windows' normal equations, no selection.
The default ``final="lstsq"`` screens the windows by the median of all their estimates (and
checks itself against the bias-compensated one), ``final="median"`` is that median: both need
every window's estimate at once, so a block fit refuses them.

Passes over the source, each holding one block:

1. the window estimates (histories thinned to ``keep`` samples), the pooled sums ``G = Σ AᵀA``,
   ``h = Σ Aᵀ r``, the excitation check's moments and the record's statistics;
2. the same windows again: residual sums about the pass-1 estimate and, by overlap-add, the Gram
   matrices of the windows' equations convolved with each kernel ``taps_{e,i}`` (so ``C Cᵀ`` of
   `_pooled_stderr` follows for the final α), and the window-pair counts;
3. the identified model simulated block by block (training fit and the gate's segments).

Memory: one block, ``span`` samples of history, the guard's ``guard_window`` levels and
O((order + 1)² p²) sums — independent of the record's length.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.signal import correlate, oaconvolve

from ...errors import EstimationError, InputError, SamplingError, arg
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
from .estimator import AlgebraicEstimator
from .plan import AlgebraicSettings
from .result import AlgebraicResult, _assemble, _offset_stderr
from .streaming import StreamingAlgebraicEstimator
from .uncertainty import (
    _bias_compensated_sums,
    _equilibrated_condition,
    _noise_kernels,
    _pooled_stderr_sums,
)
from .windows import _offset_to_value, _unscale

__all__ = ["fit_blocks"]

_WHY = {
    "lstsq": "its 5-MAD screen and its bias check need the median of every window's estimate",
    "median": "the median of every window's estimate needs them all at once",
}


def fit_blocks(
    estimator: AlgebraicEstimator,
    source,
    *,
    block_samples: int = 65536,
    keep: int = 20000,
    progress: bool = True,
) -> AlgebraicResult:
    """`AlgebraicEstimator.fit` of a record read block by block, in constant memory.

    Parameters
    ----------
    estimator : AlgebraicEstimator
        The settings; ``final`` must be ``"bias-compensated"`` (the pooled sums stream; the
        median-based ``"lstsq"`` and ``"median"`` do not).
    source : BlockSource or Recording
        The record (`physid.signals.io.open_blocks`, `physid.signals.blocks.RecordingBlocks`),
        with the model's input and output channels.
    block_samples : int, default 65536
        Samples read at a time.
    keep : int, default 20000
        Most samples kept of each per-sample history (``t``, ``estimates``, ``valid``,
        ``level``: every k-th sample, noted in ``settings["notes"]``).
    progress : bool, default True
        A progress line on stderr (silent off a terminal).

    Returns
    -------
    AlgebraicResult
        The final estimate, standard errors, verdict and training fit equal those of ``fit`` on
        the same record (to rounding); the histories are thinned.

    Raises
    ------
    InputError
        ``final="lstsq"`` or ``"median"`` (they need every window's estimate at once).
    SamplingError, EstimationError, IdentifiabilityError
        As ``fit``.

    Examples
    --------
    >>> from scipy import signal
    >>> from physid import Recording
    >>> t = np.arange(3000) * 1e-3
    >>> u = np.sin(10 * t)
    >>> x = signal.lsim(([1.0], [1.0, 2.0, 100.0]), u, t)[1]
    >>> rec = Recording(t, np.c_[u, x], ["u", "x"])
    >>> est = AlgebraicEstimator("msd", window=0.05, final="bias-compensated")
    >>> streamed = fit_blocks(est, rec, block_samples=777, progress=False)
    >>> batch = est.fit(rec).result_
    >>> bool(np.isclose(streamed.parameters["theta2"], batch.parameters["theta2"], rtol=1e-9))
    True
    """
    if not isinstance(estimator, AlgebraicEstimator):
        raise InputError(
            f"{arg('estimator')} must be an AlgebraicEstimator; got {type(estimator).__name__}."
        )
    s = estimator.settings
    if s.final != "bias-compensated":
        raise refuse("final", s.final, "bias-compensated", _WHY.get(s.final, "unknown rule"))
    if not (0.0 < float(s.final_fraction) <= 1.0):
        raise InputError(f"final_fraction must lie in (0, 1]; got {s.final_fraction!r}.")
    model = as_linear_ode_model(estimator.model)
    src, in_name, out_name, size, keep = open_source(
        source, model, estimator.known, block_samples, keep
    )
    streamed = {k: getattr(s, k) for k in s.names() if k not in AlgebraicSettings.FINAL_ONLY}
    plan = StreamingAlgebraicEstimator(model, dt=src.dt, **streamed)._plan
    n = src.n_samples
    if plan.L > n - 1:
        raise SamplingError(
            f"window = {plan.window:g} s ({plan.L} intervals) is longer than the record "
            f"({n} samples, {(n - 1) * plan.dt:g} s). Shorten the window or record longer."
        )
    run = _Run(model, s, streamed, src, (in_name, out_name), size, keep)
    bar = progress_bar(progress, 3 * n, "algebraic, streamed (3 passes)")
    try:
        run.survey(plan, bar)
        estimate = run.final(plan, bar)
        checks = (run.fit_of(bar), run.problems_of(bar))
        exists = run.n_exists
        valid_fraction = run.n_valid / exists if exists else 0.0
        result = _assemble(plan, run.history(plan), valid_fraction, estimate, checks, model, s)
    finally:
        bar.close()
    notes = [f"streamed: read in blocks of {size} samples ({n} samples)"]
    notes += [x for x in [run.thin.note(n)] if x]
    return dataclasses.replace(
        result, settings={**result.settings, "streamed": True, "notes": notes}
    )


class _Run:
    """The passes of one streamed algebraic fit and what they accumulate."""

    def __init__(self, model, settings, streamed, src, channels, size, keep):
        self.model, self.settings, self.streamed = model, settings, streamed
        self.src, self.channels, self.size = src, channels, size
        self.thin = Thinned(src.n_samples, keep)
        self.offset = model.known_output_offset()
        self.stats = RecordStats(("u", "y"), offset=self.offset)
        t_last = src.t0 + src.dt * (src.n_samples - 1)
        ff = float(settings.final_fraction)
        self.tail_from = t_last - ff * (t_last - src.t0)  # windows ending at t ≥ this [s]
        self.n_exists = self.n_valid = 0
        self.cache: dict = {}

    def _windows(self, bar):
        """``(k, t, update, A, r)`` per block: the window estimates and systems, in order."""
        src = self.src
        stream = StreamingAlgebraicEstimator(self.model, dt=src.dt, **self.streamed)
        for start, block, u, y in pairs(src, *self.channels, self.size, bar):
            upd, (A, rhs) = stream._update(u, y)
            k = start + np.arange(u.size)
            yield start, block, u, y, k, src.t0 + src.dt * k, upd, A, rhs

    def _used(self, plan, k, t, upd):
        """Windows of the pooled estimate: full, in the tail, existing, with finite estimates
        (every one: the bias-compensated rule selects none), and the valid ones among them."""
        tail = (k >= plan.span) & (t >= self.tail_from)
        every = tail & np.isfinite(upd.level) & np.isfinite(upd.estimates).all(axis=1)
        return every, tail & upd.valid

    def survey(self, plan, bar) -> None:
        """Pass 1: histories, pooled sums, the excitation check's moments, the statistics."""
        p = plan.p
        self.G, self.h = np.zeros((p, p)), np.zeros(p)
        self.W = 0
        S, xy, yy, rows = np.zeros((p, p)), np.zeros(p), 0.0, 0
        self.any_valid = False
        self.first_used = None
        for start, block, u, y, k, t, upd, A, rhs in self._windows(bar):
            if start == 0:
                self.model.check_units(block)
            self.stats.add(u, y)
            exists = np.isfinite(upd.level)
            self.n_exists += int(exists.sum())
            self.n_valid += int((upd.valid & exists).sum())
            every, valid_used = self._used(plan, k, t, upd)
            self.any_valid |= bool(valid_used.any())
            if every.any():
                Ae, re = A[:, :, every], rhs[:, every]
                self.G += np.einsum("epw,eqw->pq", Ae, Ae)
                self.h += np.einsum("epw,ew->p", Ae, re)
                self.W += int(every.sum())
                if self.first_used is None:
                    self.first_used = int(k[every][0])
            check = upd.valid & (k >= plan.span)  # `_check_window_excitation`'s rows
            X = np.moveaxis(A[:, :, check], 1, -1).reshape(-1, p)
            Y = rhs[:, check].reshape(-1)
            ok = np.isfinite(X).all(axis=1) & np.isfinite(Y)
            S += X[ok].T @ X[ok]
            xy += X[ok].T @ Y[ok]
            yy += float(Y[ok] @ Y[ok])
            rows += int(ok.sum())
            pick = self.thin.pick(start, u.size)
            self.thin.add(
                t=t[pick], theta=upd.estimates[pick], valid=upd.valid[pick], level=upd.level[pick]
            )
        self._check_record(plan)
        if rows >= p:
            ls = lambda: np.linalg.lstsq(S, xy, rcond=None)[0]  # noqa: E731
            check_excitation_moments(S, rows, plan.names, (xy, yy, ls), self._nominal(plan))

    def _check_record(self, plan) -> None:
        """`_check_signals` from the record's statistics."""
        st = self.stats
        u_zero = st.u_max == 0.0
        if u_zero and st.y_min == 0.0 and st.y_max == 0.0:
            raise EstimationError(
                "no excitation: the input u and the output y are identically zero (zero input "
                "and zero initial state), so every window integral vanishes. Record a response "
                "to a non-zero input."
            )
        if u_zero and any(kind == "b" for kind, _ in plan.columns):
            names = [nm for nm, (kd, _) in zip(plan.names, plan.columns, strict=True) if kd == "b"]
            raise EstimationError(
                f"the input u is identically zero, so the input coefficient(s) {names} cannot be "
                "estimated; give them as known or excite the system."
            )
        st.check_distinct()

    def _nominal(self, plan) -> np.ndarray:
        """The nominal α of `_check_window_excitation` (α_i = a_i T^(n−i))."""
        nominal = []
        for (kind, i), name in zip(plan.columns, plan.names, strict=True):
            try:
                v = float(self.model.parameters[name]) if kind != "o" else np.nan
            except (KeyError, TypeError, ValueError):
                v = np.nan
            nominal.append(v * plan.window ** (plan.order - i))
        return np.array(nominal)

    def final(self, plan, bar):
        """Pass 2 and the final estimate ``(final, condition, stderr, reason, covariance)``."""
        if not self.any_valid:
            return None, float("nan"), None, "no valid window", None
        alpha0 = np.linalg.lstsq(self.G, self.h, rcond=None)[0]
        acc = _WindowSums(plan, alpha0, self.first_used)
        for _, _, _, _, k, t, upd, A, rhs in self._windows(bar):
            every, _ = self._used(plan, k, t, upd)
            acc.add(k, every, A, rhs)
        acc.finish()
        n_res = plan.taps(plan.L).shape[0] * self.W

        def mean_square(a):
            return acc.sse(a, self.G) / n_res

        alpha, Gc = _bias_compensated_sums(plan, self.G, self.h, alpha0, self.W, mean_square)
        final = _offset_to_value(plan, alpha * _unscale(plan))
        condition = _equilibrated_condition(Gc)
        _, gamma, _ = _noise_kernels(plan, alpha)
        sums = (acc.sse(alpha, self.G), n_res, self.W)
        stderr, reason, cov = _pooled_stderr_sums(
            plan, alpha, sums, acc.CCt(gamma), acc.pair_counts(), Gc
        )
        if stderr is not None and ("o", 0) in plan.columns:
            _offset_stderr(plan, final, stderr, cov)
        return final, condition, stderr, reason, cov

    def _prediction(self, model, values, bar):
        """Pass 3: the model simulated over the tail (training fit) and the whole record."""
        key = tuple(sorted(values.items()))
        if key in self.cache:
            return self.cache[key]
        src = self.src
        tail0 = int(np.ceil(max((self.tail_from - src.t0) / src.dt - 1e-9, 0.0)))
        whole = PredictionStats(model, values, src.n_samples)
        tail = whole if tail0 == 0 else PredictionStats(model, values, src.n_samples - tail0)
        for start, _, u, y in pairs(src, *self.channels, self.size, bar):
            t = src.t0 + src.dt * (start + np.arange(u.size))
            y = y - self.offset
            whole.add(t, u, y)
            if tail is not whole and start + u.size > tail0:
                cut = max(tail0 - start, 0)
                tail.add(t[cut:], u[cut:], y[cut:])
        times = UniformTimes(src.t0, src.dt)
        name = self.channels[1]
        problems = whole.verdict(times, name, self.stats.unchanging(name))[1]
        fit = tail.verdict(times, name, None)[0]
        if src.n_samples - tail0 < 2 * model.order + 2:
            fit = float("nan")
        self.cache[key] = (fit, problems)
        return fit, problems

    def fit_of(self, bar):
        """The training fit [%] of (model, values), as `_training_fit`."""
        return lambda model, values: self._prediction(model, values, bar)[0]

    def problems_of(self, bar):
        """The gate's problems of (model, values), as `linear_ode_problems`."""
        return lambda model, values: self._prediction(model, values, bar)[1]

    def history(self, plan):
        """The thinned ``(t, estimates, valid, level)``."""
        p = plan.p
        th = self.thin
        return (
            th.get("t", np.empty(0)),
            th.get("theta", np.empty((0, p))),
            th.get("valid", np.empty(0, dtype=bool)),
            th.get("level", np.empty(0)),
        )


class _WindowSums:
    """Pass 2's sums over the pooled windows (constant memory).

    Residual sums about ``alpha0`` (Σ e0², Σ Aᵀ e0: the residual sum of squares at any α without
    cancellation); ``T`` the Gram matrix of ``D_i = Σ_e conv(A_e, taps_{e,i})`` over the dense
    window axis (unused windows zero) by overlap-add, so that ``C Cᵀ = Σ_ij γ_i γ_j D_i D_jᵀ`` of
    `_pooled_stderr`; and the counts n(d) of used-window pairs d apart (d = 0..L).
    """

    def __init__(self, plan, alpha0, first_used: int):
        self.plan = plan
        self.alpha0 = np.asarray(alpha0, dtype=float)
        self.taps = plan.taps(plan.L)  # (n_eq, order + 1, L + 1)
        p, L = plan.p, plan.L
        self.m = self.taps.shape[1]
        self.see0, self.sAe0 = 0.0, np.zeros(p)
        self.T = np.zeros((self.m * p, self.m * p))
        self.pending = np.zeros((L, self.m * p))
        self.first = int(first_used)  # window index of dense position 0
        self.R = np.zeros(L + 1)
        self.tail = np.zeros(L)

    def add(self, k, every, A, rhs) -> None:
        """One block's windows (``k`` their end samples, ``every`` the used ones)."""
        if k[-1] < self.first:
            return
        sel = k >= self.first
        A, rhs, use = A[:, :, sel], rhs[:, sel], every[sel]
        if use.any():
            e0 = rhs[:, use] - np.einsum("epw,p->ew", A[:, :, use], self.alpha0)
            self.see0 += float((e0 * e0).sum())
            self.sAe0 += np.einsum("epw,ew->p", A[:, :, use], e0)
        dense = np.where(use[None, None, :], A, 0.0)  # (n_eq, p, B)
        B = dense.shape[2]
        parts = []
        for i in range(self.m):  # D_i = Σ_e conv(A_e, taps_{e,i}) along the window axis
            D = sum(
                oaconvolve(dense[e], self.taps[e, i][None, :], axes=1)
                for e in range(dense.shape[0])
            )
            parts.append(D.T)  # (B + L, p)
        total = np.concatenate(parts, axis=1)  # (B + L, m·p)
        L = self.plan.L
        total[:L] += self.pending
        self.T += total[:B].T @ total[:B]  # no later window reaches these positions
        self.pending = total[B:].copy()
        ind = use.astype(float)
        z = np.concatenate([self.tail, ind])
        self.R += correlate(z, ind, mode="valid", method="fft")[::-1]  # [i] ↔ lag L − i
        if L:
            self.tail = z[-L:]

    def finish(self) -> None:
        """The last positions (no window after the record's end reaches them)."""
        self.T += self.pending.T @ self.pending
        self.pending = self.pending[:0]

    def sse(self, alpha, G) -> float:
        """Σ (r − A α)² over the used windows' equations."""
        d = np.asarray(alpha, dtype=float) - self.alpha0
        return float(self.see0 - 2.0 * d @ self.sAe0 + d @ G @ d)

    def CCt(self, gamma) -> np.ndarray:
        """``C Cᵀ`` for ``κ_e = Σ_i γ_i taps_{e,i}`` (the sign of C squares away)."""
        p = self.plan.p
        K = np.kron(np.asarray(gamma, dtype=float)[:, None], np.eye(p))
        return K.T @ self.T @ K

    def pair_counts(self) -> np.ndarray:
        """n(d), d = −L..L (rounded, as `_window_pairs`)."""
        return np.round(np.concatenate([self.R[:0:-1], self.R]))
