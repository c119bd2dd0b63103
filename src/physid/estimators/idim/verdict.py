"""The torque-error part of IDIM's verdict, judged against the noise the data show.

A fit fails on its torques when its residual is both large *relative to the torque*
(`REL_ERROR_FAIL` overall, `REL_ERROR_FAIL_JOINT` on a joint) and large *against the
torque-noise floor the record shows* (`NOISE_MARGIN` times it), and, where the record shows no
noise floor, above `SMALL_JOINT` of the largest joint's torque: a joint whose torque is small and
noisy is not a model failure because its relative error is large, only when its residual is
more than noise. The floor of joint j is the white noise of its measured torque (the robust
standard deviation of the third difference of τ_j over √20) through the parallel filter and
decimation (the filter's noise gain). A torque whose noise is below `SILENT_FLOOR` of its rms
shows no floor: it was low-pass filtered before it was logged (the real KUKA LWR4+ log of the
benchmark zoo, whose torques were filtered at 2 Hz: 2e-6 to 8e-6 of their rms; the real Franka
Panda log: 1.6e-3 to 9e-2; simulated sensors at 0.5–5 % noise: 5e-3 to 5e-2), and its third
difference measures that filter, not the sensor. The message says what was compared.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ...signals.noise import third_difference_sigma

__all__ = [
    "torque_noise_floor",
    "torque_verdict",
    "torque_verdict_sums",
    "torque_noise_sigma",
    "noise_floor",
    "noise_gain",
    "iv_verdict",
    "identification_verdict",
    "NOISE_MARGIN",
    "IV_STABLE",
    "IV_RESOLVED",
    "SMALL_JOINT",
    "SILENT_FLOOR",
]

#: A fit is "weakly identified" (not a success) when more than this fraction of its base
#: parameters have a standard error larger than the estimate itself.
WEAK_FRACTION = 0.5
#: A residual is "more than noise" above this multiple of the noise floor.
NOISE_MARGIN = 3.0
#: IV whose last three relative changes are below this is stable: not converging to ``tol`` is
#: noted, not a failure.
IV_STABLE = 0.05
#: IV whose last three iterations each moved the predicted torques by less than this many times
#: the spread the estimate's own noise gives them is stable at the resolution of the data (see
#: `iv_verdict`).
IV_RESOLVED = 1.0
#: A joint whose residual rms is below this fraction of the largest joint's torque rms is too
#: small to fail on its own (the overall limit still holds): a wrist joint's torque next to a
#: shoulder's.
SMALL_JOINT = 0.05
#: A torque whose raw white-noise std is at most this fraction of the rms of its filtered rows
#: (80 dB; the real logs of the benchmark zoo read 2e-6 to 8e-6 when filtered before logging,
#: 1.6e-3 and up when not) shows no noise floor: it was low-pass filtered before it was logged,
#: or simulated without noise. The residual of such a joint is judged as on a noise-free record.
SILENT_FLOOR = 1e-4


def torque_noise_floor(recordings, n_joints: int, decimate: int) -> np.ndarray:
    """Expected rms of white torque noise in the filtered, decimated rows, per joint [N·m].

    Parameters
    ----------
    recordings : sequence of Recording
        With ``tau1..taun``.
    n_joints : int
    decimate : int
        The parallel filter's nd.

    Returns
    -------
    ndarray, shape (n_joints,)
        ``σ̂_j · √g`` with σ̂_j the robust noise std of the raw τ_j and g the parallel filter's
        white-noise power gain (1 for nd = 1); NaN where a recording lacks the channel.
    """
    names = [f"tau{j + 1}" for j in range(n_joints)]
    sig = []
    for rec in recordings:
        if not all(n in rec.names for n in names):
            return np.full(n_joints, np.nan)
        sig.append(torque_noise_sigma(np.asarray(rec.select(names), dtype=float)))
    return noise_floor(np.max(np.array(sig), axis=0), decimate)


def torque_noise_sigma(tau) -> np.ndarray:
    """Robust white-noise std of raw torques: the MAD of the third difference over √20.

    Parameters
    ----------
    tau : ndarray, shape (n_samples, n_joints) [N·m]

    Returns
    -------
    ndarray, shape (n_joints,) [N·m]
    """
    return third_difference_sigma(tau)


def noise_floor(sigma, decimate: int) -> np.ndarray:
    """``σ · √g``: white noise of std ``sigma`` after the parallel filter of ``decimate``.

    Parameters
    ----------
    sigma : array_like, shape (n_joints,) [N·m]
        White-noise std of the raw torques (`torque_noise_sigma`).
    decimate : int
        nd of the parallel filter (g, its white-noise power gain, is 1 for nd = 1).

    Returns
    -------
    ndarray, shape (n_joints,) [N·m]
    """
    return np.asarray(sigma) * math.sqrt(noise_gain(decimate))


def noise_gain(decimate: int) -> float:
    """White-noise power gain of the parallel filter of ``decimate`` (1 for nd = 1): the
    variance of unit white noise after it."""
    return _noise_gain(int(decimate))


@functools.lru_cache(maxsize=64)
def _noise_gain(decimate: int) -> float:
    """`noise_gain`, memoised per integer nd."""
    if decimate <= 1:
        return 1.0
    from scipy import signal

    from .decimation import _decimation_sos

    half = 40 * int(decimate)
    delta = np.zeros(2 * half + 1)
    delta[half] = 1.0
    g = signal.sosfiltfilt(_decimation_sos(int(decimate)), delta)
    return float(g @ g)


def torque_verdict(tau, e, floor, fail_overall: float, fail_joint: float, *, decimate: int):
    """``(ok, sentence)``: is the torque residual a model failure?

    Parameters
    ----------
    tau, e : ndarray, shape (n_rows, n_joints)
        Fitted rows' torques and residuals (dropped equations are zero on both).
    floor : ndarray, shape (n_joints,)
        `torque_noise_floor` (NaN: unknown, only the relative limits count).
    fail_overall, fail_joint : float
        The relative limits.
    decimate : int
        The nd the floor was carried through (`noise_floor`): the raw noise it stands for,
        ``floor / √noise_gain(nd)``, is compared with the rms of the rows' torque
        (`SILENT_FLOOR`).

    Returns
    -------
    ok : bool
    sentence : str
        What was compared (empty when nothing is said).
    """
    nz = np.abs(tau) + np.abs(e) > 0
    return torque_verdict_sums(
        np.sum(e**2, axis=0),
        np.sum(tau**2, axis=0),
        nz.sum(axis=0),
        floor,
        fail_overall,
        fail_joint,
        overall=float(np.linalg.norm(e) / max(np.linalg.norm(tau), 1e-300)),
        decimate=decimate,
    )


def torque_verdict_sums(
    sum_e2,
    sum_t2,
    n_nonzero,
    floor,
    fail_overall: float,
    fail_joint: float,
    overall=None,
    *,
    decimate: int,
):
    """`torque_verdict` from per-joint sums: ``Σ e²``, ``Σ τ²`` and the count of rows where
    ``|τ| + |e| > 0`` (the streamed fit accumulates these, never the rows); ``overall``
    (``‖e‖/‖τ‖``) is computed from the sums when not given.

    Returns
    -------
    ok : bool
    sentence : str
    """
    sum_e2, sum_t2 = np.asarray(sum_e2, dtype=float), np.asarray(sum_t2, dtype=float)
    kept = np.asarray(n_nonzero) > 0
    n_j = np.maximum(np.asarray(n_nonzero), 1)
    rms_e = np.sqrt(sum_e2 / n_j)
    rms_t = np.sqrt(sum_t2 / n_j)
    rel = rms_e / np.where(rms_t > 0, rms_t, np.inf)
    if overall is None:
        overall = float(np.sqrt(np.sum(sum_e2)) / max(np.sqrt(np.sum(sum_t2)), 1e-300))
    floor = np.asarray(floor, dtype=float)
    known = np.isfinite(floor)
    # the record shows no floor where the raw noise the floor stands for is at most
    # SILENT_FLOOR of the torque (noise-free or pre-filtered data); a small joint is excused only
    # there: where it shows one, a residual far above it is a model failure however small the
    # joint (a coupled wrist's motor left out of the model)
    raw = np.where(known, floor, 0.0) / math.sqrt(noise_gain(decimate))
    silent = known & (raw <= SILENT_FLOOR * rms_t)
    floor = np.where(silent, 0.0, floor)
    noisy = np.where(known, rms_e <= NOISE_MARGIN * np.where(known, floor, 0.0), False)
    judged = known & ~silent
    noisy |= ~judged & (rms_e <= SMALL_JOINT * float(np.max(rms_t)))
    bad_joint = kept & (rel > fail_joint) & ~noisy
    total_floor = float(np.sqrt(np.sum(np.where(known, floor, 0.0) ** 2 * n_j) / n_j.sum()))
    total_e = float(np.sqrt(np.sum(sum_e2) / n_j.sum()))
    bad_overall = overall > fail_overall and not (
        known.all() and total_e <= NOISE_MARGIN * total_floor
    )
    if not (bad_joint.any() or bad_overall):
        excused = kept & (rel > fail_joint) & noisy
        if excused.any():
            js = ", ".join(f"tau{j + 1}" for j in np.flatnonzero(excused))
            return True, (
                f" {js}: relative error above {fail_joint:g}, but the residual is within "
                f"{NOISE_MARGIN:g}x the torque-noise floor of the record or below "
                f"{100 * SMALL_JOINT:g} % of the largest joint's torque (rms "
                + ", ".join(
                    f"{rms_e[j]:.3g} vs " + ("no floor" if silent[j] else f"floor {floor[j]:.3g}")
                    for j in np.flatnonzero(excused)
                )
                + f", largest torque rms {float(np.max(rms_t)):.3g}): not a model failure."
                + (
                    " No floor: the torque's noise is below "
                    f"{SILENT_FLOOR:g} of its rms, so it was filtered before it was logged "
                    "(or simulated without noise, or quantised coarser than its noise)."
                    if np.any(silent & excused)
                    else ""
                )
            )
        return True, ""
    worst = int(np.argmax(np.where(bad_joint, rel, -1.0))) if bad_joint.any() else None
    parts = [f"relative torque error {overall:.3g} overall"]
    if worst is not None:
        parts.append(
            f"{rel[worst]:.3g} on tau{worst + 1} (residual rms {rms_e[worst]:.3g} against "
            + (
                f"no torque-noise floor: its noise is below {SILENT_FLOOR:g} of its rms"
                if silent[worst]
                else f"a torque-noise floor of {floor[worst]:.3g} in the record"
            )
            + ")"
        )
    return False, (
        f" The model does not explain the torques: {', '.join(parts)}; a fit that explains the "
        f"data stays below {fail_overall:g} overall and {fail_joint:g} per joint, or within "
        f"{NOISE_MARGIN:g}x the noise floor."
    )


def iv_verdict(changes, tol: float, torque_changes=None):
    """``(ok, sentence)`` on IV's convergence: a stable estimate that missed ``tol`` is noted.

    Parameters
    ----------
    changes : sequence of float
        Relative change of the estimate at each IV iteration.
    tol : float
    torque_changes : sequence of float, optional
        For each iteration, ``‖(W (β_k − β_{k−1}))_j / σ̂_j‖ / √p``: how much it moved the
        predicted torques, in units of the spread the estimate's own noise gives them (about 1
        for an estimate of p parameters from rows of unit noise). Not given when IV diverged.

    Returns
    -------
    ok : bool
        False only when the last change exceeds ``tol``, one of the last three exceeds
        `IV_STABLE`, and one of the last three ``torque_changes`` (when given) exceeds
        `IV_RESOLVED`.
    sentence : str

    Notes
    -----
    The relative change weighs every base parameter alike, so a poorly determined one that
    wanders keeps it high while the torques the estimate predicts no longer move (IDIM-IV on a
    slow sweep with Coulomb friction simulated by pinocchio: relative changes 0.04–0.11).
    Changes of the prediction within the spread the estimate's own noise gives it are below
    what the data can tell apart (it does not grow with the record's length, as the residual
    does): the estimate is stable at the data's resolution, which is not a failure.
    """
    if not changes or changes[-1] <= tol:
        return True, ""
    last = changes[-1]
    if len(changes) >= 3 and max(changes[-3:]) <= IV_STABLE:
        return True, (
            f" IV stopped after {len(changes)} iterations with a last relative change of "
            f"{last:.2g} (> tol {tol:g}, but the last three changes stay below {IV_STABLE:g}: the "
            "estimate is stable to that level, so this is not a failure; raise max_iter to "
            "converge to tol)."
        )
    moved = list(torque_changes or ())
    if len(changes) >= 3 and len(moved) >= 3 and max(moved[-3:]) <= IV_RESOLVED:
        return True, (
            f" IV stopped after {len(changes)} iterations with a last relative change of "
            f"{last:.2g} (> tol {tol:g}): poorly determined parameters still move, but the last "
            f"three iterations moved the predicted torques by at most {max(moved[-3:]):.2g}× the "
            "spread the estimate's own noise gives them: the estimate is stable at the "
            "resolution of the data, so this is not a failure."
        )
    return False, (
        f" IV did not converge in {len(changes)} iterations (last relative change "
        f"{last:.2g} > tol {tol:g}); raise max_iter, check the gains, or improve the "
        "excitation."
    )


def identification_verdict(beta, cov, reason, cond: float, cond_limit: float, rel_error: float):
    """``(ok, sentence)``: can the data support the estimate ("weakly identified" if not)?

    A small torque residual does not make an estimate: with a poorly exciting motion most base
    parameters are free to move along the regressor's near-null directions. The fit is refused
    as weakly identified when the column-scaled condition number κ exceeds ``cond_limit`` (the
    conditioning warning's level, `physid.estimators.idim.solve.COND_WARN`) *and* the
    first-order bound on the parameters' relative error, ``κ × rel_error`` (the residual taken
    as the perturbation of the torques), exceeds 1; or when more than `WEAK_FRACTION` of the
    estimates are smaller than their standard errors. (A noise-free record leaves a residual at
    rounding level: a large κ then still pins the estimate, and the fit stands, with the
    conditioning warning.)

    Parameters
    ----------
    beta : ndarray, shape (p,)
        The base-parameter estimate.
    cov : ndarray, shape (p, p) or None
        Its covariance (``reason`` None) [units²].
    reason : str or None
        Why there is no covariance (then only the condition number counts).
    cond : float
        Condition number of the (column-scaled, weighted) regressor solved.
    cond_limit : float
        The condition number above which the first-order bound is checked (the conditioning
        warning's level).
    rel_error : float
        Overall relative torque error ``‖e‖ / ‖τ‖`` of the fit.

    Returns
    -------
    ok : bool
    sentence : str
        Empty when ``ok``.
    """
    beta = np.asarray(beta, dtype=float)
    weak, p = 0, beta.size
    if reason is None and cov is not None:
        sd = np.sqrt(np.clip(np.diag(np.asarray(cov, dtype=float)), 0.0, None))
        weak = int(np.count_nonzero(sd > np.abs(beta)))
    counted = f"{weak} of {p} estimates are smaller than their standard errors"
    bound = cond * rel_error if np.isfinite(cond) else float("inf")
    ill = not np.isfinite(cond) or (cond > cond_limit and bound > 1.0)
    if not ill and weak <= WEAK_FRACTION * p:
        return True, ""
    cause = (
        f"the condition number {cond:.3g} is above {cond_limit:.0e} and, with a relative torque "
        f"error of {rel_error:.2g}, bounds the parameters' relative error only by "
        f"{bound:.2g} (more than 100 %)"
        if ill
        else f"more than {100 * WEAK_FRACTION:g} % of the estimates are smaller than their "
        "standard errors"
    )
    return False, (
        f" Weakly identified: {cause} ({counted}); the motion does not excite the base "
        "parameters enough for the data to support the estimate, however small the torque "
        "error. Design an exciting trajectory (physid design-excitation MODEL)"
        # a longer record narrows the intervals, not the conditioning of the same motion
        + (", or fit fewer parameters." if ill else ", record longer, or fit fewer parameters.")
    )
