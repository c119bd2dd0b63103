"""The result of an input-error fit (`InputErrorResult`).

Part of `physid.estimators.input_error`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ...errors import InputError
from ..results import ResultMixin


@dataclass(frozen=True)
class InputErrorResult(ResultMixin):
    """Estimates of an input-error fit and everything needed to judge and plot them.

    Attributes
    ----------
    parameters : dict name -> float
        Estimates (SI units), fixed parameters included at their held values.
    stderr : dict name -> float, or None
        None, with `stderr_reason`, when the filtered equations of motion do not balance and
        no measurement noise on q is seen to explain it (the cut-off below the motion; a model
        or data error): the estimate is then biased beyond its scatter. Otherwise standard
        errors (``uncertainty="hac"``: the sandwich with the filtered residual's
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
        Parameters held fixed (by the user or by default); empty with ``parameter_set="base"``
        (nothing is held: the base parameters are the model's identifiable combinations).
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
        a model linear in its parameters (``parameters="base"``), named as IDIM's results name
        them (`physid.estimators.idim.BaseInfo.names`): the kept regressor column, with an
        ``R`` when other columns are regrouped into it (``"ZZ1R"``). A model's ``params=``
        refuses such names, since they are not standard parameters: use `model_parameters`
        or `predict`.
    base_expressions : dict name -> str
        With ``parameter_set="base"``: each base parameter as a combination of the standard
        ones (``"ZZ1 + ..."``); else empty.
    stderr_reason : str or None
        Why `stderr` is None (and what to change); None when it is given.
    columns : tuple of str
        With ``parameter_set="base"``: the regressor column kept for each base parameter
        (``"ZZ1"`` for ``"ZZ1R"``), in the order of `free`; else empty.
    model : ChainModel or None
        The model fitted (used by `predict`; not written by ``to_dict``).
    """

    parameters: dict[str, float]
    stderr: dict[str, float] | None
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
    columns: tuple[str, ...] = ()
    stderr_reason: str | None = None
    model: Any = field(default=None, repr=False, compare=False)

    method = "input-error"
    _history_fields = ("history", "cost_history", "t", "residuals")
    _private_fields = ("model",)
    _unpicklable_fields = ("model",)  # compiled kernels (ctypes): pickled as None

    @property
    def names(self) -> tuple[str, ...]:
        """The fitted (free) parameters (the result schema's ``names``; also ``free``)."""
        return self.free

    @property
    def derived(self) -> dict[str, float]:
        """Derived quantities: the identified combinations (expression -> value)."""
        return dict(self.combinations)

    def model_parameters(self) -> dict[str, float]:
        """The model's own parameters that give the fitted torques, for ``params=``.

        Returns
        -------
        dict name -> float
            ``parameter_set="model"``: the estimates with the held parameters (``fixed``).
            ``parameter_set="base"``: each base value on its kept column (`columns`) and 0 on
            every other column, so that ``τ = Y θ = W_b β`` (every regrouped column's effect is
            in its base parameter). Not a physical parameter set (masses may be 0): a model to
            predict torques with, not one to read inertias from.
        """
        if self.parameter_set != "base":
            return {**self.fixed, **self.parameters}
        if self.model is None:
            raise InputError(
                "this base-parameter InputErrorResult holds no model, so the columns outside "
                "the base set are unknown; set them to 0 and each kept column (result.columns) "
                "to its base value."
            )
        theta = dict.fromkeys(self.model.parameter_names, 0.0)
        theta.update(
            {c: float(self.parameters[n]) for n, c in zip(self.free, self.columns, strict=True)}
        )
        return theta

    def predict(self, recording, *, measured: bool = False):
        """Torques the identified model predicts from a recording's motion.

        The recording's q goes through the fit's own filters (`half_width`, `cutoff`,
        `derivatives`) and the model's inverse dynamics is evaluated on ``q^f, q̇^f, q̈^f``
        with `model_parameters`: the prediction is ``τ̂`` on the *filtered* valid samples (the
        quantity the fit balanced against ``τ^f``), not at every input sample.

        Parameters
        ----------
        recording : Recording
            ``t`` [s] and ``q1..qn`` [rad | m], sampled like the fit's recording;
            ``tau1..taun`` are needed only with ``measured=True``.
        measured : bool
            Also return the recording's torques through the same low-pass filter, as channels
            ``tau1_measured..``.

        Returns
        -------
        Recording
            The filter's valid samples [s]; ``tau1..taun`` predicted [N·m | N] (and the measured
            ones); ``metadata`` records the filter settings and ``"prediction"``.

        Raises
        ------
        InputError
            The result holds no model (a result built by hand or unpickled), or the recording
            has another sample period than the fit.
        """
        from .prepare import predict_torque  # the filters live with the fit's preparation

        if self.model is None:
            raise InputError(
                "this InputErrorResult holds no model; call physid.estimators.input_error."
                "prepare.predict_torque(model, result.model_parameters(), recording, "
                "half_width=result.half_width, cutoff=result.cutoff) instead, or validate a "
                "saved result file (physid.analysis.validation.validate)."
            )
        return predict_torque(
            self.model,
            self.model_parameters(),
            recording,
            half_width=self.half_width,
            cutoff=self.cutoff,
            derivatives=self.derivatives,
            dt=self.dt,
            measured=measured,
        )

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
        """Parameter histories and residuals (see `physid.report.manipulator.plot_input_error`).

        The figure comes from physid.report, imported here, lazily: the one upward import of
        this package (pyproject.toml's import-linter ``ignore_imports`` names it).
        """
        from ...report.manipulator import plot_input_error

        return plot_input_error(self, truth=truth)
