"""Finite Fourier series trajectories, the criteria of their base regressor, and the constrained
search of `physid.analysis.excitation.design_excitation` (the design variables, the smooth
objective, SLSQP from several starts, the final shrink into the limits); see that module's
docstring for the method."""

from __future__ import annotations

import time

import numpy as np
from scipy import optimize

from .._progress import Progress

#: Fraction of each limit the designed trajectory may use.
MARGIN = 0.98
#: Sharpness p of the soft maximum / minimum of log λ in the search objective.
SOFT_P = 20.0
#: Forward-difference step of the search gradient (design variables are O(0.1–1)).
FD_STEP = 1e-6
#: Largest regressor batch of the gradient [bytes] (evaluated in chunks beyond it).
BATCH_BYTES = 64 * 2**20


def fourier_trajectory(coefficients, t, period: float, q_start):
    """Evaluate the finite Fourier series of the module docstring.

    Parameters
    ----------
    coefficients : array_like, shape (n_joints, 2, H)
        ``a_jl``, ``b_jl`` [rad/s] (scale included).
    t : array_like, shape (n,) [s]
    period : float [s]
    q_start : array_like, shape (n_joints,) [rad]
        q(0).

    Returns
    -------
    q, qd, qdd : ndarray, each (n, n_joints) [rad], [rad/s], [rad/s²]
    """
    c = np.asarray(coefficients, dtype=float)
    t = np.asarray(t, dtype=float)
    H = c.shape[2]
    wf = 2.0 * np.pi / float(period)
    lw = wf * np.arange(1, H + 1)  # l ω_f
    arg = t[:, None] * lw[None, :]  # (n, H)
    s, co = np.sin(arg), np.cos(arg)
    a, b = c[:, 0, :], c[:, 1, :]  # (nj, H)
    phi = (s / lw) @ a.T - (co / lw) @ b.T
    phi0 = -(1.0 / lw) @ b.T
    q = np.asarray(q_start, dtype=float)[None, :] + phi - phi0[None, :]
    qd = co @ a.T + s @ b.T
    qdd = (-s * lw) @ a.T + (co * lw) @ b.T
    return q, qd, qdd


def _full_coefficients(free: np.ndarray, nj: int, H: int) -> np.ndarray:
    """a_j1 = −Σ_{l≥2} a_jl, b_j1 = −Σ_{l≥2} l b_jl / 1 (rest at t = 0); shape (nj, 2, H)."""
    x = free.reshape(nj, 2, H - 1)
    c = np.zeros((nj, 2, H))
    c[:, :, 1:] = x
    c[:, 0, 0] = -x[:, 0].sum(axis=1)
    c[:, 1, 0] = -(x[:, 1] * np.arange(2, H + 1)).sum(axis=1)
    return c


def _scaled(free, nj, H, period, t, q_start, limits):
    """Coefficients scaled to the largest amplitude meeting every limit on grid t, and the
    trajectory (the baseline "random, scaled to the limits")."""
    c = _full_coefficients(free, nj, H)
    q, qd, qdd = fourier_trajectory(c, t, period, np.zeros(nj))
    lo = limits["position"][:, 0] - q_start
    hi = limits["position"][:, 1] - q_start
    with np.errstate(divide="ignore", invalid="ignore"):
        up = np.where(q.max(axis=0) > 0, hi / q.max(axis=0), np.inf)
        down = np.where(q.min(axis=0) < 0, lo / q.min(axis=0), np.inf)
        sv = limits["velocity"] / np.abs(qd).max(axis=0)
        sa = limits["acceleration"] / np.abs(qdd).max(axis=0)
    s = MARGIN * np.nanmin(np.vstack([up, down, sv, sa]), axis=0)
    s = np.where(np.isfinite(s), s, 0.0)
    c = c * s[:, None, None]
    return c, q * s + q_start, qd * s, qdd * s


def _base_rows(model, columns, q, qd, qdd) -> np.ndarray:
    """The base regressor stacked over samples and joints, (n·n_joints, p)."""
    Y = np.asarray(model.regressor(q, qd, qdd), dtype=float)[:, :, columns]
    return Y.reshape(-1, Y.shape[-1])


def _eigs_scaled(a: np.ndarray) -> np.ndarray | None:
    """Eigenvalues (ascending) of the column-scaled information matrix ``D aᵀa D``; None when a
    column is zero. Batched over leading axes of ``a`` (…, rows, p)."""
    G = np.matmul(np.swapaxes(a, -1, -2), a)
    d = np.sqrt(np.einsum("...ii->...i", G))
    if np.any(d == 0):
        return None
    G = G / d[..., :, None] / d[..., None, :]
    return np.linalg.eigvalsh(G)


def _criteria(model, columns, q, qd, qdd) -> tuple[float, float]:
    """Column-scaled condition number and log det of the base regressor on the grid.

    From the eigenvalues of the column-scaled Gram matrix ``G = D WᵀW D`` (p × p): σ_i² = λ_i.
    Squaring costs digits only beyond a condition number of ~1e7, far above any design worth
    keeping, and a p × p eigenproblem is much cheaper than an SVD of the tall W (and immune to
    the BLAS thread oversubscription that makes a tall SVD 70× slower on a loaded machine).
    """
    lam = _eigs_scaled(_base_rows(model, columns, q, qd, qdd))
    if lam is None or lam[0] <= 0:
        return float("inf"), -float("inf")
    return float(np.sqrt(lam[-1] / lam[0])), float(np.sum(np.log(lam)))


def _unscaled_cond(model, columns, q, qd, qdd) -> float:
    """Condition number of the unscaled base regressor (unit-dependent)."""
    s = np.linalg.svd(_base_rows(model, columns, q, qd, qdd), compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else float("inf")


class _Search:
    """The design variables z = (free coefficients per joint, q_start), the linear maps from z
    to q, q̇, q̈ on the search grid, and the batched objective."""

    def __init__(self, model, columns, H, period, t, nj, criterion):
        self.model, self.columns, self.H, self.nj = model, columns, H, nj
        self.period, self.t, self.criterion = float(period), t, criterion
        nf = 2 * (H - 1)
        self.nf = nf
        # one joint's basis: q, q̇, q̈ on t for each unit free coefficient (q_start = 0)
        eye = _full_coefficients(np.eye(nf).ravel(), nf, H)
        q, qd, qdd = fourier_trajectory(eye, t, period, np.zeros(nf))  # (k, nf) each
        self.basis = (q, qd, qdd)
        self.nfev = 0
        self._cache: dict = {}
        self.p = SOFT_P
        self.n_standard = len(getattr(model, "regressor_names", ())) or int(np.max(columns)) + 1

    def n_variables(self) -> int:
        return self.nj * (self.nf + 1)

    def split(self, z):
        z = np.asarray(z, dtype=float)
        x = z[..., : self.nj * self.nf].reshape(z.shape[:-1] + (self.nj, self.nf))
        return x, z[..., self.nj * self.nf :]

    def pack(self, coefficients, q_start):
        return np.concatenate([np.asarray(coefficients)[:, :, 1:].reshape(-1), q_start])

    def coefficients(self, z):
        x, q0 = self.split(z)
        return _full_coefficients(x.reshape(-1), self.nj, self.H), q0

    def states(self, z):
        """q, q̇, q̈ for a batch of z (m, nv) → each (m, k, nj)."""
        x, q0 = self.split(np.atleast_2d(z))
        bq, bv, ba = self.basis
        q = np.einsum("kf,mjf->mkj", bq, x) + q0[:, None, :]
        return q, np.einsum("kf,mjf->mkj", bv, x), np.einsum("kf,mjf->mkj", ba, x)

    def constraint_matrix(self, limits):
        """Rows C and bounds so that ``lo ≤ C z ≤ hi`` is every limit on the grid (position
        range narrowed by ``(1 − MARGIN)/2`` of its width at each end, rates to ``MARGIN``)."""
        nj, nf, k = self.nj, self.nf, self.t.size
        nv = self.n_variables()
        blocks, lo, hi = [], [], []
        for j in range(nj):
            p_lo, p_hi = _inner_range(limits["position"][j])
            v = MARGIN * limits["velocity"][j]
            a = MARGIN * limits["acceleration"][j]
            for which, (low, high) in enumerate(((p_lo, p_hi), (-v, v), (-a, a))):
                if not (np.isfinite(low) and np.isfinite(high)):
                    continue
                C = np.zeros((k, nv))
                C[:, j * nf : (j + 1) * nf] = self.basis[which]
                if which == 0:
                    C[:, nj * nf + j] = 1.0
                blocks.append(C)
                lo.append(np.full(k, low))
                hi.append(np.full(k, high))
        return np.vstack(blocks), np.concatenate(lo), np.concatenate(hi)

    def _values(self, Z):
        """Objective for each row of Z (m, nv), in chunks that bound the regressor batch."""
        self.nfev += Z.shape[0]
        per = self.t.size * self.nj * self.n_standard * 8
        chunk = max(1, int(BATCH_BYTES // max(per, 1)))
        out = np.empty(Z.shape[0])
        for i in range(0, Z.shape[0], chunk):
            q, qd, qdd = self.states(Z[i : i + chunk])
            m, k, nj = q.shape
            Y = np.asarray(
                self.model.regressor(
                    q.reshape(m * k, nj), qd.reshape(m * k, nj), qdd.reshape(m * k, nj)
                ),
                dtype=float,
            )[:, :, self.columns]
            a = Y.reshape(m, k * nj, Y.shape[-1])
            G = np.matmul(a.transpose(0, 2, 1), a)  # BLAS; einsum here is 10× slower
            d = np.sqrt(np.einsum("mii->mi", G))
            bad = np.any(d == 0, axis=1)
            d = np.where(d == 0, 1.0, d)
            lam = np.linalg.eigvalsh(G / d[:, :, None] / d[:, None, :])
            bad |= ~(lam[:, 0] > 0)
            mu = np.log(np.where(lam > 0, lam, 1.0))
            if self.criterion == "cond":
                p = self.p
                v = 0.5 * (_logsumexp(p * mu) + _logsumexp(-p * mu)) / p
            else:
                v = -mu.sum(axis=1)
            out[i : i + chunk] = np.where(bad, 1e3, v)
        return out

    def fun(self, z):
        """The search objective at z (one trajectory: what SLSQP's line search asks for)."""
        z = np.asarray(z, dtype=float)
        key = z.tobytes()
        if key not in self._cache:
            self._cache = {key: float(self._values(z[None, :])[0])}
        return self._cache[key]

    def grad(self, z):
        """Forward-difference gradient, n_v + 1 trajectories in one batch."""
        z = np.asarray(z, dtype=float)
        f0 = self.fun(z)
        v = self._values(z[None, :] + FD_STEP * np.eye(z.size))
        return (v - f0) / FD_STEP

    def true_cond(self, z):
        q, qd, qdd = (a[0] for a in self.states(z))
        return _criteria(self.model, self.columns, q, qd, qdd)[0]


def _inner_range(pair):
    """The position range narrowed by ``(1 − MARGIN)/2`` of its width at each end."""
    low, high = float(pair[0]), float(pair[1])
    half = 0.5 * (1.0 - MARGIN) * (high - low)
    return (low + half, high - half) if np.isfinite(half) else (low, high)


def _logsumexp(x):
    m = x.max(axis=1)
    return m + np.log(np.exp(x - m[:, None]).sum(axis=1))


def _fit_into_limits(c, q_start, period, limits, n_fine):
    """Shrink each joint about q_start so that every limit holds on a fine grid."""
    fine = np.linspace(0.0, float(period), n_fine, endpoint=False)
    qf, qdf, qddf = fourier_trajectory(c, fine, period, q_start)
    pos = limits["position"]
    dq = qf - q_start
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.max(
            np.vstack(
                [
                    np.abs(qdf).max(axis=0) / limits["velocity"],
                    np.abs(qddf).max(axis=0) / limits["acceleration"],
                    np.where(dq.max(axis=0) > 0, dq.max(axis=0) / (pos[:, 1] - q_start), 0),
                    np.where(dq.min(axis=0) < 0, dq.min(axis=0) / (pos[:, 0] - q_start), 0),
                ]
            ),
            axis=0,
        )
    shrink = np.where(ratio > 1.0, 1.0 / ratio, 1.0)
    return c * shrink[:, None, None]


def _search_from_starts(
    search, period, limits, qs, free_start, candidates, randoms, n_starts, max_iter, n_fine,
    deadline,
):  # fmt: skip
    """SLSQP from the best random trajectories within the time budget; (true condition number,
    coefficients, start position, start index) after each pass."""
    nj, criterion = search.nj, search.criterion
    pos = limits["position"]
    C, lo, hi = search.constraint_matrix(limits)
    constraints = [
        {"type": "ineq", "fun": lambda z: C @ z - lo, "jac": lambda z: C},
        {"type": "ineq", "fun": lambda z: hi - C @ z, "jac": lambda z: -C},
    ]
    inner = np.array([_inner_range(p) for p in pos])
    q0_bounds = [tuple(r) if free_start else (q0, q0) for r, q0 in zip(inner, qs, strict=True)]
    bounds = [(None, None)] * (nj * search.nf) + q0_bounds
    order = np.argsort(randoms)[: int(n_starts)]
    results = []
    bar = Progress(len(order), "design-excitation: optimising", unit="starts")
    for i, k in enumerate(order):
        bar.advance(1 if i else 0)
        left = deadline - time.perf_counter()
        if left <= 0 and results:
            break
        z0 = search.pack(candidates[k], qs)
        stop_at = time.perf_counter() + max(left, 0.0) / (len(order) - i)

        def callback(xk, stop_at=stop_at):
            if time.perf_counter() > stop_at:
                raise StopIteration

        # continuation: a loose soft bound first (wide basin), then a tight one (p × 3)
        for p in (SOFT_P, 3.0 * SOFT_P) if criterion == "cond" else (SOFT_P,):
            search.p = p
            sol = optimize.minimize(
                search.fun,
                z0,
                jac=search.grad,
                method="SLSQP",
                bounds=bounds,
                constraints=constraints,
                callback=callback,
                options={"maxiter": int(max_iter), "ftol": 1e-10},
            )
            z = np.asarray(sol.x, dtype=float)
            c, q0 = search.coefficients(z)
            q0 = np.clip(q0, inner[:, 0], inner[:, 1]) if free_start else qs
            c = _fit_into_limits(c, q0, period, limits, n_fine)
            z0 = search.pack(c, q0)
            results.append((search.true_cond(z0), c, q0, i))
            if time.perf_counter() > stop_at:
                break
    bar.close()
    return results
