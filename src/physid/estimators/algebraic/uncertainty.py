"""Uncertainty of the pooled final estimate: noise propagation through the window kernels, and the
bias-compensated (errors-in-variables) least squares that serves as its reference."""

from __future__ import annotations

import numpy as np
from scipy import signal

from .plan import _Plan
from .windows import _offset_to_value, _unscale

#: The default (``final="lstsq"``) withholds its standard errors (``stderr`` None with the reason)
#: where its estimate lies more than this many of them from the bias-compensated one
#: (`_withhold_if_biased`). Not RLS's 0.5 (``MAX_BIAS_TO_STDERR``, a bias estimated on the same
#: data): this shift also holds the two estimates' sampling disagreement, about 0.7 se where there
#: is no bias (60 dB). Measured (benchmarks/bench_coverage.py): at 0.5 the default withholds
#: 59-68 % of the 60 dB fits and the rest over-cover (θ2 97.6 / 98.4 %, 200 trials); at 1.0 it
#: withholds 13 % (paper's MSD) / 29 % (ζ = 0.5) there and covers 94.3 / 96.6 % and
#: 95.1 / 95.4 % (θ1 / θ2, 400 trials), and withholds every 30 dB fit.
MAX_SHIFT_TO_STDERR = 1.0


def _equilibrated_condition(G: np.ndarray) -> float:
    """Condition number of the unit-diagonal scaling of the symmetric matrix ``G``."""
    d = np.sqrt(np.abs(np.diag(G)))
    if not np.all(d > 0) or not np.all(np.isfinite(G)):
        return float("inf")
    w = np.linalg.eigvalsh(G / d[:, None] / d[None, :])
    return float(w[-1] / w[0]) if w[0] > 0 else float("inf")


def _noise_kernels(plan: _Plan, alpha):
    """Taps (n_eq, order+1, L+1), the weights γ_i of the y-kernels in the residual, and κ_e."""
    n = plan.order
    taps = plan.taps(plan.L)
    col = {c: k for k, c in enumerate(plan.columns)}
    gamma = np.array(
        [
            alpha[col[("a", i)]] if ("a", i) in col else plan.known_a[i] * plan.window ** (n - i)
            for i in range(n + 1)
        ]
    )
    return taps, gamma, np.einsum("i,eij->ej", gamma, taps)


#: Iterations of the bias-compensated least squares (converges in 3-5 at 20-60 dB).
BIAS_COMPENSATION_ITERATIONS = 20


def _bias_compensated(plan: _Plan, A, rhs, G, h, alpha):
    """Bias-compensated pooled least squares (``final="bias-compensated"``).

    White output noise ``ε`` (variance σ²) enters both ``A`` (the y-kernels of the unknown
    ``a_i``) and ``r`` (the known ones, ``a_n = 1`` included), so ``E[G] = G₀ + W σ² Σ_e M_e`` and
    ``E[h] = h₀ + W σ² Σ_e d_e`` with ``W`` windows, ``M_e[c, c'] = τ_{e,c}·τ_{e,c'}`` and
    ``d_e[c] = −Σ_{known i} γ_i τ_{e,c}·τ_{e,i}`` (``τ_{e,i}`` the taps of kernel ``(ν_e, i)``;
    input columns carry no noise). The errors-in-variables bias of ``G⁻¹ h`` is removed by solving
    ``(G − W σ² M) α = h − W σ² d``, with σ² re-estimated from the residual of the compensated
    fit, ``E[(r − A α)²] = σ² ‖κ_e‖²`` (Zheng's bias-eliminated least squares; Söderström 2007,
    *Errors-in-variables methods in system identification*, sec. 4). Returns (α, G − W σ² M).
    """
    W = A.shape[2]

    def mean_square(a):  # mean of (r − A a)² over every equation of every window
        return float(((rhs - np.einsum("epw,p->ew", A, a)) ** 2).mean())

    return _bias_compensated_sums(plan, G, h, alpha, W, mean_square)


def _bias_compensated_sums(plan: _Plan, G, h, alpha, W: int, mean_square):
    """`_bias_compensated` from the pooled sums ``G``, ``h``, the number of windows ``W`` and the
    residuals' mean square as a function of α (a record read in blocks)."""
    taps, _, _ = _noise_kernels(plan, alpha)
    n = plan.order
    y_cols = [(c, i) for c, (kind, i) in enumerate(plan.columns) if kind == "a"]
    known_y = [i for i in range(n + 1) if ("a", i) not in plan.columns]
    M = np.zeros((plan.p, plan.p))
    d_per = np.zeros((plan.p, n + 1))  # Σ_e τ_{e,c}·τ_{e,i}
    for c, i in y_cols:
        for c2, i2 in y_cols:
            M[c, c2] = float(np.einsum("ej,ej->", taps[:, i, :], taps[:, i2, :]))
        for k in known_y:
            d_per[c, k] = float(np.einsum("ej,ej->", taps[:, i, :], taps[:, k, :]))
    a = alpha
    Gc = G
    for _ in range(BIAS_COMPENSATION_ITERATIONS):
        _, gamma, kappa = _noise_kernels(plan, a)
        sigma2 = float(mean_square(a) / (kappa**2).sum(axis=1).mean())
        d = -(d_per[:, known_y] @ gamma[known_y])
        Gc = G - W * sigma2 * M
        a_new = np.linalg.solve(Gc, h - W * sigma2 * d)
        if np.allclose(a_new, a, rtol=1e-12, atol=0):
            a = a_new
            break
        a = a_new
    return a, Gc


#: Plain text (a result's ``stderr_reason`` is data, not an error: no argument marks).
_USE_COMPENSATED = "final='bias-compensated'"


def _withhold_if_biased(plan: _Plan, equations, t, every, final, stderr):
    """The default's (``final="lstsq"``) standard errors, or (None, reason) where its estimate is
    farther than `MAX_SHIFT_TO_STDERR` of them from the bias-compensated estimate.

    The reference is ``final="bias-compensated"`` over every full window (``every``): consistent,
    with nominal coverage at 30 and 60 dB (benchmarks/bench_coverage.py). The default differs from
    it by the errors-in-variables bias of the output noise inside ``A`` (θ2 of the paper's MSD:
    +1 %, about 6 standard errors, at 30 dB) and by the selection of its 5-MAD screen, which the
    covariance (a fixed set of windows) does not model: the screen drops 13 % of the windows at
    30 dB and 1.7-2.5 % at 60 dB, which alone leaves sd(error)/se ≈ 1.1 (coverage 91 %) for the
    ζ = 0.5 MSD at 60 dB; it also keeps a window that straddles an input jump out of the estimate,
    which the reference then feels. The check is a difference of two estimates from the same
    record, so it costs one more pooled solve.
    """
    A, rhs = equations
    A = A[:, :, -t.size :][:, :, every]
    rhs = rhs[:, -t.size :][:, every]
    G = np.einsum("epw,eqw->pq", A, A)
    h = np.einsum("epw,ew->p", A, rhs)
    try:
        alpha = np.linalg.lstsq(G, h, rcond=None)[0]
        alpha, _ = _bias_compensated(plan, A, rhs, G, h, alpha)
    except np.linalg.LinAlgError:
        alpha = np.full(plan.p, np.nan)
    reference = _offset_to_value(plan, alpha * _unscale(plan))
    if not np.all(np.isfinite(reference)):
        return None, (
            "the bias of the estimate could not be checked (the bias-compensated reference "
            f"is singular); use {_USE_COMPENSATED} for standard errors."
        )
    shift = np.asarray(final, dtype=float) - reference
    shifted = [
        f"{nm} (shift {d:.3g}, se {stderr[nm]:.3g})"
        for nm, d, v in zip(plan.names, shift, final, strict=True)
        if abs(d) > MAX_SHIFT_TO_STDERR * stderr[nm] and abs(d) > 1e-9 * abs(v)
    ]
    if not shifted:
        return stderr, None
    return None, (
        "the estimate lies more than "
        f"{MAX_SHIFT_TO_STDERR:g} standard error(s) from the bias-compensated one (errors in the "
        "variables from the output noise, or windows dropped by the screen): "
        + ", ".join(shifted)
        + f"; a 95 % interval would not cover. Use {_USE_COMPENSATED} for an estimate "
        "without that bias and with honest standard errors."
    )


def _window_pairs(plan: _Plan, used) -> np.ndarray:
    """n(d), d = −L..L: the number of pairs of used windows (end samples ``used``) d apart."""
    L = plan.L
    span = int(used[-1] - used[0]) + 1
    ind = np.zeros(span)
    ind[used - used[0]] = 1.0
    full = signal.correlate(ind, ind, mode="full", method="fft" if span > 512 else "direct")
    mid = span - 1
    n_d = np.zeros(2 * L + 1)  # n(d), d = -L..L
    lo, hi = max(0, mid - L), min(full.size, mid + L + 1)
    n_d[lo - (mid - L) : hi - (mid - L)] = np.round(full[lo:hi])
    return n_d


def _quadratic_term(plan: _Plan, kappa, n_d) -> np.ndarray:
    """The second-order part of the pooled estimate's covariance, per σ⁴ (p, p).

    The noise inside ``A`` (the y-columns ``c``: ``N_{e,w,c} = τ_{e,c} · ε`` over window ``w``)
    meets the residual's noise ``κ_e · ε`` in the quadratic forms ``Q_c = Σ_{e,w} N_{e,w,c}
    (κ_e · ε)_w = εᵀ B_c ε``. For Gaussian noise ``Cov(Q_c, Q_c') = σ⁴ [tr(B_c B_c'ᵀ) +
    tr(B_c B_c')]``. The first trace is already in ``σ² C Cᵀ`` (``C`` is built from the noisy
    ``A``); this is the second, ``Σ_{e,e'} Σ_d n(d) X^{ee'}_{c'}(d) X^{e'e}_c(−d)`` with the
    kernel cross-correlations ``X^{ee'}_c(d) = Σ_i κ_e[i] τ_{e',c}[i + d]`` and ``n(d)`` the number
    of pairs of used windows ``d`` samples apart (`_window_pairs`). It is negative where the kernels are odd
    against each other: without it the θ1 intervals of the ζ = 0.5 MSD at 30 dB (where the
    quadratic part is a large share) over-cover (99 %).
    """
    taps = plan.taps(plan.L)
    y_cols = [(c, i) for c, (kind, i) in enumerate(plan.columns) if kind == "a"]
    T = np.zeros((plan.p, plan.p))
    if not y_cols:
        return T
    n_eq = kappa.shape[0]
    # X[e, e', c][d + L] = Σ_i κ_e[i] τ_{e',c}[i + d]
    X = {
        (e, e2, c): np.correlate(taps[e2, i], kappa[e], mode="full")
        for e in range(n_eq)
        for e2 in range(n_eq)
        for c, i in y_cols
    }
    for c, _ in y_cols:
        for c2, _ in y_cols:
            T[c, c2] = sum(
                float(np.dot(n_d, X[(e, e2, c2)] * X[(e2, e, c)][::-1]))
                for e in range(n_eq)
                for e2 in range(n_eq)
            )
    return 0.5 * (T + T.T)


def _pooled_stderr(plan: _Plan, A, rhs, alpha, used, G=None):
    """Standard errors of the pooled least-squares estimate under white noise on the output.

    The pooled estimate solves ``G α = h``, ``G = Σ_w A_wᵀ A_w``, ``h = Σ_w A_wᵀ r_w``, over the
    used windows ``w``. At the true ``α`` the residual of equation ``e`` of the window ending at
    sample ``k`` is exactly the output noise filtered by that equation's effective kernel,
    ``r − A α = −Σ_j κ_e[j] ε_{k−L+j}`` with ``κ_e = Σ_i γ_i taps_{e,i}`` (``γ_i = α_i`` for an
    unknown ``a_i``, ``a_i T^(n−i)`` for a known one, ``γ_n = 1``); the signal part cancels because
    the samples satisfy the ODE. So, to first order,

        α̂ − α = G⁻¹ Σ_t c_t ε_t,    c_t = −Σ_e Σ_k A_e(k) κ_e[t − k + L]   (a convolution)

    and ``Cov(α̂) = σ² G⁻¹ (Σ_t c_t c_tᵀ) G⁻¹``: the overlap of the windows (which share ``L`` of
    their ``L + 1`` samples) is accounted for exactly, instead of treating the windows as
    independent. ``σ²`` comes from the residuals, ``E[(r − A α̂)²] = σ² ‖κ_e‖²``. Noise that is
    not white, and the second-order bias from noise inside ``A`` (errors in the variables, which
    biases θ2 at low SNR), are not included: see docs/algebraic.md for the measured coverage.

    ``A`` (n_eq, p, n_used), ``rhs`` (n_eq, n_used), ``alpha`` (p,) dimensionless, ``used`` the
    sample index of each used window's end. Returns (stderr dict in SI units, None, covariance
    (p, p) in SI units) or (None, reason, None).
    """
    n_eq = A.shape[0]
    _, _, kappa = _noise_kernels(plan, alpha)  # effective kernel of each equation
    resid = rhs - np.einsum("epw,p->ew", A, alpha)
    span = int(used[-1] - used[0]) + 1
    dense = np.zeros((n_eq, plan.p, span))
    dense[:, :, used - used[0]] = A
    C = np.zeros((plan.p, span + plan.L))
    for e in range(n_eq):
        for q in range(plan.p):
            C[q] -= (
                signal.oaconvolve(dense[e, q], kappa[e])
                if span > 256
                else np.convolve(dense[e, q], kappa[e])
            )
    if G is None:
        G = np.einsum("epw,eqw->pq", A, A)
    sums = (float((resid**2).sum()), resid.size, A.shape[2])
    return _pooled_stderr_sums(plan, alpha, sums, C @ C.T, _window_pairs(plan, used), G)


def _pooled_stderr_sums(plan: _Plan, alpha, sums, CCt, n_d, G):
    """`_pooled_stderr` from accumulated sums: ``sums = (Σ resid², resid count, windows)``,
    ``CCt = Σ_t c_t c_tᵀ``, the window pairs ``n_d`` (`_window_pairs`) and ``G``."""
    _, _, kappa = _noise_kernels(plan, alpha)
    see, n_res, W = sums
    dof = n_res - plan.p
    k2 = (kappa**2).sum(axis=1)  # ‖κ_e‖²
    if dof <= 0 or not np.all(k2 > 0):
        return None, "too few window equations for a residual variance", None
    sigma2 = float(see / (W * k2.sum()) * n_res / dof)
    meat = sigma2 * CCt + sigma2**2 * _quadratic_term(plan, kappa, n_d)
    left = np.linalg.solve(G, meat)
    cov = np.linalg.solve(G, left.T).T  # G⁻¹ meat G⁻¹
    var = np.clip(np.diag(0.5 * (cov + cov.T)), 0.0, None)
    se = np.sqrt(var) * np.abs(_unscale(plan))
    if not np.all(np.isfinite(se)):
        return None, "the pooled window system is singular", None
    scale = _unscale(plan)
    cov_si = 0.5 * (cov + cov.T) * np.outer(scale, scale)
    return {nm: float(v) for nm, v in zip(plan.names, se, strict=True)}, None, cov_si
