"""Uncertainty of the recursive estimator's final estimate: white-row and HAC sandwiches, white
output noise through the state-variable filter, and the bias-compensated least squares."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np

from ...filters.state_variable import state_variable_filter

#: An estimated errors-in-variables bias above this many standard errors withholds the interval
#: (``stderr`` None with the reason): at 0.5 the coverage of a nominal 95 % interval is still
#: ≥ 92 % (|z| ≤ 1.96 with the centre shifted by 0.5 σ).
MAX_BIAS_TO_STDERR = 0.5


def _weighted_rows(X, Y, theta, M: int, last: int, lam: float):
    """``(w, X, e)`` of the final estimate at row ``last``: each row's forgetting weight
    ``λ^age`` (the initial rows up to ``M`` share the age of row ``M + 1``), the rows and their
    residuals."""
    i = np.arange(last + 1)
    age = np.where(i <= M, max(last - M - 1, 0), last - i).astype(float)
    with np.errstate(under="ignore"):
        w = lam**age
    Xw = X[: last + 1]
    return w, Xw, Y[: last + 1] - Xw @ theta


def _final_covariance(X, Y, theta, M: int, last: int, lam: float):
    """Nominal covariance of θ̂ at row ``last``: the weighted-LS sandwich with white row noise.

    Weights as in the recursion (rows ≤ M: λ^{last−M−1}, later rows λ^{last−i}; 1 at row M). With
    ``S = Σ w x xᵀ``, ``A = Σ w² x xᵀ``: ``Cov = σ̂² S⁻¹ A S⁻¹``, ``σ̂² = Σ w e² / Σ w · n/(n − p)``
    with ``n = (Σ w)² / Σ w²`` the effective number of rows. For λ = 1 this is the textbook
    ``σ̂² (XᵀX)⁻¹`` (R cancels). Noise in the regressors (errors in variables) is not included.
    """
    w, Xw, e = _weighted_rows(X, Y, theta, M, last, lam)
    S = (Xw * w[:, None]).T @ Xw
    A = (Xw * (w**2)[:, None]).T @ Xw
    n_eff = w.sum() ** 2 / (w**2).sum()
    p = X.shape[1]
    sigma2 = float((w * e**2).sum() / w.sum() * n_eff / max(n_eff - p, 1.0))
    left = np.linalg.solve(S, A)  # S⁻¹ A
    cov = sigma2 * np.linalg.solve(S, left.T).T  # σ̂² S⁻¹ A S⁻¹ (S, A symmetric)
    return sigma2, 0.5 * (cov + cov.T)


def _hac_covariance(X, Y, theta, M: int, last: int, lam: float, bandwidth: int):
    """Covariance of θ̂ at row ``last`` valid under the pre-filter's coloured residual (HAC).

    The final estimate is the weighted least squares ``θ̂ = S⁻¹ Σ w_i x_i y_i`` (weights as in
    `_final_covariance`), so ``θ̂ − θ = S⁻¹ Σ_i g_i`` with the scores ``g_i = w_i x_i e_i``. The
    state-variable filter colours the noise in ``e_i`` (and in ``x_i``) over its impulse response,
    so neighbouring scores are correlated and the white-row formula is wrong (on the paper's MSD
    it overstates the spread 6-10x: the residual's power lies above the regressors' band). The
    Newey–West estimator (Newey & West 1987) sums the score autocovariances up to ``bandwidth``
    lags with Bartlett weights,

        Ω = Γ₀ + Σ_{k=1}^{K} (1 − k/(K + 1)) (Γ_k + Γ_kᵀ),   Γ_k = Σ_i g_{i+k} g_iᵀ,

    and ``Cov(θ̂) = S⁻¹ Ω S⁻¹``. ``K`` covers the filter's memory (`_hac_bandwidth`). Noise in the
    regressors biases θ̂ at low SNR (errors in variables); that bias is not in the interval (see
    docs/recursive.md for the measured coverage).
    """
    w, Xw, e = _weighted_rows(X, Y, theta, M, last, lam)
    g = Xw * (w * e)[:, None]  # (n, p) scores
    S = (Xw * w[:, None]).T @ Xw
    n = g.shape[0]
    K = int(min(max(bandwidth, 1), n - 1))
    omega = g.T @ g
    for k in range(1, K + 1):  # K ≤ a few hundred lags; each lag one (p × n)(n × p) product
        gamma = g[k:].T @ g[:-k]
        omega += (1.0 - k / (K + 1.0)) * (gamma + gamma.T)
    p = X.shape[1]
    omega *= n / max(n - p, 1)
    left = np.linalg.solve(S, omega)
    cov = np.linalg.solve(S, left.T).T  # S⁻¹ Ω S⁻¹
    return 0.5 * (cov + cov.T)


def _svf_impulse(reg, spec, dt: float, order: int) -> np.ndarray:
    """Impulse responses of the SVF states ``w, ẇ, …`` (n_imp, highest + 1), to e^-40."""
    sigma_min = 2 * np.pi * reg.cutoff * np.sin(np.pi / (2 * order))
    n_imp = int(min(math.ceil(40.0 / (sigma_min * dt)), 200_000))
    impulse = np.zeros(n_imp)
    impulse[0] = 1.0
    return state_variable_filter(impulse, dt, reg.cutoff, max(spec.order, spec.input_order), order)


def _bias_compensated_ls(
    reg, theta, spec, values, M: int, last: int, lam: float, dt: float, order: int
):
    """Final θ̂ with the errors-in-variables bias of white output noise removed (BCLS).

    Output noise ``ε`` (variance σ²) reaches the columns of the unknown ``a_j`` through the SVF
    state ``h_j`` and ``Y`` through ``−η``, ``η = h_n + Σ_{known a_i} a_i h_i``; so
    ``E[Σ w x xᵀ] = S₀ + σ² Σw H`` and ``E[Σ w x Y] = b₀ + σ² Σw d`` with ``H_jk = ⟨h_j, h_k⟩`` and
    ``d_j = −⟨h_j, η⟩`` (input columns carry no noise). Solving ``(S − σ² Σw H) θ = b − σ² Σw d``,
    with σ² re-estimated from the residual of the compensated fit, removes the bias (Zheng's
    bias-eliminated least squares; Söderström 2007, sec. 4). Returns (θ, S − σ² Σw H).
    """
    i = np.arange(last + 1)
    age = np.where(i <= M, max(last - M - 1, 0), last - i).astype(float)
    with np.errstate(under="ignore"):
        w = lam**age
    X = reg.X[: last + 1]
    Yv = reg.Y[: last + 1]
    S = (X * w[:, None]).T @ X
    b = (X * w[:, None]).T @ Yv
    h = _svf_impulse(reg, spec, dt, order)

    def weighted_sse(th):  # Σ w e², e = Y − X θ
        e = Yv - X @ th
        return float((w * e**2).sum())

    return _bias_compensated_sums(
        reg.names, spec, values, theta, S, b, float(w.sum()), weighted_sse, h
    )


def _bias_compensated_sums(names, spec, values, theta, S, b, sw: float, weighted_sse, h):
    """`_bias_compensated_ls` from the weighted sums ``S = Σ w x xᵀ``, ``b = Σ w x Y``,
    ``Σ w`` and the weighted residual sum of squares as a function of θ (a record read in
    blocks); ``h`` the SVF impulse responses. Returns (θ, S − σ² Σw H)."""
    n_ord = spec.order
    a_names = list(spec.a_names)
    cols = [a_names.index(nm) if nm in a_names else None for nm in names]
    eta = h[:, n_ord].copy()
    for j, name in enumerate(a_names):
        if name not in names:
            eta += values[name] * h[:, j]
    p = len(names)
    H = np.zeros((p, p))
    d = np.zeros(p)
    for q, cq in enumerate(cols):
        if cq is None:
            continue
        d[q] = -float(h[:, cq] @ eta)
        for r, cr in enumerate(cols):
            if cr is not None:
                H[q, r] = float(h[:, cq] @ h[:, cr])
    th = np.asarray(theta, dtype=float)
    Sc = S
    for _ in range(20):
        kappa = _kappa(spec, h, {**values, **dict(zip(names, th, strict=True))})
        sigma2 = weighted_sse(th) / (sw * float(kappa @ kappa))
        Sc = S - sigma2 * sw * H
        new = np.linalg.solve(Sc, b - sigma2 * sw * d)
        done = np.allclose(new, th, rtol=1e-12, atol=0)
        th = new
        if done:
            break
    return th, Sc


def _kappa(spec, h, a) -> np.ndarray:
    """κ = h_n + Σ_{j<n} a_j h_j: white output noise → the regression's residual."""
    kappa = h[:, spec.order].copy()
    for j, name in enumerate(spec.a_names):
        kappa += a[name] * h[:, j]
    return kappa


def _output_noise_covariance(
    reg, theta, spec, values, M: int, last: int, lam: float, dt: float, order: int, S=None
):
    """Covariance of θ̂ at row ``last`` under white noise on the measured output, through the SVF.

    With output noise ``ε`` (variance σ²), the residual of row ``i`` at the true θ is that noise
    through the pre-filter and the model's polynomial: ``e_i = Σ_k κ[s_i − k] ε_k`` with
    ``κ = h_n + Σ_{j<n} a_j h_j`` (``h_j`` the impulse response of the SVF state ``w^(j)``, ``s_i``
    row i's sample; input columns carry no noise). The weighted least squares error is then, to
    first order, ``S⁻¹ Σ_k c_k ε_k`` with ``c_k = Σ_i w_i x_i κ[s_i − k]`` (one convolution), so

        Cov(θ̂) = σ² S⁻¹ (Σ_k c_k c_kᵀ) S⁻¹,    σ² = Σ w e² / (Σ w · ‖κ‖²).

    This is exact for the coloured residual the SVF makes (a lag-window HAC estimate is not: the
    residual's power sits near the cut-off, the regressors' near the system's frequency, and the
    long-run variance of their product is 30-100x below its lag-0 value, which any lag window
    leaks into). Noise in the regressors also biases θ̂ at low SNR (errors in variables); that
    bias is not in the interval (see docs/recursive.md for the measured coverage).
    """
    from scipy.signal import fftconvolve

    i = np.arange(last + 1)
    age = np.where(i <= M, max(last - M - 1, 0), last - i).astype(float)
    with np.errstate(under="ignore"):
        w = lam**age
    X = reg.X[: last + 1]
    e = reg.Y[: last + 1] - X @ theta
    if S is None:
        S = (X * w[:, None]).T @ X
    h = _svf_impulse(reg, spec, dt, order)
    kappa = _kappa(spec, h, {**values, **dict(zip(reg.names, theta, strict=True))})
    s_idx = reg.sample_index[: last + 1]
    N = int(s_idx[-1]) + 1
    xw = np.zeros((N, X.shape[1]))
    xw[s_idx] = X * w[:, None]
    # c_k = Σ_s xw[s] κ[s − k]: a convolution of the time-reversed xw with κ
    C = fftconvolve(xw[::-1], kappa[:, None], axes=0)[:N][::-1]
    sums = (float((w * e**2).sum()), float(w.sum()), X.shape[0])
    pairs = _pairs(_dense_weights(s_idx, w, N), kappa.size)
    return _output_noise_sums(reg.names, spec, h, kappa, S, C.T @ C, sums, pairs)


def _pairs(u, n_imp: int) -> np.ndarray:
    """n(d), d = −D..D: the weighted number of row pairs d samples apart (``u`` dense weights)."""
    from scipy.signal import correlate

    N = u.size
    D = min(N, n_imp) - 1
    return correlate(u, u, mode="full", method="fft")[N - 1 - D : N + D]


def _output_noise_sums(names, spec, h, kappa, S, CtC, sums, pairs):
    """`_output_noise_covariance` from accumulated sums: ``CtC = Σ_k c_k c_kᵀ``, ``sums =
    (Σ w e², Σ w, rows)`` and the row pairs ``pairs`` (`_pairs`)."""
    see, sw, n_rows = sums
    p = S.shape[0]
    sigma2 = see / (sw * float(kappa @ kappa)) * n_rows / max(n_rows - p, 1)
    meat = sigma2 * CtC + sigma2**2 * _quadratic_term(
        SimpleNamespace(names=names), spec, h, kappa, None, pairs=pairs
    )
    left = np.linalg.solve(S, meat)
    cov = np.linalg.solve(S, left.T).T
    return 0.5 * (cov + cov.T)


def _dense_weights(s_idx, w, N: int) -> np.ndarray:
    out = np.zeros(N)
    out[s_idx] = w
    return out


def _quadratic_term(reg, spec, h, kappa, u, pairs=None) -> np.ndarray:
    """The second-order (noise × noise) part of the covariance per σ⁴ (p, p).

    The noise in the columns of the unknown ``a_j`` (``h_j`` through the SVF) meets the
    residual's (``−κ``) in ``Q_c = Σ_i w_i N_{i,c} e_i = εᵀ B_c ε``; for Gaussian noise
    ``Cov(Q_c, Q_c') = σ⁴ [tr(B_c B_c'ᵀ) + tr(B_c B_c')]``. The first trace is already in
    ``σ² Cᵀ C`` (``C`` is built from the noisy regressors); this is the second,
    ``Σ_d n(d) X_{c'}(d) X_c(−d)`` with ``X_c(d) = Σ_m κ[m] h_c[m + d]`` and ``n(d)`` the weighted
    number of row pairs ``d`` samples apart (``pairs``, lags −D..D, when already accumulated; else
    from the dense weights ``u``). Without it the θ1 intervals of the ζ = 0.5 MSD at
    30 dB over-cover (99 %; benchmarks/bench_coverage.py), as the algebraic estimator's did.
    """
    from scipy.signal import correlate

    a_names = list(spec.a_names)
    cols = [(q, a_names.index(nm)) for q, nm in enumerate(reg.names) if nm in a_names]
    p = len(reg.names)
    T = np.zeros((p, p))
    if not cols:
        return T
    n_imp = kappa.size
    if pairs is None:
        N = u.size
        D = min(N, n_imp) - 1
        pairs = correlate(u, u, mode="full", method="fft")[N - 1 - D : N + D]  # n(d), d = -D..D
    D = (pairs.size - 1) // 2
    X = {
        j: correlate(h[:, j], kappa, mode="full", method="fft")[n_imp - 1 - D : n_imp + D]
        for _, j in cols
    }
    for q, j in cols:
        for r, k in cols:
            T[q, r] = float(np.dot(pairs, X[k] * X[j][::-1]))
    return 0.5 * (T + T.T)


def _hac_bandwidth(prefilter: str, cutoff: float, dt: float, order: int, half_width: int) -> int:
    """Lags of the HAC sum: the pre-filter's memory.

    Butterworth SVF: 8 time constants of its slowest mode, ``8 / (ω_c sin(π / 2N) dt)`` samples
    (its impulse response has decayed to 3e-4 there); differential FIR filters: their length
    ``2 M + 1``.
    """
    if prefilter == "butterworth":
        sigma_min = 2 * np.pi * cutoff * np.sin(np.pi / (2 * order))
        return int(math.ceil(8.0 / (sigma_min * dt)))
    return 2 * int(half_width) + 1


def final_uncertainty(
    reg,
    spec,
    theta,
    M: int,
    last: int,
    lam: float,
    dt: float,
    *,
    known,
    prefilter: str,
    prefilter_order,
    bias_compensation: bool,
):
    """The final θ̂ at row ``last`` (bias-compensated on request) and its uncertainty.

    Butterworth pre-filter: white output noise through the SVF (`_output_noise_covariance`),
    with the standard errors withheld where the estimated errors-in-variables bias exceeds
    `MAX_BIAS_TO_STDERR` of them (unless ``bias_compensation``); differential pre-filter:
    Newey–West HAC. Returns (θ̂, covariance, stderr dict or None, stderr_reason or None, the
    method's name).
    """
    values_all = dict(spec.parameters)
    values_all.update(known or {})
    highest = max(spec.order, spec.input_order)
    order = highest + 1 if prefilter_order is None else int(prefilter_order)
    half = max(highest + 1, int(round(2.0 / (reg.cutoff * dt))))
    bandwidth = _hac_bandwidth(prefilter, reg.cutoff, dt, order, half)
    eiv_bias = None
    if prefilter == "butterworth":
        values_known = {k: float(v) for k, v in values_all.items()}
        theta_bc, S_bc = _bias_compensated_ls(
            reg, theta, spec, values_known, M, last, lam, dt, order
        )
        if bias_compensation:
            theta = theta_bc
            cov = _output_noise_covariance(
                reg, theta, spec, values_known, M, last, lam, dt, order, S=S_bc
            )
            method = "bias-compensated; white output noise through the SVF"
        else:
            eiv_bias = theta - theta_bc  # estimated errors-in-variables bias
            cov = _output_noise_covariance(reg, theta, spec, values_known, M, last, lam, dt, order)
            method = "white output noise through the state-variable filter"
    else:
        cov = _hac_covariance(reg.X, reg.Y, theta, M, last, lam, bandwidth)
        method = f"Newey-West HAC, {bandwidth} lags"
    return _stderr_verdict(reg.names, theta, cov, eiv_bias, method)


def _stderr_verdict(names, theta, cov, eiv_bias, method: str):
    """``(θ̂, cov, stderr, reason, method)``: the standard errors, withheld with the reason where
    the estimated errors-in-variables bias ``eiv_bias`` (None: not estimated) exceeds
    `MAX_BIAS_TO_STDERR` of them."""
    stderr = {nm: float(np.sqrt(max(cov[i, i], 0.0))) for i, nm in enumerate(names)}
    if eiv_bias is None:
        return theta, cov, stderr, None, method
    # an interval is honest only if the bias is small against its width
    biased = [
        f"{nm} (bias ≈ {eiv_bias[i]:.3g}, se {stderr[nm]:.3g})"
        for i, nm in enumerate(names)
        if abs(eiv_bias[i]) > MAX_BIAS_TO_STDERR * stderr[nm]
    ]
    if not biased:
        return theta, cov, stderr, None, method
    reason = (
        "the output noise biases the estimate by more than "
        f"{MAX_BIAS_TO_STDERR:g} standard error(s) (errors in the variables): "
        + ", ".join(biased)
        + "; a 95 % interval would not cover. Use bias_compensation=True "
        "for an unbiased estimate with honest standard errors."
    )
    return theta, cov, None, reason, method
