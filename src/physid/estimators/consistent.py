"""Physically consistent estimates of a rigid-body arm's parameters (log-Cholesky).

A link's 10 standard parameters (m, m·c, I about the link frame's origin) describe a real body
exactly when its 4×4 pseudo-inertia ``J = [[½ tr(I) E − I, m c], [m cᵀ, m]]`` is positive definite
(Wensing, Kim & Slotine, "Linear matrix inequalities for physically consistent inertial
parameter identification", IEEE RA-L 2018). Every such J is ``J = L Lᵀ`` with L lower triangular
and a positive diagonal, written ``L_ii = exp(α_i)`` (the log-Cholesky parametrisation of Rucker &
Wensing, "Smooth parameterization of rigid-body inertia", IEEE RA-L 2022): 10 unconstrained
numbers per link, one-to-one with the positive definite J. Friction coefficients and armatures
are kept ≥ 0 by bounds.

The fit minimises the same weighted torque residual as the unconstrained IDIM estimate. With
``W = Q R`` (the weighted base regressor) and β̂ its least-squares solution,
``‖W β − τ‖² = ‖R (β − β̂)‖² + ‖W β̂ − τ‖²`` for every β, so only the p rows ``R (K β(x) − β̂)``
enter `scipy.optimize.least_squares`, plus a tiny pull (1e-3 of the scale) towards the model's
nominal standard parameters along the directions the base parameters leave free.
"""

from __future__ import annotations

import re

import numpy as np
from scipy import linalg, optimize

from ..errors import InputError, arg

__all__ = ["consistent_estimate", "log_cholesky_to_standard", "standard_to_log_cholesky"]

_LINK = ("m", "mcx", "mcy", "mcz", "XX", "XY", "XZ", "YY", "YZ", "ZZ")
_NONNEGATIVE = ("Ia", "Fv", "Fc", "Fvp", "Fvn", "Fcp", "Fcn")
_TRIL = np.tril_indices(4)


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


def consistent_estimate(model, info, W, y, beta_hat, weights):
    """The closest physically consistent parameters to an IDIM estimate.

    Parameters
    ----------
    model : ChainModel
        A rigid-body model whose regressor columns are the 10 standard parameters of each link
        (``m{j}``, ``mcx{j}``, …, ``ZZ{j}``) and drive terms (``Ia{j}``, ``Fv{j}``, …).
    info : BaseInfo
        From `physid.estimators.idim.base_regressor_info`.
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
    from ..models.inertial import pseudo_inertia, pseudo_inertia_to_standard
    from .idim import ConsistentEstimate

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
    R = R / d[None, :]  # ‖a β − b‖² = ‖R (β − β̂)‖² + ‖a β̂ − b‖²
    e_ols = float(np.sum((b - a @ beta_hat) ** 2))

    nominal = np.asarray(model.beta(), dtype=float)
    scale = np.maximum(np.abs(nominal), 1e-3 * max(np.abs(nominal).max(), 1e-12))
    link_ids = sorted(links)
    n_x = 10 * len(link_ids) + len(drive)
    x0 = np.zeros(n_x)
    lower = np.full(n_x, -np.inf)
    for k, j in enumerate(link_ids):
        x0[10 * k : 10 * k + 10] = standard_to_log_cholesky(nominal[links[j]])
    off = 10 * len(link_ids)
    for k, i in enumerate(drive):
        x0[off + k] = nominal[i]
        if re.match(r"(Ia|Fv|Fc|Fvp|Fvn|Fcp|Fcn)\d+$", names[i]):
            lower[off + k] = 0.0
            x0[off + k] = max(x0[off + k], 0.0)

    link_cols = np.array([links[j] for j in link_ids])  # (n_links, 10)
    n_links = len(link_ids)
    diag = np.diag_indices(4)

    def standard(x):
        # all links at once: L (n_links, 4, 4) lower triangular, exp on the diagonal, J = L Lᵀ
        L = np.zeros((n_links, 4, 4))
        L[:, _TRIL[0], _TRIL[1]] = x[:off].reshape(n_links, 10)
        L[:, diag[0], diag[1]] = np.exp(L[:, diag[0], diag[1]])
        beta = np.empty(len(names))
        beta[link_cols] = pseudo_inertia_to_standard(L @ np.swapaxes(L, 1, 2))
        beta[drive] = x[off:]
        return beta

    def residual(x):
        beta = standard(x)
        return np.concatenate([R @ (K @ beta - beta_hat), 1e-3 * (beta - nominal) / scale])

    sol = optimize.least_squares(
        residual,
        x0,
        bounds=(lower, np.full(n_x, np.inf)),
        ftol=1e-9,
        xtol=1e-9,
        max_nfev=100,  # iterations; each also costs n_x evaluations for the 2-point Jacobian
    )
    beta_c = standard(sol.x)
    base_c = K @ beta_c
    cost = float(np.sum((R @ (base_c - beta_hat)) ** 2)) + e_ols

    at_boundary, min_eig = [], {}
    for j in link_ids:
        w = np.linalg.eigvalsh(pseudo_inertia(beta_c[links[j]]))
        min_eig[f"link{j}"] = float(w[0])
        if w[0] < 1e-6 * max(float(w[-1]), 1e-300):
            at_boundary.append(f"link{j}")
    for k, i in enumerate(drive):
        if lower[off + k] == 0.0 and beta_c[i] <= 1e-9 * max(scale[i], 1.0):
            at_boundary.append(names[i])
    ratio = cost / e_ols if e_ols > 0 else float("inf")
    message = f"consistent estimate: torque cost {ratio:.4g}× the unconstrained one; " + (
        f"at the boundary: {', '.join(at_boundary)}." if at_boundary else "no link at the boundary."
    )
    return ConsistentEstimate(
        standard=dict(zip(names, beta_c.tolist(), strict=True)),
        base=dict(zip(info.names, base_c.tolist(), strict=True)),
        cost_ratio=float(ratio),
        at_boundary=tuple(at_boundary),
        min_eigenvalues=min_eig,
        message=message,
    )
