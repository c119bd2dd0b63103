"""The RLS recursion's estimates at every row without a loop: running weighted sums
(``scipy.signal.lfilter``) and a batched equilibrated solve."""

from __future__ import annotations

import numpy as np
from scipy import signal

from ..._validate import check_in_range, check_int, check_positive
from ...errors import InputError, arg

#: Smallest eigenvalue of the unit-diagonal (equilibrated) information matrix that counts as
#: invertible. The equilibrated matrix has eigenvalues in (0, p], so this is a reciprocal condition
#: number threshold that does not depend on the units of the regressors.
MIN_EQUILIBRATED_EIGENVALUE = 1e-10


def _equilibrated_solve(S: np.ndarray, rhs: np.ndarray):
    """Solve ``S θ = rhs`` for a stack of symmetric matrices (..., p, p); see `_packed_solve`."""
    p = S.shape[-1]
    iu = np.triu_indices(p)
    return _packed_solve(S[..., iu[0], iu[1]], rhs, p)


#: Rows per block in `weighted_ls_path` and `_packed_solve`: the temporaries of a block (64 kB)
#: stay in cache and in the allocator's free lists instead of fresh page-faulted memory per op.
_SOLVE_BLOCK = 8192


def _packed_solve(S_packed: np.ndarray, rhs: np.ndarray, p: int, diagonal_only: bool = False):
    """`_packed_solve_block` over blocks of `_SOLVE_BLOCK` matrices (any leading shape)."""
    lead = S_packed.shape[:-1]
    flat_S = S_packed.reshape(-1, S_packed.shape[-1])
    flat_rhs = rhs.reshape(-1, p)
    count = flat_S.shape[0]
    theta = np.empty((count, p))
    inv = np.empty((count, p) if diagonal_only else (count, p, p))
    ok = np.empty(count, dtype=bool)
    for start in range(0, count, _SOLVE_BLOCK):
        block = slice(start, start + _SOLVE_BLOCK)
        theta[block], inv[block], ok[block] = _packed_solve_block(
            flat_S[block], flat_rhs[block], p, diagonal_only
        )
    return theta.reshape(lead + (p,)), inv.reshape(lead + inv.shape[1:]), ok.reshape(lead)


def _packed_solve_block(S_packed: np.ndarray, rhs: np.ndarray, p: int, diagonal_only: bool):
    """Solve ``S θ = rhs`` for a stack of symmetric matrices with Jacobi scaling and LDLᵀ.

    ``S_packed`` (..., p(p+1)/2) holds the upper triangle row by row (``np.triu_indices(p)``).
    ``S = D^{1/2} Ŝ D^{1/2}`` with ``Ŝ`` unit-diagonal, so the test of invertibility and the solve
    do not depend on the scale of the sums (which grow like k for λ = 1 and shrink like λ^k without
    excitation) or on the units of the columns. ``Ŝ = L Δ Lᵀ`` is factorised elementwise over the
    stack (Python loops run over the p matrix indices only, each line a vectorised operation on all
    samples: much faster than numpy's batched LAPACK calls on 2×2 matrices). A matrix counts as
    invertible when every pivot ``Δ_j > MIN_EQUILIBRATED_EIGENVALUE`` (pivots of a unit-diagonal
    matrix lie between its smallest eigenvalue and 1).

    Returns (θ (..., p), S⁻¹ (..., p, p) or its diagonal (..., p), ok (...)), NaN where not ok;
    ``S⁻¹ = D^{-1/2} L⁻ᵀ Δ⁻¹ L⁻¹ D^{-1/2}``.
    """
    iu = np.triu_indices(p)
    packed_first = np.ascontiguousarray(np.moveaxis(S_packed, -1, 0))  # contiguous entries
    rhs_first = np.ascontiguousarray(np.moveaxis(rhs, -1, 0))
    entry = {(int(a), int(b)): packed_first[c] for c, (a, b) in enumerate(zip(*iu, strict=True))}
    diag = [entry[i, i] for i in range(p)]
    ok = np.ones(S_packed.shape[:-1], dtype=bool)
    for d in diag:
        ok &= (d > 0) & np.isfinite(d)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        sc = [1.0 / np.sqrt(d) for d in diag]  # D^{-1/2}
        L = [[None] * p for _ in range(p)]
        piv = []
        for j in range(p):  # Δ_j = Ŝ_jj − Σ_k L_jk² Δ_k ;  L_ij = (Ŝ_ij − Σ_k L_ik L_jk Δ_k) / Δ_j
            dj = 1.0 - sum(L[j][k] ** 2 * piv[k] for k in range(j))  # Ŝ_jj = 1
            piv.append(dj)
            ok &= dj > MIN_EQUILIBRATED_EIGENVALUE
            for i in range(j + 1, p):
                s_ij = entry[j, i] * sc[i] * sc[j]
                L[i][j] = (s_ij - sum(L[i][k] * L[j][k] * piv[k] for k in range(j))) / dj
        z = []
        for i in range(p):  # L z = D^{-1/2} rhs
            z.append(rhs_first[i] * sc[i] - sum(L[i][k] * z[k] for k in range(i)))
        th = [None] * p
        for i in reversed(range(p)):  # Δ Lᵀ θ̂ = z, θ = D^{-1/2} θ̂
            th[i] = z[i] / piv[i] - sum(L[k][i] * th[k] for k in range(i + 1, p))
        Li = [[None] * p for _ in range(p)]  # L⁻¹ (unit lower triangular)
        for jj in range(p):
            for i in range(jj + 1, p):
                Li[i][jj] = -(L[i][jj] + sum(L[i][k] * Li[k][jj] for k in range(jj + 1, i)))
        shape = S_packed.shape[:-1] + ((p,) if diagonal_only else (p, p))
        inv = np.empty(shape)
        for i in range(p):
            for jj in (i,) if diagonal_only else range(i, p):
                # (Ŝ⁻¹)_ij = Σ_{k ≥ j} (L⁻¹)_ki (L⁻¹)_kj / Δ_k
                val = sum(
                    (1.0 if k == i else Li[k][i]) * (1.0 if k == jj else Li[k][jj]) / piv[k]
                    for k in range(jj, p)
                )
                val = val * sc[i] * sc[jj]
                if diagonal_only:
                    inv[..., i] = val
                else:
                    inv[..., i, jj] = val
                    inv[..., jj, i] = val
        theta = np.stack([th[i] * sc[i] for i in range(p)], axis=-1)
    theta[~ok] = np.nan
    inv[~ok] = np.nan
    return theta, inv, ok


def _first_invertible_row(X: np.ndarray, weight: float, init_samples: int) -> int | None:
    """Index M of the last OLS row: the first M ≥ init_samples − 1 with Σ_{i≤M} x xᵀ invertible.

    Searched block by block (running sums carried over), so a record that is excited early costs
    one block, not a pass over all rows.
    """
    start = init_samples - 1
    n, p = X.shape
    if start >= n:
        return None
    iu = np.triu_indices(p)
    carry = (X[:start, iu[0]] * X[:start, iu[1]]).sum(axis=0) / weight
    for begin in range(start, n, _SOLVE_BLOCK):
        block = X[begin : begin + _SOLVE_BLOCK]
        sums = carry + np.cumsum(block[:, iu[0]] * block[:, iu[1]], axis=0) / weight
        _, _, ok = _packed_solve_block(sums, np.zeros((sums.shape[0], p)), p, True)
        hits = np.flatnonzero(ok)
        if hits.size:
            return int(begin + hits[0])
        carry = sums[-1]
    return None


def weighted_ls_path(
    X,
    Y,
    *,
    forgetting: float = 1.0,
    weight: float = 1.0,
    init_end: int,
    covariance: str = "full",
):
    """Estimates of the RLS recursion (eqs. 3–4) at every row, computed without a loop.

    Parameters
    ----------
    X : array_like, shape (..., n_rows, p)
        Regressor rows (leading axes, e.g. Monte-Carlo trials, are batched).
    Y : array_like, shape (..., n_rows)
    forgetting : float in (0, 1]
        λ.
    weight : float > 0
        R, the (constant) noise variance assumed for each row.
    init_end : int
        M: rows ``0..M`` form the OLS initialisation (eq. 4).
    covariance : {"full", "diagonal"}
        Return ``P_k`` as (..., n_rows, p, p) or only its diagonal (..., n_rows, p).

    Returns
    -------
    theta : ndarray, shape (..., n_rows, p)
        θ̂_k, NaN for rows before M and where the weighted information is singular.
    P : ndarray
        The recursion's ``P_k`` (eq. 3): ``S_M⁻¹`` at row M and ``(λ S_k)⁻¹`` after it, with ``S_k``
        the weighted information matrix (module docstring).
    ok : ndarray of bool, shape (..., n_rows)

    Notes
    -----
    ``S_k = λ S_{k−1} + x_k x_kᵀ / R`` is a first-order IIR filter along the rows:
    ``lfilter([1], [1, −λ])`` on the (n, p, p) outer products, started at row M + 1 from the OLS
    information of rows 0..M (which the recursion weighs like row M + 1). With λ < 1 the sums stay
    bounded (≤ max‖x‖² / (1 − λ)); with λ = 1 they grow like k, and the Jacobi-scaled solve keeps
    the conditioning independent of that growth. Without excitation the sums decay like λ^k; rows
    whose information has underflowed or become singular are NaN (the streaming form holds its
    estimate).
    """
    X = np.asarray(X, dtype=float)
    Y = np.asarray(Y, dtype=float)
    lam = _check_forgetting(forgetting)
    r = check_positive(weight, "weight")
    n_rows, p = X.shape[-2], X.shape[-1]
    M = int(init_end)
    if not 0 <= M < n_rows:
        raise InputError(f"init_end must index a row in [0, {n_rows - 1}]; got {M}.")
    if covariance not in ("full", "diagonal"):
        raise InputError(f"covariance must be 'full' or 'diagonal'; got {covariance!r}.")
    iu = np.triu_indices(p)
    lead = X.shape[:-2]
    theta = np.empty(X.shape)
    P = np.empty(lead + ((n_rows, p, p) if covariance == "full" else (n_rows, p)))
    ok = np.zeros(lead + (n_rows,), dtype=bool)
    head = (slice(None),) * len(lead)  # index the row axis explicitly (P may be (..., n, p, p))
    theta[head + (slice(0, M),)] = np.nan
    P[head + (slice(0, M),)] = np.nan
    # Rows 0..M enter as one block: feed S_M / λ at row M, then x_k x_kᵀ / R. The filter output is
    # S_k for k > M (S_{M+1} = S_M + G_{M+1}: no λ on the OLS block, as eq. 3 started from eq. 4
    # does) and S_M / λ at M, so eq. 3's P is (λ · output)⁻¹ on every row and θ̂ = output⁻¹ ·
    # (the same filter on x y / R). Rows go in blocks (lfilter's state carried across), so every
    # temporary stays small and cache-resident; each block is fully vectorised.
    zi_S = np.zeros(lead + (1, iu[0].size))
    zi_b = np.zeros(lead + (1, p))
    for start in range(M, n_rows, _SOLVE_BLOCK):
        rows = slice(start, min(start + _SOLVE_BLOCK, n_rows))
        Xb, Yb = X[..., rows, :], Y[..., rows]
        G = Xb[..., :, iu[0]] * Xb[..., :, iu[1]] / r  # upper triangle of x xᵀ / R
        g = Xb * Yb[..., None] / r  # x y / R
        if start == M:
            X0, Y0 = X[..., : M + 1, :], Y[..., : M + 1]
            G[..., 0, :] = (X0[..., iu[0]] * X0[..., iu[1]]).sum(axis=-2) / (r * lam)
            g[..., 0, :] = (X0 * Y0[..., None]).sum(axis=-2) / (r * lam)
        S, zi_S = signal.lfilter([1.0], [1.0, -lam], G, axis=-2, zi=zi_S)  # S_k = λ S_{k−1} + G_k
        b, zi_b = signal.lfilter([1.0], [1.0, -lam], g, axis=-2, zi=zi_b)  # b_k = λ b_{k−1} + g_k
        th, S_inv, ok_b = _packed_solve_block(
            S.reshape(-1, iu[0].size), b.reshape(-1, p), p, covariance == "diagonal"
        )
        theta[head + (rows,)] = th.reshape(b.shape)
        P[head + (rows,)] = (S_inv / lam).reshape(b.shape[:-1] + S_inv.shape[1:])  # (λ S_k)⁻¹
        ok[head + (rows,)] = ok_b.reshape(b.shape[:-1])
    return theta, P, ok


def _check_forgetting(forgetting) -> float:
    """λ as a float in (0, 1], else `InputError` saying how to choose it."""
    try:
        return check_in_range(forgetting, "forgetting", 0.0, 1.0, low_open=True)
    except InputError:
        raise InputError(
            f"{arg('forgetting')} must lie in (0, 1] (λ); got {forgetting!r}. Use 0.95–1: "
            "1 keeps all data (constant parameters), λ < 1 forgets with a memory of about "
            "1 / (1 − λ) samples (0.998: 500 samples) to track changing parameters."
        ) from None


def _check_init_samples(init_samples, p: int) -> int:
    if init_samples is None:
        return 10 * p
    return check_int(
        init_samples,
        "init_samples",
        minimum=p,
        fix=f"It must be >= the number of unknowns ({p}) so the OLS start (eq. 4) is defined.",
    )
