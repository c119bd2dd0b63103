"""The RLS recursion itself, one row or a chunk at a time: the pure step `rls_update` and the
stateful `StreamingRLS` (Joseph-form covariance update with a cap on its trace)."""

from __future__ import annotations

import math

import numpy as np

from ..._validate import as_1d, as_2d, check_finite, check_positive
from ...errors import InputError, ShapeError
from .batch import _check_forgetting, _check_init_samples, _packed_solve

#: Default cap of trace(P) in the streaming form, relative to trace(P) at initialisation.
DEFAULT_COVARIANCE_LIMIT_FACTOR = 1e8


def rls_update(
    theta,
    P,
    x,
    y,
    forgetting: float = 1.0,
    weight: float = 1.0,
    *,
    covariance_limit: float = math.inf,
):
    """One step of the recursion (eq. 3) with a Joseph-form covariance update; pure function.

    Parameters
    ----------
    theta : array_like, shape (p,)
        θ̂_k.
    P : array_like, shape (p, p)
        P_k, symmetric positive definite.
    x : array_like, shape (p,)
        Regressor row x_{k+1}.
    y : float
        Observation y_{k+1}.
    forgetting : float in (0, 1]
        λ.
    weight : float > 0
        R.
    covariance_limit : float, default inf
        Cap on trace(P_{k+1}): when ``trace(P⁺) / λ`` would exceed it, the step forgets less,
        ``λ_eff = max(λ, trace(P⁺) / limit)`` (anti-wind-up for directions without excitation).

    Returns
    -------
    (theta, P) : new arrays; the inputs are not modified.

    Examples
    --------
    With P = I, R = 1 and x = (1, 0), the gain is 1/2 and P₁₁ halves:

    >>> th, P = rls_update(np.zeros(2), np.eye(2), np.array([1.0, 0.0]), 2.0)
    >>> th.tolist(), P.tolist()
    ([1.0, 0.0], [[0.5, 0.0], [0.0, 1.0]])
    """
    theta = np.asarray(theta, dtype=float)
    P = np.asarray(P, dtype=float)
    x = np.asarray(x, dtype=float)
    v = P @ x  # P_k x
    s = weight + x @ v  # R + xᵀ P_k x  (> 0)
    K = v / s  # K = P_k x (R + xᵀ P_k x)⁻¹
    theta_new = theta + K * (y - x @ theta)  # θ + K α,  α = y − xᵀ θ
    # Joseph form: P⁺ = (I − K xᵀ) P (I − K xᵀ)ᵀ + K R Kᵀ, expanded as P − K vᵀ − v Kᵀ + s K Kᵀ.
    # It equals the printed P − K xᵀ P for the optimal K but is symmetric term by term and PSD for
    # any K (errors in K enter at second order), where the printed form loses symmetry.
    Kv = np.outer(K, v)
    P_plus = P - Kv - Kv.T + s * np.outer(K, K)
    P_plus = 0.5 * (P_plus + P_plus.T)
    lam_eff = max(forgetting, np.trace(P_plus) / covariance_limit)
    return theta_new, P_plus / min(lam_eff, 1.0)


def _rls_rows_2(theta, P, X_rows, Y_rows, lam, r, limit, out_theta, out_P):
    """`_rls_rows` unrolled for p = 2 (the MSD): about 1 µs per row instead of 13."""
    t0, t1 = theta
    (a, b), (_, d) = P  # P = [[a, b], [b, d]]
    store_theta = out_theta.append
    store_P = out_P.append
    for (x0, x1), y in zip(X_rows, Y_rows, strict=True):
        v0 = a * x0 + b * x1  # v = P x
        v1 = b * x0 + d * x1
        s = r + x0 * v0 + x1 * v1  # s = R + xᵀ P x
        K0 = v0 / s  # K = P x / s
        K1 = v1 / s
        alpha = y - x0 * t0 - x1 * t1  # α = y − xᵀ θ
        t0 += K0 * alpha  # θ ← θ + K α
        t1 += K1 * alpha
        a = a - 2.0 * K0 * v0 + s * K0 * K0  # Joseph: P − K vᵀ − v Kᵀ + s K Kᵀ
        b = b - K0 * v1 - v0 * K1 + s * K0 * K1
        d = d - 2.0 * K1 * v1 + s * K1 * K1
        trace = a + d  # P ← P⁺ / λ_eff,  λ_eff = max(λ, trace(P⁺) / limit) ≤ 1
        lam_eff = lam if trace <= lam * limit else min(trace / limit, 1.0)
        if lam_eff < 1.0:
            a /= lam_eff
            b /= lam_eff
            d /= lam_eff
        store_theta((t0, t1))
        store_P((a, b, b, d))
    return [t0, t1], [[a, b], [b, d]]


def _rls_rows(theta, P, X_rows, Y_rows, lam, r, limit, out_theta, out_P):
    """The recursion over a block of rows in Python floats (p is small; numpy per row is slow).

    Same equations as `rls_update` (Joseph form, trace cap); writes θ and P after each row.
    """
    p = len(theta)
    if p == 2:
        return _rls_rows_2(theta, P, X_rows, Y_rows, lam, r, limit, out_theta, out_P)
    rng = range(p)
    for x, y in zip(X_rows, Y_rows, strict=True):
        v = [sum(P[i][j] * x[j] for j in rng) for i in rng]  # v = P x
        s = r + sum(x[i] * v[i] for i in rng)  # s = R + xᵀ P x
        K = [vi / s for vi in v]  # K = P x / s
        alpha = y - sum(x[i] * theta[i] for i in rng)  # α = y − xᵀ θ
        theta = [theta[i] + K[i] * alpha for i in rng]  # θ ← θ + K α
        # Joseph form P⁺ = P − K vᵀ − v Kᵀ + s K Kᵀ, filled upper triangle → exactly symmetric.
        Pn = [[0.0] * p for _ in rng]
        trace = 0.0
        for i in rng:
            Ki, vi, Pi = K[i], v[i], P[i]
            for j in range(i, p):
                val = Pi[j] - Ki * v[j] - vi * K[j] + s * Ki * K[j]
                Pn[i][j] = val
                Pn[j][i] = val
            trace += Pn[i][i]
        lam_eff = min(max(lam, trace / limit), 1.0)  # forget less when trace(P) passes the cap
        if lam_eff < 1.0:
            inv = 1.0 / lam_eff
            Pn = [[val * inv for val in row] for row in Pn]
        P = Pn
        out_theta.append(theta)
        out_P.append([val for row in P for val in row])
    return theta, P


class StreamingRLS:
    """The RLS recursion (eq. 3) fed one row or a chunk of rows at a time.

    Parameters
    ----------
    n_parameters : int
        p, the number of unknowns.
    forgetting : float in (0, 1], default 1
        λ.
    weight : float > 0, default 1
        R.
    init_samples : int, optional
        Rows for the OLS initialisation (eq. 4); default 10 p. If those rows do not determine θ
        (singular ``Σ x xᵀ``), rows are added until they do — the same rule as the batch form.
    covariance_limit : float, optional
        Cap on trace(P); default 1e8 × trace(P) at initialisation. It is inactive whenever the
        regressors keep some excitation, and then the streaming and batch forms agree.

    Attributes
    ----------
    theta : ndarray (p,) — current θ̂ (NaN before initialisation).
    covariance : ndarray (p, p) — current P.
    n_rows : int — rows received.
    init_end : int or None — index M of the last OLS row.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> X = rng.normal(size=(50, 2)); Y = X @ [2.0, -1.0]
    >>> est = StreamingRLS(2, init_samples=5)
    >>> th = est.update(X[:20], Y[:20]); th = est.update(X[20:], Y[20:])
    >>> np.allclose(est.theta, [2.0, -1.0])
    True
    """

    def __init__(
        self,
        n_parameters: int,
        *,
        forgetting: float = 1.0,
        weight: float = 1.0,
        init_samples: int | None = None,
        covariance_limit: float | None = None,
    ):
        self.n_parameters = int(n_parameters)
        if self.n_parameters < 1:
            raise InputError(f"n_parameters must be >= 1; got {n_parameters!r}.")
        self.forgetting = _check_forgetting(forgetting)
        self.weight = check_positive(weight, "weight")
        p = self.n_parameters
        self.init_samples = _check_init_samples(init_samples, p)
        self._limit_setting = covariance_limit
        if covariance_limit is not None:
            check_positive(covariance_limit, "covariance_limit")
        self._limit = math.inf
        # running sums of the OLS start (eq. 4) until it happens: Σ x xᵀ / R (upper triangle),
        # Σ x y / R and the number of rows
        self._sum_S = np.zeros(self.n_parameters * (self.n_parameters + 1) // 2)
        self._sum_B = np.zeros(self.n_parameters)
        self._n_accumulated = 0
        self._theta: list[float] | None = None
        self._P: list[list[float]] | None = None
        self.n_rows = 0
        self.init_end: int | None = None

    @property
    def covariance_limit(self) -> float:
        """The trace(P) cap in force (inf before initialisation)."""
        return self._limit

    @property
    def theta(self) -> np.ndarray:
        """θ̂ after the last row, shape (p,) (NaN before initialisation)."""
        if self._theta is None:
            return np.full(self.n_parameters, np.nan)
        return np.array(self._theta)

    @property
    def covariance(self) -> np.ndarray:
        """P after the last row, shape (p, p) (eq. 3's P; NaN before initialisation)."""
        if self._P is None:
            return np.full((self.n_parameters, self.n_parameters), np.nan)
        return np.array(self._P)

    @property
    def initialized(self) -> bool:
        """Whether the OLS start (eq. 4) has happened."""
        return self._theta is not None

    def update(self, x, y, *, return_covariance: bool = False):
        """Feed one row (x shape (p,), y scalar) or a chunk (x (n, p), y (n,)).

        Returns
        -------
        ndarray, shape (n, p)
            θ̂ after each row (NaN before initialisation); with ``return_covariance`` also the
            (n, p, p) P after each row.
        """
        p = self.n_parameters
        X = as_2d(x, "x") if np.ndim(x) != 1 else as_1d(x, "x")[None, :]
        Y = as_1d(y, "y")
        if X.shape[1] != p or X.shape[0] != Y.size:
            raise ShapeError(
                f"x must have shape (n, {p}) and y shape (n,); got x {X.shape} and y {Y.shape}."
            )
        check_finite(X, "x")
        check_finite(Y[:, None], "y")
        n = X.shape[0]
        out_theta = np.full((n, p), np.nan)
        out_P = np.full((n, p, p), np.nan)
        start = 0
        if self._theta is None:
            start = self._try_initialise(X, Y, out_theta, out_P)
        if self._theta is not None and start < n:
            th_rows: list = []
            P_rows: list = []
            self._theta, self._P = _rls_rows(
                self._theta,
                self._P,
                X[start:].tolist(),
                Y[start:].tolist(),
                self.forgetting,
                self.weight,
                self._limit,
                th_rows,
                P_rows,
            )
            out_theta[start:] = np.array(th_rows)
            out_P[start:] = np.array(P_rows).reshape(-1, p, p)
        self.n_rows += n
        return (out_theta, out_P) if return_covariance else out_theta

    def _try_initialise(self, X, Y, out_theta, out_P) -> int:
        """Accumulate rows until the OLS of eq. 4 is defined; return the first row left to recurse.

        Only the running sums ``S = Σ x xᵀ / R`` (upper triangle) and ``B = Σ x y / R`` are kept
        (O(p²) memory), and a chunk's candidate starts are tested together: the cumulative sums of
        the chunk's rows give ``S`` at every row, one vectorised equilibrated solve tests them
        all (O(p³) per row, independent of how many rows came before — the old form re-solved the
        whole buffer at every row, O(n²) on input that never excites the system).
        """
        p = self.n_parameters
        iu = np.triu_indices(p)
        G = X[:, iu[0]] * X[:, iu[1]] / self.weight  # (n, p(p+1)/2) rows of Σ x xᵀ / R
        g = X * Y[:, None] / self.weight
        # The running sums continue across chunks in one sequential order, ((S + G₁) + G₂) + …,
        # so that chunked input gives the same bits as one call (S + cumsum(G) would not).
        S_rows = np.cumsum(np.vstack([self._sum_S, G]), axis=0)[1:]
        B_rows = np.cumsum(np.vstack([self._sum_B, g]), axis=0)[1:]
        count = self._n_accumulated + np.arange(1, X.shape[0] + 1)
        candidates = np.flatnonzero(count >= self.init_samples)
        if candidates.size:
            theta, S_inv, ok = _packed_solve(S_rows[candidates], B_rows[candidates], p)
            hits = np.flatnonzero(ok)
            if hits.size:
                j = int(hits[0])
                k = int(candidates[j])
                th, Si = theta[j], S_inv[j]
                self._theta = th.tolist()  # θ_M = P_M B_M            (eq. 4)
                self._P = (0.5 * (Si + Si.T)).tolist()  # P_M = (X_Mᵀ R⁻¹ X_M)⁻¹
                trace0 = float(np.trace(Si))
                self._limit = (
                    DEFAULT_COVARIANCE_LIMIT_FACTOR * trace0
                    if self._limit_setting is None
                    else float(self._limit_setting)
                )
                self.init_end = self.n_rows + k
                out_theta[k] = th
                out_P[k] = self._P
                self._sum_S = np.zeros(iu[0].size)
                self._sum_B = np.zeros(p)
                self._n_accumulated = 0
                return k + 1
        self._sum_S = S_rows[-1].copy()
        self._sum_B = B_rows[-1].copy()
        self._n_accumulated = int(count[-1])
        return X.shape[0]
