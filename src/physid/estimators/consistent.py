"""Physically consistent estimates of a rigid-body arm's parameters.

A link's 10 standard parameters (m, m·c, I about the link frame's origin) describe a real body
exactly when its 4×4 pseudo-inertia ``J = [[½ tr(I) E − I, m c], [m cᵀ, m]]`` is positive definite
(Wensing, Kim & Slotine, "Linear matrix inequalities for physically consistent inertial
parameter identification", IEEE RA-L 2018). J is linear in the standard parameters, so the
closest consistent estimate is a convex problem: a quadratic torque cost over the cone of
positive definite pseudo-inertias (and friction coefficients and armatures ≥ 0).

The fit minimises the same weighted torque residual as the unconstrained IDIM estimate. With
``W = Q R`` (the weighted base regressor) and β̂ its least-squares solution,
``‖W β − τ‖² = ‖R (β − β̂)‖² + ‖W β̂ − τ‖²`` for every β, so only the p rows ``R (K β − β̂)``
enter, plus a tiny pull (1e-3 of the scale) towards the model's nominal standard parameters
along the directions the base parameters leave free. For an IV estimate (not the LS solution)
the same rows give the distance to β̂ in the metric of the regressor, and the reported cost
ratio is measured on the rows themselves, ``‖W β_c − τ‖² / ‖W β̂ − τ‖²`` (it can be below 1).
A solver that stops before its duality-gap target (step budget `MAX_NEWTON_STEPS`, or a stalled
line search) says so: ``converged=False`` and the IDIM result's ``success=False``. It is solved by the barrier method
(`_barrier_solve`: Newton steps with the analytic gradient and Hessian of ``log det J``), to a
duality gap of 1e-10 of the unconstrained cost: the global optimum, in about a hundred Newton
steps of a (n_parameters × n_parameters) system. Links that end on the boundary of the cone
(a singular J: a body flat or thin in some direction) are reported.

The log-Cholesky parametrisation (``J = L Lᵀ``, ``L_ii = exp(α_i)``; Rucker & Wensing, "Smooth
parameterization of rigid-body inertia", IEEE RA-L 2022) maps 10 unconstrained numbers to a
realisable body (`log_cholesky_to_standard` and its inverse); the previous solver ran
`scipy.optimize.least_squares` in it, which converges slowly towards the boundary (where
``α → −∞``) and stopped at its iteration cap with a higher cost.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
from scipy import linalg

from ..errors import InputError, arg

__all__ = [
    "ConsistentEstimate",
    "consistent_estimate",
    "log_cholesky_to_standard",
    "standard_to_log_cholesky",
]

_LINK = ("m", "mcx", "mcy", "mcz", "XX", "XY", "XZ", "YY", "YZ", "ZZ")
_NONNEGATIVE = ("Ia", "Fv", "Fc", "Fvp", "Fvn", "Fcp", "Fcn")
_TRIL = np.tril_indices(4)
#: Newton steps the barrier method may take in all (about 100 are needed).
MAX_NEWTON_STEPS = 500


@dataclass(frozen=True)
class ConsistentEstimate:
    """A physically consistent estimate (see `IDIMEstimator` with ``consistent=True``).

    Attributes
    ----------
    standard : dict name -> float
        Standard parameters (10 per link, then drive terms) of a physically realisable arm.
    base : dict name -> float
        Its base parameters.
    cost_ratio : float
        ``‖W β_c − τ‖² / ‖W β̂ − τ‖²`` on the fitted (weighted) rows: the price of consistency
        (≥ 1 for OLS/WLS; an IV estimate is not the least-squares solution, so it can be < 1).
    at_boundary : tuple of str
        Links whose pseudo-inertia is (numerically) singular, and friction terms at zero.
    min_eigenvalues : dict link -> float
        Smallest eigenvalue of each link's pseudo-inertia [kg·m²].
    message : str
    converged : bool
        Whether the solver reached its duality-gap target (else `message` says why, and the
        IDIM result reports ``success=False``).
    """

    standard: dict[str, float]
    base: dict[str, float]
    cost_ratio: float
    at_boundary: tuple[str, ...]
    min_eigenvalues: dict[str, float]
    message: str
    converged: bool = True


def log_cholesky_to_standard(x) -> np.ndarray:
    """10 log-Cholesky numbers → standard parameters ``[m, mcx, mcy, mcz, XX, XY, XZ, YY, YZ, ZZ]``.

    Parameters
    ----------
    x : array_like, shape (10,)
        The lower triangle of L row by row, diagonal entries as logarithms.

    Returns
    -------
    ndarray, shape (10,)
        Standard parameters of the body with pseudo-inertia ``L Lᵀ`` (always realisable).
    """
    from ..models.inertial import pseudo_inertia_to_standard

    L = np.zeros((4, 4))
    L[_TRIL] = np.asarray(x, dtype=float)
    d = np.diag_indices(4)
    L[d] = np.exp(L[d])
    return pseudo_inertia_to_standard(L @ L.T)


def standard_to_log_cholesky(p10, floor: float = 1e-9) -> np.ndarray:
    """Inverse of `log_cholesky_to_standard` (a non-realisable body is lifted to ``floor``).

    Parameters
    ----------
    p10 : array_like, shape (10,)
    floor : float
        Eigenvalues of J below ``floor · max(|eig|, 1)`` are raised to it first.

    Returns
    -------
    ndarray, shape (10,)
    """
    from ..models.inertial import pseudo_inertia

    J = pseudo_inertia(np.asarray(p10, dtype=float))
    w, v = np.linalg.eigh(J)
    w = np.maximum(w, floor * max(float(np.abs(w).max()), 1.0))
    L = np.linalg.cholesky((v * w) @ v.T)
    d = np.diag_indices(4)
    L[d] = np.log(L[d])
    return L[_TRIL]


def _layout(names):
    """Links (joint number → 10 column indices) and the drive terms of a regressor."""
    index = {n: i for i, n in enumerate(names)}
    links = {}
    for n in names:
        m = re.fullmatch(r"m(\d+)", n)
        if m:
            j = m[1]
            cols = [index.get(f"{p}{j}") for p in _LINK]
            if None not in cols:
                links[int(j)] = cols
    used = {i for cols in links.values() for i in cols}
    drive = [i for i in range(len(names)) if i not in used]
    return links, drive


def _standard_map() -> np.ndarray:
    """P (10, 16) with ``pseudo_inertia_to_standard(J) = P vec(J)`` (the map is linear)."""
    from ..models.inertial import pseudo_inertia_to_standard

    return pseudo_inertia_to_standard(np.eye(16).reshape(16, 4, 4)).T


def _barrier(beta, link_cols, positive, E, derivatives=True):
    """−Σ log det J_l − Σ log β_i (inf outside), its gradient and Hessian (or None, None)."""
    from ..models.inertial import pseudo_inertia

    n_links = link_cols.shape[0]
    J = pseudo_inertia(beta[link_cols])  # (n_links, 4, 4)
    try:
        Lc = np.linalg.cholesky(J)
    except np.linalg.LinAlgError:
        return np.inf, None, None
    xp = beta[positive]
    if np.any(xp <= 0):
        return np.inf, None, None
    phi = -2.0 * float(np.sum(np.log(np.diagonal(Lc, axis1=1, axis2=2)))) - float(
        np.sum(np.log(xp))
    )
    if not derivatives:
        return phi, None, None
    Jinv = np.linalg.inv(J)
    B = Jinv[:, None] @ E[None]  # J⁻¹ E_i, (n_links, 10, 4, 4)
    g = np.zeros(beta.size)
    H = np.zeros((beta.size, beta.size))
    g_links = -np.trace(B, axis1=2, axis2=3)
    # tr(J⁻¹E_i J⁻¹E_j) = vec(B_i) · vec(B_jᵀ)
    H_links = B.reshape(n_links, 10, 16) @ np.swapaxes(B, 2, 3).reshape(n_links, 10, 16).transpose(
        0, 2, 1
    )
    for li in range(n_links):
        cols = link_cols[li]
        g[cols] += g_links[li]
        H[np.ix_(cols, cols)] += H_links[li]
    g[positive] -= 1.0 / xp
    H[positive, positive] += 1.0 / xp**2
    return phi, g, H


def _feasible_start(nominal, scale, link_cols, positive) -> np.ndarray:
    """A strictly feasible start: the nominal parameters, each link lifted inside the cone."""
    from ..models.inertial import pseudo_inertia

    beta = nominal.copy()
    for cols in link_cols:
        J = pseudo_inertia(beta[cols])
        w, v = np.linalg.eigh(J)
        w = np.maximum(w, 1e-6 * max(float(np.abs(w).max()), 1e-12))
        beta[cols] = _standard_map() @ ((v * w) @ v.T).ravel()
    beta[positive] = np.maximum(beta[positive], 1e-3 * scale[positive])
    return beta


def _barrier_solve(A, b, nominal, scale, link_cols, positive, e_ols, *, max_steps=500):
    """min ‖A β − b‖² + ‖10⁻³ (β − β_nom)/s‖² s.t. every J_l(β) ≻ 0 and β_i > 0 (i in positive).

    A convex problem (a quadratic over the cone of positive definite pseudo-inertias), solved by
    the barrier method (Boyd & Vandenberghe, *Convex Optimization*, §11.3): Newton's method on
    ``t f(β) − Σ_l log det J_l(β) − Σ_i log β_i`` with a backtracking line search that stays
    strictly feasible, ``t`` raised 50× per round until the duality gap ν/t is below
    1e-10 of the unconstrained torque cost. Gradient and Hessian of ``log det J`` are analytic
    (J is linear in the 10 standard parameters: ``∂J/∂p_i = E_i``, ``∂ log det J/∂p_i =
    tr(J⁻¹E_i)``, ``∂² = −tr(J⁻¹E_i J⁻¹E_j)``).

    Returns
    -------
    (ndarray (n_beta,), int, str or None)
        The solution, the number of Newton steps, and None when the duality gap reached its
        target after a completed centering step, else why not (the step budget ran out, or the
        line search stalled with a Newton decrement still above 1e-6).
    """
    from ..models.inertial import pseudo_inertia

    n_links = link_cols.shape[0]
    E = pseudo_inertia(np.eye(10))  # (10, 4, 4): ∂J/∂p_i
    pull = 1e-3 / scale
    H0 = 2.0 * (A.T @ A + np.diag(pull**2))
    c0 = 2.0 * (A.T @ b + pull**2 * nominal)

    def f(beta):
        r = A @ beta - b
        q = pull * (beta - nominal)
        return float(r @ r + q @ q)

    def barrier(beta, derivatives=True):
        return _barrier(beta, link_cols, positive, E, derivatives)

    beta = _feasible_start(nominal, scale, link_cols, positive)
    nu = 4 * n_links + positive.size
    target = 1e-10 * max(e_ols, f(beta), 1e-300)
    t = nu / max(f(beta), 1e-300)
    steps = 0
    problem: str | None = f"the step budget ({max_steps} Newton steps) ran out"
    while steps < max_steps:
        stalled = None
        for _ in range(100):  # Newton on t f + φ
            phi, g, H = barrier(beta)
            grad = t * (H0 @ beta - c0) + g
            hess = t * H0 + H
            try:
                step = -np.linalg.solve(hess, grad)
            except np.linalg.LinAlgError:
                step = -np.linalg.lstsq(hess, grad, rcond=None)[0]
            decrement = float(-grad @ step)
            steps += 1
            if decrement / 2.0 <= 1e-9 or steps >= max_steps:
                break
            value = t * f(beta) + phi
            alpha = 1.0
            while alpha > 1e-12:
                trial = beta + alpha * step
                phi_t = barrier(trial, derivatives=False)[0]
                if np.isfinite(phi_t) and t * f(trial) + phi_t <= value - 0.25 * alpha * decrement:
                    break
                alpha *= 0.5
            else:
                if decrement / 2.0 > 1e-6:
                    stalled = (
                        f"the line search stalled (Newton decrement {decrement / 2.0:.2g} at "
                        f"duality gap {nu / t:.2g})"
                    )
                break
            beta = trial
        if stalled is not None:
            problem = stalled
            break
        if nu / t <= target:
            problem = None
            break
        t *= 50.0
    if problem is not None and steps >= max_steps:
        problem = f"the step budget ({max_steps} Newton steps) ran out at duality gap {nu / t:.2g}"
    return beta, steps, problem


def consistent_estimate(model, info, W, y, beta_hat, weights):
    """The closest physically consistent parameters to an IDIM estimate.

    Parameters
    ----------
    model : ChainModel
        A rigid-body model whose regressor columns are the 10 standard parameters of each link
        (``m{j}``, ``mcx{j}``, …, ``ZZ{j}``) and drive terms (``Ia{j}``, ``Fv{j}``, …).
    info : BaseInfo
        From `physid.estimators.idim.base_parameters.base_regressor_info`.
    W : ndarray, shape (n_rows, n_joints, p)
    y : ndarray, shape (n_rows, n_joints) [N·m]
    beta_hat : ndarray, shape (p,)
        Unconstrained base-parameter estimate.
    weights : ndarray, shape (n_joints,)
        Per-joint weights of the fit.

    Returns
    -------
    ConsistentEstimate

    Raises
    ------
    InputError
        The model does not have the standard rigid-body parametrisation.
    """
    from ..models.inertial import pseudo_inertia

    names = info.column_names
    links, drive = _layout(names)
    if not links:
        raise InputError(
            f"{arg('consistent', 'True', cli='')} needs a rigid-body model whose regressor holds "
            "the 10 standard inertial parameters of each link (m1, mcx1, …, ZZ1, …), e.g. a URDF "
            f"model; this model's regressor columns are {list(names)[:6]}…"
        )
    p = info.n_base
    K = info.matrix
    a = (W * weights[None, :, None]).reshape(-1, p)
    b = (y * weights[None, :]).ravel()
    norms = np.linalg.norm(a, axis=0)
    d = 1.0 / np.where(norms > 0, norms, 1.0)
    _, R = linalg.qr(a * d, mode="economic")
    R = R / d[None, :]  # ‖a β − b‖² = ‖R (β − β̂)‖² + ‖a β̂ − b‖² when β̂ is the LS solution
    e_hat = float(np.sum((b - a @ beta_hat) ** 2))  # the cost of the given estimate (any β̂)

    nominal = np.asarray(model.beta(), dtype=float)
    scale = np.maximum(np.abs(nominal), 1e-3 * max(np.abs(nominal).max(), 1e-12))
    link_ids = sorted(links)
    link_cols = np.array([links[j] for j in link_ids], dtype=int)  # (n_links, 10)
    positive = np.array(
        [i for i in drive if re.match(r"(Ia|Fv|Fc|Fvp|Fvn|Fcp|Fcn)\d+$", names[i])], dtype=int
    )
    beta_c, steps, problem = _barrier_solve(
        R @ K, R @ beta_hat, nominal, scale, link_cols, positive, e_hat, max_steps=MAX_NEWTON_STEPS
    )
    base_c = K @ beta_c
    # the torque cost from the rows themselves: the identity through R holds only for the LS
    # solution, not for an IV estimate
    cost = float(np.sum((b - a @ base_c) ** 2))

    at_boundary, min_eig = [], {}
    for j in link_ids:
        w = np.linalg.eigvalsh(pseudo_inertia(beta_c[links[j]]))
        min_eig[f"link{j}"] = float(w[0])
        if w[0] < 1e-6 * max(float(w[-1]), 1e-300):
            at_boundary.append(f"link{j}")
    for i in positive:
        if beta_c[i] <= 1e-6 * scale[i]:
            at_boundary.append(names[i])
    ratio = cost / e_hat if e_hat > 0 else float("inf")
    message = (
        f"consistent estimate: torque cost {ratio:.4g}× the unconstrained one; "
        + (
            f"at the boundary: {', '.join(at_boundary)}"
            if at_boundary
            else "no link at the boundary"
        )
        + f" ({steps} Newton steps)."
    )
    if problem is not None:
        message += (
            f" The barrier method did not converge: {problem}; the estimate is feasible but "
            "not the optimum (its cost ratio is an upper bound)."
        )
    return ConsistentEstimate(
        standard=dict(zip(names, beta_c.tolist(), strict=True)),
        base=dict(zip(info.names, base_c.tolist(), strict=True)),
        cost_ratio=float(ratio),
        at_boundary=tuple(at_boundary),
        min_eigenvalues=min_eig,
        message=message,
        converged=problem is None,
    )
