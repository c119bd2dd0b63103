"""`RecursiveLeastSquares`: the recursive estimator fitted to a recording."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..._validate import check_positive
from ...errors import EstimationError, IdentifiabilityError, InputError, arg
from ...models.linear_ode import LinearODEModel, as_linear_ode_model, natural_frequency_damping
from .._linear import (
    check_distinct_channels,
    check_distinct_signals,
    check_known_finite,
    coefficient_units,
    derived_with_stderr,
    physical_statement,
)
from .._regression import check_excitation
from ..base import EstimatorMixin
from ..plausibility import check_magnitude, gate, linear_ode_problems
from ..results import ParameterDict
from .batch import _check_forgetting, _check_init_samples, _first_invertible_row, weighted_ls_path
from .online import StreamingRecursiveEstimator
from .regression import _offset_to_value, build_regression
from .result import MIN_FIT_PERCENT, RecursiveResult, _jsonable_settings, _training_fit
from .uncertainty import (
    _final_covariance,
    final_uncertainty,
)


def _nominal_of(spec: LinearODEModel, names: Sequence[str]) -> np.ndarray:
    """Nominal values of the unknowns ``names`` (NaN where the model has none)."""
    out = []
    for name in names:
        try:
            out.append(float(spec.parameters[name]))
        except (KeyError, TypeError, ValueError):
            out.append(np.nan)
    return np.array(out)


class RecursiveLeastSquares(EstimatorMixin):
    """Recursive least squares with forgetting for linear ODE models (paper section 3).

    Parameters
    ----------
    model : "msd" or LinearODEModel
    forgetting : float in (0, 1], default 1
        λ; 1 weighs all rows equally.
    weight : float > 0, default 1
        R, the noise variance assumed per row (scales P, not θ̂).
    prefilter : {"butterworth", "differential"}
        Causal Butterworth state-variable filter (default) or the project's non-causal FIR
        differential filters (order ≤ 2, batch only).
    prefilter_cutoff : float, optional [Hz]
        Default `default_prefilter_cutoff` (10× the model's nominal frequency, ≤ f_s/10).
    init_samples : int, optional
        Rows of the OLS start (eq. 4), default 10 p.
    unknown : sequence of str, optional
        Coefficients to estimate (default the model's ``unknown`` less the names in ``known``;
        MSD: theta1, theta2).
    known : mapping, optional
        Values of the other coefficients (default nominal; MSD: b0 = 1).
    prefilter_order : int, optional
        Butterworth order, ≥ n + 1 (default n + 1).
    covariance : {"full", "diagonal"}
        Store P per sample as (n, p, p) (8 p² bytes per sample: 32 MB for 1e6 samples and p = 2)
        or only its diagonal.
    transient_samples : int, optional
        Samples dropped at the start before the first row. Default: the SVF start-up rule
        (`svf_transient_samples`, 240 samples at 18.4 Hz and 1 kHz). Pass 0 when the record starts
        at rest (u, y and their derivatives zero), where the filter's zero state is already right.
    bias_compensation : bool, default False
        Remove the errors-in-variables bias that white noise on the measured output causes
        (`_bias_compensated_ls`) from the *final* estimate (the per-sample history is unchanged).
        Without it, where that bias exceeds half a standard error (e.g. the paper's MSD at 30 dB)
        the result gives no standard errors and says why.

    Examples
    --------
    >>> from scipy import signal
    >>> from physid import Recording
    >>> t = np.arange(4000) * 1e-3
    >>> u = np.sin(10 * t)
    >>> x = signal.lsim(([1.0], [1.0, 2.0, 100.0]), u, t)[1]
    >>> est = RecursiveLeastSquares("msd").fit(Recording(t, np.c_[u, x], ["u", "x"]))
    >>> round(est.result_.derived["natural_frequency"], 2)
    10.0
    """

    def __init__(
        self,
        model="msd",
        *,
        forgetting: float = 1.0,
        weight: float = 1.0,
        prefilter: str = "butterworth",
        prefilter_cutoff: float | None = None,
        init_samples: int | None = None,
        unknown: Sequence[str] | None = None,
        known: Mapping[str, float] | None = None,
        prefilter_order: int | None = None,
        covariance: str = "full",
        transient_samples: int | None = None,
        bias_compensation: bool = False,
    ):
        self.model = model
        self.forgetting = forgetting
        self.weight = weight
        self.prefilter = prefilter
        self.prefilter_cutoff = prefilter_cutoff
        self.init_samples = init_samples
        self.unknown = unknown
        self.known = known
        self.prefilter_order = prefilter_order
        self.covariance = covariance
        self.transient_samples = transient_samples
        self.bias_compensation = bias_compensation

    def fit(self, recording) -> RecursiveLeastSquares:
        """Estimate the unknowns at every sample of ``recording``.

        The channels are the model's ``input_name`` and ``output_name`` (the MSD: ``u`` and ``x``;
        an output ``x`` or ``y`` is accepted as a fallback, as by the algebraic estimator).
        """
        lam = _check_forgetting(self.forgetting)
        r = check_positive(self.weight, "weight")
        if self.covariance not in ("full", "diagonal"):
            raise InputError(f"covariance must be 'full' or 'diagonal'; got {self.covariance!r}.")
        spec, in_name, out_name = self._channels(recording)
        check_magnitude((recording[in_name], recording[out_name]), (in_name, out_name))
        dt = recording.dt
        reg = build_regression(
            spec,
            recording[out_name],
            recording[in_name],
            dt,
            unknown=self.unknown,
            known=self.known,
            prefilter=self.prefilter,
            prefilter_cutoff=self.prefilter_cutoff,
            prefilter_order=self.prefilter_order,
            discard=self.transient_samples,
        )
        M = self._start_row(spec, reg, r)
        theta_rows, P_rows, ok_rows = weighted_ls_path(
            reg.X, reg.Y, forgetting=lam, weight=r, init_end=M, covariance=self.covariance
        )
        estimates, cov = _histories(spec, reg, recording.n_samples, theta_rows, P_rows)
        last = np.flatnonzero(ok_rows)[-1]
        sigma2, white_cov = _final_covariance(reg.X, reg.Y, theta_rows[last], M, last, lam)
        theta_final, cov_final, stderr, stderr_reason, stderr_method = final_uncertainty(
            reg,
            spec,
            theta_rows[last],
            M,
            last,
            lam,
            dt,
            known=self.known,
            prefilter=self.prefilter,
            prefilter_order=self.prefilter_order,
            bias_compensation=self.bias_compensation,
        )
        theta_final, stderr, cov_final = _offset_to_si(
            spec, reg.names, theta_final, stderr, cov_final
        )
        fitted = {nm: float(theta_final[i]) for i, nm in enumerate(reg.names)}
        values = dict(spec.parameters)
        values.update(self.known or {})
        known_values = {k: float(v) for k, v in values.items() if k not in reg.names}
        known_values = {k: v for k, v in known_values.items() if k in spec.coefficient_names}
        lost = int(np.count_nonzero(~ok_rows[M:]))
        success, message, fit = self._checked_verdict(
            spec, {**known_values, **fitted}, reg.names, recording, (in_name, out_name), lost
        )
        if not success:
            stderr, stderr_reason = None, "no trustworthy estimate"
        cov_final = None if stderr is None else np.array(cov_final, dtype=float)
        self.result_ = self._result(
            recording,
            spec,
            reg,
            estimates=estimates,
            cov=cov,
            values=values,
            fitted=fitted,
            known_values=known_values,
            uncertainty=(stderr, stderr_reason, cov_final),
            verdict=(success, message, fit),
            init_end=int(reg.sample_index[M]),
            rates=(lam, r),
            metadata=_metadata(reg, sigma2, white_cov, stderr_method),
        )
        self.regression_ = reg
        return self

    @staticmethod
    def _checked_verdict(spec, values, names, recording, channels, lost):
        """The fit's verdict (`_verdict`), then the plausibility gate on a success."""
        success, message, fit = _verdict(spec, values, names, recording, channels, lost)
        if success:
            in_name, out_name = channels
            problems = linear_ode_problems(
                spec, values, recording.t, recording[in_name], recording[out_name]
            )
            success, message = gate(success, message, problems)
        return success, message, fit

    def _channels(self, recording) -> tuple[LinearODEModel, str, str]:
        """The model and the recording's input and output channel names, checked."""
        spec = as_linear_ode_model(self.model)
        names = getattr(recording, "names", None)
        if names is None:
            raise InputError(f"fit expects a Recording; got {type(recording).__name__}.")
        in_name, out_name = spec.recording_channels(names)
        spec.check_units(recording)  # a force [N] for the normalised msd is an error
        check_distinct_channels(in_name, out_name)
        check_known_finite(self.known)
        check_distinct_signals(recording[in_name], recording[out_name])
        return spec, in_name, out_name

    def _start_row(self, spec: LinearODEModel, reg, r: float) -> int:
        """Index M of the last row of the OLS start (eq. 4), after checking that the rows are
        enough and excite every unknown."""
        p = len(reg.names)
        init = _check_init_samples(self.init_samples, p)
        n_rows = reg.X.shape[0]
        if n_rows < max(init, p):
            raise EstimationError(
                f"the regression has {n_rows} rows after the {reg.discarded}-sample pre-filter "
                f"transient but needs at least {max(init, p)} ({arg('init_samples')}, >= {p} "
                f"unknowns). Use a longer record, fewer {arg('init_samples')} (>= {p}) or a higher "
                f"{arg('prefilter_cutoff')} [Hz] (a shorter transient)."
            )
        check_excitation(reg.X, reg.names, reg.Y, _nominal_of(spec, reg.names))
        M = _first_invertible_row(reg.X, r, init)
        if M is None:  # pragma: no cover - check_excitation catches this first
            raise IdentifiabilityError("the regressors never determine all unknowns.")
        return M

    def _result(
        self,
        recording,
        spec: LinearODEModel,
        reg,
        *,
        estimates,
        cov,
        values,
        fitted,
        known_values,
        uncertainty,
        verdict,
        init_end: int,
        rates: tuple[float, float],
        metadata,
    ) -> RecursiveResult:
        """The `RecursiveResult` of a fit, with the derived quantities and their errors."""
        stderr, stderr_reason, cov_final = uncertainty
        success, message, fit = verdict
        omega0, zeta = _msd_series(spec, reg.names, estimates, values)
        derived, derived_stderr, derived_units, physical = derived_with_stderr(
            spec, {**known_values, **fitted}, reg.names, cov_final
        )
        if success and physical_statement(physical):
            message = f"{message} {physical_statement(physical)}".strip()
        units = {**coefficient_units(spec, reg.names), **derived_units}
        return RecursiveResult(
            t=np.array(recording.t),
            estimates=estimates,
            covariance=cov,
            names=reg.names,
            parameters=ParameterDict(fitted, derived),
            stderr=stderr,
            natural_frequency=omega0,
            damping_ratio=zeta,
            valid_fraction=float(np.mean(np.all(np.isfinite(estimates), axis=1))),
            forgetting=rates[0],
            weight=rates[1],
            prefilter=self.prefilter,
            prefilter_cutoff=reg.cutoff,
            discarded=reg.discarded,
            init_end=init_end,
            success=success,
            message=message,
            metadata=metadata,
            derived=derived,
            stderr_reason=stderr_reason,
            derived_stderr=derived_stderr,
            final_covariance=cov_final,
            physical=physical,
            units=units,
            known=known_values,
            settings={**_jsonable_settings(self.get_params()), "dt": float(recording.dt)},
            model_name=spec.name,
            fit_percent=fit,
            model=spec,
        )

    # parity with the algebraic estimator's result attributes, for the CLI
    @property
    def valid_fraction(self) -> float:
        return self.result_.valid_fraction

    def stream(self, dt: float, *, t_start: float = 0.0) -> StreamingRecursiveEstimator:
        """An online form of `fit` fed raw ``(u, y)`` chunks: see `StreamingRecursiveEstimator`.

        Parameters
        ----------
        dt : float [s]
            Sample period of the stream.
        t_start : float [s], default 0
            Time of the first sample.
        """
        return StreamingRecursiveEstimator(self, dt, t_start=t_start)


def _metadata(reg, sigma2: float, white_cov, stderr_method: str) -> dict:
    """The result's ``metadata``: rows, residual variance and how the standard errors came."""
    return {
        "rows": int(reg.X.shape[0]),
        "residual_variance": sigma2,
        # the white-row sandwich (the stderr before the output-noise model; kept for
        # comparison: it overstates the spread 6-10x on SVF-filtered data)
        "stderr_white_rows": {
            nm: float(np.sqrt(max(white_cov[i, i], 0.0))) for i, nm in enumerate(reg.names)
        },
        "stderr_method": stderr_method,
    }


def _histories(spec: LinearODEModel, reg, n: int, theta_rows, P_rows):
    """Per-sample estimates (SI, NaN outside the rows) and P (full or diagonal) of ``n`` samples."""
    p = len(reg.names)
    estimates = np.full((n, p), np.nan)
    estimates[reg.sample_index] = _offset_to_value(spec, reg.names, theta_rows)
    cov = np.full((n,) + P_rows.shape[1:], np.nan)
    cov[reg.sample_index] = P_rows
    return estimates, cov


def _offset_to_si(spec: LinearODEModel, names, theta, stderr, cov):
    """The final estimate with the offset column δ = a_0 o turned into o, and its standard error
    and covariance row and column scaled alike (copies)."""
    theta_si = _offset_to_value(spec, names, theta)
    if stderr is not None and len(theta_si) and not np.array_equal(theta_si, theta):
        k = [i for i in range(len(names)) if theta_si[i] != theta[i]][0]
        a0 = theta[k] / theta_si[k] if theta_si[k] != 0 else np.nan
        stderr[names[k]] = float(stderr[names[k]] / abs(a0))
        cov = np.array(cov, dtype=float, copy=True)
        cov[k, :] /= a0  # δ = a0·o: o's row and column scale by 1/a0 (signed)
        cov[:, k] /= a0
    return theta_si, stderr, cov


def _msd_series(spec: LinearODEModel, names, estimates, values):
    """Per-sample natural frequency and damping ratio of an MSD-form model (None, None else)."""
    if not spec.is_msd:
        return None, None
    th1 = (
        estimates[:, names.index("theta1")]
        if "theta1" in names
        else np.where(np.isnan(estimates[:, 0]), np.nan, values["theta1"])
    )
    th2 = (
        estimates[:, names.index("theta2")]
        if "theta2" in names
        else np.where(np.isnan(estimates[:, 0]), np.nan, values["theta2"])
    )
    return natural_frequency_damping(th1, th2)


def _verdict(spec: LinearODEModel, values, names, recording, channels, lost: int, fit_of=None):
    """Success, message and training fit [%] of the final estimate ``values`` (every
    coefficient): finite, explaining the output, and with ``lost`` rows without information.
    ``fit_of`` (no arguments → fit [%]) replaces `_training_fit` of ``recording`` (a record read
    in blocks)."""
    fitted = {nm: values[nm] for nm in names}
    derived, _, _, _ = derived_with_stderr(spec, values, names)
    finite = all(np.isfinite(v) for v in [*fitted.values(), *derived.values()])
    fit = float("nan")
    if finite:
        fit = fit_of() if fit_of is not None else _training_fit(spec, values, recording, *channels)
    if not finite:
        return (
            False,
            (
                "the final estimate is not finite (for the MSD: θ2 ≤ 0 gives no natural "
                "frequency); check the excitation and the sign conventions of u and x."
            ),
            fit,
        )
    if np.isfinite(fit) and fit < MIN_FIT_PERCENT:
        return (
            False,
            (
                f"the identified model explains almost nothing of the output (fit {fit:.1f} % "
                f"< {MIN_FIT_PERCENT:g} %, 100·(1 − ‖y − ŷ‖/‖y − ȳ‖) on the fitted record): "
                "the data look like noise, or the input does not drive the output. Check the "
                "channels and the excitation."
            ),
            fit,
        )
    if lost:
        return (
            True,
            (
                f"{lost} sample(s) after the start had no usable information (λ < 1 without "
                "excitation); their estimates are NaN. Raise forgetting or keep exciting the "
                "system."
            ),
            fit,
        )
    return True, "", fit
