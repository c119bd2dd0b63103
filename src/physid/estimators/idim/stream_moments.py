"""Streamed IDIM, the accumulators: what the main pass keeps of the rows (never the rows).

Per candidate decimation nd, per cross-validation fold (`physid.estimators.idim.choose`'s folds:
contiguous fifths of each record), per class of equation (near a speed reversal of a joint with
dry friction or at low speed, or not: the fit may drop the former after a first solve) and per
joint j, the upper-triangular factor ``R`` of the augmented rows ``[W_j | τ_j]`` (a streaming QR:
``R ← qr([R; new rows])``; ``Rᵀ R`` is their Gram, and least squares from ``R`` keeps the
conditioning of a QR of the rows). For ``stderr="filtered"`` also the lagged products
``Σ_t W_tᵀ (Σ_{l=1..8} ρ_l W_{t−l})`` within a record (the banded noise correlation of the
parallel filter), carried across the windows' edges; a thinned sample of the rows (at most
`stream_plan.MAX_KEPT_ROWS`) for the result's residuals; counts and extrema.

Peak memory of the accumulators: ``n_candidates · (5 · 2 · n_joints · (p+1)² + 2 · n_joints · p²)``
floats plus the sample (``MAX_KEPT_ROWS · n_joints · (p + 1)`` floats): independent of the length.
`RowMoments` merge exactly (``a + b``, ``sum(...)``) and pickle (map-reduce over workers).
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field

import numpy as np
from scipy import signal

from ...errors import InputError
from .choose import FOLDS
from .decimation import _decimation_sos, decimated_noise_correlation, decimation_edge
from .stream_plan import StreamPlan
from .stream_window import Margins, RawReader, window_rows, windows

__all__ = ["RowMoments", "CandidateMoments", "idim_moments"]

LAGS = 8


@dataclass(eq=False)
class CandidateMoments:
    """The accumulators of one candidate decimation (see the module docstring).

    Attributes
    ----------
    R : ndarray, shape (FOLDS, 2, n_joints, p + 1, p + 1)
        QR factor of ``[W_j | τ_j]`` per fold, class (0: other rows, 1: reversal rows), joint.
    kept : ndarray of int, shape (FOLDS, 2, n_joints)
        Equations with a non-zero regressor row.
    n_rows : int
        Decimated rows.
    n_stuck, n_reversal : ndarray of int, shape (n_joints,)
        Equations dropped by the stiction rule; rows marked as near a reversal.
    lagged : ndarray, shape (2, n_joints, p, p) or None
        ``Σ_t X_tᵀ S_t + S_tᵀ X_t`` (``S_t = Σ_l ρ_l X_{t−l}``) of all rows (0) and of the rows
        without the reversal rows (1); None for ``stderr="iid"``.
    tau_min, tau_max, tau_abs : ndarray, shape (n_joints,)
        Extrema of the decimated torques [N·m].
    sample : dict
        Every k-th row: ``W``, ``tau``, ``t``, ``rev``, ``order`` (source, row).
    """

    R: np.ndarray
    kept: np.ndarray
    n_rows: int
    n_stuck: np.ndarray
    n_reversal: np.ndarray
    lagged: np.ndarray | None
    tau_min: np.ndarray
    tau_max: np.ndarray
    tau_abs: np.ndarray
    sample: dict = field(default_factory=dict)

    @classmethod
    def empty(cls, nj: int, p: int, lagged: bool) -> CandidateMoments:
        """Accumulators of no rows."""
        return cls(
            R=np.zeros((FOLDS, 2, nj, p + 1, p + 1)),
            kept=np.zeros((FOLDS, 2, nj), dtype=np.int64),
            n_rows=0,
            n_stuck=np.zeros(nj, dtype=np.int64),
            n_reversal=np.zeros(nj, dtype=np.int64),
            lagged=np.zeros((2, nj, p, p)) if lagged else None,
            tau_min=np.full(nj, np.inf),
            tau_max=np.full(nj, -np.inf),
            tau_abs=np.zeros(nj),
            sample={"W": [], "tau": [], "t": [], "rev": [], "order": []},
        )

    def merged(self, other: CandidateMoments) -> CandidateMoments:
        """The accumulators of both sets of rows (QR of the stacked factors: exact)."""
        R = np.linalg.qr(np.concatenate([self.R, other.R], axis=-2), mode="r")
        lag = None if self.lagged is None else self.lagged + other.lagged
        return CandidateMoments(
            R=R,
            kept=self.kept + other.kept,
            n_rows=self.n_rows + other.n_rows,
            n_stuck=self.n_stuck + other.n_stuck,
            n_reversal=self.n_reversal + other.n_reversal,
            lagged=lag,
            tau_min=np.minimum(self.tau_min, other.tau_min),
            tau_max=np.maximum(self.tau_max, other.tau_max),
            tau_abs=np.maximum(self.tau_abs, other.tau_abs),
            sample={k: self.sample[k] + other.sample[k] for k in self.sample},
        )


@dataclass(eq=False)
class RowMoments:
    """Accumulated moments of the decimated rows of some sources, per candidate nd.

    Merge with ``+`` (or ``sum``): the moments of the union of the sources' rows. Picklable.

    Attributes
    ----------
    candidates : dict
        nd -> `CandidateMoments`.
    sources : tuple of int
        The plan's sources these moments hold.
    timings : dict
        Seconds spent per stage (read, state filter, regressor, parallel filter, accumulate).
    """

    candidates: dict
    sources: tuple
    timings: dict = field(default_factory=dict)

    def __add__(self, other):
        if isinstance(other, int) and other == 0:
            return self
        if not isinstance(other, RowMoments):
            return NotImplemented
        if sorted(self.candidates) != sorted(other.candidates):
            raise InputError(
                "moments of different plans cannot be merged (candidate decimations "
                f"{sorted(self.candidates)} and {sorted(other.candidates)})."
            )
        twice = sorted(set(self.sources) & set(other.sources))
        if twice:
            raise InputError(f"the moments of source(s) {twice} would be counted twice.")
        times = dict(self.timings)
        for key, v in other.timings.items():
            times[key] = times.get(key, 0.0) + v
        return RowMoments(
            {nd: c.merged(other.candidates[nd]) for nd, c in self.candidates.items()},
            tuple(sorted(self.sources + other.sources)),
            times,
        )

    __radd__ = __add__


def _accumulate(acc: CandidateMoments, rows, fold, tails, rho, keep):
    """Add one window's rows of one candidate to its accumulators (vectorised over rows)."""
    W, tau, _, t, stuck, rev = rows
    if W.shape[0] == 0:
        return
    kept = np.any(W != 0.0, axis=2)
    live = kept | (tau != 0.0)
    cls = np.zeros(kept.shape, dtype=bool) if rev is None else rev
    aug = np.concatenate([W, tau[:, :, None]], axis=2)  # (r, nj, p + 1)
    for f in np.unique(fold):  # a window holds one or two folds
        in_f = fold == f
        for c in (0, 1):
            sel = in_f[:, None] & (cls == bool(c)) & live
            for j in np.flatnonzero(sel.any(axis=0)):  # per joint
                new = np.concatenate([acc.R[f, c, j], aug[sel[:, j], j]])
                acc.R[f, c, j] = np.linalg.qr(new, mode="r")
            acc.kept[f, c] += np.sum(in_f[:, None] & (cls == bool(c)) & kept, axis=0)
    acc.n_rows += W.shape[0]
    if stuck is not None:
        acc.n_stuck += stuck.sum(axis=0)
    if rev is not None:
        acc.n_reversal += rev.sum(axis=0)
    acc.tau_min = np.minimum(acc.tau_min, tau.min(axis=0))
    acc.tau_max = np.maximum(acc.tau_max, tau.max(axis=0))
    acc.tau_abs = np.maximum(acc.tau_abs, np.abs(tau).max(axis=0))
    if acc.lagged is not None:
        variants = [W] if rev is None else [W, np.where(rev[:, :, None], 0.0, W)]
        for v, X in enumerate(variants):
            acc.lagged[v] += _lagged(X, tails, v, rho)
        if rev is None:
            acc.lagged[1] = acc.lagged[0]
    if keep.any():
        acc.sample["W"].append(W[keep])  # a boolean index copies: nothing of the window is held
        acc.sample["tau"].append(tau[keep])
        acc.sample["t"].append(t[keep])
        acc.sample["rev"].append(np.zeros(kept[keep].shape, bool) if rev is None else rev[keep])


@functools.lru_cache(maxsize=32)
def noise_correlation(nd: int, lags: int = LAGS) -> np.ndarray:
    """`decimated_noise_correlation` by an FFT autocorrelation (the same ρ to rounding; the
    direct correlation costs seconds at nd ≈ 300)."""
    if nd <= 1:
        return decimated_noise_correlation(nd, lags)
    half = 40 * nd
    delta = np.zeros(2 * half + 1)
    delta[half] = 1.0
    g = signal.sosfiltfilt(_decimation_sos(nd), delta)
    r = signal.fftconvolve(g, g[::-1], mode="full")[g.size - 1 :]
    out = np.zeros(lags + 1)
    out[0] = 1.0
    out[1:] = r[nd * np.arange(1, lags + 1)] / r[0]
    return out


def _lagged(X, tails, v: int, rho):
    """``Σ_t X_tᵀ S_t + S_tᵀ X_t`` per joint, ``S_t = Σ_{l=1..8} ρ_l X_{t−l}`` (the rows before
    this window's come from ``tails[v]``, which is updated)."""
    Y = np.concatenate([tails[v], X])
    r = X.shape[0]
    S = np.zeros_like(X)
    for ell in range(1, LAGS + 1):  # 8 lags, each a vectorised axpy
        S += rho[ell] * Y[LAGS - ell : LAGS - ell + r]
    tails[v] = Y[-LAGS:]
    G = np.matmul(X.transpose(1, 2, 0), S.transpose(1, 0, 2))  # (nj, p, p): Σ_t X_tᵀ S_t
    return G + G.transpose(0, 2, 1)


def idim_moments(model, plan: StreamPlan, source, index: int, *, timings=None, progress=None):
    """The main pass over one source: its `RowMoments` for every candidate nd.

    Parameters
    ----------
    model : ChainModel
    plan : StreamPlan
        From `plan_streamed` over the sources this one belongs to.
    source : BlockSource or Recording
    index : int
        The source's position among the plan's sources (its length, statistics, folds).
    timings : dict, optional
        Filled with seconds per stage.
    progress : Progress, optional
        Advanced by the raw samples read.

    Returns
    -------
    RowMoments

    Notes
    -----
    Peak memory: one window of raw samples, buffers of full-rate rows for the longest window,
    ``max(block_samples + margins, 1.5 · block_samples + 12·nd) · (n_joints · p + n_joints) ·
    8`` bytes (margins: ``12·nd`` before the owned range, the parallel filter's ~95·nd after
    it; see `stream_window._reuse`), the parallel filter's temporaries (lifted in place, from
    nd = 40 on: ~25/nd of a window; below, a copy of up to 96 columns of the window, and about
    three more where ``sosfilt`` runs on every sample; an nd = 1 candidate: a copy of a step's
    rows), plus the accumulators (see the module docstring).
    """
    from ...signals.blocks import as_block_source
    from .base_parameters import base_regressor_info

    source = as_block_source(source)
    k = int(index)
    if not 0 <= k < len(plan.sources) or int(source.n_samples) != plan.sources[k].n:
        raise InputError(
            f"index {index!r} does not name a source of this plan with {source.n_samples} "
            f"samples (the plan's lengths: {plan.lengths})."
        )
    nj, p = plan.n_joints, plan.n_base
    columns = base_regressor_info(model).columns
    mg = Margins(plan)
    chans = [f"q{j + 1}" for j in range(nj)] + [f"tau{j + 1}" for j in range(nj)]
    reader = RawReader(source, chans, plan.block_samples, timings)
    lagged = plan.settings["stderr"] == "filtered"
    accs = {nd: CandidateMoments.empty(nj, p, lagged) for nd in plan.candidates}
    tails = {nd: [np.zeros((LAGS, nj, p)), np.zeros((LAGS, nj, p))] for nd in plan.candidates}
    base = {nd: sum(plan.n_rows(i, nd) for i in range(k)) for nd in plan.candidates}
    n = plan.sources[k].n
    done, cache = 0, {}
    for win in windows(plan, k, mg):
        raw = reader.get(win[4], win[5])
        rows = window_rows(model, columns, plan, k, raw, win, mg, timings, cache)
        tic = time.perf_counter()
        for nd, r in rows.items():
            edge = decimation_edge(nd)
            s = r[2] - plan.offset()
            local = (s - edge) // nd if nd > 1 else s
            keep = (base[nd] + local) % plan.thinning(nd) == 0
            fold = np.minimum((r[2] / float(n) * FOLDS).astype(int), FOLDS - 1)
            rho = noise_correlation(int(nd))
            _accumulate(accs[nd], r, fold, tails[nd], rho, keep)
            if keep.any():
                accs[nd].sample["order"].append(np.c_[np.full(keep.sum(), k), r[2][keep]])
        if timings is not None:
            timings["accumulate"] = timings.get("accumulate", 0.0) + time.perf_counter() - tic
        if progress is not None:
            progress.advance(min(win[5], n) - done)
            done = min(win[5], n)
    return RowMoments(accs, (k,), dict(timings or {}))
