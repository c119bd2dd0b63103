"""The algebraic estimator's result and the final estimate pooled from the valid windows."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...errors import InputError
from ...models.linear_ode import as_linear_ode_model, natural_frequency_damping
from .._linear import (
    LinearODEResultMixin,
    coefficient_units,
    derived_with_stderr,
    physical_statement,
    simulate_prediction,
)
from ..plausibility import gate, linear_ode_problems
from ..results import ParameterDict, ResultMixin
from .plan import AlgebraicSettings, _Plan
from .uncertainty import (
    _bias_compensated,
    _equilibrated_condition,
    _pooled_stderr,
    _withhold_if_biased,
)
from .windows import _offset_to_value, _unscale

#: Largest condition number of the pooled (dimensionless, unit-diagonal) normal matrix for which
#: the final estimate is reported as a success: beyond it, relative rounding errors of 1e-16 in the
#: window integrals move the estimate by more than 1e-4 relative.
MAX_CONDITION = 1e12


@dataclass(frozen=True)
class AlgebraicResult(LinearODEResultMixin, ResultMixin):
    """Estimates of the algebraic estimator at every sample time.

    Attributes
    ----------
    t : ndarray, shape (n_samples,) [s]
        Times ``t0`` of the estimates (window ends; each estimate uses samples up to ``t0`` only).
    estimates : ndarray, shape (n_samples, n_unknown)
        Per-window estimates in SI units; NaN where no window exists yet (also ``history``).
    names : tuple of str
        Names of the estimated coefficients (columns of ``estimates``).
    valid : ndarray of bool, shape (n_samples,)
        Windows that exist, solved, and passed the determinant guard.
    level : ndarray, shape (n_samples,)
        Determinant level of each window's system (``|det|``; see `AlgebraicEstimator`).
    parameters : dict
        The fitted coefficients: the final estimate from the valid full windows in the trailing
        ``final_fraction`` of the record; by default (``final="lstsq"``) least squares over their
        pooled equations, after dropping the windows whose own estimate lies beyond 5 robust
        standard deviations (1.4826 · MAD) of the median; with ``final="median"`` the median of
        their estimates.
    success, message, valid_fraction
        Whether a trustworthy final estimate exists; what to change otherwise; fraction of
        existing windows that are valid.
    known : dict
        Coefficients held at known values.
    window : float [s], mu, integration, block
        Settings used (``window`` is the rounded ``L · dt``).
    derived : dict
        For the MSD ``natural_frequency`` [rad/s] and ``damping_ratio`` (and ``mass``,
        ``damping``, ``stiffness`` when ``b0 = 1/m`` is known or fitted); for a model whose
        coefficients are expressions of physical parameters (``a = ["k/m", "c/m"]``), those
        parameters where the coefficients determine them (see ``physical``).
    stderr : dict or None
        Standard errors of the fitted coefficients (see `AlgebraicEstimator`); None with
        ``stderr_reason`` when they cannot be given honestly.
    stderr_reason : str or None
    derived_stderr : dict or None
        Standard errors of ``derived`` by the delta method from ``final_covariance``; None
        whenever ``stderr`` is None.
    final_covariance : ndarray (len(names), len(names)) or None
        Covariance of the final estimate (SI, ordered like ``names``; its diagonal is
        ``stderr``²); None whenever ``stderr`` is None.
    physical : dict or None
        For a model in physical terms, `PhysicalParameters.to_dict` of the final estimate:
        ``values``, ``stderr``, ``identifiable``, ``unidentifiable``, ``combinations`` and
        ``message`` (which, when physical parameters are not identifiable, also ends
        ``message``); None for other models.
    units : dict
        name -> unit of ``parameters`` and ``derived``.
    settings : dict
        Every `AlgebraicSettings` value used, and ``dt`` [s].
    model : LinearODEModel
        The model fitted (not written by ``to_dict``; ``model_name`` is).
    fit_percent : float
        Output-error fit ``100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖)`` of the identified model on the fitted
        record (NaN when not computed).
    """

    t: np.ndarray
    estimates: np.ndarray
    names: tuple[str, ...]
    valid: np.ndarray
    level: np.ndarray
    parameters: dict[str, float]
    success: bool
    message: str
    valid_fraction: float
    known: dict[str, float] = field(default_factory=dict)
    window: float = float("nan")
    mu: int = 0
    integration: str = "exact"
    block: int = 1
    derived: dict[str, float] = field(default_factory=dict)
    stderr: dict[str, float] | None = None
    stderr_reason: str | None = None
    derived_stderr: dict[str, float] | None = None
    final_covariance: np.ndarray | None = None
    physical: dict | None = None
    units: dict[str, str] = field(default_factory=dict)
    settings: dict[str, Any] = field(default_factory=dict)
    model_name: str = ""
    fit_percent: float = float("nan")
    model: Any = field(default=None, repr=False, compare=False)

    method = "algebraic"
    _history_fields = ("t", "estimates", "valid", "level")
    _private_fields = ("model",)

    def series(self, name: str) -> np.ndarray:
        """Per-time estimate of one coefficient (or, for the MSD, ``natural_frequency`` /
        ``damping_ratio``); a known coefficient gives a constant array."""
        if name in self.names:
            return self.estimates[:, self.names.index(name)].copy()
        if name in self.known:
            return np.full(self.t.size, self.known[name])
        if name in ("natural_frequency", "damping_ratio") and {"theta1", "theta2"} <= (
            set(self.names) | set(self.known)
        ):
            omega0, zeta = natural_frequency_damping(self.series("theta1"), self.series("theta2"))
            return omega0 if name == "natural_frequency" else zeta
        raise InputError(f"no series {name!r}; available: {list(self.names) + list(self.known)}.")

    def plot(
        self,
        names: Sequence[str] | None = None,
        truth: Mapping[str, float] | None = None,
        ax=None,
    ):
        """Estimates against time with the invalid windows shaded; returns the Figure.

        A model in physical terms (``msd-force``: m, c, k) shows those parameters over time
        with their final value and 95 % interval (`physid.report.physical.plot_physical`);
        give ``names`` to plot coefficients instead.

        Parameters
        ----------
        names : sequence of str, optional
            Series to draw (default: ω0 and ζ for the MSD, else the fitted names).
        truth : mapping, optional
            True values drawn as dashed lines.
        ax : matplotlib Axes, optional
            Draw the first series into this axes instead of a new figure.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from ...report.algebraic import plot_algebraic

        if ax is None and names is None and (self.physical or {}).get("identifiable"):
            from ...report.physical import plot_physical  # the m, c, k the model declares

            return plot_physical(self, truth=truth, title="algebraic estimator (sliding windows)")
        if ax is None:
            return plot_algebraic(self, names=names, truth=truth)
        return plot_algebraic(self, names=names, truth=truth, ax=ax)


def _make_result(
    plan: _Plan,
    t,
    theta,
    valid,
    level,
    final_fraction: float,
    final_rule: str,
    equations=None,
    *,
    model=None,
    settings: AlgebraicSettings | None = None,
    signals=None,
) -> AlgebraicResult:
    """The result of the per-window estimates: the final estimate, its uncertainty and verdict."""
    exists = np.isfinite(level)
    valid_fraction = float(valid[exists].mean()) if exists.any() else 0.0
    tail = t >= t[-1] - final_fraction * (t[-1] - t[0])
    estimate = _final_estimate(plan, t, theta, valid, level, tail, final_rule, equations)
    checks = None
    if signals is not None:
        checks = (
            lambda model, values: _training_fit(model, values, signals, tail),
            lambda model, values: linear_ode_problems(model, values, *signals),
        )
    return _assemble(
        plan, (t, theta, valid, level), valid_fraction, estimate, checks, model, settings
    )


def _assemble(plan: _Plan, history, valid_fraction: float, estimate, checks, model, settings):
    """The `AlgebraicResult` of a final estimate ``(final, condition, stderr, stderr_reason,
    covariance)``: its verdict, with ``checks = (training fit, gate problems)`` (callables of the
    model and every coefficient's value; None: not run), derived quantities and units."""
    t, theta, valid, level = history
    names = plan.names
    final, condition, stderr, stderr_reason, cov_final = estimate
    success, message = _window_verdict(final, condition, valid_fraction)
    if final is None:
        final = np.full(len(names), np.nan)
    params = {k: float(v) for k, v in zip(names, final, strict=True)}
    known = dict(plan.known)
    model = as_linear_ode_model(model if model is not None else "msd")
    success, message, fit = _model_verdict(
        model, {**known, **params}, names, checks, success, message
    )
    if success and checks is not None:
        success, message = gate(success, message, checks[1](model, {**known, **params}))
    if not success:
        stderr, stderr_reason = None, stderr_reason or "no trustworthy estimate"
    if stderr is None:
        cov_final = None  # withheld with the standard errors (stderr_reason)
    derived, derived_stderr, derived_units, physical = derived_with_stderr(
        model, {**known, **params}, names, cov_final
    )
    if success and physical_statement(physical):
        message = f"{message} {physical_statement(physical)}".strip()
    units = {**coefficient_units(model, names), **derived_units}
    return AlgebraicResult(
        t=t,
        estimates=theta,
        names=names,
        valid=valid,
        level=level,
        parameters=ParameterDict(params, derived),
        success=success,
        message=message,
        valid_fraction=valid_fraction,
        known=known,
        window=plan.window,
        mu=plan.nus[0],
        integration=plan.rule,
        block=plan.block,
        derived=derived,
        stderr=stderr,
        stderr_reason=None if stderr is not None else stderr_reason,
        derived_stderr=derived_stderr,
        final_covariance=cov_final,
        physical=physical,
        units=units,
        settings={**(settings or AlgebraicSettings()).as_dict(), "dt": plan.dt},
        model_name=model.name,
        fit_percent=fit,
        model=model,
    )


def _final_estimate(plan: _Plan, t, theta, valid, level, tail, final_rule: str, equations):
    """The final estimate from the full windows in ``tail``, by ``final_rule``.

    Returns (final in SI units or None when no window qualifies, condition number of the pooled
    system (NaN for the median), stderr dict or None, stderr_reason, covariance or None).
    """
    full = np.zeros(t.size, dtype=bool)
    full[plan.span :] = True
    use = valid & full & tail
    if final_rule == "bias-compensated" and use.any():
        # every full window enters: selecting windows by their noisy determinant (the guard) or
        # by their own estimate (the screen) biases the pooled estimate at low SNR; the pooled
        # least squares weighs a flat window by its small information anyway
        use = full & tail & np.isfinite(level) & np.isfinite(theta).all(axis=1)
    if not use.any():
        return None, float("nan"), None, "no valid window", None
    if final_rule == "median":
        reason = "final='median' has no standard error model; use final='lstsq' for standard errors"
        return np.median(theta[use], axis=0), float("nan"), None, reason, None
    # every full window with a finite estimate: the windows of the bias-compensated reference
    every = full & tail & np.isfinite(level) & np.isfinite(theta).all(axis=1)
    return _pooled_final(plan, t, theta, use, every, final_rule, equations)


def _pooled_final(plan: _Plan, t, theta, use, every, final_rule: str, equations):
    """Pooled least squares over the equations of the windows in ``use`` (after the 5-MAD
    screen), with its standard errors; returns as `_final_estimate`."""
    # Screen first: a window whose own estimate lies beyond 5 robust standard deviations
    # (1.4826 MAD) of the median is an outlier (e.g. it straddles a jump of the input,
    # where the local interpolant of the exact rule breaks); pooling would let it bias
    # the result, the median would not.
    med = np.median(theta[use], axis=0)
    spread = 1.4826 * np.median(np.abs(theta[use] - med), axis=0)
    bound = (np.inf if final_rule == "bias-compensated" else 5.0) * spread + 1e-12 * np.abs(med)
    close = np.all(np.abs(theta - med) <= bound, axis=1, where=use[:, None])
    use = use & close
    # pooled least squares over every equation of the used windows (dimensionless
    # unknowns α, then back to SI): Σ AᵀA α = Σ Aᵀ r
    A, rhs = equations
    A = A[:, :, -t.size :][:, :, use]
    rhs = rhs[:, -t.size :][:, use]
    G = np.einsum("epw,eqw->pq", A, A)
    h = np.einsum("epw,ew->p", A, rhs)
    alpha = np.linalg.lstsq(G, h, rcond=None)[0]
    if final_rule == "bias-compensated":
        alpha, G = _bias_compensated(plan, A, rhs, G, h, alpha)
    final = _offset_to_value(plan, alpha * _unscale(plan))
    condition = _equilibrated_condition(G)
    stderr, stderr_reason, cov_final = _pooled_stderr(plan, A, rhs, alpha, np.flatnonzero(use), G)
    if stderr is not None and ("o", 0) in plan.columns:
        _offset_stderr(plan, final, stderr, cov_final)
    if stderr is not None and final_rule == "lstsq":
        stderr, stderr_reason = _withhold_if_biased(plan, equations, t, every, final, stderr)
    return final, condition, stderr, stderr_reason, cov_final


def _offset_stderr(plan: _Plan, final, stderr, cov_final) -> None:
    """Turn the standard error and covariance of δ = a_0 o into those of o (in place)."""
    # se(o) ≈ se(δ)/|a_0| (the relative error of a_0 is far smaller)
    name = plan.names[plan.columns.index(("o", 0))]
    a0 = abs(final[plan.columns.index(("a", 0))] if ("a", 0) in plan.columns else plan.known_a[0])
    stderr[name] = float(stderr[name] / a0) if a0 > 0 else float("nan")
    k = plan.columns.index(("o", 0))  # the same scaling of its row and column
    cov_final[k, :] /= a0 if a0 > 0 else np.nan
    cov_final[:, k] /= a0 if a0 > 0 else np.nan


def _window_verdict(final, condition: float, valid_fraction: float) -> tuple[bool, str]:
    """Success and message from the windows alone (``final`` None: no valid full window)."""
    if final is None:
        return False, (
            "no valid full window: the determinant of every window system is small or zero. "
            "Check that the input excites the system, lengthen the window, raise block, or relax "
            "the guard."
        )
    message = ""
    if valid_fraction < 0.5:
        message = (
            f"only {valid_fraction:.0%} of the windows passed the determinant guard; lengthen "
            "the window, raise block, or excite the system more richly."
        )
    if not np.all(np.isfinite(final)):
        return False, "the pooled least-squares system is singular; use final='median'."
    if np.isfinite(condition) and condition > MAX_CONDITION:
        return False, (
            f"the pooled window system is ill-conditioned (condition number {condition:.1e} > "
            f"{MAX_CONDITION:.0e}), so rounding decides the estimate: lower mu, lengthen the "
            "window, or excite the system more richly."
        )
    return True, message


def _model_verdict(model, values, names, checks, success: bool, message: str):
    """Success, message and training fit [%] after the identified model's own checks: finite
    derived quantities and an output-error fit (``checks[0]``) of at least `MIN_FIT_PERCENT`."""
    derived, _, _, _ = derived_with_stderr(model, values, names)
    if success and not all(np.isfinite(v) for v in derived.values()):
        success = False
        message = (
            "a derived quantity is not finite (for the MSD: θ2 ≤ 0 gives no natural frequency); "
            "check the excitation and the sign conventions of u and x."
        )
    fit = float("nan")
    if success and checks is not None:
        fit = checks[0](model, values)
        if np.isfinite(fit) and fit < MIN_FIT_PERCENT:
            success = False
            message = (
                f"the identified model explains almost nothing of the output (fit {fit:.1f} % "
                f"< {MIN_FIT_PERCENT:g} %, 100·(1 − ‖y − ŷ‖/‖y − ȳ‖) on the fitted record): the "
                "data look like noise, or the input does not drive the output. Check the channels "
                "and the excitation."
            )
    return success, message, fit


#: Below this output-error fit [%] on the fitted record the model "explains nothing": pure noise
#: gives about 0 %, an output with white noise at 0 dB SNR 29 %, at 10 dB 68 %.
MIN_FIT_PERCENT = 10.0


def _training_fit(model, values, signals, tail) -> float:
    """Output-error fit [%] of the model on the part of the record the final estimate used."""
    t, u, y = signals
    sel = np.flatnonzero(tail)
    if sel.size < 2 * model.order + 2:
        return float("nan")
    t, u, y = t[sel], u[sel], y[sel]
    y_hat, _ = simulate_prediction(model, values, t, u, y)
    if not np.all(np.isfinite(y_hat)):
        return float("nan")
    spread = float(np.linalg.norm(y - y.mean()))
    if spread == 0.0:
        return float("nan")
    return 100.0 * (1.0 - float(np.linalg.norm(y - y_hat)) / spread)
