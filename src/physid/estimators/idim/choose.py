"""The decimation chosen by the data: a cross-validated torque residual over folds of the record.

`decimate_candidates` lists the decimation factors tried when ``decimate="auto"``: the spectrum
rule's (the parallel filter's cut-off at half the state filter's, ``nd = 1.6π/Ω``), the state
filter's own cut-off (``0.8π/Ω``) and a wider one (``0.5π/Ω``), each lowered to keep enough
equations. `cross_validated_error` scores one candidate: the rows are cut into contiguous folds
in time; each fold is predicted by the OLS fit of the others and compared with one target for
every candidate, the measured torque through the *least* smoothing candidate's parallel filter
(so a candidate that smooths away torque the arm really produced is not rewarded for it). The
regression is cheap; the rows of every candidate share the state filter and the regressor.
"""

from __future__ import annotations

import math

import numpy as np

from .solve import lstsq

__all__ = ["decimate_candidates", "cross_validated_error", "pick", "FOLDS", "FACTORS"]

#: Parallel-filter cut-offs tried, as ``nd = floor(f · π / Ω)`` for each f (the first is the
#: spectrum rule's).
FACTORS = (1.6, 0.8, 0.5)
#: Folds of the cross-validation.
FOLDS = 5
#: A candidate replaces the spectrum rule's only when its error is this much lower (relative).
MARGIN = 0.02


def decimate_candidates(cutoff: float, n_shortest: int, n_base: int, nj: int) -> list[int]:
    """The decimation factors tried (distinct, the spectrum rule's first).

    Parameters
    ----------
    cutoff : float [rad/sample]
        The state filter's cut-off Ω.
    n_shortest : int
        Samples of the shortest recording.
    n_base, nj : int
        Base parameters and joints (at least 20 equations per base parameter are kept).

    Returns
    -------
    list of int
    """
    n_min = 0.75 * n_shortest  # after the state filter
    rows_needed = max(20.0 * n_base / nj, 50.0)
    cap = int(n_min / (rows_needed + 24.0))
    out: list[int] = []
    for f in FACTORS:
        nd = max(1, min(int(math.floor(f * np.pi / cutoff)), cap))
        if nd not in out:
            out.append(nd)
    return out


def cross_validated_error(W, tau, target, segments, folds: int = FOLDS) -> float:
    """Relative torque error ``‖target − Ŵβ‖/‖target‖`` of fold-wise OLS predictions.

    Parameters
    ----------
    W : ndarray, shape (n_rows, n_joints, p)
        Rows of one candidate (dropped equations are zero rows and are not scored).
    tau : ndarray, shape (n_rows, n_joints)
        The rows' torques (what each fold's fit regresses on).
    target : ndarray, shape (n_rows, n_joints)
        The torque every candidate is compared with, at these rows.
    segments : ndarray of int, shape (n_rows,)
        Recording of each row (folds are contiguous within each recording).
    folds : int

    Returns
    -------
    float
        NaN when a fold leaves too few equations to fit.
    """
    n, nj, p = W.shape
    rank = np.zeros(n)
    for s in np.unique(segments):  # per recording, not per sample
        sel = segments == s
        rank[sel] = np.arange(int(sel.sum())) / max(int(sel.sum()), 1)
    fold = np.minimum((rank * folds).astype(int), folds - 1)
    kept = np.any(W != 0.0, axis=2)
    num = den = 0.0
    ones = np.ones(nj)
    for f in range(folds):
        train, test = fold != f, fold == f
        if int(kept[train].sum()) <= 2 * p:
            return float("nan")
        beta = lstsq(W[train], tau[train], ones)
        e = (target[test] - W[test] @ beta)[kept[test]]
        num += float(e @ e)
        t = target[test][kept[test]]
        den += float(t @ t)
    return math.sqrt(num / den) if den > 0 else float("nan")


def pick(candidates: list[int], errors: list[float]) -> tuple[int, str]:
    """The chosen nd and the sentence that says why.

    The spectrum rule's candidate (the first) stays unless another has a cross-validated error
    lower by more than `MARGIN`; among those, the lowest error wins.
    """
    first, e0 = candidates[0], errors[0]
    best, eb = first, e0
    for nd, e in zip(candidates[1:], errors[1:], strict=True):
        if (
            np.isfinite(e)
            and (not np.isfinite(eb) or e < eb)
            and (not np.isfinite(e0) or e < (1.0 - MARGIN) * e0)
        ):
            best, eb = nd, e
    scores = ", ".join(f"{nd}: {e:.4g}" for nd, e in zip(candidates, errors, strict=True))
    why = (
        f" decimate {best} chosen by a {FOLDS}-fold cross-validated torque error (decimate: "
        f"error {scores}; against the torque through the parallel filter of decimate "
        f"{min(candidates)}; the spectrum rule's {first} stays unless another is "
        f"{100 * MARGIN:g} % better)."
    )
    return best, why
