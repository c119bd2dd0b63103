"""Input-error, step 2: the least-squares fit (plain, noise-compensated) and the bound check.

Part of `physid.estimators.input_error`.
"""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy import optimize

from ...errors import InputError
from ...filters.band import choose_filter, noise_floor, white_floor
from ...models.identifiability import (
    NUMERIC_RTOL,
    NumericIdentifiability,
    numeric_identifiability,
    svd_tall,
)
from .core import (
    BOUND_RTOL,
    BoundWarning,
    _gram_least_squares,
    linear_least_squares,
    quality_factor,
)
from .prepare import _Problem


@dataclass(eq=False)
class _Solution:
    """What `InputErrorEstimator._solve` found."""

    sol: Any
    theta_hat: np.ndarray
    residuals: np.ndarray
    jacobian: np.ndarray
    after: NumericIdentifiability
    at_bound: tuple[str, ...]
    bound_text: str
    start_nfev: int
    njev: int
    history: np.ndarray
    cost_history: np.ndarray
    covariance: np.ndarray | None = None  # noise="compensate": from the noise replicates
    noise: str = "ignore"  # what was done about the noise on q ("auto" resolved)
    noise_shift: dict[str, float] | None = None  # compensated minus plain least squares


def solve(est, problem: _Problem) -> _Solution:
    """Linear start (optional), trust-region least squares, and the bound check."""
    if resolve_noise(est, problem) == "compensate":
        return solve_compensated(est, problem)
    free_idx, scale = problem.free_idx, problem.scale
    lower, upper = problem.lower[free_idx], problem.upper[free_idx]
    # residual scaled by 1/sqrt(N) so that 2*cost = J
    sqrt_n = math.sqrt(problem.n_valid)
    history: list[np.ndarray] = []
    cost_history: list[float] = []
    counter = {"jac": 0}

    def fun(x: np.ndarray) -> np.ndarray:
        theta = problem.full_theta(x)
        e = problem.residual_matrix(theta)
        history.append(theta)
        cost_history.append(quality_factor(e))
        return e.ravel() / sqrt_n

    def jac(x: np.ndarray) -> np.ndarray:
        counter["jac"] += 1
        return problem.jacobian(problem.full_theta(x))[:, free_idx] / sqrt_n

    start_nfev = 0
    if est.start == "linear":
        problem.theta0, start_nfev = linear_start(
            est,
            problem.qf,
            problem.qdf,
            problem.qddf,
            problem.tau_f,
            problem.theta0,
            free_idx,
            problem.lower,
            problem.upper,
            scale,
        )
    sol = optimize.least_squares(
        fun,
        problem.theta0[free_idx],
        jac=jac,
        bounds=(lower, upper),
        x_scale=scale[free_idx],
        method="trf",
        max_nfev=int(est.max_nfev),
        xtol=est.xtol,
        ftol=est.ftol,
        gtol=est.gtol,
    )
    at_bound, bound_text = bound_check(est, problem, sol)
    theta_hat = problem.full_theta(sol.x)
    jac_hat = problem.jacobian(theta_hat)[:, free_idx]
    after: NumericIdentifiability = numeric_identifiability(
        jac_hat,
        problem.free_names,
        scale[free_idx],
        beta_names=getattr(problem.model, "beta_names", None),
    )
    return _Solution(
        sol=sol,
        theta_hat=theta_hat,
        residuals=problem.residual_matrix(theta_hat),
        jacobian=jac_hat,
        after=after,
        at_bound=at_bound,
        bound_text=bound_text,
        start_nfev=int(start_nfev),
        njev=int(counter["jac"]),
        history=np.array(history) if history else np.empty((0, len(problem.names))),
        cost_history=np.array(cost_history),
    )


def resolve_noise(est, problem: _Problem) -> str:
    """``"compensate"`` or ``"ignore"``: ``noise="auto"`` resolved for this recording.

    ``"auto"`` compensates when the spectrum of q shows a noise floor that reaches frequencies a
    cut-off could pass (`physid.filters.FilterChoice.noisy`) and the model has the linear form
    the compensation needs (``regressor`` and ``beta``); else it ignores the noise (noise-free
    or nearly noise-free data cost nothing extra and give the same estimate as before).
    """
    if est.noise != "auto":
        return est.noise
    model, f = problem.model, problem.filtered
    if not all(hasattr(model, a) for a in ("regressor", "beta")):
        return "ignore"
    advice = problem.advice or choose_filter(f.q, f.dt, half_width=f.half_width)
    return "compensate" if advice.noisy else "ignore"


def bound_check(est, problem: _Problem, sol) -> tuple[tuple[str, ...], str]:
    """Free parameters that ended on (or within ``BOUND_RTOL`` of) a bound, and the text."""
    free_idx, scale = problem.free_idx, problem.scale
    lower, upper = problem.lower[free_idx], problem.upper[free_idx]
    # -- parameters that ended on a bound: a boundary point, not a minimum of J
    x_hat = sol.x
    near = BOUND_RTOL * np.maximum(scale[free_idx], 1.0)
    with np.errstate(invalid="ignore"):
        on_bound = (np.asarray(sol.active_mask) != 0) | (
            (np.isfinite(lower) & (x_hat - lower <= near))
            | (np.isfinite(upper) & (upper - x_hat <= near))
        )
    free_names = problem.free_names
    at_bound = tuple(n for n, b in zip(free_names, on_bound, strict=True) if b)
    bound_text = ""
    if at_bound:
        where = ", ".join(
            f"{n} = {x_hat[k]:.6g} (bounds [{lower[k]:.6g}, {upper[k]:.6g}])"
            for k, n in enumerate(free_names)
            if on_bound[k]
        )
        bound_text = (
            f"the fit ended on a bound: {where}. The data push these parameters out of the "
            "physical region, which usually means the model does not match the system (e.g. "
            "kinetic='paper' fitted to data of the exact kinetic energy, "
            "wrong gains, or a missing friction term); their standard errors are not "
            "meaningful (NaN). Check the model, or set bounds= if the bound was too tight."
        )
        sigma = noise_floor(problem.filtered.q)
        advice = problem.advice or choose_filter(
            problem.filtered.q, problem.dt, half_width=problem.filtered.half_width
        )
        if advice.noisy:
            bound_text += (
                f" Or measurement noise: q carries noise of σ ≈ {np.max(sigma):.2g}, and with "
                f"Ω_g = {problem.filtered.cutoff:.4g} (the motion needs "
                f"{advice.cutoff:.3g}) its errors-in-variables bias can push inertias to "
                "zero: lower the cut-off or use cutoff='auto'."
            )
        warnings.warn(bound_text, BoundWarning, stacklevel=4)
        problem.notes.append(bound_text)
    return at_bound, bound_text


def noise_fraction(beta, data, replicates) -> float:
    """The share of the data's residual energy that its noise on q explains, from replicates.

    A replicate ``x + ε`` carries the noise twice where the data ``x`` carries it once, so its
    residual energy at β exceeds the data's by the noise-induced part N; with a model or filter
    error of energy E the data's energy is E + N, and the share ``N / (E + N)`` (about 1, or a
    little above from the noise's second-order terms, when the noise explains the residual).

    Parameters
    ----------
    beta : ndarray (p,)
        The regressor parameters at the estimate.
    data : (G, h, t)
        The data's normal equations ``YᵀY``, ``Yᵀτ^f`` and ``τ^fᵀτ^f``.
    replicates : iterable of (G_k, h_k, t_k)
        The same for each re-noised replicate.

    Returns
    -------
    float
    """

    def energy(g, h, t):
        return float(beta @ g @ beta - 2.0 * beta @ h + t)

    e0 = energy(*data)
    e_rep = float(np.mean([energy(*r) for r in replicates]))
    # the replicates' scatter can leave e_rep a little below e0 when the noise is negligible
    return max(0.0, (e_rep - e0) / e0) if e0 > 0 else 1.0


def replicate_normal_equations(est, f, normal_equations) -> tuple[list, list, list]:
    """The normal equations of ``est.noise_replicates`` re-noised copies of the record.

    Each copy adds white noise of the level seen on q (`noise_floor`; and on the measured τ,
    `white_floor`) and goes through the fit's own filters (``f.refilter``);
    ``normal_equations(qf, qdf, qddf, tau_f)`` returns ``(G, h, t)``. Returns the lists of G,
    h and t. The draws come from ``est.random_state``: the same data give the same replicates.
    """
    sigma_q = noise_floor(f.q)
    sigma_tau = white_floor(f.tau) if f.tau is not None else None
    rng = np.random.default_rng(est.random_state)
    grams, rhss, tts = [], [], []
    for _ in range(int(est.noise_replicates)):
        q_k = f.q + rng.normal(size=f.q.shape) * sigma_q
        tau_k = None
        if sigma_tau is not None:
            tau_k = f.tau + rng.normal(size=f.tau.shape) * sigma_tau
        g_k, r_k, tt_k = normal_equations(*f.refilter(q_k, tau_k))
        grams.append(g_k)
        rhss.append(r_k)
        tts.append(tt_k)
    return grams, rhss, tts


def replicate_covariance(beta, grams, rhss, r_d, d=None) -> np.ndarray:
    """``H⁻¹ Var ψ H⁻¹`` of a compensated estimate from its replicates' scores.

    ψ_k = Dᵀ (G_k β − h_k) (D = ∂β/∂θ; None: the identity), ``Var ψ ≈ (1 + 1/B) Cov_k ψ_k``
    over the B replicates, and ``H = (R_c D)ᵀ (R_c D)`` from ``r_d = R_c D``; an infinite
    matrix when H is numerically singular.
    """
    if d is None:
        scores = np.array([g @ beta - r for g, r in zip(grams, rhss, strict=True)])
    else:
        scores = np.array([d.T @ (g @ beta - r) for g, r in zip(grams, rhss, strict=True)])
    p = r_d.shape[1]
    omega = (1.0 + 1.0 / len(grams)) * np.cov(scores, rowvar=False).reshape(p, -1)
    sv, vt = svd_tall(r_d)  # H = Dᵀ A_c D = (R_c D)ᵀ (R_c D)
    if sv.size < p or not np.all(sv > NUMERIC_RTOL * sv[0]):
        return np.full((p, p), np.inf)
    h_inv = (vt.T / sv**2) @ vt
    return h_inv @ omega @ h_inv


def _require_linear_form(model, setting: str, alternative: str) -> None:
    """Refuse ``setting`` for a model without the linear form ``τ = Y β(θ)``."""
    for attr in ("regressor", "beta"):
        if not hasattr(model, attr):
            raise InputError(
                f"{setting} needs a model that is linear in its base parameters (with "
                f"{attr!r}); this model has none. Use {alternative}."
            )


def _regressor_normal_equations(model, qf, qdf, qddf, tau_f):
    """``(YᵀY, Yᵀτ^f, τ^fᵀτ^f)`` of the model's full regressor Y on filtered signals."""
    y = np.asarray(model.regressor(qf, qdf, qddf), dtype=float)
    y = y.reshape(-1, y.shape[-1])
    return y.T @ y, y.T @ tau_f.ravel(), float(tau_f.ravel() @ tau_f.ravel())


def _beta_maps(problem: _Problem):
    """``β(θ)`` and ``∂β/∂θ_free`` of the model (forward differences without ``beta_jacobian``)."""
    model, free_idx = problem.model, problem.free_idx

    def beta_of(theta):
        return np.asarray(model.beta(problem.as_params(theta)), dtype=float)

    def d_beta(theta):  # ∂β/∂θ_free
        if hasattr(model, "beta_jacobian"):
            jac = np.asarray(model.beta_jacobian(problem.as_params(theta)), dtype=float)
            return jac[:, free_idx]
        base = beta_of(theta)
        cols = []
        for i in free_idx:
            step = 1e-7 * max(abs(theta[i]), 1.0)
            t2 = theta.copy()
            t2[i] += step
            cols.append((beta_of(t2) - base) / step)
        return np.column_stack(cols)

    return beta_of, d_beta


def solve_compensated(est, problem: _Problem) -> _Solution:
    """Least squares with the errors-in-variables bias of the noise on q compensated.

    The model is linear in β(θ): τ̂ = Y(x) β with x = (q^f, q̇^f, q̈^f). Noise on q makes
    the normal equations biased, ``E[YᵀY] = Y0ᵀY0 + C``, ``E[Yᵀτ] = Y0ᵀτ + c`` (C, c of
    order σ²), which attenuates the inertias. Adding a further white noise of the same
    level σ̂ (`noise_floor`) to q and filtering again gives ``E[A(x + ε)] = A(x) + C`` to
    first order, so ``A_c = 2 A(x) - mean_k A(x + ε_k)`` and ``b_c = 2 b(x) - mean_k
    b(x + ε_k)`` are unbiased for ``Y0ᵀY0`` and ``Y0ᵀτ`` (simulation-extrapolation to zero
    noise on the normal equations, where the noise enters linearly in σ²; Cook & Stefanski
    1994). θ̂ minimises ``(β(θ) - β̂_c)ᵀ A_c (β(θ) - β̂_c)``.

    Covariance: θ̂ solves ``ψ(θ) = Dᵀ (A_c β(θ) - b_c) = 0`` with D = ∂β/∂θ. Linearised in
    the noise, ψ_k = Dᵀ(A(x + ε_k) β̂ - b(x + ε_k)) scatters like the data's own score, so
    ``Var ψ_c ≈ (1 + 1/B) Cov_k ψ_k`` and ``Cov θ̂ = H⁻¹ Var ψ_c H⁻¹``, ``H = Dᵀ A_c D``.
    Only the noise contributes: the deterministic filter mismatch does not inflate it (the
    HAC sandwich cannot tell the two apart).
    """
    model, f = problem.model, problem.filtered
    _require_linear_form(model, "noise='compensate'", "noise='ignore'")
    free_idx, scale, names = problem.free_idx, problem.scale, problem.names
    lower, upper = problem.lower[free_idx], problem.upper[free_idx]
    normal_equations = functools.partial(_regressor_normal_equations, model)
    gram, rhs, tt = normal_equations(f.qf, f.qdf, f.qddf, f.tau_f)
    grams, rhss, tts = replicate_normal_equations(est, f, normal_equations)
    gram_c = 2.0 * gram - np.mean(grams, axis=0)  # A_c = 2 A(x) - mean A(x + ε)
    rhs_c = 2.0 * rhs - np.mean(rhss, axis=0)
    history: list[np.ndarray] = []
    beta_of, d_beta = _beta_maps(problem)

    def solve(gram_, rhs_, theta_start):
        beta_hat, r = _gram_least_squares(gram_, rhs_)

        def small(x):
            theta = problem.full_theta(x)
            history.append(theta)
            return r @ (beta_of(theta) - beta_hat)

        sol = optimize.least_squares(
            small,
            theta_start[free_idx],
            jac=lambda x: r @ d_beta(problem.full_theta(x)),
            bounds=(lower, upper),
            x_scale=scale[free_idx],
            method="trf",
            xtol=1e-14,
            ftol=1e-14,
            gtol=1e-14,
            max_nfev=int(est.max_nfev),
        )
        return sol, r

    plain, _ = solve(gram, rhs, problem.theta0)  # uncompensated, for the shift
    n_plain = len(history)
    sol, r_c = solve(gram_c, rhs_c, problem.full_theta(plain.x))
    theta_hat = problem.full_theta(sol.x)
    at_bound, bound_text = bound_check(est, problem, sol)
    # -- covariance from the replicates' scores (see the docstring)
    d = d_beta(theta_hat)
    beta_hat_theta = beta_of(theta_hat)
    problem.noise_fraction = noise_fraction(
        beta_hat_theta, (gram, rhs, tt), zip(grams, rhss, tts, strict=True)
    )
    cov = replicate_covariance(beta_hat_theta, grams, rhss, r_c @ d, d)
    jac_hat = problem.jacobian(theta_hat)[:, free_idx]
    after = numeric_identifiability(
        jac_hat,
        problem.free_names,
        scale[free_idx],
        beta_names=getattr(model, "beta_names", None),
    )
    shift = {
        n: float(theta_hat[i] - problem.full_theta(plain.x)[i])
        for n, i in zip(problem.free_names, free_idx, strict=True)
    }
    hist = np.array(history[n_plain:]) if len(history) > n_plain else np.empty((0, len(names)))
    residuals = problem.residual_matrix(theta_hat)
    return _Solution(
        sol=sol,
        theta_hat=theta_hat,
        residuals=residuals,
        jacobian=jac_hat,
        after=after,
        at_bound=at_bound,
        bound_text=bound_text,
        start_nfev=int(plain.nfev),
        njev=int(sol.njev or 0),
        history=hist,
        cost_history=np.full(hist.shape[0], quality_factor(residuals)),
        covariance=cov,
        noise_shift=shift,
        noise="compensate",
    )


def linear_start(est, qf, qdf, qddf, tau_f, theta0, free_idx, lower, upper, scale):
    """Solve the problem in the base parameters, then map β̂ back to θ.

    The model is linear in β(θ): τ̂ = Y(q, q̇, q̈) β(θ). With Y = QR and β̂ any least-squares
    solution of Y β = τ^f, ``|Y β(θ) - τ^f|² = |R (β(θ) - β̂)|² + |Y β̂ - τ^f|²`` for every θ,
    so minimising the small residual ``R (β(θ) - β̂)`` (n_beta rows) has the same minimiser
    as the full problem.
    """
    model = est.model
    _require_linear_form(model, "start='linear'", "start='initial'")
    names = tuple(model.parameter_names)
    y = np.asarray(model.regressor(qf, qdf, qddf), dtype=float)
    beta_hat, r = linear_least_squares(y.reshape(-1, y.shape[-1]), tau_f.ravel())

    def beta_of(theta):
        return np.asarray(model.beta(dict(zip(names, theta.tolist(), strict=True))), dtype=float)

    def small(x):
        theta = theta0.copy()
        theta[free_idx] = x
        return r @ (beta_of(theta) - beta_hat)

    small_jac = "2-point"
    if hasattr(model, "beta_jacobian"):

        def small_jac(x):  # ∂/∂θ_free of R (β(θ) - β̂) = R ∂β/∂θ
            theta = theta0.copy()
            theta[free_idx] = x
            db = np.asarray(
                model.beta_jacobian(dict(zip(names, theta.tolist(), strict=True))), dtype=float
            )
            return r @ db[:, free_idx]

    sol = optimize.least_squares(
        small,
        theta0[free_idx],
        jac=small_jac,
        bounds=(lower[free_idx], upper[free_idx]),
        x_scale=scale[free_idx],
        method="trf",
        xtol=1e-14,
        ftol=1e-14,
        gtol=1e-14,
        max_nfev=2000,
    )
    theta = theta0.copy()
    theta[free_idx] = sol.x
    return theta, int(sol.nfev)
