"""The recursive estimator run online on raw ``(u, y)`` chunks, with constant memory."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._validate import check_positive, check_signal_pair
from ...errors import InputError
from ...filters.state_variable import StreamingStateVariableFilter, svf_transient_samples
from ...models.linear_ode import as_linear_ode_model, natural_frequency_damping
from .prefilter import _prefilter_settings
from .regression import _offset_to_value, _regression_rows, _split_with_offset
from .streaming import StreamingRLS


@dataclass(frozen=True)
class StreamingRecursiveUpdate:
    """Estimates for the samples of one chunk.

    Attributes
    ----------
    t : ndarray (n_new,) [s]
    estimates : ndarray (n_new, p) — θ̂ after each sample (NaN during the pre-filter transient and
        before the OLS start), in SI units.
    valid : ndarray of bool (n_new,)
    names : tuple of str — the unknown of each column.
    natural_frequency, damping_ratio : ndarray (n_new,) or None — MSD only ([rad/s], 1).
    """

    t: np.ndarray
    estimates: np.ndarray
    valid: np.ndarray
    names: tuple[str, ...]
    natural_frequency: np.ndarray | None = None
    damping_ratio: np.ndarray | None = None


class StreamingRecursiveEstimator:
    """`RecursiveLeastSquares` run online on raw ``(u, y)`` chunks, with constant memory.

    A `StreamingStateVariableFilter` (its state carried across chunks) builds the regression rows
    of each new sample, the rows inside the pre-filter start-up transient are dropped exactly as
    in the batch `RecursiveLeastSquares.fit` (``transient_samples``, default
    `svf_transient_samples`), and the rest feed a `StreamingRLS` (OLS start, then eq. 3 in Joseph
    form). For any chunking the estimates equal the batch ``fit`` of the whole record (tests:
    chunks of 1, 7 and 1000 samples, ≤ 1e-9 relative). Memory: the filter state and p × p numbers
    (plus the ``init_samples`` rows of the OLS start until it happens).

    Only the causal ``prefilter="butterworth"`` streams (the differential filters are
    non-causal). The batch form's whole-record excitation check cannot run online: a stream
    without excitation keeps NaN (before the start) or holds its estimate.

    Parameters
    ----------
    estimator : RecursiveLeastSquares
        Settings (model, forgetting, weight, prefilter cut-off and order, init_samples, unknown,
        known, transient_samples).
    dt : float [s]
        Sample period.
    t_start : float [s], default 0

    Examples
    --------
    >>> from scipy import signal
    >>> from physid.estimators.recursive import RecursiveLeastSquares
    >>> t = np.arange(3000) * 1e-3
    >>> u = np.sin(10 * t)
    >>> x = signal.lsim(([1.0], [1.0, 2.0, 100.0]), u, t)[1]
    >>> online = RecursiveLeastSquares("msd").stream(dt=1e-3)
    >>> for i in range(0, t.size, 500):
    ...     upd = online.update(u[i:i + 500], x[i:i + 500])
    >>> round(float(upd.natural_frequency[-1]), 2)
    10.0
    """

    def __init__(self, estimator, dt: float, *, t_start: float = 0.0):
        est = estimator
        self.dt = check_positive(dt, "dt")
        self.t_start = float(t_start)
        if est.prefilter != "butterworth":
            raise InputError(
                f"only prefilter='butterworth' (causal) can stream; got {est.prefilter!r}. The "
                "differential FIR filters need future samples: use fit() on the whole record."
            )
        spec = as_linear_ode_model(est.model)
        self._spec = spec
        self._unknown, self._values = _split_with_offset(spec, est.unknown, est.known)
        highest, cutoff, order, discard = _prefilter_settings(
            spec, self.dt, est.prefilter_cutoff, est.prefilter_order, est.transient_samples
        )
        if discard is None:
            discard = svf_transient_samples(cutoff, self.dt, order)
        self.discarded = discard
        self.prefilter_cutoff = float(cutoff)
        self._highest = highest
        self._svf = StreamingStateVariableFilter(
            self.dt, cutoff, highest, n_channels=2, filter_order=order
        )
        self._rls = StreamingRLS(
            len(self._unknown),
            forgetting=est.forgetting,
            weight=est.weight,
            init_samples=est.init_samples,
        )
        self.n_samples = 0

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the estimated coefficients (columns of the estimates)."""
        return self._unknown

    @property
    def theta(self) -> np.ndarray:
        """θ̂ after the last sample, shape (p,)."""
        return self._rls.theta

    @property
    def covariance(self) -> np.ndarray:
        """eq. 3's P after the last sample, shape (p, p)."""
        return self._rls.covariance

    def _rows(self, u, y):
        """The regression rows of the next samples (the pre-filter's state carried on).

        Returns ``(index, keep, X, Y)``: the samples' global indices (n_new,), which of them give a
        row (after the start-up transient, as in ``fit``), and those rows (n_rows, p), (n_rows,).
        Advances the pre-filter and `n_samples`, not the recursion.
        """
        u, y = check_signal_pair(u, y)
        y = y - self._spec.known_output_offset()  # as build_regression: a held offset removed
        n_new = u.size
        p = len(self._unknown)
        index = np.arange(self.n_samples, self.n_samples + n_new)
        keep = index >= self.discarded  # rows after the start-up transient (as in fit)
        X, Y = np.empty((0, p)), np.empty(0)
        if n_new:
            derivs = self._svf.update(np.column_stack([y, u]))  # (n_new, 2, highest + 1)
            if keep.any():
                X, Y = _regression_rows(
                    self._spec,
                    self._unknown,
                    self._values,
                    derivs[keep, 0, :],
                    derivs[keep, 1, :],
                )
        self.n_samples += n_new
        return index, keep, X, Y

    def update(self, u, y) -> StreamingRecursiveUpdate:
        """Feed the next samples ``u``, ``y`` (shape (n_new,)); return their estimates."""
        index, keep, X, Y = self._rows(u, y)
        n_new = index.size
        p = len(self._unknown)
        estimates = np.full((n_new, p), np.nan)
        if Y.size:
            estimates[keep] = _offset_to_value(self._spec, self._unknown, self._rls.update(X, Y))
        valid = np.all(np.isfinite(estimates), axis=1)
        omega0 = zeta = None
        if self._spec.is_msd:
            th = {nm: estimates[:, i] for i, nm in enumerate(self._unknown)}
            nan = np.where(valid, 0.0, np.nan)
            th1 = th.get("theta1", self._values["theta1"] + nan)
            th2 = th.get("theta2", self._values["theta2"] + nan)
            omega0, zeta = natural_frequency_damping(np.asarray(th1), np.asarray(th2))
            omega0, zeta = np.atleast_1d(omega0), np.atleast_1d(zeta)
        return StreamingRecursiveUpdate(
            t=self.t_start + self.dt * index,
            estimates=estimates,
            valid=valid,
            names=self._unknown,
            natural_frequency=omega0,
            damping_ratio=zeta,
        )
