"""Input-error, step 3: the residual balance check, the standard errors and the result.

Part of `physid.estimators.input_error`.
"""

from __future__ import annotations

import warnings

import numpy as np

from ...filters.band import choose_filter, noise_floor
from ..plausibility import gate, implausible_scale, still_joints, too_perfect
from .core import NOISE_SHARE, RESIDUAL_WARN, FilterWarning, quality_factor
from .prepare import _Problem
from .result import InputErrorResult
from .solve import _Solution
from .uncertainty import _expression_values, hac_lags, iid_covariance, sandwich_covariance


def conclude(est, problem: _Problem, solution: _Solution, recordings=()) -> InputErrorResult:
    """Residual balance check, uncertainty, message and the result object (``recordings``: the
    fitted ones, whose channels without a unit an implausible mass names)."""
    names, free_names = problem.names, problem.free_names
    e_hat, tau_f, notes = solution.residuals, problem.tau_f, problem.notes
    cost = quality_factor(e_hat)
    tau_rms = np.sqrt(np.mean(tau_f**2, axis=0))
    relative_residual = np.sqrt(np.mean(e_hat**2, axis=0)) / np.where(tau_rms > 0, tau_rms, 1.0)
    withhold = _balance_check(est, problem, relative_residual)

    cov, cov_iid, lags = _covariances(est, problem, solution)

    def standard_errors(c: np.ndarray) -> dict[str, float]:
        out = {n: float("nan") for n in names}
        out.update({n: float(v) for n, v in zip(free_names, np.sqrt(np.diag(c)), strict=True)})
        out.update({n: float("nan") for n in solution.at_bound})
        return out

    sd = np.sqrt(np.diag(cov))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    stderr = standard_errors(cov) if withhold is None else None

    theta_hat = solution.theta_hat
    structural = problem.structural
    combos = tuple(c.expression for c in structural.combinations)
    combo_values, combo_errors = _expression_values(combos, names, theta_hat, cov, problem.free_idx)
    if withhold is not None:
        combo_errors = {k: float("nan") for k in combo_errors}
    success, message = _message(est, problem, solution)
    scale = implausible_scale(problem.as_params(solution.theta_hat), problem.model, recordings)
    success, message = gate(success, message, [*_implausible(problem, solution), *scale])
    sol, after, f = solution.sol, solution.after, problem.filtered
    return InputErrorResult(
        parameters=problem.as_params(theta_hat),
        stderr=stderr,
        correlation=corr,
        free=free_names,
        cost=cost,
        nfev=int(sol.nfev),
        njev=solution.njev,
        success=success,
        message=message,
        history=solution.history,
        cost_history=solution.cost_history,
        parameter_names=names,
        unidentifiable=combos,
        unidentifiable_text=tuple(structural.texts),
        combinations=combo_values,
        combination_stderr=combo_errors,
        fixed=problem.fixed,
        initial=problem.as_params(problem.theta0),
        half_width=f.half_width,
        cutoff=float(f.cutoff),
        filter_choice=f.choice.reason if f.choice else "",
        noise_std=(problem.advice.noise_std if problem.advice is not None else noise_floor(f.q)),
        dt=problem.dt,
        torque=est.torque,
        derivatives=est.derivatives,
        start=est.start,
        start_nfev=solution.start_nfev,
        condition_number=after.condition_number,
        singular_values=np.asarray(after.singular_values),
        filter_passband_edge=problem.band.passband_edge,
        filter_energy_fraction=problem.band.fractions,
        relative_residual=relative_residual,
        warnings=tuple(notes),
        at_bound=solution.at_bound,
        uncertainty=est.uncertainty,
        hac_lags=lags,
        # withheld too: the iid errors are the optimistic ones
        stderr_iid=standard_errors(cov_iid) if withhold is None else dict.fromkeys(names, np.nan),
        noise=solution.noise,
        noise_shift=dict(solution.noise_shift or {}),
        t=problem.t,
        residuals=e_hat,
        units=dict(getattr(problem.model, "units", {}) or {}),
        stderr_reason=withhold,
    )


def _covariances(est, problem: _Problem, solution: _Solution):
    """``(cov, cov_iid, lags)``: the covariance reported (the compensated one, the HAC sandwich
    or iid; see `sandwich_covariance` and `iid_covariance`), the iid one and the HAC lags."""
    e_hat = solution.residuals
    cov_iid = iid_covariance(solution.jacobian, e_hat)
    lags = hac_lags(problem.filtered.half_width)
    if solution.covariance is not None:
        cov = solution.covariance
    elif est.uncertainty == "hac":
        cov = sandwich_covariance(solution.jacobian, e_hat, lags)
    else:
        cov = cov_iid
    return cov, cov_iid, lags


def _balance_check(est, problem: _Problem, relative_residual: np.ndarray) -> str | None:
    """Warn when the filtered equations do not balance; why the intervals are withheld, or None.

    Intervals are withheld when the equations do not balance and no measurement noise is seen
    to explain it (a filter cut-off below the motion, or a model or data error): the standard
    errors then describe the scatter about a biased estimate (m1 37 standard errors off on an
    encoder-quantised drive log).
    """
    share = problem.noise_fraction  # noise="compensate": the noise's share of the residual
    explained = share is None or share >= NOISE_SHARE
    withhold = None
    if relative_residual.max() > RESIDUAL_WARN:
        worst = int(np.argmax(relative_residual))
        head = (
            "the filtered equations of motion balance only to "
            f"{relative_residual[worst]:.2g} of the torque on joint {worst + 1} (relative "
            f"rms residual at the optimum, limit {RESIDUAL_WARN:g}); expect estimates biased "
            "by roughly that order or more."
        )
        cause, withhold = _residual_cause(problem, share, explained)
        text = head + cause + " See docs/input-error.md."
        if est.check_filter:
            warnings.warn(text, FilterWarning, stacklevel=4)
            problem.notes.append(text)
        if withhold is not None:
            withhold = (
                f"the filtered equations of motion balance only to "
                f"{relative_residual[worst]:.2g} of the torque on joint {worst + 1} and "
                f"{withhold}: the estimates are biased by about that much, and standard errors "
                "(which describe only the scatter) would give intervals that miss the truth."
                + cause
            )
    if withhold is None and not explained:
        # a small residual can still be mostly model error, and the noise then tiny: the
        # replicates compare the two whatever the residual's size
        withhold = (
            f"the noise on q explains only {100 * share:.2g} % of the residual's energy (measured "
            "with the noise replicates), the rest is a model or data error (friction the model "
            "lacks, stiction, a filter that smears a discontinuity, wrong gains): the estimates "
            "are biased beyond their scatter, and standard errors would give intervals that "
            "miss the truth. A cut-off closer to the motion, or IDIM (which filters and "
            "decimates differently), may fit better."
        )
    return withhold


def _residual_cause(problem: _Problem, share, explained: bool) -> tuple[str, str | None]:
    """Why the filtered equations do not balance (a sentence), and the reason to withhold."""
    f = problem.filtered
    advice = problem.advice or choose_filter(f.q, f.dt, half_width=f.half_width)
    edge = problem.band.passband_edge
    noisy = advice.noisy
    if advice.signal_band > edge:  # too low: bias from the filter
        # on noisy q the residual may be the noise's (which the intervals carry): withhold
        # only where no noise is seen
        withhold = None if noisy and explained else "the cut-off is below the motion"
        cause = (
            f" The cut-off Ω_g={f.cutoff:.4g} is too low for the motion (it reaches "
            f"{advice.signal_band:.3g} rad/sample, the filter is flat to {edge:.3g}): "
            f"raise it to Ω_g >= {advice.cutoff:.3g} for M={f.half_width}, or use "
            "cutoff='auto'."
        )
        return cause, withhold
    if noisy and f.cutoff > 1.2 * advice.cutoff:  # too high: noise in q̈^f
        return (
            f" The cut-off Ω_g={f.cutoff:.4g} is higher than the motion needs "
            f"({advice.cutoff:.3g} for M={f.half_width}) and lets the measurement noise "
            f"(σ ≈ {np.max(advice.noise_std):.2g} on q) into q̈^f, which biases the "
            "inertias towards zero: lower it, or use cutoff='auto'."
        ), None
    if noisy and explained:
        return (
            f" The filter already holds just the motion; the residual is measurement "
            f"noise (σ ≈ {np.max(advice.noise_std):.2g} on q), whose errors-in-variables "
            "bias no filter choice removes (a longer record allows a larger M and a "
            "lower Ω_g; or use an instrumental-variable method)."
        ), None
    if noisy:  # the noise replicates say the noise is only a small part of the residual
        return (
            f" The noise on q (σ ≈ {np.max(advice.noise_std):.2g}) explains only "
            f"{100 * share:.2g} % of the residual's energy (measured with "
            "the noise replicates): the rest is a model or data error (friction the model "
            "lacks, stiction, wrong gains, a torque offset, a filter that smears a "
            "discontinuity)."
        ), f"the noise on q explains only {100 * share:.2g} % of the residual's energy"
    return (
        " The filter holds the motion and no noise floor is visible: check the "
        "model (a missing friction term, wrong gains) and the data (a quantised "
        "encoder: its steps are noise that the cut-off must stop; try a lower cut-off)."
    ), "no measurement noise explains the residual"


def _implausible(problem: _Problem, solution: _Solution) -> list[str | None]:
    """The plausibility gate's sentences: a joint that never moves while parameters that act
    only through its motion are free, and a fit exact to rounding on torques that never change.

    A free parameter acts only through joint j when its Jacobian column has (almost) all its
    energy on joint j's equations (friction, rotor inertia). A parameter whose column has no
    energy at all acts through no joint here: it is named once, on its own, not under every
    still joint.
    """
    names, nj = problem.free_names, problem.tau_f.shape[1]
    out: list[str | None] = []
    still = still_joints(problem.filtered.q)
    jac = np.asarray(solution.jacobian, dtype=float)
    if (
        still
        and jac.ndim == 2
        and jac.shape[0] == problem.tau_f.size
        and jac.shape[1] == len(names)
    ):
        energy = np.sum(jac.reshape(-1, nj, jac.shape[1]) ** 2, axis=0)  # (joint, parameter)
        total = energy.sum(axis=0)
        for j in still:
            own = [
                n for k, n in enumerate(names) if total[k] > 0 and energy[j, k] >= 0.99 * total[k]
            ]
            if not own:
                continue
            q = problem.filtered.q[:, j]
            out.append(
                f"joint {j + 1} never moves (q{j + 1} spans {np.ptp(q):.2g}, standard deviation "
                f"{np.std(q):.2g}: no more than its measurement noise), so {', '.join(own)} "
                "(which act only through its motion) are not in the data and their values are "
                f"noise. Move joint {j + 1} in the experiment (physid design-excitation), or hold "
                "them at known values (identify = false in the model file)."
            )
        inert = [n for k, n in enumerate(names) if not total[k] > 0]
        if inert:
            out.append(
                f"{', '.join(inert)} change no torque in this record (their columns of the "
                "Jacobian are zero), so their values are not in the data. Record a motion that "
                "excites them, or hold them at known values (identify = false in the model file)."
            )
    torque_names = [f"tau{j + 1}" for j in range(nj)]
    out.append(too_perfect(solution.residuals, problem.tau_f, torque_names))
    return out


def _message(est, problem: _Problem, solution: _Solution) -> tuple[bool, str]:
    """``(success, message)``: the solver's verdict, bounds, identifiability, noise on q."""
    sol, after, notes = solution.sol, solution.after, problem.notes
    structural = problem.structural
    message = sol.message
    success = bool(sol.success)
    if not success:
        message += (
            f" The fit stopped after {sol.nfev} evaluations; raise max_nfev (now "
            f"{est.max_nfev}) or use start='linear'."
        )
    if solution.at_bound:
        success = False
        message += " Not a minimum: " + solution.bound_text
    if not after.ok:
        notes.append("after the fit: " + after.summary())
        message += " Warning: " + after.summary() + "."
    if structural.combinations:
        message += " Identifiable only as combinations: " + "; ".join(structural.texts) + "."
    f = problem.filtered
    advice = problem.advice or choose_filter(f.q, f.dt, half_width=f.half_width)
    if solution.noise == "ignore" and advice.noisy:
        message += (
            f" q is noisy (σ ≈ {np.max(advice.noise_std):.2g}): the standard errors describe "
            "the scatter, not the errors-in-variables bias that noise causes, so their "
            "intervals need not hold the truth; noise='compensate' removes most of that bias "
            "and gives intervals that do (docs/input-error.md)."
        )
    if solution.noise_shift is not None:
        moved = max(solution.noise_shift, key=lambda n: abs(solution.noise_shift[n]))
        message += (
            f" Noise on q (σ ≈ {np.max(noise_floor(f.q)):.2g}) compensated with "
            f"{est.noise_replicates} replicates; it moved {moved} by "
            f"{solution.noise_shift[moved]:+.4g}."
        )
    return success, message
