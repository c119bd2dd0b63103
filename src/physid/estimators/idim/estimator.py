"""IDIM: the estimator (`IDIMEstimator`), a pipeline of the stages of `physid.estimators.idim`.

``fit`` runs: rows (`.rows.idim_rows`: state filter, base regressor, parallel filtering and
decimation, stuck equations dropped) -> checks of the rows (`.solve.check_excitation`) -> OLS,
then WLS or IV (`.solve`, `.iv`) -> covariance (`.uncertainty`) -> the torque-error verdict and
message -> optional consistent estimate (`physid.estimators.consistent`) -> `.result.IDIMResult`.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..._validate import check_int, check_positive
from ...errors import IdentifiabilityError, InputError, SamplingError, arg
from .._stiction import (
    STICK_AUTO,
    check_stick_threshold,
    drop_equations,
    dropped_summary,
    elevated_joints,
    motionless_joints,
    never_moving,
)
from ..base import EstimatorMixin
from ..consistent import consistent_estimate
from ..plausibility import gate, implausible_scale, too_perfect, unchanging
from .base_parameters import BaseInfo, base_regressor_info, unit_of
from .iv import controller, describe_controller, iv_iterations
from .result import IDIMResult
from .rows import IDIMRows, idim_rows
from .solve import (
    COND_WARN,
    ConditionWarning,
    check_equation_count,
    check_excitation,
    condition_number,
    joint_sigma,
    lstsq,
)
from .uncertainty import STDERR_METHODS, covariance
from .verdict import identification_verdict, iv_verdict, torque_noise_floor, torque_verdict

__all__ = ["IDIMEstimator", "METHODS", "REL_ERROR_FAIL", "REL_ERROR_FAIL_JOINT"]

#: Estimation methods of `IDIMEstimator`.
METHODS = ("ols", "wls", "iv")
#: Relative torque error ``‖τ̂ − τ‖/‖τ‖`` on the fitted rows above which the fit reports
#: ``success=False``: overall, and for any single joint. A model that explains the data leaves
#: the noise and unmodelled effects: 5e-4 (planar2, σ_q = 1e-4 rad), 0.01 (arm6 README session),
#: 0.05–0.15 on real industrial arms in the literature; a wrong model or wrong data leaves far
#: more: 0.48 overall / 0.83 on tau2 for mean-removed q and τ (``--detrend``), 0.42 / 0.77 for
#: swapped joints (planar2).
REL_ERROR_FAIL = 0.2
REL_ERROR_FAIL_JOINT = 0.5


class StictionWarning(UserWarning):
    """The stiction rule dropped most of a joint's equations (named, with the fix)."""


@dataclass(eq=False)
class _Estimate:
    """What the solve steps of `IDIMEstimator.fit` found (arrays of the fitted rows)."""

    beta: np.ndarray  # (p,)
    weights: np.ndarray  # (n_joints,): ones for OLS, 1/σ̂_j for WLS and IV
    sigma: np.ndarray  # (n_joints,): residual std per joint at beta
    history: list = field(default_factory=list)
    Z: np.ndarray | None = None  # IV instruments
    changes: list = field(default_factory=list)  # IV: relative change per iteration


class IDIMEstimator(EstimatorMixin):
    """Inverse-dynamic-model identification of the base parameters: OLS, WLS or IV.

    Settings follow scikit-learn's protocol (`EstimatorMixin`: ``get_params``, ``set_params``,
    a ``repr`` of the settings that differ from the defaults, ``fit_arrays``).

    Parameters
    ----------
    model : ChainModel
        Linear in its base parameters (``regressor``, ``base_parameters()``).
    method : {"ols", "wls", "iv"}
        Ordinary least squares; Gautier's two-step weighted least squares (rows of joint j
        weighted by ``1/σ̂_j`` from the OLS residual); or Janot–Gautier instrumental variables
        (instruments from a simulated closed loop of the current estimate, weighted like WLS).
    differentiation : {"physid", "butterworth"}
        State filter (see `idim_rows`).
    cutoff : float [rad/sample] or "auto"
        State-filter cut-off.
    half_width : int, optional
        FIR half-width M of the physid filter.
    decimate : int or "auto"
        Parallel-filter decimation factor nd; "auto": chosen by a cross-validated torque error
        among the spectrum rule's band, the state filter's own and the octaves below it down to
        1/32 of it (`physid.estimators.idim.choose`).
    stderr : {"filtered", "hac", "iid"}
        ``"filtered"`` (default): white torque noise per joint passed through the known parallel
        filter and decimation, so the decimated residual's correlation ``ρ_l`` is the filter's
        own (lag 1 ≈ 0.18) and the sandwich uses it instead of estimating it: 94.3 / 93.5 /
        93.5 % coverage (OLS / WLS / IV) of 400 trials on planar2, where the HAC of ~64 rows
        gives 85–86 % (`benchmarks/bench_idim.py --part c`), and 98.6–100 % on the demo's arm6.
        ``"hac"``: the Newey–West sandwich with an estimated correlation (for residuals coloured
        by model error, at the price of a downward bias on few rows); ``"iid"``: classical
        ``σ² (WᵀW)⁻¹``.
    per_joint_variance : bool
        With ``stderr="iid"``: one noise variance per joint instead of a pooled one.
    hac_lag : int, optional
        HAC bandwidth in decimated rows (default: from the residual's correlation length).
    kp, kd : array_like (n_joints,), optional
        PD gains of the closed loop (IV only; default: the recording's metadata ``kp``/``kd``).
    feedforward : {None, "none", "gravity", "gravity+friction"}
        IV only: the feed-forward the controller added to the PD law, simulated at the current
        estimate (`physid.estimators.idim.iv`); None: the metadata's ``feedforward``, else PD.
    max_iter : int
        IV iterations at most.
    tol : float
        IV stops when the relative change of the estimate falls below this.
    consistent : bool
        Also compute a physically consistent estimate (`ConsistentEstimate`).
    check_condition : bool
        Warn (`ConditionWarning`) above a condition number of 1e3 and refuse above 1e8.
    stick_threshold : "auto" or float
        Joints with dry friction (``Fc``, ``Fcp``, ``Fcn``): which equations to drop, where the
        friction torque is unknown (stiction) and the filters smear the stick/slip switch.
        ``"auto"`` (default): where the data show sticking, the measured position staying
        within its noise for a sustained interval, widened only by the filters' main lobes; a
        number F in (0, 1): where the filtered |q̇_j| is below F times its rms (the rule of
        earlier versions); 0 keeps every equation. The message gives the share dropped per
        joint and warns about a joint that loses most of its equations; `IDIMRows.stuck`
        marks them.
    """

    def __init__(
        self,
        model,
        method: str = "ols",
        *,
        differentiation: str = "physid",
        cutoff: float | str = "auto",
        half_width: int | None = None,
        decimate: int | str = "auto",
        stderr: str = "filtered",
        per_joint_variance: bool = True,
        hac_lag: int | None = None,
        kp=None,
        kd=None,
        feedforward: str | None = None,
        max_iter: int = 10,
        tol: float = 1e-4,
        consistent: bool = False,
        check_condition: bool = True,
        stick_threshold: float | str = "auto",
    ):
        self.model = model
        self.method = method
        self.differentiation = differentiation
        self.cutoff = cutoff
        self.half_width = half_width
        self.decimate = decimate
        self.stderr = stderr
        self.per_joint_variance = per_joint_variance
        self.hac_lag = hac_lag
        self.kp = kp
        self.kd = kd
        self.feedforward = feedforward
        self.max_iter = max_iter
        self.tol = tol
        self.consistent = consistent
        self.check_condition = check_condition
        self.stick_threshold = stick_threshold

    # checks ---------------------------------------------------------------------------
    def _check_settings(self) -> None:
        if self.method not in METHODS:
            raise InputError(f"method must be one of {METHODS}; got {self.method!r}.")
        if self.stderr not in STDERR_METHODS:
            raise InputError(f"stderr must be 'hac', 'iid' or 'filtered'; got {self.stderr!r}.")
        check_int(self.max_iter, "max_iter", minimum=1)
        check_int(self.hac_lag, "hac_lag", minimum=0, allow_none=True)
        check_int(self.half_width, "half_width", minimum=1, allow_none=True)
        check_positive(self.tol, "tol")
        check_stick_threshold(self.stick_threshold)

    def _check_excitation(self, W: np.ndarray, info: BaseInfo, where: str) -> float:
        """Refuse unexcited columns and meaningless conditioning; warn on poor conditioning."""
        return check_excitation(W, info, where, warn=self.check_condition)

    # fit --------------------------------------------------------------------------------
    def fit(self, recording):
        """Identify the base parameters from one recording or a list of them.

        Parameters
        ----------
        recording : Recording or sequence of Recording
            ``t`` [s], ``q1..qn`` [rad], ``tau1..taun`` [N·m] (IV also ``r1..rn`` [rad] and
            the PD gains, in the metadata or as ``kp``/``kd``). Several recordings are filtered
            each on its own and stacked.

        Returns
        -------
        self
            With ``result_`` (`IDIMResult`), ``rows_`` (`IDIMRows`) and ``base_`` (`BaseInfo`).

        Raises
        ------
        IdentifiabilityError
            An unexcited base parameter, or a condition number above 1e8.
        InputError
            IV without a known controller; bad settings.
        SamplingError, ShapeError
            Recordings that differ in joints or sample period; decimation leaving fewer rows
            than parameters.
        """
        from ...signals.recording import Recording

        self._check_settings()
        recs = [recording] if isinstance(recording, Recording) else list(recording)
        model = self.model
        _check_all_unknown(model)
        info = base_regressor_info(model)
        loops = None
        if self.method == "iv":
            loops = controller(recs, int(model.n_joints), self.kp, self.kd, self.feedforward)
        rows = self._rows(recs, info)
        notes: list[str] = []
        self._check_rows(rows, info, notes, recs)
        rows = _drop_reversals(rows)
        self._warn_heavy(rows, notes, recs)
        est = self._solve(recs, rows, info, loops, notes)
        e = rows.tau - rows.W @ est.beta
        cov, lag, reason = covariance(
            rows.W,
            e,
            est.weights,
            est.Z,
            rows.segments,
            decimate=rows.decimate,
            stderr=self.stderr,
            per_joint_variance=self.per_joint_variance,
            lag=self.hac_lag,
        )
        # the one condition number of the fit: that of the regressor solved (weighted for WLS/IV)
        cond = float(condition_number(rows.W * est.weights[None, :, None]))
        rel = _relative_errors(rows.tau, e)
        success, message = self._verdict(est, rows, rel, cond, recs)
        overall = float(np.linalg.norm(e) / max(np.linalg.norm(rows.tau), 1e-300))
        ok, sentence = identification_verdict(est.beta, cov, reason, cond, COND_WARN, overall)
        success, message = success and ok, message + sentence
        message += describe_controller(loops) if loops else ""
        scale = implausible_scale(dict(zip(info.names, est.beta, strict=True)), model, recs)
        success, message = gate(success, message, [*_implausible(rows.tau, e), *scale])
        consistent = None
        if self.consistent:
            consistent = consistent_estimate(model, info, rows.W, rows.tau, est.beta, est.weights)
            if not consistent.converged:
                success = False
                message += " " + consistent.message
                notes.append(consistent.message)
        self.result_ = self._result(
            info,
            rows,
            est,
            e,
            (cov, lag, reason),
            cond,
            rel,
            (success, message),
            consistent,
            notes,
            len(recs),
        )
        self.rows_ = rows
        self.base_ = info
        return self

    # the steps ----------------------------------------------------------------------------
    def _rows(self, recs, info: BaseInfo, **changes) -> IDIMRows:
        """Filtered, decimated rows of the recordings, with the fit's settings (``changes``
        override some: the cut-off and decimation a first pass chose, another stiction rule)."""
        settings = {
            "differentiation": self.differentiation,
            "cutoff": self.cutoff,
            "half_width": self.half_width,
            "decimate": self.decimate,
            "stick_threshold": self.stick_threshold,
        }
        return idim_rows(self.model, recs, info=info, **{**settings, **changes})

    def _check_rows(self, rows: IDIMRows, info: BaseInfo, notes: list[str], recs=()) -> None:
        """Enough equations, every column excited, conditioning (its warning also in notes)."""
        nj, p = int(self.model.n_joints), info.n_base
        check_equation_count(rows.W.shape[0], nj, p, rows.decimate)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ConditionWarning)
            try:
                self._check_excitation(rows.W, info, "the recording(s)")
            except IdentifiabilityError as exc:
                self._blame_stiction_rule(recs, rows, info, exc)
                raise
        for w in caught:
            notes.append(str(w.message))
            warnings.warn(w.message, w.category, stacklevel=3)

    def _warn_heavy(self, rows: IDIMRows, notes: list[str], recs=()) -> None:
        """A warning (also in notes) per joint that lost most of its equations, counting every
        drop (the residual's next to reversals and at low speed too), and per joint that never
        moves."""
        _, heavy = dropped_summary(rows.stuck, self.stick_threshold, candidates=rows.reversal)
        for text in heavy + _motionless(recs, int(self.model.n_joints)):
            warnings.warn(text, StictionWarning, stacklevel=3)
            notes.append(text)

    def _blame_stiction_rule(self, recs, rows: IDIMRows, info: BaseInfo, exc) -> None:
        """Raise a clearer error when the stiction rule, not the record, left too little.

        Called on a failed excitation check: when equations were dropped and the rows with
        every equation kept pass the check, the rule made the record unidentifiable; say so.
        """
        if rows.stuck is None or not rows.stuck.any() or not recs:
            return
        try:
            full = self._rows(
                recs, info, cutoff=rows.cutoff, decimate=rows.decimate, stick_threshold=0.0
            )
            check_excitation(full.W, info, "the recording(s)", warn=False)
        except (IdentifiabilityError, SamplingError):
            return
        share = rows.stuck.mean(axis=0)
        per = ", ".join(f"joint {j + 1} {100 * s:.0f} %" for j, s in enumerate(share) if s > 0)
        raise IdentifiabilityError(
            f"the stiction rule ({arg('stick_threshold')}={self.stick_threshold!r}) dropped "
            f"{int(rows.stuck.sum())} of {rows.stuck.size} joint equations ({per}) and what "
            f"is left cannot be identified ({exc}). With every equation kept the record is "
            f"well excited: keep them with {arg('stick_threshold', '0', cli='0')} if the joints "
            "do not really stick."
        ) from exc

    def _solve(self, recs, rows: IDIMRows, info: BaseInfo, loops, notes) -> _Estimate:
        """OLS; then Gautier's WLS (weights 1/σ̂_j from the OLS residual); then IV iterations."""
        W, y, p = rows.W, rows.tau, info.n_base
        nj = W.shape[1]
        beta = lstsq(W, y, np.ones(nj))
        est = _Estimate(beta, np.ones(nj), joint_sigma(W, y, beta, p), [beta])
        if self.method in ("wls", "iv"):
            est.weights = 1.0 / np.where(est.sigma > 0, est.sigma, 1.0)
            est.beta = lstsq(W, y, est.weights)
            est.history.append(est.beta)
            est.sigma = joint_sigma(W, y, est.beta, p)
        if self.method == "iv":
            est.beta, est.Z, est.changes = iv_iterations(
                self.model,
                info,
                recs,
                rows,
                loops,
                est.beta,
                est.weights,
                est.history,
                notes,
                (self.differentiation, self.max_iter, self.tol),
            )
            est.sigma = joint_sigma(W, y, est.beta, p)
        return est

    def _torque_verdict(self, rows: IDIMRows, beta, recs):
        """``(ok, sentence)``: the residual against the relative limits and the noise floor
        (`physid.estimators.idim.verdict`)."""
        e = rows.tau - rows.W @ beta
        floor = torque_noise_floor(recs, rows.W.shape[1], rows.decimate)
        ok, sentence = torque_verdict(
            rows.tau, e, floor, REL_ERROR_FAIL, REL_ERROR_FAIL_JOINT, decimate=rows.decimate
        )
        if not ok:
            sentence += (
                " Check the channel map (q and tau of each joint, their units and signs), do "
                "not remove the mean of q or tau (a torque-sensor offset is the model's OF "
                "term), and check that the model belongs to the arm."
            )
        return ok, sentence

    def _verdict(self, est: _Estimate, rows: IDIMRows, rel, cond: float, recs):
        """``(success, message)``: finite estimates, torques explained, IV converged."""
        success = bool(np.all(np.isfinite(est.beta)))
        weighted = "" if self.method == "ols" else ", rows weighted by 1/σ̂_j as solved"
        message = (
            f"IDIM-{self.method.upper()} on {len(recs)} recording(s), {rows.W.shape[0]} rows; "
            f"condition number {cond:.4g} (column-scaled{weighted})."
        )
        message += rows.choice
        message += dropped_summary(rows.stuck, self.stick_threshold, candidates=rows.reversal)[0]
        ok, sentence = self._torque_verdict(rows, est.beta, recs)
        success &= ok
        message += sentence
        ok, sentence = iv_verdict(
            est.changes if self.method == "iv" else (), self.tol, _torque_changes(est, rows)
        )
        success &= ok
        message += sentence
        return success, message

    def _result(
        self, info, rows, est, e, uncertainty, cond, rel, verdict, consistent, notes, n_recs
    ) -> IDIMResult:
        """The `IDIMResult` of the steps' outputs."""
        model, names = self.model, info.names
        cov, lag, reason = uncertainty
        sd = np.sqrt(np.clip(np.diag(cov), 0.0, None)) if reason is None else None
        units = {n: unit_of(c, model) for n, c in zip(names, info.independent, strict=True)}
        derived: dict[str, float] = {}
        if consistent is not None:
            derived = dict(consistent.standard)
            units.update({n: unit_of(n, model) for n in derived})
        return IDIMResult(
            stick_threshold=_stick_value(self.stick_threshold),
            reversal_joints=_reversal_joints(rows),
            names=names,
            parameters=dict(zip(names, est.beta.tolist(), strict=True)),
            base_expressions=dict(zip(names, info.expressions, strict=True)),
            columns=info.independent,
            stderr=None if sd is None else dict(zip(names, sd.tolist(), strict=True)),
            stderr_reason=reason,
            stderr_method=self.stderr,
            covariance=cov,
            derived=derived,
            units=units,
            method=f"idim-{self.method}",
            success=verdict[0],
            message=verdict[1],
            condition_number=cond,
            relative_error=rel,
            joint_sigma={f"tau{j + 1}": float(s) for j, s in enumerate(est.sigma)},
            n_rows=int(rows.W.shape[0]),
            n_recordings=n_recs,
            cutoff=rows.cutoff,
            half_width=rows.half_width,
            decimate=rows.decimate,
            dt=rows.dt,
            differentiation=self.differentiation,
            hac_lag=int(lag),
            iterations=len(est.changes),
            iv_changes=tuple(est.changes),
            consistent=consistent,
            warnings=tuple(notes),
            history=np.array(est.history),
            t=rows.t,
            residuals=e,
            model=model,
        )


def _torque_changes(est: _Estimate, rows: IDIMRows) -> list[float]:
    """For each IV iteration, ``‖(W (β_k − β_{k−1}))_j / σ̂_j‖ / √p`` on the fit's rows: how far
    it moved the predicted torques, in units of the spread the estimate's own noise gives them
    (``σ̂_j`` the residual std of joint j; an estimate from rows of unit noise moves its
    prediction by about √p). Empty for OLS and WLS, and when IV diverged and kept an earlier
    iterate (then no change is a sign of stability)."""
    n = len(est.changes)
    if n == 0 or len(est.history) < n + 1 or not np.array_equal(est.beta, est.history[-1]):
        return []
    p = rows.W.shape[-1]
    sigma = np.asarray(est.sigma, dtype=float)
    scale = 1.0 / np.where(sigma > 0, sigma, np.inf)
    Ww = (rows.W * scale[None, :, None]).reshape(-1, p)
    steps = est.history[-(n + 1) :]
    return [  # per iteration (at most max_iter)
        float(np.linalg.norm(Ww @ (after - before))) / math.sqrt(p)
        for before, after in zip(steps[:-1], steps[1:], strict=True)
    ]


def _drop_reversals(rows: IDIMRows, joints=None) -> IDIMRows:
    """Drop the equations near speed reversals or at low speed (`reversal_samples`) of the
    joints whose residual shows friction the model does not explain there.

    A first OLS fit on the rows kept; for each joint with dry friction whose reversal
    equations leave an rms residual twice the others' (`elevated_joints`), those equations
    join ``stuck`` — unless that would leave a base column unexcited or raise the condition
    number tenfold (then they are kept). ``joints`` (bool per joint) given: drop those joints'
    (what `validate` repeats). Returns the rows (``W``, ``tau`` zeroed in place).
    """
    if rows.reversal is None or not rows.reversal.any():
        return rows
    kept = np.any(rows.W != 0.0, axis=2)
    if joints is None:
        beta = lstsq(rows.W, rows.tau, np.ones(rows.W.shape[1]))
        joints = elevated_joints(rows.tau - rows.W @ beta, rows.reversal, kept)
    if not np.any(joints):
        return rows
    extra = rows.reversal & joints[None, :] & kept
    W2 = np.where(extra[:, :, None], 0.0, rows.W)
    before = condition_number(rows.W)
    after = condition_number(W2)
    if not np.isfinite(after) or after > max(10.0 * before, COND_WARN):
        return rows
    stuck = rows.stuck | extra
    drop_equations(rows.W, rows.tau, extra)
    return dataclasses.replace(rows, stuck=stuck)


def _motionless(recs, nj: int) -> list[str]:
    """A warning per joint that never moves in any recording (named, with the fix)."""
    moving = np.zeros(nj, dtype=bool)
    for rec in recs:
        names = [f"q{j + 1}" for j in range(nj)]
        if all(n in rec.names for n in names):
            moving |= ~motionless_joints(rec.select(names))
    return never_moving(moving)


def _reversal_joints(rows: IDIMRows) -> tuple:
    """1-based joints whose reversal equations the fit dropped (`_drop_reversals`)."""
    if rows.reversal is None or rows.stuck is None:
        return ()
    return tuple(int(j) + 1 for j in np.flatnonzero(np.any(rows.reversal & rows.stuck, axis=0)))


def _stick_value(value):
    """The ``stick_threshold`` as the result records it: ``"auto"`` or a float."""
    value = check_stick_threshold(value)
    return value if value == STICK_AUTO else float(value)


def _relative_errors(y: np.ndarray, e: np.ndarray) -> dict[str, float]:
    """``‖e‖/‖y‖`` overall (``"overall"``) and per joint (``"tau1"``…)."""
    tau_norm = np.linalg.norm(y, axis=0)
    rel = {"overall": float(np.linalg.norm(e) / max(np.linalg.norm(y), 1e-300))}
    for j in range(e.shape[1]):
        rel[f"tau{j + 1}"] = float(np.linalg.norm(e[:, j]) / max(tau_norm[j], 1e-300))
    return rel


def _implausible(tau: np.ndarray, e: np.ndarray) -> list[str | None]:
    """The plausibility gate's sentences (`physid.estimators.plausibility`): torques that
    never change, and a fit exact to rounding on them."""
    names = [f"tau{j + 1}" for j in range(tau.shape[1])]
    return [unchanging(tau, names, "torque"), too_perfect(e, tau, names)]


def _check_all_unknown(model) -> None:
    """Refuse a model that marks parameters as known: IDIM cannot hold them.

    IDIM estimates every base parameter, i.e. combinations of all standard parameters; a value
    marked known (``identify = false`` in a model file, a sidecar's ``identify = [...]``) would
    be estimated anyway, so the fit refuses instead of ignoring the mark.
    """
    names = tuple(getattr(model, "parameter_names", ()))
    unknown = getattr(model, "unknown", None)
    if unknown is None:
        return
    known = [n for n in names if n not in set(unknown)]
    if known:
        shown = ", ".join(known[:8]) + (f", … ({len(known)} in all)" if len(known) > 8 else "")
        raise InputError(
            f"model {getattr(model, 'name', '')!r} marks {shown} as known (identify = false in "
            "its model file, or a sidecar's identify = [...] list: model.unknown), but IDIM "
            "estimates every base parameter, combinations of all of them, and cannot hold "
            "some at given values. Remove the marks to estimate them all, or use "
            f"{arg('method', repr('input-error'), cli='input-error')}, which holds the known "
            "ones."
        )
