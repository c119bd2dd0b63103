"""The result of an input-error fit (`InputErrorResult`).

Part of `physid.estimators.input_error`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from ..results import ResultMixin


@dataclass(frozen=True)
class InputErrorResult(ResultMixin):
    """Estimates of an input-error fit and everything needed to judge and plot them.

    Attributes
    ----------
    parameters : dict name -> float
        Estimates (SI units), fixed parameters included at their held values.
    stderr : dict name -> float
        Standard errors (``uncertainty="hac"``: the sandwich with the filtered residual's
        autocorrelation, `sandwich_covariance`; ``"iid"``: ``s² (JᵀJ)⁻¹``). ``NaN`` for fixed
        parameters and for parameters that ended on a bound, ``inf`` along numerically
        unidentifiable directions. They describe the scatter, not the errors-in-variables bias
        of noisy q; see ``docs/input-error.md``.
    correlation : ndarray, shape (n_free, n_free)
        Correlation matrix of the free parameters (order: `free`).
    free : tuple of str
        The estimated parameters.
    cost : float [N²·m²]
        The paper's J at the estimate.
    nfev, njev : int
        Residual and Jacobian evaluations of the main fit.
    success : bool
    message : str
    history : ndarray, shape (nfev, n_params)
        Every parameter at every residual evaluation (columns: `parameter_names`).
    cost_history : ndarray, shape (nfev,)
        J at every residual evaluation.
    parameter_names : tuple of str
    unidentifiable : tuple of str
        Combinations the data cannot separate, e.g. ``("m1*l1**2",)``.
    unidentifiable_text : tuple of str
        The same in words, e.g. ``("m1 and l1 enter only as m1*l1**2",)``.
    combinations : dict expression -> float
        Value of each unidentifiable combination at the estimate (this is what is identified).
    combination_stderr : dict expression -> float
    fixed : dict name -> float
        Parameters held fixed (by the user or by default). With ``parameter_set="base"``: the
        standard parameters outside the base set, at 0 (``τ = W_b β = Y θ`` for θ equal to β on
        the base columns and 0 elsewhere, so ``parameters`` and ``fixed`` together give the
        fitted torque through the model's inverse dynamics).
    initial : dict name -> float
        Starting values (after ``start="linear"``, the values the main fit started from).
    half_width : int
        M used (chosen from the data with ``cutoff="auto"``).
    cutoff : float [rad/sample]
        Ω_g used.
    filter_choice : str
        With ``cutoff="auto"``: which M and Ω_g were chosen and why (`choose_filter`); else "".
    noise_std : ndarray, shape (n_joints,) [rad]
        White-noise level on each q estimated from the top of its spectrum (`noise_floor`).
    dt : float [s]
    torque : str
        ``"measured"`` or ``"pd"``.
    derivatives : str
        ``"paper"`` or ``"consistent"``.
    start : str
    start_nfev : int
        Evaluations of the cheap linear-start problem (0 for ``start="initial"``).
    condition_number : float
        Of the column-scaled Jacobian of the free parameters at the estimate.
    singular_values : ndarray
        Relative singular values of that Jacobian.
    filter_passband_edge : float [rad/sample]
    filter_energy_fraction : ndarray, shape (n_joints,)
        See `filter_band_check`.
    relative_residual : ndarray, shape (n_joints,)
        ``rms(τ̂ - τ^f) / rms(τ^f)`` per joint at the estimate: how well the filtered equations of
        motion balance (a `FilterWarning` is raised above ``RESIDUAL_WARN``).
    warnings : tuple of str
    at_bound : tuple of str
        Free parameters that ended on a bound (`BoundWarning`; their ``stderr`` is NaN and
        ``success`` is False).
    uncertainty : str
        ``"hac"`` or ``"iid"``: how ``stderr`` was computed.
    hac_lags : int [samples]
        Flat part of the HAC kernel (`hac_lags`: 2M).
    stderr_iid : dict name -> float
        The iid standard errors ``s² (JᵀJ)⁻¹``, for comparison.
    noise : str
        ``"ignore"`` or ``"compensate"``: what the fit did (``noise="auto"`` resolved; see
        `InputErrorEstimator`).
    noise_shift : dict name -> float
        With ``noise="compensate"``: compensated minus plain least-squares estimate of each free
        parameter (the errors-in-variables bias removed); else empty.
    t : ndarray, shape (n_valid,) [s]
        Times of the valid (filtered) samples.
    residuals : ndarray, shape (n_valid, n_joints) [N·m]
        ``τ̂ - τ^f`` at the estimate.
    units : dict name -> str
        Units of the parameters.
    parameter_set : str
        ``"model"``: the model's own parameters were fitted; ``"base"``: the base parameters of
        a model linear in its parameters (``parameters="base"``), named by their leading
        standard parameter (as in IDIM's results).
    base_expressions : dict name -> str
        With ``parameter_set="base"``: each base parameter as a combination of the standard
        ones (``"ZZ1 + ..."``); else empty.
    """

    parameters: dict[str, float]
    stderr: dict[str, float]
    correlation: np.ndarray
    free: tuple[str, ...]
    cost: float
    nfev: int
    njev: int
    success: bool
    message: str
    history: np.ndarray
    cost_history: np.ndarray
    parameter_names: tuple[str, ...]
    unidentifiable: tuple[str, ...]
    unidentifiable_text: tuple[str, ...]
    combinations: dict[str, float]
    combination_stderr: dict[str, float]
    fixed: dict[str, float]
    initial: dict[str, float]
    half_width: int
    cutoff: float
    filter_choice: str
    noise_std: np.ndarray
    dt: float
    torque: str
    derivatives: str
    start: str
    start_nfev: int
    condition_number: float
    singular_values: np.ndarray
    filter_passband_edge: float
    filter_energy_fraction: np.ndarray
    relative_residual: np.ndarray
    warnings: tuple[str, ...]
    at_bound: tuple[str, ...]
    uncertainty: str
    hac_lags: int
    stderr_iid: dict[str, float]
    noise: str
    noise_shift: dict[str, float]
    t: np.ndarray = field(repr=False)
    residuals: np.ndarray = field(repr=False)
    units: dict[str, str] = field(default_factory=dict)
    parameter_set: str = "model"
    base_expressions: dict[str, str] = field(default_factory=dict)

    method = "input-error"
    _history_fields = ("history", "cost_history", "t", "residuals")

    @property
    def names(self) -> tuple[str, ...]:
        """The fitted (free) parameters (the result schema's ``names``; also ``free``)."""
        return self.free

    @property
    def derived(self) -> dict[str, float]:
        """Derived quantities: the identified combinations (expression -> value)."""
        return dict(self.combinations)

    @property
    def stderr_reason(self) -> str | None:
        """None: input-error always reports (nominal) standard errors, see ``stderr``."""
        return None

    def summary(self) -> str:
        """Estimates with standard errors, J, evaluations and the identifiability findings."""
        lines = [super().summary()]
        lines.append(
            f"  J = {self.cost:.6g}  ({self.nfev} residual / {self.njev} Jacobian evaluations)"
        )
        pairs = zip(self.unidentifiable_text, self.combinations.items(), strict=False)
        for text, (expr, value) in pairs:
            lines.append(f"  {text}: {expr} = {value:.8g}")
        if self.fixed:
            lines.append("  fixed: " + ", ".join(f"{k}={v:g}" for k, v in self.fixed.items()))
        return "\n".join(lines)

    def plot(self, truth: Mapping[str, float] | None = None):
        """Parameter histories and residuals (see `physid.report.manipulator.plot_input_error`)."""
        from . import _plot_result  # the one lazy upward import lives in the package module

        return _plot_result(self, truth)
