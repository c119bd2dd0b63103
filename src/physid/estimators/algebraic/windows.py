"""The linear system of every window: sliding FIR integrals of the kernels over y and u."""

from __future__ import annotations

import math

import numpy as np
from scipy import signal

from .kernels import _kernel_coefficients
from .plan import _Plan

#: Windows up to this many samples use direct convolution (exact summation, as fast as FFT at
#: this size); longer windows use overlap-add FFT convolution.
DIRECT_CONVOLUTION_MAX_TAPS = 256


def _sliding(x: np.ndarray, taps: np.ndarray, out: np.ndarray) -> None:
    """``out[c, k] = Σ_j taps[c, j] x[k + j]`` for every full window (``out`` (n_c, len(x) − L)).

    Each kernel is a FIR filter; all window positions come from one convolution per kernel.
    """
    if taps.shape[1] <= DIRECT_CONVOLUTION_MAX_TAPS:
        for c in range(taps.shape[0]):  # a handful of kernels, each a full-length convolution
            out[c] = np.convolve(x, taps[c, ::-1], mode="valid")
    else:
        out[:] = signal.oaconvolve(x[None, :], taps[:, ::-1], mode="valid", axes=1)


def _window_systems(plan: _Plan, u: np.ndarray, y: np.ndarray, first: int, ends: np.ndarray):
    """Rows of the windows ending at local indices ``ends`` (consecutive, ascending).

    Returns ``A`` (n_eq, p, n_w) and ``rhs`` (n_eq, n_w), time on the last axis. ``first`` is the
    global index of ``u[0]``. A window ending at global index ``g`` exists if ``g >= L`` (full) or,
    with ``expanding=True``, ``g >= min_intervals`` (window [0, g]). Missing windows are NaN.

    Equation ``ν``: ``Σ_i α_i Iy_i − Σ_i β_i Iu_i = 0`` with ``Iy_i = ∫ K_{ν,i} y dσ``,
    ``α_i = a_i T^(n−i)``, ``β_i = b_i T^(n−i)``, ``α_n = 1``; unknowns left, known right.
    """
    n_eq = len(plan.nus)
    n = plan.order
    n_w = ends.size
    T = plan.window
    # weight of each kernel row: unknown coefficient -> column of A (sign: y left, u right);
    # known coefficient -> right-hand side, times α_i = a_i T^(n−i) (α_n = 1) or β_i = b_i T^(n−i)
    col = {(kind, i): c for c, (kind, i) in enumerate(plan.columns)}
    A = np.zeros((n_eq, plan.p, n_w))
    rhs = np.zeros((n_eq, n_w))
    exists = np.zeros(n_w, dtype=bool)

    def scatter(kind, i, values, where, scale=1.0):
        """Add the integrals of kernel (ν, i) on y (kind "a") or u ("b") into A or rhs."""
        sign = 1.0 if kind == "a" else -1.0
        if (kind, i) in col:
            A[:, col[(kind, i)], where] = sign * scale * values
        else:
            known = plan.known_a[i] if kind == "a" else plan.known_b[i]
            rhs[:, where] -= sign * known * T ** (n - i) * scale * values

    L = plan.L
    g = ends + first
    full = g >= L
    if full.any():
        k0 = int(np.argmax(full))
        seg = slice(int(ends[k0]) - L, int(ends[-1]) + 1)
        taps = plan.taps(L)
        for kind, sig, idx in (("a", y, plan.y_index), ("b", u, plan.u_index)):
            if idx:
                buf = np.empty((n_eq * len(idx), n_w - k0))
                _sliding(sig[seg], taps[:, idx, :].reshape(-1, L + 1), buf)
                buf = buf.reshape(n_eq, len(idx), -1)
                for j, i in enumerate(idx):
                    scatter(kind, i, buf[:, j], slice(k0, None))
        exists[k0:] = True
    if plan.expanding:
        # Windows [0, g] shorter than T at the start of the record: one set of taps per length
        # (a startup cost over at most L windows, independent of the record length).
        grow = (~full) & (g >= plan.min_intervals)
        if plan.rule == "simpson":
            grow &= g % 2 == 0
        for k in np.flatnonzero(grow):
            length = int(g[k])
            taps = plan.taps(length)
            seg = slice(int(ends[k]) - length, int(ends[k]) + 1)
            # column scale (T_window / T)^(n − i) keeps the unknowns α_i = a_i T^(n−i)
            for kind, sig, idx in (("a", y, plan.y_index), ("b", u, plan.u_index)):
                for i in idx:
                    scatter(kind, i, taps[:, i, :] @ sig[seg], k, (length / L) ** (n - i))
            exists[k] = True
    if ("o", 0) in col:
        K = _offset_column(plan)  # (n_eq,) at the full window length
        c = col[("o", 0)]
        scale = np.ones(n_w)
        if plan.expanding:
            short = (~full) & exists
            scale[short] = (g[short] / L) ** n  # δ' of a window of length ℓ: (ℓ / L)^n δ'
        A[:, c, :] = np.where(exists[None, :], K[:, None] * scale[None, :], 0.0)
    A[:, :, ~exists] = np.nan
    rhs[:, ~exists] = np.nan
    return A, rhs


def _offset_column(plan: _Plan) -> np.ndarray:
    """Coefficient of δ' = a_0 T^n o in each equation: how the annihilator handles a constant.

    A measured output ``y_m = y + o`` satisfies ``Σ a_i y_m^(i) = Σ b_j u^(j) + a_0 o``. In the
    window's dimensionless time the constant ``δ' = α_0 o = a_0 T^n o`` has the Laplace transform
    ``δ'/s``. The estimator's operations on it, ``s^(−ν) d^N/ds^N (δ'/s)``, give
    ``δ' (−1)^N N! s^(−(ν+N+1))``, whose inverse transform at the window end (τ = 1) is
    ``δ' (−1)^N N! / (ν + N)!``. (Multiplying by s first, ``s · δ'/s = δ'``, and one more d/ds
    would annihilate the constant instead; keeping it gives δ' as one more *linear* unknown, so the
    offset is estimated, not just removed.) With the equation written as
    ``Σ α_i Iy_i − Σ β_i Iu_i − δ' K_ν = 0`` and the row scale of the kernels,
    ``K_ν = scale_ν (−1)^N N! / (ν + N)!``, entered with the sign of an output term (−).
    tests/test_algebraic.py::test_output_offset_is_estimated checks it on a record with a 1 cm
    offset: θ and o to 1e-6.
    """
    _, scale = _kernel_coefficients(plan.order, plan.nus, plan.n_derivatives)
    N = plan.n_derivatives
    return np.array(
        [
            -scale[r] * (-1.0) ** N * math.factorial(N) / math.factorial(nu + N)
            for r, nu in enumerate(plan.nus)
        ]
    )


def _offset_to_value(plan: _Plan, theta: np.ndarray) -> np.ndarray:
    """SI estimates with the offset column δ = a_0 o turned into o (in place; returns theta)."""
    if ("o", 0) not in plan.columns:
        return theta
    c = plan.columns.index(("o", 0))
    if ("a", 0) in plan.columns:
        a0 = theta[..., plan.columns.index(("a", 0))]
    else:
        a0 = plan.known_a[0]
    with np.errstate(divide="ignore", invalid="ignore"):
        theta[..., c] = theta[..., c] / a0
    return theta


def _unscale(plan: _Plan) -> np.ndarray:
    """Factors from the dimensionless unknowns to SI: a_i = α_i / T^(n−i), b_i = β_i / T^(n−i)."""
    T = plan.window
    return np.array([T ** -(plan.order - i) for _, i in plan.columns])  # ("o", 0): δ = δ'/T^n
