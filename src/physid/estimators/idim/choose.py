"""The decimation chosen by the data: a cross-validated torque residual over folds of the record.

`decimate_candidates` lists the decimation factors tried when ``decimate="auto"``: the spectrum
rule's (the parallel filter's cut-off at half the state filter's, ``nd = 1.6π/Ω``), the state
filter's own cut-off (``0.8π/Ω``) and every octave below down to Ω/32, each lowered to keep
enough equations (`FACTORS`). `cross_validated_error` scores one candidate: the record is cut
into contiguous folds in time; the OLS estimate from the candidate's rows outside a fold
predicts the torque on common evaluation rows inside it, so every candidate's estimate is judged
on the same equations. Those are the rows of the most smoothing candidate: the band where the
motion is and a rigid model holds. Judged on the least smoothed rows instead, the estimate that
also explains what lies above that band wins: vibration of elastic joints, or the noise of the
differentiated positions in the regressor, which pulls the inertias towards zero as any noise
in a regressor does; on an elastic 2-link arm whose drives carry a current ripple
(benchmarks/zoo, case h with ``ripple=0.1``) that put the link inertias 51 % and 254 % off
at the automatic 477 Hz cut-off. The regression is cheap; the rows of every candidate share
the state filter and the regressor.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["decimate_candidates", "cross_validated_error", "pick", "FOLDS", "FACTORS"]

#: Parallel-filter cut-offs tried, as ``nd = floor(f · π / Ω)`` for each f: the spectrum
#: rule's (the parallel cut-off 0.8π/nd at Ω/2), the state filter's cut-off, then every octave
#: below down to Ω/32. Measured on the zoo (benchmarks/zoo/README.md): down to Ω/32 the
#: elastic arm with a current ripple keeps a 15 Hz band at its 477 Hz cut-off (nd 134, below
#: its 17 Hz joint mode), its base parameters' mean error 0.0293 → 0.0034; further down (two
#: more octaves, nd 536) they gain a little more (0.00155) and its held-out prediction
#: loses (0.1106 → 0.1185, the recipe 0.1175).
FACTORS = (1.6, 0.8, 3.2, 6.4, 12.8, 25.6)
#: Folds of the cross-validation.
FOLDS = 5
#: A candidate replaces the spectrum rule's only when its error is this much lower (relative).
MARGIN = 0.02


def decimate_candidates(
    cutoff: float, n_shortest: int, n_base: int, nj: int, edge: int = 0
) -> list[int]:
    """The decimation factors tried (distinct, the spectrum rule's first).

    Parameters
    ----------
    cutoff : float [rad/sample]
        The state filter's cut-off Ω.
    n_shortest : int
        Samples of the shortest recording.
    n_base, nj : int
        Base parameters and joints (at least 20 equations per base parameter are kept).
    edge : int, optional
        Samples the state filter drops at each end [samples] (its half-width M, or the
        Butterworth states' edge). The default half-width drops at most a quarter of the
        record, which bounds the samples left from below; a longer filter given explicitly
        leaves fewer, and the largest candidate must still fit in them.

    Returns
    -------
    list of int
    """
    n_min = min(0.75 * n_shortest, n_shortest - 2.0 * edge)  # after the state filter
    rows_needed = max(20.0 * n_base / nj, 50.0)
    cap = int(n_min / (rows_needed + 24.0))
    out: list[int] = []
    for f in FACTORS:
        nd = max(1, min(int(math.floor(f * np.pi / cutoff)), cap))
        if nd not in out:
            out.append(nd)
    return out


def _folds(segments, samples, lengths, folds: int) -> np.ndarray:
    """Fold of each row: contiguous blocks of time within each recording."""
    frac = samples / np.asarray(lengths, dtype=float)[segments]
    return np.minimum((frac * folds).astype(int), folds - 1)


def cross_validated_error(fit_rows, eval_rows, lengths, folds: int = FOLDS) -> float:
    """Relative torque error ``‖τ_e − W_e β̂_f‖/‖τ_e‖`` of fold-wise OLS estimates.

    Each fold's estimate β̂_f is fitted on one candidate's rows outside the fold and judged on
    the common evaluation rows inside it, so that every candidate is compared on the same
    equations: the quality of its estimate, not of its filter.

    Parameters
    ----------
    fit_rows, eval_rows : tuple
        ``(W, tau, segments, samples)``: rows (n, n_joints, p), torques (n, n_joints), the
        recording and sample of each row. Dropped equations (zero rows) are not used.
    lengths : sequence of int
        Samples of each recording.
    folds : int

    Returns
    -------
    float
        NaN when a fold leaves too few equations to fit.
    """
    W, tau, seg, smp = fit_rows
    We, te, sege, smpe = eval_rows
    p = W.shape[-1]
    fold = _folds(seg, smp, lengths, folds)
    fold_e = _folds(sege, smpe, lengths, folds)
    kept = np.any(W != 0.0, axis=2)
    kept_e = np.any(We != 0.0, axis=2)
    # normal equations per fold on unit-norm columns (a p × p solve per fold, not a QR of the
    # rows: the folds' Gram matrices are summed once)
    a = W.reshape(-1, p)
    d = 1.0 / np.where((n := np.linalg.norm(a, axis=0)) > 0, n, 1.0)
    rows_fold = np.repeat(fold, W.shape[1])
    grams = np.zeros((folds, p, p))
    rhs = np.zeros((folds, p))
    for f in range(folds):  # per fold, not per sample
        af = a[rows_fold == f] * d
        grams[f] = af.T @ af
        rhs[f] = af.T @ tau.reshape(-1)[rows_fold == f]
    g_all, r_all = grams.sum(axis=0), rhs.sum(axis=0)
    num = den = 0.0
    for f in range(folds):
        test = fold_e == f
        if int(kept[fold != f].sum()) <= 2 * p:
            return float("nan")
        beta = np.linalg.lstsq(g_all - grams[f], r_all - rhs[f], rcond=None)[0] * d
        e = (te[test] - We[test] @ beta)[kept_e[test]]
        t = te[test][kept_e[test]]
        num += float(e @ e)
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
        f"error {scores}; each estimate judged on the rows of decimate {max(candidates)}; "
        f"the spectrum rule's {first} stays unless another is "
        f"{100 * MARGIN:g} % better)."
    )
    return best, why
