"""IDIM stage 5: the solvers (OLS, WLS, IV) and the checks of the regressor they solve.

Arrays in, arrays out. ``W`` is (n_rows, n_joints, p), ``y`` (n_rows, n_joints) and ``weights``
(n_joints,) scale every equation of joint j (WLS: ``1/σ̂_j``; ones for OLS). Every solve scales
the columns to unit norm first (`scaled_lstsq`), so the conditioning it meets is the
column-scaled `condition_number` of the weighted regressor.
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy import linalg

from ...errors import IdentifiabilityError, SamplingError
from .base_parameters import BaseInfo, joint_of

__all__ = [
    "ConditionWarning",
    "check_equation_count",
    "condition_number",
    "check_excitation",
    "scaled_lstsq",
    "lstsq",
    "weighted",
    "iv_solve",
    "joint_sigma",
    "COND_WARN",
    "COND_REFUSE",
]

#: Column-scaled condition number above which the fit warns (`ConditionWarning`) and above which
#: it refuses (an estimate is then meaningless).
COND_WARN = 1e3
COND_REFUSE = 1e8
#: A base-regressor column whose norm is below this fraction of the largest counts as unexcited.
UNEXCITED_RTOL = 1e-9


class ConditionWarning(UserWarning):
    """The base regressor is badly conditioned: the estimates will be poor; design the excitation."""


def condition_number(W) -> float:
    """Condition number of a regressor with its columns scaled to unit norm.

    Parameters
    ----------
    W : array_like, shape (n_rows, ..., p)
        Rows of the regression (all leading axes are rows).

    Returns
    -------
    float
        ``σ_max / σ_min`` of ``W D`` with ``D`` making every column unit norm (inf if singular).
        Scaling makes the number independent of the units of the parameters.
    """
    a = np.asarray(W, dtype=float)
    a = a.reshape(-1, a.shape[-1])
    norms = np.linalg.norm(a, axis=0)
    if np.any(norms == 0):
        return float("inf")
    s = np.linalg.svd(a / norms, compute_uv=False)
    return float(s[0] / s[-1]) if s[-1] > 0 else float("inf")


def check_equation_count(n_rows: int, n_joints: int, n_base: int, decimate: int) -> None:
    """Refuse rows that hold no more equations than base parameters.

    Parameters
    ----------
    n_rows, n_joints, n_base : int
        Decimated rows, joints (equations per row) and base parameters.
    decimate : int
        nd of the rows (named in the message).

    Raises
    ------
    SamplingError
        ``n_rows · n_joints ≤ n_base``, with what to change.
    """
    if n_rows * n_joints <= n_base:
        raise SamplingError(
            f"after filtering and decimate={decimate} only {n_rows} rows × {n_joints} joints "
            f"= {n_rows * n_joints} equations remain for {n_base} base parameters; use a "
            "smaller decimate, a longer recording, or more recordings."
        )


def check_excitation(W: np.ndarray, info: BaseInfo, where: str, *, warn: bool = True) -> float:
    """Refuse unexcited columns and meaningless conditioning; warn on poor conditioning.

    Parameters
    ----------
    W : ndarray, shape (n_rows, n_joints, p)
        The (unweighted) base regressor rows: how well the experiment excites each parameter.
    info : BaseInfo
    where : str
        What the rows come from, for the messages.
    warn : bool
        Warn (`ConditionWarning`) above `COND_WARN`.

    Returns
    -------
    float
        The column-scaled condition number of ``W``.

    Raises
    ------
    IdentifiabilityError
        An unexcited column, or a condition number above `COND_REFUSE`.
    """
    a = W.reshape(-1, W.shape[-1])
    norms = np.linalg.norm(a, axis=0)
    dead = np.flatnonzero(norms <= UNEXCITED_RTOL * max(norms.max(), 1e-300))
    if dead.size:
        text = []
        for k in dead:
            j = joint_of(info.names[k])
            text.append(f"{info.names[k]}" + (f" (joint {j})" if j is not None else ""))
        raise IdentifiabilityError(
            f"nothing in {where} excites the base parameter(s) {', '.join(text)}: their "
            "regressor columns are zero (e.g. a joint that never moves, or never "
            "accelerates). Move those joints in the experiment (physid design-excitation), "
            "or fix those parameters in the model."
        )
    cond = condition_number(a)
    if cond > COND_REFUSE:
        scaled = a / norms
        _, r, perm = linalg.qr(scaled, mode="economic", pivoting=True)
        weakest = info.names[perm[-1]]
        raise IdentifiabilityError(
            f"the base regressor of {where} has condition number {cond:.3g} (limit "
            f"{COND_REFUSE:.0e}): the data cannot separate the base parameters (the weakest "
            f"is {weakest}); an estimate would be meaningless. Record a better exciting "
            "trajectory (physid design-excitation MODEL) or stack more experiments."
        )
    if warn and cond > COND_WARN:
        warnings.warn(
            f"the base regressor has condition number {cond:.3g} (column-scaled; above "
            f"{COND_WARN:.0e} the estimates of weakly excited parameters are poor). Design "
            "a better excitation with physid design-excitation MODEL (or "
            "physid.analysis.design_excitation).",
            ConditionWarning,
            stacklevel=3,
        )
    return cond


def scaled_lstsq(a, b) -> np.ndarray:
    """argmin ‖a x − b‖² by numpy's lstsq on the columns of ``a`` scaled to unit norm.

    Parameters
    ----------
    a : ndarray, shape (n, p)
    b : ndarray, shape (n,)

    Returns
    -------
    ndarray, shape (p,)
        Scaling makes the solve independent of the units of the parameters; a zero column
        is left unscaled.
    """
    norms = np.linalg.norm(a, axis=0)
    d = 1.0 / np.where(norms > 0, norms, 1.0)
    x, *_ = np.linalg.lstsq(a * d, b, rcond=None)
    return x * d


def weighted(W, y, weights) -> tuple[np.ndarray, np.ndarray]:
    """The weighted equations as one least-squares problem: ``a`` (n·n_joints, p), ``b``."""
    p = W.shape[-1]
    a = (W * weights[None, :, None]).reshape(-1, p)
    b = (y * weights[None, :]).ravel()
    return a, b


def lstsq(W, y, weights) -> np.ndarray:
    """argmin Σ_j w_j² ‖W_j β − y_j‖² by a column-scaled QR (numpy lstsq)."""
    return scaled_lstsq(*weighted(W, y, weights))


def iv_solve(Z, W, y, weights) -> np.ndarray:
    """β = (Zᵀ Ω W)⁻¹ Zᵀ Ω τ with the per-joint weights Ω = diag(w_j²), column-scaled."""
    p = W.shape[-1]
    z = (Z * weights[None, :, None]).reshape(-1, p)
    a, b = weighted(W, y, weights)
    norms = np.linalg.norm(a, axis=0)
    d = 1.0 / np.where(norms > 0, norms, 1.0)
    zn = np.linalg.norm(z, axis=0)
    dz = 1.0 / np.where(zn > 0, zn, 1.0)
    A = (z * dz).T @ (a * d)
    x = np.linalg.solve(A, (z * dz).T @ b)
    return x * d


def joint_sigma(W, y, beta, p) -> np.ndarray:
    """Residual std per joint, σ̂_j² = ‖ρ_j‖² / (r − p/n_joints) (Gautier's two-step weights)."""
    e = y - W @ beta
    n, nj = e.shape
    kept = np.sum(np.any(W != 0.0, axis=2), axis=0)  # equations not dropped (stick_threshold)
    return np.sqrt(np.sum(e**2, axis=0) / np.maximum(kept - p / nj, 1.0))
