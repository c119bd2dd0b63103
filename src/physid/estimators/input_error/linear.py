"""Input-error over the base parameters of a model that is linear in its parameters.

Part of `physid.estimators.input_error` (``parameters="base"``, the default for rigid-body and
URDF models). A rigid-body model's torque is ``τ = Y(q, q̇, q̈) θ`` with θ the standard inertial
and drive parameters; only the base combinations ``β = K θ`` reach the torque
(``τ = W_b β``, ``W_b = Y[..., independent]``; `physid.models.base`). Over θ the input-error
Jacobian is singular (arm6: 78 parameters, 52 base combinations). Over β the residual of the
paper's quality factor, evaluated on the filtered signals::

    e(β) = W_b(q^f, q̇^f, q̈^f) β - τ^f                               (paper, eq. 5)

is linear in β: its Jacobian is W_b itself, exact, and one Gauss–Newton step from any start is
the minimum (a linear least-squares solve, done once). The filters are the paper's (the
input-error FIR low-pass and derivative filters of `physid.filters.filter_derivatives`, or
``cutoff="auto"``), applied to q and τ; there is no parallel filtering or decimation (that is
IDIM's recipe): this is the paper's method applied to the robot.

Standard errors: the HAC sandwich with the filtered residual's autocorrelation over 2M lags
(`sandwich_covariance`), or the iid formula; with ``noise="compensate"`` the normal equations are
corrected for the errors-in-variables bias of the noise on q with re-noised replicates, which
also give the covariance (as for the nonlinear fit, `.solve.solve_compensated`).

Memory: W_b, ``n_valid · n_joints · n_base`` floats, plus one block of the full regressor
(``BLOCK`` samples); the noise replicates are reduced to their normal equations block by block.
"""

from __future__ import annotations

import numpy as np

from ...errors import InputError, arg
from ...models.identifiability import (
    StructuralIdentifiability,
    numeric_identifiability,
    raise_if_not_excited,
)
from .._stiction import (
    STICK_AUTO,
    coarse_speed_rms,
    contamination_reach,
    coulomb_joints,
    dilate,
    drop_equations,
    dropped_summary,
    elevated_joints,
    reversal_samples,
    sticking_samples,
)
from ..idim.base_parameters import base_regressor, base_regressor_info
from ..idim.solve import scaled_lstsq
from .core import _gram_least_squares, quality_factor
from .prepare import _Filtered, _Problem, check_band, filter_recording
from .solve import (
    _Solution,
    noise_fraction,
    replicate_covariance,
    replicate_normal_equations,
    resolve_noise,
)

#: Samples per block of the full regressor while W_b is built.
BLOCK = 4096


def linear_in_parameters(model) -> bool:
    """True when the model's parameters are its regressor's columns (``τ = Y θ``).

    Parameters
    ----------
    model : ChainModel

    Returns
    -------
    bool
        True for rigid-body (URDF, DH) models: their parameters are the columns of
        ``regressor`` (``regressor_names``), ``β(θ) = θ``, and they give ``base_parameters()``;
        False for symbolic chains (the paper's arm, whose lengths enter nonlinearly).
    """
    needed = ("regressor", "regressor_names", "base_parameters", "beta_names", "beta_jacobian")
    if not all(hasattr(model, a) for a in needed):
        return False
    try:
        if tuple(model.beta_names) != tuple(model.parameter_names):
            return False
        jac = np.asarray(model.beta_jacobian(), dtype=float)
    except Exception:  # no usable linear form
        return False
    return jac.shape == (len(model.parameter_names),) * 2 and np.allclose(jac, np.eye(jac.shape[0]))


def _normal_equations(model, columns, qf, qdf, qddf, tau_f, stuck=None):
    """``(W_bᵀW_b, W_bᵀτ^f, τ^fᵀτ^f)`` block by block, never holding W_b of the whole record.

    ``stuck`` (n, n_joints) of bool, optional: the equations dropped (`_stuck_mask`).
    """
    p = len(columns)
    gram, rhs, tt = np.zeros((p, p)), np.zeros(p), 0.0
    for s in range(0, qf.shape[0], BLOCK):
        sl = slice(s, s + BLOCK)
        w = base_regressor(model, columns, qf[sl], qdf[sl], qddf[sl], block=BLOCK)
        t = tau_f[sl]
        if stuck is not None:
            w, t = drop_equations(w, t.copy(), stuck[sl])
        w = w.reshape(-1, p)
        gram += w.T @ w
        rhs += w.T @ t.ravel()
        tt += float(t.ravel() @ t.ravel())
    return gram, rhs, tt


def _stuck_mask(model, f: _Filtered):
    """Bool per sample and joint: the equations of a sticking joint with dry friction (to drop).

    Stiction (see `physid.estimators._stiction`): where the measured position stays within its
    noise for a sustained interval, widened by the filter's main lobe (π/Ω samples; at most M),
    not its whole length. None when the model has no dry-friction term.
    """
    coulomb = coulomb_joints(model)
    if not coulomb.any():
        return None
    m = int(f.half_width)
    reach = min(m, contamination_reach(float(f.cutoff), 1))
    stuck = dilate(sticking_samples(f.q, f.dt, coulomb), reach)
    return stuck[m : m + f.qf.shape[0]]


def _drop_reversals(model, f: _Filtered, w, tau_f, stuck):
    """Also drop the equations next to speed reversals or at low speed (`reversal_samples`)
    where a first fit's residual shows friction the model does not explain
    (`physid.estimators._stiction.elevated_joints`); ``w``, ``tau_f`` in place. Returns the
    equations dropped and the candidates of the residual test."""
    coulomb = coulomb_joints(model)
    reach = min(int(f.half_width), contamination_reach(float(f.cutoff), 1))
    candidate = reversal_samples(f.qdf, coulomb, reach, coarse_speed_rms(f.q, f.dt)) & ~stuck
    if not candidate.any():
        return stuck, candidate
    p = w.shape[-1]
    beta = scaled_lstsq(w.reshape(-1, p), tau_f.ravel())
    kept = np.any(w != 0.0, axis=2)
    joints = elevated_joints(tau_f - w @ beta, candidate, kept)
    extra = candidate & joints[None, :]
    if not extra.any():
        return stuck, candidate
    drop_equations(w, tau_f, extra)
    return stuck | extra, candidate


class _LinearSolve:
    """What `least_squares` would return for the one exact step (message, success, counts)."""

    def __init__(self, message: str):
        self.message = message
        self.success = True
        self.nfev = 1
        self.njev = 1


def refuse_nonlinear_settings(est) -> None:
    """Refuse ``fixed=`` and ``bounds=``, which name the model's own (standard) parameters."""
    for name in ("fixed", "bounds"):
        if getattr(est, name):
            raise InputError(
                f"{arg(name)} applies to the model's own parameters; with "
                f"{arg('parameters', repr('base'), cli='base')} the fit estimates the base "
                "parameters, a linear problem with one solution and no bounds. Drop "
                f"{arg(name)}, or use {arg('parameters', repr('model'), cli='model')}."
            )


def prepare_base(est, recording) -> _Problem:
    """Filter, check the band, and set up the base-parameter problem (no hold plan needed)."""
    model = est.model
    f: _Filtered = filter_recording(est, recording)
    notes: list[str] = []
    if f.choice is not None:
        notes.append(f.choice.reason)
    band, advice = check_band(est, f, notes, stacklevel=4)
    bp = model.base_parameters()
    # named as IDIM names them (`BaseInfo.names`: "mcx1R" where other columns are regrouped into
    # the kept column mcx1), so that a base value is never taken for the standard parameter of
    # the same name (a model's params= refuses these names)
    names = tuple(base_regressor_info(model).names)
    truth = np.asarray(bp.base_matrix, dtype=float) @ np.asarray(model.beta(), dtype=float)
    structural = StructuralIdentifiability(
        parameter_names=names,
        identifiable=names,
        combinations=(),
        singular_values=np.ones(len(names)),
    )
    p = len(names)
    problem = _Problem(
        model=model,
        filtered=f,
        advice=advice,
        names=names,
        t=f.t,
        qf=f.qf,
        qdf=f.qdf,
        qddf=f.qddf,
        tau_f=f.tau_f,
        dt=float(f.dt),
        band=band,
        structural=structural,
        fixed={},
        free_idx=list(range(p)),
        theta0=truth,  # the nominal base parameters: reported as `initial`, not needed to solve
        scale=np.where(truth != 0.0, np.abs(truth), 1.0),
        lower=np.full(p, -np.inf),
        upper=np.full(p, np.inf),
        notes=notes,
    )
    problem.base = bp  # type: ignore[attr-defined]
    return problem


def solve_base(est, problem: _Problem) -> _Solution:
    """The exact linear least-squares solve over β (optionally noise-compensated)."""
    model, f = problem.model, problem.filtered
    columns = problem.base.independent_index  # type: ignore[attr-defined]
    names = problem.names
    p = len(names)
    w = base_regressor(model, columns, f.qf, f.qdf, f.qddf, block=BLOCK)
    stuck = _stuck_mask(model, f)
    tau_f = f.tau_f
    if stuck is not None:
        w, tau_f = drop_equations(w, tau_f.copy(), stuck)
        stuck, candidates = _drop_reversals(model, f, w, tau_f, stuck)
        sentence, heavy = dropped_summary(
            stuck,
            STICK_AUTO,
            "fit IDIM with stick_threshold=0, or drop the joint's Coulomb term",
            candidates=candidates,
        )
        if sentence:
            problem.notes.append(sentence.strip())
            problem.notes.extend(heavy)
    w2 = w.reshape(-1, p)
    norms = np.linalg.norm(w2, axis=0)
    problem.before = numeric_identifiability(
        w2, names, 1.0 / np.where(norms > 0, norms, 1.0), beta_names=names
    )
    raise_if_not_excited(problem.before, "the base regressor of this recording")
    covariance = None
    shift = None
    noise = resolve_noise(est, problem)
    if noise == "compensate":
        beta, covariance, shift = _compensated(est, problem, w2, tau_f, stuck)
        how = f"noise-compensated normal equations ({est.noise_replicates} replicates)"
    else:  # min |W_b β - τ^f|²: lstsq of the column-scaled W_b, exact in one step
        beta = scaled_lstsq(w2, tau_f.ravel())
        how = "linear least squares"
    residuals = (w @ beta) - tau_f
    message = (
        f"{how} over the {p} base parameters: the residual is linear in them, so one "
        "Gauss–Newton step is the minimum."
    )
    return _Solution(
        sol=_LinearSolve(message),
        theta_hat=beta,
        residuals=residuals,
        jacobian=w2,
        after=problem.before,
        at_bound=(),
        bound_text="",
        start_nfev=0,
        njev=1,
        history=beta[None, :].copy(),
        cost_history=np.array([quality_factor(residuals)]),
        covariance=covariance,
        noise_shift=shift,
        noise=noise,
    )


def _compensated(est, problem: _Problem, w2: np.ndarray, tau_f: np.ndarray, stuck=None):
    """β̂ from ``A_c = 2A(x) - mean A(x + ε_k)``, and its covariance from the replicates.

    The same simulation-extrapolation as `.solve.solve_compensated`, with ∂β/∂θ = identity.
    """
    model, f = problem.model, problem.filtered
    columns = problem.base.independent_index  # type: ignore[attr-defined]
    gram, rhs = w2.T @ w2, w2.T @ tau_f.ravel()

    def normal_equations(qf, qdf, qddf, tau_f):
        return _normal_equations(model, columns, qf, qdf, qddf, tau_f, stuck=stuck)

    grams, rhss, tts = replicate_normal_equations(est, f, normal_equations)
    gram_c = 2.0 * gram - np.mean(grams, axis=0)
    rhs_c = 2.0 * rhs - np.mean(rhss, axis=0)
    beta, r_c = _gram_least_squares(gram_c, rhs_c)
    plain, _ = _gram_least_squares(gram, rhs)
    cov = replicate_covariance(beta, grams, rhss, r_c)  # H = A_c = R_cᵀ R_c
    shift = {n: float(b - a) for n, a, b in zip(problem.names, plain, beta, strict=True)}
    problem.noise_fraction = noise_fraction(
        beta,
        (gram, rhs, float(tau_f.ravel() @ tau_f.ravel())),
        zip(grams, rhss, tts, strict=True),
    )
    return beta, cov, shift
