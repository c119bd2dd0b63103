"""Streamed IDIM, the solve: estimate, covariance and verdict from accumulated `RowMoments`.

Everything `IDIMEstimator.fit` computes from the rows, computed from the per-joint QR factors
``R_j`` of ``[W_j | τ_j]`` (`stream_moments`): a weighted stack ``[w_1 R_1; …; w_n R_n]`` has the
same column norms, singular values and least-squares solution as the weighted rows, so the
column-scaled solve, the condition number and the excitation check are those of the rows; the
residual of joint j is ``‖R_j [β; −1]‖``.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from scipy import linalg

from ...errors import IdentifiabilityError, SamplingError, arg
from .._stiction import STICK_AUTO, dropped_summary_counts, never_moving
from .base_parameters import base_regressor_info, unit_of
from .choose import pick
from .result import IDIMResult
from .solve import (
    COND_WARN,
    ConditionWarning,
    check_equation_count,
    check_excitation,
    condition_number,
)
from .stream_moments import RowMoments, noise_correlation
from .stream_plan import StreamPlan, motionless
from .verdict import identification_verdict, iv_verdict, noise_floor, torque_verdict_sums

__all__ = ["fit_moments"]


def _joint_factors(R5):
    """Per joint, the factor of all folds (R5: (FOLDS, n_joints, p+1, p+1)) -> (nj, p+1, p+1)."""
    stacked = np.concatenate(list(R5), axis=-2)  # (nj, FOLDS·(p+1), p+1)
    return np.linalg.qr(stacked, mode="r")


def _solve(Rj, weights):
    """Column-scaled least squares on the weighted stack: β (p,), the stack's QR factor."""
    p = Rj.shape[-1] - 1
    a = (Rj * weights[:, None, None]).reshape(-1, p + 1)
    norms = np.linalg.norm(a[:, :p], axis=0)
    d = 1.0 / np.where(norms > 0, norms, 1.0)
    r = np.linalg.qr(a * np.append(d, 1.0), mode="r")
    try:  # R β = Qᵀ τ: a triangular solve (QR of the scaled stack, as lstsq does on the rows)
        x = linalg.solve_triangular(r[:p, :p], r[:p, p])
    except (linalg.LinAlgError, ValueError):
        x = linalg.lstsq(r[:p, :p], r[:p, p])[0]
    if not np.all(np.isfinite(x)):
        x = linalg.lstsq(r[:p, :p], r[:p, p])[0]
    return x * d


def _e2(Rj, beta):
    """Σ e_j² per joint from the factors: ‖R_j [β; −1]‖²."""
    v = np.append(beta, -1.0)
    return np.sum((Rj @ v) ** 2, axis=-1)


def _cv_errors(plan: StreamPlan, moments: RowMoments):
    """`choose.cross_validated_error` of every candidate from the fold factors."""
    nds = list(plan.candidates)
    ev = moments.candidates[max(nds)]  # the in-memory fit's evaluation rows (`choose`)
    Re = _merge_classes(ev.R)  # (FOLDS, nj, p+1, p+1)
    errors = []
    p = plan.n_base
    for nd in nds:
        c = moments.candidates[nd]
        Rf = _merge_classes(c.R)
        G = np.einsum("fjki,fjkl->fil", Rf, Rf)  # per fold Gram of [W | τ], summed over joints
        norms = np.sqrt(np.clip(np.diag(G.sum(axis=0))[:p], 0.0, None))
        d = 1.0 / np.where(norms > 0, norms, 1.0)
        g = G[:, :p, :p] * d[:, None] * d[None, :]
        h = G[:, :p, p] * d
        kept = c.kept.sum(axis=(1, 2))
        num = den = 0.0
        for f in range(G.shape[0]):  # per fold
            if int(kept.sum() - kept[f]) <= 2 * p:
                num = float("nan")
                break
            beta = np.linalg.lstsq(g.sum(0) - g[f], h.sum(0) - h[f], rcond=None)[0] * d
            num += float(np.sum(_e2(Re[f], beta)))
            den += float(np.sum(Re[f][:, :, p] ** 2))
        errors.append(math.sqrt(num / den) if den > 0 and np.isfinite(num) else float("nan"))
    return errors


def _merge_classes(R):
    """(FOLDS, 2, nj, m, m) -> (FOLDS, nj, m, m): both classes of rows in one factor."""
    return np.linalg.qr(np.concatenate([R[:, 0], R[:, 1]], axis=-2), mode="r")


def fit_moments(model, plan: StreamPlan, moments: RowMoments) -> IDIMResult:
    """The streamed fit's estimate, covariance and verdict from the moments of all its sources.

    Parameters
    ----------
    model : ChainModel
    plan : StreamPlan
    moments : RowMoments
        The sum of `idim_moments` over every source of the plan.

    Returns
    -------
    IDIMResult
        As `IDIMEstimator.fit`'s ``result_``; ``t`` and ``residuals`` hold every k-th row
        (the warnings say k when k > 1).

    Raises
    ------
    IdentifiabilityError
        An unexcited base parameter, or a condition number above 1e8.
    SamplingError
        Fewer equations than base parameters.
    """
    missing = sorted(set(range(len(plan.sources))) - set(moments.sources))
    if missing:
        raise SamplingError(
            f"the moments lack source(s) {[k + 1 for k in missing]} of the plan; add the "
            "idim_moments of every source before fit_moments."
        )
    info = base_regressor_info(model)
    nj, p = plan.n_joints, plan.n_base
    notes: list[str] = []
    if len(plan.candidates) > 1:
        nd, why = pick(list(plan.candidates), _cv_errors(plan, moments))
    else:
        nd, why = plan.candidates[0], ""
    c = moments.candidates[nd]
    rest, rev = (_joint_factors(c.R[:, cl]) for cl in (0, 1))
    full = np.linalg.qr(np.concatenate([rest, rev], axis=-2), mode="r")
    _check_rows(plan, c, full, info, notes, nd)
    # _drop_reversals: a first OLS; joints whose reversal rows fit twice worse lose them
    dropped = np.zeros(nj, dtype=bool)
    if plan.stick == STICK_AUTO and c.n_reversal.any():
        beta0 = _solve(full, np.ones(nj))
        kept_rev, kept_rest = c.kept[:, 1].sum(0), c.kept[:, 0].sum(0)
        rms_c = np.sqrt(_e2(rev, beta0) / np.maximum(kept_rev, 1))
        rms_r = np.sqrt(_e2(rest, beta0) / np.maximum(kept_rest, 1))
        joints = (kept_rev >= 1) & (kept_rest >= 10) & (rms_c > 2.0 * rms_r)
        if joints.any():
            cand = np.where(joints[:, None, None], rest, full)
            before = condition_number(full[:, :, :p])
            after = condition_number(cand[:, :, :p])
            if np.isfinite(after) and after <= max(10.0 * before, COND_WARN):
                dropped = joints & (kept_rev > 0)
                full = cand
    n_stuck = c.n_stuck + np.where(dropped, c.kept[:, 1].sum(0), 0)
    _warn_heavy(plan, c, n_stuck, notes)
    kept = c.kept.sum(axis=(0, 1)) - np.where(dropped, c.kept[:, 1].sum(0), 0)
    est = _estimates(plan, full, kept)
    cov, lag = _covariance(plan, c, full, dropped, est, nd)
    w = est["weights"]
    cond = float(condition_number(full[:, :, :p] * w[:, None, None]))
    e2 = _e2(full, est["beta"])
    t2 = np.sum(full[:, :, p] ** 2, axis=-1)
    rel = {"overall": float(math.sqrt(e2.sum()) / max(math.sqrt(t2.sum()), 1e-300))}
    rel.update(
        {f"tau{j + 1}": float(math.sqrt(e2[j]) / max(math.sqrt(t2[j]), 1e-300)) for j in range(nj)}
    )
    sample = _sample(c, est["beta"], dropped, notes, plan.thinning(nd))
    success, message = _verdict(plan, c, est, (e2, t2, kept), cond, nd, why, n_stuck)
    reason = None if np.all(np.isfinite(cov)) else "the normal equations are singular"
    ok, sentence = identification_verdict(
        est["beta"], cov, reason, cond, COND_WARN, rel["overall"]
    )  # as IDIMEstimator.fit: an estimate the data cannot support is not a success
    success, message = success and ok, message + sentence
    from ..plausibility import gate

    success, message = gate(success, message, _implausible(c, n_stuck, sample))
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None)) if np.all(np.isfinite(cov)) else None
    names = info.names
    return IDIMResult(
        stick_threshold=plan.settings["stick_threshold"]
        if plan.settings["stick_threshold"] == STICK_AUTO
        else float(plan.settings["stick_threshold"]),
        reversal_joints=tuple(int(j) + 1 for j in np.flatnonzero(dropped)),
        names=names,
        parameters=dict(zip(names, est["beta"].tolist(), strict=True)),
        base_expressions=dict(zip(names, info.expressions, strict=True)),
        columns=info.independent,
        stderr=None if sd is None else dict(zip(names, sd.tolist(), strict=True)),
        stderr_reason=None if sd is not None else "the normal equations are singular",
        stderr_method=plan.settings["stderr"],
        covariance=cov,
        units={n: unit_of(col, model) for n, col in zip(names, info.independent, strict=True)},
        method=f"idim-{plan.settings['method']}",
        success=success,
        message=message,
        condition_number=cond,
        relative_error=rel,
        joint_sigma={f"tau{j + 1}": float(s) for j, s in enumerate(est["sigma"])},
        n_rows=int(c.n_rows),
        n_recordings=len(plan.sources),
        cutoff=plan.cutoff,
        half_width=plan.half_width,
        decimate=nd,
        dt=plan.dt,
        differentiation=plan.settings["differentiation"],
        hac_lag=int(lag),
        derived={},
        iterations=0,
        iv_changes=(),
        consistent=None,
        warnings=tuple(notes),
        history=np.array(est["history"]),
        t=sample["t"],
        residuals=sample["e"],
        model=model,
    )


def _check_rows(plan, c, full, info, notes, nd) -> None:
    """`IDIMEstimator._check_rows` on the factors: equations, excitation."""
    nj, p = plan.n_joints, plan.n_base
    check_equation_count(c.n_rows, nj, p, nd)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConditionWarning)
        try:
            check_excitation(
                full[:, :, :p], info, "the recording(s)", warn=plan.settings["check_condition"]
            )
        except IdentifiabilityError as exc:
            if c.n_stuck.any():
                raise IdentifiabilityError(
                    f"{exc} The stiction rule ({arg('stick_threshold')}="
                    f"{plan.settings['stick_threshold']!r}) dropped {int(c.n_stuck.sum())} of "
                    f"{c.n_rows * nj} joint equations; if the joints do not really stick, keep "
                    f"them with {arg('stick_threshold', '0', cli='0')}."
                ) from exc
            raise
    for w in caught:
        notes.append(str(w.message))
        warnings.warn(w.message, w.category, stacklevel=4)


def _warn_heavy(plan, c, n_stuck, notes) -> None:
    """`IDIMEstimator._warn_heavy` on the counts: a joint that lost most of its equations (all
    drops counted, the residual's too), a joint that never moves."""
    _, heavy = dropped_summary_counts(
        n_stuck, c.n_rows, plan.settings["stick_threshold"], by_residual=n_stuck - c.n_stuck
    )
    moving = np.zeros(plan.n_joints, dtype=bool)
    for st in plan.sources:
        moving |= ~motionless(st)
    heavy += never_moving(moving)
    from .estimator import StictionWarning

    for text in heavy:
        warnings.warn(text, StictionWarning, stacklevel=4)
        notes.append(text)


def _estimates(plan, full, kept):
    """OLS, then WLS (weights 1/σ̂_j): β, weights, σ̂, history."""
    nj, p = plan.n_joints, plan.n_base
    ones = np.ones(nj)

    def sigma(beta):
        return np.sqrt(_e2(full, beta) / np.maximum(kept - p / nj, 1.0))

    beta = _solve(full, ones)
    est = {"beta": beta, "weights": ones, "sigma": sigma(beta), "history": [beta]}
    if plan.settings["method"] == "wls":
        s = est["sigma"]
        est["weights"] = 1.0 / np.where(s > 0, s, 1.0)
        est["beta"] = _solve(full, est["weights"])
        est["history"].append(est["beta"])
        est["sigma"] = sigma(est["beta"])
    return est


def _covariance(plan, c, full, dropped, est, nd):
    """`uncertainty.covariance` ("filtered" or "iid") from the factors and lagged products."""
    nj, p = plan.n_joints, plan.n_base
    w, n = est["weights"], c.n_rows
    Rw = (full[:, :, :p] * w[:, None, None]).reshape(-1, p)
    A = Rw.T @ Rw
    ew2 = _e2(full, est["beta"]) * w**2
    if plan.settings["per_joint_variance"]:
        var = ew2 / max(n - p / nj, 1.0)
    else:
        var = np.full(nj, ew2.sum() / max(n * nj - p, 1))
    Gj = np.einsum("jki,jkl->jil", full[:, :, :p], full[:, :, :p])
    meat = np.einsum("j,jil->il", var * w**2, Gj)
    lag = 0
    if plan.settings["stderr"] == "filtered":
        L = np.where(dropped[:, None, None], c.lagged[1], c.lagged[0])
        rho = noise_correlation(int(nd))
        meat = meat + np.einsum("j,jil->il", var * w**2, L)
        lag = rho.size - 1
        if nd <= 1:
            meat = np.einsum("j,jil->il", var * w**2, Gj)
    try:
        A_inv = np.linalg.solve(A, np.eye(p))
    except np.linalg.LinAlgError:
        return np.full((p, p), np.nan), 0
    return A_inv @ meat @ A_inv.T, lag


def _sample(c, beta, dropped, notes, k):
    """The kept sample's time and residuals (every k-th row)."""
    s = c.sample
    if not s["W"]:
        return {"t": np.empty(0), "e": np.empty((0, len(dropped))), "tau": np.empty((0, 0))}
    order = np.concatenate(s["order"])
    idx = np.lexsort((order[:, 1], order[:, 0]))
    W = np.concatenate(s["W"])[idx]
    tau = np.concatenate(s["tau"])[idx]
    rev = np.concatenate(s["rev"])[idx] & dropped[None, :]
    W[rev] = 0.0
    tau = np.where(rev, 0.0, tau)
    if k > 1:
        notes.append(
            f"the result's t and residuals hold every {k}-th of the {c.n_rows} decimated rows "
            "(the streamed fit keeps at most 20000 rows; the estimate uses them all)."
        )
    return {"t": np.concatenate(s["t"])[idx], "e": tau - W @ beta, "tau": tau}


def _verdict(plan, c, est, sums, cond, nd, why, n_stuck):
    """`IDIMEstimator._verdict` from the sums."""
    from .estimator import REL_ERROR_FAIL, REL_ERROR_FAIL_JOINT

    e2, t2, kept = sums
    method = plan.settings["method"]
    success = bool(np.all(np.isfinite(est["beta"])))
    weighted = "" if method == "ols" else ", rows weighted by 1/σ̂_j as solved"
    message = (
        f"IDIM-{method.upper()} on {len(plan.sources)} recording(s), {c.n_rows} rows; "
        f"condition number {cond:.4g} (column-scaled{weighted})."
    )
    message += why
    by_residual = n_stuck - c.n_stuck
    message += dropped_summary_counts(
        n_stuck, c.n_rows, plan.settings["stick_threshold"], by_residual=by_residual
    )[0]
    sigma = np.max(np.array([s.tau_sigma for s in plan.sources]), axis=0)
    floor = noise_floor(sigma, nd)
    # rows with |τ| + |e| > 0: every equation kept (a dropped one is zero on both sides)
    ok, sentence = torque_verdict_sums(
        e2, t2, kept, floor, REL_ERROR_FAIL, REL_ERROR_FAIL_JOINT, decimate=nd
    )
    if not ok:
        sentence += (
            " Check the channel map (q and tau of each joint, their units and signs), do "
            "not remove the mean of q or tau (a torque-sensor offset is the model's OF "
            "term), and check that the model belongs to the arm."
        )
    success &= ok
    message += sentence
    ok, sentence = iv_verdict((), 1e-4)
    return success and ok, message + sentence


def _implausible(c, n_stuck, sample):
    """The gate's sentences from the extrema (torques that never change; an exact fit)."""
    from ..plausibility import _ROUNDING

    nj = c.tau_min.size
    lo = np.where(n_stuck > 0, np.minimum(c.tau_min, 0.0), c.tau_min)
    hi = np.where(n_stuck > 0, np.maximum(c.tau_max, 0.0), c.tau_max)
    flat = ~((hi - lo) > _ROUNDING * c.tau_abs)
    names = [f"tau{j + 1}" for j in np.flatnonzero(flat)]
    if not names:
        return []
    from ..plausibility import unchanging

    fake = np.zeros((2, nj))
    fake[1, ~flat] = 1.0
    out = [unchanging(fake, [f"tau{j + 1}" for j in range(nj)], "torque")]
    scale = max(float(np.max(c.tau_abs)), np.finfo(float).tiny)
    e = sample["e"]
    rel = float(np.max(np.abs(e))) / scale if e.size else 0.0
    if np.isfinite(rel) and rel <= _ROUNDING * max(1, c.n_rows):
        out.append(
            f"the fit is exact to rounding (largest residual {rel:.2g} of the output, on the "
            f"rows kept in the result) because {', '.join(names)} never change(s): the data "
            "hold nothing for the parameters to explain."
        )
    return out
