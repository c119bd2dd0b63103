"""Per-window solution: the block least squares, the determinant level and its guard."""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from .plan import _Plan
from .windows import _offset_to_value, _unscale, _window_systems


def _solve(plan: _Plan, A: np.ndarray, rhs: np.ndarray, n_out: int):
    """Estimates (scaled unknowns, (n_out, p)) and determinant level for the last ``n_out`` windows.

    ``A`` (n_eq, p, n_w) holds ``(block − 1) block_stride`` extra leading windows. Square single
    windows are solved directly and their level is ``|det A|``; otherwise the normal equations
    ``(Σ_k A_kᵀA_k) θ = Σ_k A_kᵀ r_k`` over the block's windows, with level
    ``sqrt(det(Σ A_kᵀA_k))`` (the product of the singular values; ``|det A|`` for one square
    window). Normal equations square the condition number; the dimensionless unknowns keep it
    moderate, and they make the block sums cheap.
    """
    p = plan.p
    K, s = plan.block, plan.block_stride
    square = K == 1 and A.shape[0] == p
    if square:
        M = A[:, :, -n_out:]
        v = rhs[:, -n_out:]
    else:
        AtA = np.einsum("epw,eqw->pqw", A, A)  # (p, p, n_w)
        Atr = np.einsum("epw,ew->pw", A, rhs)
        exist = np.isfinite(AtA).all(axis=(0, 1))
        AtA[:, :, ~exist] = 0.0
        Atr[:, ~exist] = 0.0
        n_w = A.shape[2]
        M = np.zeros((p, p, n_out))
        v = np.zeros((p, n_out))
        any_exist = np.zeros(n_out, dtype=bool)
        for j in range(K):  # K block members (a loop over the block, not over samples)
            sl = slice(n_w - n_out - j * s, n_w - j * s)
            M += AtA[:, :, sl]
            v += Atr[:, sl]
            any_exist |= exist[sl]
        M[:, :, ~any_exist] = np.nan
    with np.errstate(divide="ignore", invalid="ignore"):
        if p == 1:
            d = M[0, 0]
            theta = (v[0] / d)[:, None]
        elif p == 2:
            # Cramer's rule: for 2×2 as accurate as LU and ~20× faster than batched LAPACK;
            # missing windows are NaN rows and stay NaN.
            d = M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]
            theta = np.empty((n_out, 2))
            theta[:, 0] = (v[0] * M[1, 1] - M[0, 1] * v[1]) / d
            theta[:, 1] = (M[0, 0] * v[1] - M[1, 0] * v[0]) / d
        else:
            Mt = np.moveaxis(M, 2, 0)  # (n_out, p, p)
            vt = v.T
            d = np.full(n_out, np.nan)
            theta = np.full((n_out, p), np.nan)
            finite = np.isfinite(Mt).all(axis=(1, 2)) & np.isfinite(vt).all(axis=1)
            d[finite] = np.linalg.det(Mt[finite])
            ok = finite & (d != 0)
            if ok.any():
                theta[ok] = np.linalg.solve(Mt[ok], vt[ok][..., None])[..., 0]
    theta[d == 0] = np.nan
    level = np.abs(d) if square else np.sqrt(np.abs(d))
    return theta, level


def _trailing_median(values: np.ndarray, history: np.ndarray, size: int) -> np.ndarray:
    """Median of the trailing ``size`` entries of ``concat(history, values)`` at each new entry
    (fewer at the very start). Exact selection, so batch and streamed results agree bit for bit."""
    full = np.concatenate([history, values])
    h = history.size
    out = np.empty(values.size)
    if full.size >= size:
        med = ndimage.median_filter(full, size=size, origin=size // 2, mode="nearest")
        start = max(h, size - 1)
        out[start - h :] = med[start:]
    n_start = min(values.size, max(size - 1 - h, 0))  # entries with fewer than `size` predecessors
    if n_start:
        head = full[: h + n_start]
        cols = np.arange(head.size)
        step = max(1, 2_000_000 // head.size)  # bound the (rows, columns) work array
        for r0 in range(0, n_start, step):  # one pass unless guard_window is in the thousands
            c = np.arange(h + r0 + 1, h + min(r0 + step, n_start) + 1)  # values available
            tri = np.sort(np.where(cols[None, :] < c[:, None], head[None, :], np.inf), axis=1)
            rows = np.arange(c.size)
            out[r0 : r0 + c.size] = 0.5 * (tri[rows, (c - 1) // 2] + tri[rows, c // 2])
    return out


def _guard(plan: _Plan, theta: np.ndarray, level: np.ndarray, history: np.ndarray):
    """Validity mask and updated level history.

    A window is valid when it exists, its system was solved, its level is > 0 and (guard > 0)
    ``level >= guard · median(trailing guard_window non-zero levels, itself included)``. Zero
    levels (windows that saw no signal, e.g. a record that starts at rest) carry no scale and are
    left out of the running median. ``history`` holds the last ``guard_window − 1`` non-zero levels.
    """
    lv = np.where(np.isfinite(level), level, 0.0)
    positive = lv > 0
    valid = positive & np.isfinite(theta).all(axis=1)
    lp = lv[positive]
    if plan.guard > 0 and lp.size:
        running = _trailing_median(lp, history, plan.guard_window)
        valid[positive] &= lp >= plan.guard * running
    keep = plan.guard_window - 1
    new_history = np.concatenate([history, lp])[-keep:] if keep else history[:0]
    return valid, new_history


def _run(plan: _Plan, u, y, first: int, n_out: int, history: np.ndarray):
    """Estimates for the last ``n_out`` samples of (u, y) whose first sample has global index
    ``first``. Returns (theta in SI units (n_out, p), valid, level, new history)."""
    n_w = n_out + (plan.block - 1) * plan.block_stride
    n_avail = min(n_w, u.size)
    ends = np.arange(u.size - n_avail, u.size)
    A, rhs = _window_systems(plan, u, y, first, ends)
    if n_avail < n_w:  # block members before the first sample: no window
        pad = n_w - n_avail
        A = np.concatenate([np.full((*A.shape[:2], pad), np.nan), A], axis=2)
        rhs = np.concatenate([np.full((rhs.shape[0], pad), np.nan), rhs], axis=1)
    theta, level = _solve(plan, A, rhs, n_out)
    valid, history = _guard(plan, theta, level, history)
    return _offset_to_value(plan, theta * _unscale(plan)), valid, level, history, (A, rhs)
