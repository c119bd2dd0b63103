"""IDIM stage 6: the covariance of the estimate (filtered, HAC or iid standard errors).

Standard errors are a heteroscedasticity-and-autocorrelation-consistent (HAC) sandwich
(Newey & West 1987, Bartlett weights): the filters leave the decimated residual correlated over a
few rows and of different variance per joint, and the classical ``σ² (WᵀW)⁻¹`` then is too
optimistic. ``stderr="filtered"`` uses the correlation the parallel filter gives white noise
instead of estimating it; ``stderr="iid"`` gives the classical form (with a variance per joint
when ``per_joint_variance=True``).
"""

from __future__ import annotations

import math

import numpy as np

from .decimation import decimated_noise_correlation

__all__ = ["hac_covariance", "covariance", "STDERR_METHODS"]

#: Ways `covariance` computes the standard errors.
STDERR_METHODS = ("hac", "iid", "filtered")


def _newey_west_lag(n_rows: int) -> int:
    """Newey–West plug-in lag ``floor(4 (T/100)^(2/9))``."""
    return int(math.floor(4.0 * (n_rows / 100.0) ** (2.0 / 9.0)))


def _correlation_length(e: np.ndarray, segments: np.ndarray) -> int:
    """First lag at which the mean (over joints) residual autocorrelation drops below 0.1."""
    seg0 = e[segments == segments[0]]
    x = seg0 - seg0.mean(axis=0)
    n = x.shape[0]
    nfft = 1 << int(math.ceil(math.log2(2 * n)))
    spec = np.abs(np.fft.rfft(x, nfft, axis=0)) ** 2
    acf = np.fft.irfft(spec, nfft, axis=0)[:n]
    acf = acf / np.where(acf[0] > 0, acf[0], 1.0)
    mean_acf = acf.mean(axis=1)
    below = np.flatnonzero(mean_acf < 0.1)
    return int(below[0]) if below.size else n // 4


def hac_covariance(scores, bread_inv, segments=None, lag: int | None = None) -> np.ndarray:
    """Newey–West (Bartlett) sandwich ``A⁻¹ S A⁻ᵀ`` for a (possibly IV) least-squares estimate.

    Parameters
    ----------
    scores : array_like, shape (n_rows, p)
        Per time row, the sum over joints of instrument × residual, ``g_t = Σ_j Z_tj e_tj``.
    bread_inv : array_like, shape (p, p)
        ``A⁻¹`` with ``A = Zᵀ W`` (``WᵀW`` for OLS).
    segments : array_like of int, shape (n_rows,), optional
        Recording of each row: lags never pair rows of two recordings.
    lag : int, optional
        Bandwidth L (Bartlett weights ``1 − l/(L+1)``); default: Newey–West's plug-in.

    Returns
    -------
    ndarray, shape (p, p)
        ``A⁻¹ (Σ_{|l|≤L} w_l Γ_l) A⁻ᵀ``, ``Γ_l = Σ_t g_t g_{t−l}ᵀ``.
    """
    g = np.asarray(scores, dtype=float)
    n = g.shape[0]
    seg = np.zeros(n, dtype=int) if segments is None else np.asarray(segments)
    lag = _newey_west_lag(n) if lag is None else int(lag)
    S = g.T @ g
    for ell in range(1, lag + 1):
        same = seg[ell:] == seg[:-ell]
        gamma = (g[ell:] * same[:, None]).T @ g[:-ell]
        S += (1.0 - ell / (lag + 1.0)) * (gamma + gamma.T)
    B = np.asarray(bread_inv, dtype=float)
    return B @ S @ B.T


def covariance(
    W, e, weights, Z, segments, *, decimate=1, stderr="filtered", per_joint_variance=True, lag=None
):
    """Covariance of the estimate: HAC sandwich, classical (per-joint variance), or classical
    with the correlation the parallel filter gives white noise (``stderr="filtered"``).

    Parameters
    ----------
    W : ndarray, shape (n_rows, n_joints, p)
    e : ndarray, shape (n_rows, n_joints)
        Residual ``y − W β̂``.
    weights : ndarray, shape (n_joints,)
    Z : ndarray like W, or None
        The instruments (IV); None for least squares.
    segments : ndarray of int, shape (n_rows,)
    decimate : int
        nd of the rows (``stderr="filtered"``).
    stderr : {"filtered", "hac", "iid"}
    per_joint_variance : bool
        iid and filtered: one variance per joint instead of a pooled one.
    lag : int, optional
        HAC bandwidth (default: from the residual's correlation length).

    Returns
    -------
    cov : ndarray, shape (p, p)
    lag : int
        The lag used (0 for iid).
    reason : str or None
        Why there is no covariance (singular normal equations), else None.
    """
    n, nj = e.shape
    p = W.shape[-1]
    Ww = W * weights[None, :, None]
    ew = e * weights[None, :]
    A_rows = Ww if Z is None else Z * weights[None, :, None]
    A = A_rows.reshape(-1, p).T @ Ww.reshape(-1, p)  # ZᵀW (WᵀW for LS), weighted
    try:
        A_inv = np.linalg.solve(A, np.eye(p))
    except np.linalg.LinAlgError:
        return np.full((p, p), np.nan), 0, "the normal equations are singular"
    dof = n * nj / max(n * nj - p, 1)
    if stderr == "hac":
        if lag is None:
            lag = max(_newey_west_lag(n), 3 * _correlation_length(ew, segments))
            lag = int(min(lag, max(n // 4, 1)))
        scores = np.einsum("tjp,tj->tp", A_rows, ew)  # g_t = Σ_j Z_tj e_tj
        cov = dof * hac_covariance(scores, A_inv, segments, lag)
        return cov, lag, None
    # iid: Cov = A⁻¹ (Σ_j Z_jᵀ Σ_jj W_j... ) A⁻ᵀ with the weighted residual variance
    if per_joint_variance:
        var = np.sum(ew**2, axis=0) / max(n - p / nj, 1.0)
    else:
        var = np.full(nj, np.sum(ew**2) / max(n * nj - p, 1))
    Zs = A_rows * np.sqrt(var)[None, :, None]
    meat = Zs.reshape(-1, p).T @ Zs.reshape(-1, p)
    if stderr == "filtered":  # Σ_j = σ_j² R, R_kl = ρ(|k − l|) within a recording
        rho = decimated_noise_correlation(int(decimate))
        for ell in range(1, min(rho.size, n)):
            same = (segments[ell:] == segments[:-ell])[:, None, None]
            G = np.einsum("tjp,tjq->pq", Zs[ell:] * same, Zs[:-ell])
            meat += rho[ell] * (G + G.T)
        return A_inv @ meat @ A_inv.T, rho.size - 1, None
    return A_inv @ meat @ A_inv.T, 0, None
