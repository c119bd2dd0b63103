"""The weighted sums a streamed recursive fit accumulates over its rows (`RowMoments`), and the
final estimate's uncertainty computed from them (`uncertainty_from_moments`), with the same
formulas as the in-memory fit (`physid.estimators.recursive.uncertainty`)."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
from scipy.signal import correlate, fftconvolve

from .uncertainty import (
    _bias_compensated_sums,
    _kappa,
    _output_noise_sums,
    _stderr_verdict,
    _svf_impulse,
)


class RowMoments:
    """Weighted sums over the rows of a recursive fit, fed block by block (constant memory).

    Row ``i``'s weight is the recursion's ``w_i = λ^age`` at the final row ``last`` (the OLS start
    rows ``0..M`` share the age of row ``M + 1``). The sums are those of `_final_covariance`,
    `_bias_compensated_ls` and `_output_noise_covariance`; the convolutions ``C_j = xw ⋆ h_j`` of
    the weighted rows with each SVF impulse response are accumulated by overlap-add (a pending
    tail of ``n_imp − 1`` samples), so ``Cᵀ C`` for ``κ = Σ_j a_j h_j`` is ``Σ_jl a_j a_l T_jl``
    at any θ.

    Parameters
    ----------
    spec : LinearODEModel
    online : StreamingRecursiveEstimator
        The estimator whose rows are fed (its cut-off, transient and time step).
    lam : float
        λ.
    init_end, last : int
        Rows M (the OLS start's last) and the final row.
    theta0 : ndarray (p,)
        The centre of the residual sums (the online estimate: Σ w e² about it has no
        cancellation).
    prefilter_order : int or None
        The SVF's order (None: model order + 1).
    """

    def __init__(self, spec, online, *, lam, init_end, last, theta0, prefilter_order):
        self.spec, self.lam, self.M, self.last = spec, float(lam), int(init_end), int(last)
        self.theta0 = np.asarray(theta0, dtype=float)
        p = self.theta0.size
        self.dt = online.dt
        highest = max(spec.order, spec.input_order)
        self.order = highest + 1 if prefilter_order is None else int(prefilter_order)
        self.h = _svf_impulse(
            SimpleNamespace(cutoff=online.prefilter_cutoff), spec, self.dt, self.order
        )
        n_imp = self.h.shape[0]
        nh = spec.order + 1  # κ uses h_0 … h_n
        self.S, self.A = np.zeros((p, p)), np.zeros((p, p))
        self.b, self.sxe0 = np.zeros(p), np.zeros(p)
        self.sw = self.sw2 = self.see0 = 0.0
        self.T = np.zeros((nh * p, nh * p))  # Σ_k [C_0 … C_n]_kᵀ [C_0 … C_n]_k
        first = online.discarded  # sample of row 0; rows are consecutive samples
        self.pending = np.zeros((n_imp - 1, nh * p))
        self.pending_k0 = first - (n_imp - 1)  # the lag index k of pending[0]
        n_samples = first + last + 1
        self.D = min(n_samples, n_imp) - 1
        self.R = np.zeros(self.D + 1)  # n(d), d = 0..D
        self.tail = np.zeros(self.D)  # the last D dense weights
        self.n_rows = 0

    def weights(self, rows: np.ndarray) -> np.ndarray:
        """``w_i`` of rows ``rows`` at the final row."""
        M, last = self.M, self.last
        age = np.where(rows <= M, max(last - M - 1, 0), last - rows).astype(float)
        with np.errstate(under="ignore"):
            return self.lam**age

    def add(self, row0: int, X: np.ndarray, Y: np.ndarray) -> None:
        """Add the rows ``row0 …`` of one block."""
        if not Y.size:
            return
        w = self.weights(row0 + np.arange(Y.size))
        Xw = X * w[:, None]
        self.S += Xw.T @ X  # Σ w x xᵀ
        self.A += (Xw * w[:, None]).T @ X  # Σ w² x xᵀ
        self.b += Xw.T @ Y  # Σ w x Y
        self.sw += float(w.sum())
        self.sw2 += float(w @ w)
        e0 = Y - X @ self.theta0
        self.see0 += float(w @ (e0 * e0))  # Σ w e0²
        self.sxe0 += Xw.T @ e0  # Σ w x e0
        self._convolve(Xw)
        self._pairs(w)
        self.n_rows += Y.size

    def _convolve(self, Xw: np.ndarray) -> None:
        """Overlap-add of ``C_j[k] = Σ_s xw[s] h_j[s − k]`` for this block's samples."""
        B, p = Xw.shape
        nh = self.T.shape[0] // p
        n_imp = self.h.shape[0]
        # the block's contribution to lags k = s_a − (n_imp − 1) … s_b − 1 (time-reversed
        # convolution, as the in-memory form)
        parts = [fftconvolve(Xw[::-1], self.h[:, j : j + 1], axes=0)[::-1] for j in range(nh)]
        total = np.concatenate(parts, axis=1)  # (B + n_imp − 1, nh·p), column j·p + q
        total[: n_imp - 1] += self.pending
        self._settle(total[:B], self.pending_k0)  # no later sample reaches these lags
        self.pending = total[B:].copy()
        self.pending_k0 += B

    def _settle(self, C: np.ndarray, k0: int) -> None:
        """Add the finished lags (those ≥ 0, as the in-memory sum) to ``T``."""
        C = C[max(0, -k0) :]
        self.T += C.T @ C

    def _pairs(self, w: np.ndarray) -> None:
        """n(d) += Σ w[s] w[s − d] for this block's samples s (the last D weights carried)."""
        D = self.D
        z = np.concatenate([self.tail, w])
        self.R += correlate(z, w, mode="valid", method="fft")[::-1]  # [i] ↔ lag D − i
        if D:
            self.tail = z[-D:]

    def finish(self) -> None:
        """Settle the last pending lags (the record ends: nothing more reaches them)."""
        self._settle(self.pending, self.pending_k0)
        self.pending = self.pending[:0]

    def weighted_sse(self, theta) -> float:
        """Σ w (Y − X θ)² from the sums about θ0 (exact in exact arithmetic)."""
        d = np.asarray(theta, dtype=float) - self.theta0
        return float(self.see0 - 2.0 * d @ self.sxe0 + d @ self.S @ d)

    def white_covariance(self, theta):
        """`_final_covariance` (white rows): ``(σ̂², σ̂² S⁻¹ A S⁻¹)``."""
        p = self.S.shape[0]
        n_eff = self.sw**2 / self.sw2
        sigma2 = self.weighted_sse(theta) / self.sw * n_eff / max(n_eff - p, 1.0)
        left = np.linalg.solve(self.S, self.A)
        cov = sigma2 * np.linalg.solve(self.S, left.T).T
        return float(sigma2), 0.5 * (cov + cov.T)

    def CtC(self, kappa_coefficients) -> np.ndarray:
        """``Σ_k c_k c_kᵀ`` for ``κ = Σ_j c_j h_j`` (j = 0 … n)."""
        p = self.S.shape[0]
        K = np.kron(np.asarray(kappa_coefficients, dtype=float)[:, None], np.eye(p))
        return K.T @ self.T @ K

    def pair_counts(self) -> np.ndarray:
        """n(d) for d = −D … D."""
        return np.concatenate([self.R[:0:-1], self.R])


def uncertainty_from_moments(acc: RowMoments, spec, names, theta, values, *, bias_compensation):
    """`final_uncertainty` (Butterworth pre-filter) from accumulated `RowMoments`.

    Returns (θ̂, covariance, stderr dict or None, stderr_reason or None, the method's name).
    """
    values = {k: float(v) for k, v in values.items()}
    h = acc.h
    theta = np.asarray(theta, dtype=float)
    theta_bc, S_bc = _bias_compensated_sums(
        names, spec, values, theta, acc.S, acc.b, acc.sw, acc.weighted_sse, h
    )
    eiv_bias = None
    S = acc.S
    if bias_compensation:
        theta, S = theta_bc, S_bc
        method = "bias-compensated; white output noise through the SVF"
    else:
        eiv_bias = theta - theta_bc
        method = "white output noise through the state-variable filter"
    a = {**values, **dict(zip(names, theta, strict=True))}
    kappa = _kappa(spec, h, a)
    coefficients = [a[nm] for nm in spec.a_names] + [1.0]  # κ = Σ_j a_j h_j + h_n
    sums = (acc.weighted_sse(theta), acc.sw, acc.n_rows)
    cov = _output_noise_sums(
        names, spec, h, kappa, S, acc.CtC(coefficients), sums, acc.pair_counts()
    )
    return _stderr_verdict(names, theta, cov, eiv_bias, method)
