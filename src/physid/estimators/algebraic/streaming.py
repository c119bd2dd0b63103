"""The algebraic estimator fed chunk by chunk, with constant memory."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..._validate import check_positive, check_signal_pair
from ...models.linear_ode import as_linear_ode_model
from .plan import AlgebraicSettings, _settings_plan
from .solve import _run


@dataclass(frozen=True)
class StreamingUpdate:
    """Estimates for the samples of one chunk: ``t`` [s], ``estimates`` (n_new, n_unknown) in SI
    units, ``valid`` (n_new,), ``level`` (n_new,) and the coefficient ``names``."""

    t: np.ndarray
    estimates: np.ndarray
    valid: np.ndarray
    level: np.ndarray
    names: tuple[str, ...]


class StreamingAlgebraicEstimator:
    """The algebraic estimator fed chunk by chunk, with constant memory.

    It keeps the last ``L + (block − 1) block_stride`` samples and the last ``guard_window − 1``
    determinant levels; the estimates for each chunk equal the batch estimates
    (`algebraic_estimates`) of the same samples to rounding (≤ 1e-10).

    Parameters
    ----------
    model : "msd", path to a TOML model file, or LinearODEModel
        The linear ODE to identify.
    dt : float [s]
        Sample period of the stream.
    t_start : float [s]
        Time of the first sample.
    **settings
        Any `AlgebraicSettings` field except ``final_fraction`` and ``final`` (a stream has no
        final estimate).

    Examples
    --------
    The record of `AlgebraicEstimator`'s example fed in chunks of 100 samples gives the same
    per-window estimates as the batch estimator:

    >>> from scipy import signal
    >>> from physid.estimators.algebraic import algebraic_estimates
    >>> t = np.arange(1000) * 1e-3
    >>> u = np.sin(10 * t)
    >>> x = signal.lsim(([1.0], [1.0, 2.0, 100.0]), u, t)[1]
    >>> stream = StreamingAlgebraicEstimator("msd", dt=1e-3, window=0.05)
    >>> updates = [stream.update(u[i:i + 100], x[i:i + 100]) for i in range(0, 1000, 100)]
    >>> streamed = np.concatenate([upd.estimates for upd in updates])
    >>> batch = algebraic_estimates(u, x, 1e-3, "msd", window=0.05).estimates
    >>> bool(np.allclose(streamed, batch, rtol=1e-10, atol=0, equal_nan=True))
    True
    >>> np.round(updates[-1].estimates[-1], 3).tolist()   # θ1, θ2 at t = 0.999 s
    [2.0, 100.0]
    """

    def __init__(self, model="msd", *, dt: float, t_start: float = 0.0, **settings):
        self.dt = check_positive(dt, "dt")
        allowed = [n for n in AlgebraicSettings.names() if n not in AlgebraicSettings.FINAL_ONLY]
        s = AlgebraicSettings.from_kwargs("StreamingAlgebraicEstimator", allowed, **settings)
        model = as_linear_ode_model(model)
        self._plan = _settings_plan(model, self.dt, s)
        self._offset = model.known_output_offset()  # a held offset is removed from each chunk
        self.t_start = float(t_start)
        self.reset()

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the estimated coefficients (columns of the estimates)."""
        return self._plan.names

    def reset(self) -> None:
        """Forget the stream (start again at ``t_start``)."""
        self._u = np.empty(0)
        self._y = np.empty(0)
        self._n_seen = 0
        self._history = np.empty(0)

    def update(self, u, y) -> StreamingUpdate:
        """Feed the next samples and return their estimates.

        Parameters
        ----------
        u, y : array_like, shape (n_new,)
            Input and output samples.

        Returns
        -------
        StreamingUpdate
            The chunk's estimates.
        """
        return self._update(u, y)[0]

    def _update(self, u, y):
        """`update`, and the new samples' window systems ``(A (n_eq, p, n_new), r (n_eq,
        n_new))`` in the dimensionless unknowns (None for an empty chunk)."""
        u, y = check_signal_pair(u, y)
        y = y - self._offset
        plan = self._plan
        u_all = np.concatenate([self._u, u])
        y_all = np.concatenate([self._y, y])
        first = self._n_seen - self._u.size
        n_new = u.size
        t = self.t_start + self.dt * np.arange(self._n_seen, self._n_seen + n_new)
        if n_new == 0:
            p = plan.p
            empty = StreamingUpdate(t, np.empty((0, p)), np.empty(0, bool), np.empty(0), plan.names)
            return empty, None
        theta, valid, level, self._history, (A, rhs) = _run(
            plan, u_all, y_all, first, n_new, self._history
        )
        keep = plan.span
        self._u = u_all[-keep:].copy()
        self._y = y_all[-keep:].copy()
        self._n_seen += n_new
        upd = StreamingUpdate(t, theta, valid, level, plan.names)
        return upd, (A[:, :, -n_new:], rhs[:, -n_new:])
