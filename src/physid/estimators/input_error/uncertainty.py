"""Input-error's standard errors: iid, the HAC sandwich for the filtered residual, combinations.

Part of `physid.estimators.input_error`. The noise-compensated covariance (from re-noised
replicates) is computed with the compensated solve, in `.solve`.
"""

from __future__ import annotations

import math

import numpy as np

from ...models.identifiability import NUMERIC_RTOL, svd_tall


def hac_lags(half_width: int) -> int:
    """Flat part L [samples] of the HAC kernel for filters of half-width M: ``L = 2M``.

    The residual at sample t is a 2M + 1-tap FIR of the noise on q and τ (the filters of
    half-width M), so residuals more than 2M samples apart share no noise sample: their
    covariance is zero. The kernel is 1 up to lag L and tapers to 0 at 2L.

    Parameters
    ----------
    half_width : int
        M of the filters.

    Returns
    -------
    int [samples]
    """
    return 2 * int(half_width)


def iid_covariance(jacobian, residuals, *, rtol: float = NUMERIC_RTOL) -> np.ndarray:
    """``s² (JᵀJ)⁻¹``: the covariance if the residuals were independent with one variance.

    ``s² = |e|² / (n_rows - p)``; ``(JᵀJ)⁻¹ = V S⁻² Vᵀ`` through the SVD ``J = U S Vᵀ`` (no
    explicit inverse). Optimistic for filtered residuals (see `sandwich_covariance`).

    Parameters
    ----------
    jacobian : array_like, shape (n_rows, p)
    residuals : array_like, n_rows values in any shape
    rtol : float
        Singular values below ``rtol * s_max`` make the covariance infinite.

    Returns
    -------
    ndarray, shape (p, p)
    """
    jac = np.asarray(jacobian, dtype=float)
    e = np.asarray(residuals, dtype=float)
    p = jac.shape[1]
    s2 = float(np.sum(e**2)) / max(e.size - p, 1)
    sv, vt = svd_tall(jac)
    if sv.size < p or not np.all(sv > rtol * sv[0]):
        return np.full((p, p), np.inf)
    return s2 * (vt.T / sv**2) @ vt


def sandwich_covariance(jacobian, residuals, lags: int, *, rtol: float = NUMERIC_RTOL):
    """Covariance of a least-squares estimate whose residuals are correlated over ``lags`` samples.

    Derivation. θ̂ minimises ``S(θ) = Σ_t e_tᵀ e_t`` (e_t: the residuals of sample t, one per
    joint), so ``Σ_t J_tᵀ e_t(θ̂) = 0`` with ``J_t = ∂e_t/∂θ``. Linearising about the limit θ*,
    ``θ̂ - θ* ≈ -H⁻¹ Σ_t g_t`` with the Hessian approximation ``H = Σ_t J_tᵀ J_t = JᵀJ`` and the
    score of sample t ``g_t = J_tᵀ e_t`` (p values). Hence the sandwich::

        Cov(θ̂) = H⁻¹ Ω H⁻¹,   Ω = Var(Σ_t g_t) = Γ_0 + Σ_{l>=1} (Γ_l + Γ_lᵀ),
        Γ_l = Σ_t g_{t+l} g_tᵀ.

    The iid formula ``s² H⁻¹`` is the special case where every Γ_l (l >= 1) vanishes and e is
    homoscedastic; the filtered residual is neither (a white noise on q comes out of the
    2M + 1-tap filters correlated over 2M samples, with a spectrum shaped like Ω^4 by q̈^f).
    Ω is estimated with a flat-top kernel (Politis & Romano 1995; a Newey–West estimator with a
    trapezoidal instead of a Bartlett window): weight 1 up to lag L (`hac_lags`: 2M, beyond which
    the filtered noise has no correlation, so the kernel does not bias the sum), tapering to 0 at
    2L; the estimate is projected onto the positive semi-definite matrices (negative eigenvalues,
    which the flat-top kernel can leave, set to 0). H⁻¹ is applied through the SVD of J, never
    inverted explicitly.

    Parameters
    ----------
    jacobian : array_like, shape (n_samples * n_joints, p)
        ``∂e/∂θ`` of the free parameters, rows ordered like ``residuals.ravel()``.
    residuals : array_like, shape (n_samples, n_joints)
        ``e(θ̂)``.
    lags : int [samples]
        Flat part L of the kernel (0: the heteroskedasticity-robust sandwich, no correlation).
    rtol : float
        Singular values of J below ``rtol * s_max`` make the covariance infinite.

    Returns
    -------
    ndarray, shape (p, p)
        The covariance (``inf`` everywhere when J is numerically rank-deficient).

    Notes
    -----
    Γ_l for l = 0..2L come from FFT cross-correlations of the scores, one parameter at a time:
    peak memory ``O(n_samples · p)`` floats beyond the Jacobian itself.

    Examples
    --------
    A straight-line fit with iid residuals: with L = 0 the sandwich agrees with s² (JᵀJ)⁻¹ to
    the sampling error of the variance:

    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> x = np.linspace(0, 1, 4000)
    >>> jac = np.column_stack([np.ones_like(x), x])
    >>> e = rng.normal(size=(x.size, 1))
    >>> cov = sandwich_covariance(jac, e, lags=0)
    >>> iid = np.linalg.inv(jac.T @ jac)
    >>> bool(np.allclose(np.diag(cov) / np.diag(iid), 1.0, rtol=0.1))
    True
    """
    from scipy import fft

    e = np.asarray(residuals, dtype=float)
    if e.ndim == 1:
        e = e[:, None]
    n, nj = e.shape
    jac = np.asarray(jacobian, dtype=float)
    p = jac.shape[1]
    g = np.einsum("tjp,tj->tp", jac.reshape(n, nj, p), e)  # g_t = J_tᵀ e_t
    lags = int(lags)
    top = min(2 * lags, n - 1)  # the kernel reaches 0 at lag 2L
    lag = np.arange(top + 1)
    weight = np.clip(2.0 - lag / lags, 0.0, 1.0) if lags > 0 else (lag == 0).astype(float)
    nfft = fft.next_fast_len(n + top + 1)
    spec = fft.rfft(g, nfft, axis=0)
    omega = np.empty((p, p))
    for a in range(p):  # Γ_l[a, :] = Σ_t g_a[t + l] g[t]: irfft(G_a conj(G))[l]
        corr = fft.irfft(spec[:, a, None] * np.conj(spec), nfft, axis=0)[: top + 1]
        omega[a] = weight @ corr  # Σ_l w_l Γ_l[a, :] over l >= 0
    omega = omega + omega.T - g.T @ g  # Γ_0 + Σ_{l>=1} w_l (Γ_l + Γ_lᵀ)
    lam, vec = np.linalg.eigh(0.5 * (omega + omega.T))
    omega = (vec * np.clip(lam, 0.0, None)) @ vec.T  # nearest PSD matrix
    sv, vt = svd_tall(jac)
    if sv.size < p or not np.all(sv > rtol * sv[0]):
        return np.full((p, p), np.inf)
    h_inv_half = vt.T / sv**2  # H⁻¹ = V S⁻² Vᵀ
    return h_inv_half @ (vt @ omega @ vt.T) @ h_inv_half.T


def _expression_values(expressions, names, theta, cov_free, free_idx):
    """Value and delta-method standard error of each combination expression."""
    import sympy as sp

    symbols = [sp.Symbol(n) for n in names]
    env = dict(zip(names, symbols, strict=True))
    values, errors = {}, {}
    from ...errors import ExpressionError
    from ...expressions import parse_expression

    for expr_text in expressions:
        try:  # the whitelist parser, never sympify: the names may come from a user's file
            expr = parse_expression(str(expr_text), env)
        except ExpressionError:
            continue
        if not expr.free_symbols <= set(symbols):
            continue
        subs = dict(zip(symbols, theta, strict=True))
        values[expr_text] = float(expr.subs(subs))
        grad = np.array([float(sp.diff(expr, symbols[i]).subs(subs)) for i in free_idx])
        var = float(grad @ cov_free @ grad) if cov_free.size else 0.0
        errors[expr_text] = math.sqrt(var) if var >= 0 and math.isfinite(var) else float("inf")
    return values, errors
