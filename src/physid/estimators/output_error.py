"""Output-error identification of structures: simulate the model and fit its outputs.

What MATLAB's ``greyest``/``nlgreyest`` do for grey-box models: the parameters θ minimise
Σ_channels Σ_t ((y_sim(θ) − y)/s_c)², y_sim from `physid.simulate.structure` (exact for the
linear part, ``solve_ivp`` with cubic springs or friction), by `scipy.optimize.least_squares`
(trust-region reflective) over log θ (so masses, stiffnesses and dampings stay positive). Any
outputs will do: a subset of the nodes, velocities, accelerations. The start is the
equation-error estimate where the model allows it (every displacement measured, parameters
entering linearly), else the nominal values. The record must start at rest.

Weights and intervals: a first fit with s_c = the channel's spread, then a refit with s_c = the
channel's residual standard deviation, so that the residuals are white with unit variance when
the model is right and only the output sensors are noisy; the covariance is (JᵀJ)⁻¹ at the
optimum. When a force is measured with noise, the simulated outputs carry that noise filtered
by the structure (errors in variables): the residuals are no longer white and (JᵀJ)⁻¹ is too
narrow, so the intervals are withheld with the reason.
"""

from __future__ import annotations

import numpy as np

from ..errors import EstimationError, InputError, arg
from .base import EstimatorMixin
from .equation_error import (
    EquationErrorEstimator,
    StructureResult,
    _check_unknown,
    _structure,
    fit_percent,
    noise_report,
    record_arrays,
)

__all__ = ["OutputErrorEstimator"]


class OutputErrorEstimator(EstimatorMixin):
    """Output-error (simulation) estimator of a structure's physical parameters.

    Parameters
    ----------
    model : StructureModel or str
        Any outputs (displacements, velocities, accelerations; a subset of the nodes).
    unknown : sequence of str, optional
        Parameters to estimate (default the model's ``identify = true`` ones).
    initial : mapping, optional
        Start values (default: the equation-error estimate where possible, else nominal).
    max_evaluations : int
        Limit of simulations of `scipy.optimize.least_squares`.

    Attributes
    ----------
    result_ : StructureResult
        After `fit`; ``history`` holds nothing (the optimiser's path is not kept).
    """

    method = "output-error"

    def __init__(self, model, *, unknown=None, initial=None, max_evaluations=400):
        self.model = model
        self.unknown = unknown
        self.initial = initial
        self.max_evaluations = max_evaluations

    def _start(self, model, unknown, recording) -> tuple[dict, str]:
        if self.initial is not None:
            bad = [k for k in self.initial if k not in unknown]
            if bad:
                raise InputError(f"{arg('initial')} names {bad}, not among unknown {unknown}.")
            return {**{k: model.parameters[k] for k in unknown}, **self.initial}, "given"
        try:
            est = EquationErrorEstimator(model, unknown=unknown).fit(recording).result_
            start = dict(est.parameters)
            if all(v > 0 for v in start.values()):
                return start, "equation-error"
        except (EstimationError, InputError):
            pass
        return {k: model.parameters[k] for k in unknown}, "nominal values"

    def fit(self, recording):
        """Fit the simulated outputs to the recording's.

        Parameters
        ----------
        recording : Recording
            Forces and outputs, uniformly sampled, starting at rest.

        Returns
        -------
        self
        """
        from scipy.optimize import least_squares

        from ..simulate.structure import batch_outputs, structure_response

        model = _structure(self.model)
        unknown = _check_unknown(model, self.unknown)
        u, y, dt = record_arrays(model, recording)
        t = recording.t
        start, how = self._start(model, unknown, recording)
        nonpositive = [k for k, v in start.items() if not v > 0]
        if nonpositive:
            raise InputError(
                f"output-error fits log θ and needs positive start values; {nonpositive} are "
                f"not. Give {arg('initial')} or fix them (identify = false)."
            )
        known = {k: v for k, v in model.parameters.items() if k not in unknown}

        def simulate(x):
            params = {**known, **dict(zip(unknown, np.exp(x), strict=True))}
            return structure_response(model, t, u, params)[1]

        scale = np.std(y, axis=0)
        scale[scale == 0] = 1.0

        def residual(x, s):
            try:
                r = (simulate(x) - y) / s
            except (np.linalg.LinAlgError, ValueError, RuntimeError):
                return np.full(y.size, 1e6)
            return np.where(np.isfinite(r), r, 1e6).ravel()

        def jacobian(x, s):
            # central differences in log θ, every perturbed set simulated in one batch run
            step = 1e-6
            sets = []
            for j in range(x.size):
                for sign in (1.0, -1.0):
                    xj = x.copy()
                    xj[j] += sign * step
                    sets.append({**known, **dict(zip(unknown, np.exp(xj), strict=True))})
            ys = batch_outputs(model, t, u, sets) / s
            return ((ys[0::2] - ys[1::2]) / (2 * step)).reshape(x.size, -1).T

        x0 = np.log([start[k] for k in unknown])
        opts = {"max_nfev": self.max_evaluations, "jac": jacobian}
        sol = least_squares(residual, x0, args=(scale,), **opts)
        s2 = np.std((simulate(sol.x) - y), axis=0)  # reweight by the residual spread
        s2[s2 == 0] = 1.0
        sol = least_squares(residual, sol.x, args=(s2,), **opts)
        self.result_ = _result(model, unknown, sol, s2, known, u, y, dt, how)
        return self


def _result(model, unknown, sol, s2, known, u, y, dt, how) -> StructureResult:
    theta = np.exp(sol.x)
    params = dict(zip(unknown, map(float, theta), strict=True))
    noise, noisy, _ = noise_report(model, u, y, dt, {**known, **params})
    y_hat = (sol.fun.reshape(y.shape) * s2) + y
    fits = dict(zip(model.output_names, map(float, fit_percent(y, y_hat)), strict=True))
    J = sol.jac / theta[None, :]  # ∂r/∂θ = ∂r/∂log θ / θ
    dof = max(sol.fun.size - len(unknown), 1)
    sigma2 = float(sol.fun @ sol.fun) / dof
    cov = stderr = reason = None
    try:
        cov = sigma2 * np.linalg.inv(J.T @ J)
        stderr = dict(zip(unknown, map(float, np.sqrt(np.maximum(np.diag(cov), 0))), strict=True))
    except np.linalg.LinAlgError:
        reason = "the Jacobian is singular at the optimum (parameters not determined by the data)"
    messages = [f"output-error from {how}: {sol.message}"]
    ident = model.identifiability(unknown)
    success = bool(sol.success) and not ident.unidentifiable and all(np.isfinite(theta))
    if ident.unidentifiable:
        messages.append(ident.message)
    if noisy:
        snrs = ", ".join(
            f"{c} ≈ {noise[c]['snr_db']:.0f} dB" for c in model.input_names if noise[c]["snr_db"]
        )
        reason = (
            f"an input is measured with noise ({snrs}, from its spectrum above the band): the "
            "simulated outputs carry it through the structure (errors in variables), the "
            "residuals are not white and (JᵀJ)⁻¹ would be too narrow; use method equation-error "
            "for intervals that hold"
        )
        messages.append("intervals withheld: " + reason)
        cov = stderr = None
    return StructureResult(
        method="output-error",
        names=tuple(unknown),
        parameters=params,
        stderr=stderr,
        stderr_reason=reason,
        units={k: model.units.get(k, "") for k in params},
        success=success,
        message="; ".join(messages) + ".",
        covariance=cov,
        fit_percent=fits,
        noise=noise,
        input_noisy=bool(noisy),
        estimator="nonlinear least squares on the simulated outputs",
        settings={"evaluations": int(sol.nfev)},
        known=known,
        model_name=model.name,
        model=model,
    )
