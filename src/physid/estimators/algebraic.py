"""Algebraic (Fliess / Sira-Ramírez) sliding-window estimator for linear ODE models of any order.

The model is ``Σ_{i=0}^{n} a_i y^(i) = Σ_{i=0}^{m} b_i u^(i)`` with ``a_n = 1`` and ``m < n``
(Oueslati et al. 2011, eq. 15). Over a window of length ``T`` ending at ``t0`` we write
``σ = (t − (t0 − T)) / T ∈ [0, 1]`` (the window runs *forward* in time) and

1. take the Laplace transform in the local time (eq. 16): the unknown initial conditions enter as a
   polynomial in ``s`` of degree ``n − 1``;
2. differentiate ``N = n + extra_derivatives`` times with respect to ``s``, which annihilates that
   polynomial;
3. multiply by ``s^(−ν)`` for ``ν = μ, μ + 1, …`` (one equation per ``ν``) and return to the time
   domain: ``s^(−q) d^k/ds^k Y(s)`` is the iterated integral
   ``∫_0^T (T − τ)^(q−1) / (q−1)! (−τ)^k y(t0 − T + τ) dτ``.

Collecting the terms of each ``a_i`` (and ``b_i``) gives one polynomial kernel ``K_{ν,i}(σ)`` per
equation and coefficient, so every entry of the linear system is ``∫_0^1 K_{ν,i}(σ) y(...) dσ`` (or
the same kernel on ``u``): a FIR filter over the last ``L + 1 = T / Ts + 1`` samples. The kernels
are derived once with sympy (`algebraic_kernels`, cached). They coincide with the
modulating-function form ``K_{ν,i} = (−1)^i d^i/dσ^i [(1 − σ)^(ν−1) (−σ)^N / (ν − 1)!]``
(integration by parts), which the tests check independently.

Scaling: in dimensionless time the unknowns are ``α_i = a_i T^(n−i)`` and ``β_i = b_i T^(n−i)``,
which keeps the per-window systems well conditioned; estimates are converted back to SI units.

Where we differ from the paper (details and evidence in ``docs/algebraic.md``):

* eq. 17-18 integrate ``γ(t0 − τT)`` against ``(1 − τ)^(m−1) τ^n``, i.e. they apply the Laplace
  rules to the time-*reversed* signal ``Γ(u) = γ(t0 − u)``. That signal solves the reversed ODE,
  whose odd-order coefficients change sign, so the printed estimator returns ``−θ1`` instead of
  ``θ1``. The paper's ζ ≈ 7e-4 hides it; at ζ = 0.3 it is obvious. We integrate forward in time.
* eq. 20, entry (2, 1) reads ``2 P_{μ+1,0} + P_{μ,1}``; the derivation gives
  ``2 P_{μ+1,1} + P_{μ,2}`` (the row-2 entries are the row-1 entries with ``μ → μ + 1``).
* eq. 19 writes ``s d²X/ds`` for ``s d²X/ds²`` in the θ1 term; eq. 21 ends with the sample ``(n)``
  where ``(L)`` is meant, and its step ``Ts`` multiplies ``T^(m+n)`` (the dimensionless step is
  ``Ts / T``); that extra common factor ``T`` cancels in eq. 20.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np
from scipy import ndimage, signal

from .._validate import check_positive, check_signal_pair
from ..errors import EstimationError, InputError, SamplingError
from ..models.linear_ode import as_linear_ode_model, natural_frequency_damping
from ._linear import (
    LinearODEResultMixin,
    check_distinct_channels,
    check_distinct_signals,
    check_known_finite,
    coefficient_units,
    derived_with_stderr,
    physical_statement,
)
from .base import EstimatorMixin
from .results import ParameterDict, ResultMixin

__all__ = [
    "AlgebraicEstimator",
    "AlgebraicResult",
    "AlgebraicSettings",
    "StreamingAlgebraicEstimator",
    "algebraic_estimates",
    "algebraic_kernels",
    "quadrature_taps",
    "INTEGRATION_RULES",
    "min_window_intervals",
    "MAX_MU",
]

#: Integration rules for the window integrals.
INTEGRATION_RULES = ("exact", "simpson", "trapezoid")

#: Default degree of the local Lagrange interpolant used by the "exact" rule.
DEFAULT_INTERPOLATION_DEGREE = 7

#: Default guard threshold: a window is invalid when its determinant level is below this fraction
#: of the median level over the trailing `guard_window` windows.
DEFAULT_GUARD = 0.1


# ----------------------------------------------------------------------------------------------
# Symbolic derivation (sympy, once, cached)
# ----------------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=64)
def algebraic_kernels(order: int, nus: tuple[int, ...], n_derivatives: int | None = None):
    """Kernels ``K_{ν,i}(σ)`` of the algebraic estimator, derived with sympy (Laplace route).

    Parameters
    ----------
    order : int
        Model order ``n`` (highest output derivative).
    nus : tuple of int
        Powers ``ν`` of the ``s^(−ν)`` multiplier, one equation each; every ``ν >= order + 1``.
    n_derivatives : int, optional
        Number ``N >= order`` of ``d/ds`` applied to annihilate the initial conditions
        (default ``order``).

    Returns
    -------
    tuple of tuple of sympy.Expr
        ``kernels[r][i]`` is ``K_{nus[r], i}(σ)`` for ``i = 0..order``, a polynomial in the symbol
        ``sigma`` (dimensionless window time, 0 at the oldest sample, 1 at ``t0``). Equation ``r``
        reads ``Σ_i a_i T^(−i) ∫_0^1 K_{ν,i} y dσ = Σ_i b_i T^(−i) ∫_0^1 K_{ν,i} u dσ``.

    Notes
    -----
    ``d^N/ds^N [s^i Y(s)] s^(−ν) = Σ_k c_k s^(j_k − ν) Y^(k)(s)`` and, with ``T = 1``,
    ``L^{-1}[s^(−q) Y^(k)](1) = ∫_0^1 (1 − σ)^(q−1)/(q−1)! (−σ)^k y(σ) dσ`` (Cauchy's repeated
    integral and ``L[(−t)^k y] = Y^(k)``); ``q >= 1`` requires ``ν >= order + 1``.

    Examples
    --------
    >>> k = algebraic_kernels(2, (3,))
    >>> str(k[0][2])  # the a_2 = 1 (ÿ) kernel of the MSD for ν = 3
    '6*sigma**2 - 6*sigma + 1'
    """
    import sympy as sp

    n = int(order)
    N = n if n_derivatives is None else int(n_derivatives)
    if N < n:
        raise InputError(f"n_derivatives must be >= the model order {n}; got {N}.")
    s = sp.Symbol("s", positive=True)
    sigma = sp.Symbol("sigma")
    Y = sp.Function("Y")
    out = []
    for nu in nus:
        if nu < n + 1:
            raise InputError(
                f"each ν (mu and above) must be >= order + 1 = {n + 1} so that every term is an "
                f"integral; got ν = {nu}. Increase mu."
            )
        row = []
        for i in range(n + 1):
            expr = sp.expand(s ** (-nu) * sp.diff(s**i * Y(s), s, N))
            poly = sp.Integer(0)
            for term in sp.Add.make_args(expr):
                derivs = list(term.atoms(sp.Derivative))
                if derivs:
                    k = int(derivs[0].derivative_count)
                    rest = term / derivs[0]
                else:
                    k = 0
                    rest = term / Y(s)
                coeff, power = rest.as_coeff_exponent(s)
                q = int(-power)
                # s^(-q) Y^(k)(s)  <->  ∫_0^1 (1-σ)^(q-1)/(q-1)! (-σ)^k y(σ) dσ
                poly += coeff * (1 - sigma) ** (q - 1) / sp.factorial(q - 1) * (-sigma) ** k
            row.append(sp.expand(poly))
        out.append(tuple(row))
    return tuple(out)


@functools.lru_cache(maxsize=64)
def _kernel_coefficients(order: int, nus: tuple[int, ...], n_derivatives: int):
    """Float polynomial coefficients (ascending powers), shape (n_eq, order+1, degree+1), and the
    row scale 1/||K_{ν,n}||_2 that normalises each equation (matters only for least squares)."""
    import sympy as sp

    kernels = algebraic_kernels(order, nus, n_derivatives)
    sigma = sp.Symbol("sigma")
    degree = max(sp.Poly(k, sigma).degree() for row in kernels for k in row if k != 0)
    coeffs = np.zeros((len(nus), order + 1, degree + 1))
    scale = np.empty(len(nus))
    for r, row in enumerate(kernels):
        for i, k in enumerate(row):
            for (p,), c in sp.Poly(k, sigma).terms():
                coeffs[r, i, p] = float(c)
        scale[r] = 1.0 / math.sqrt(float(sp.integrate(row[order] ** 2, (sigma, 0, 1))))
    coeffs.setflags(write=False)
    scale.setflags(write=False)
    return coeffs, scale


# ----------------------------------------------------------------------------------------------
# Quadrature: kernels -> FIR taps
# ----------------------------------------------------------------------------------------------
def quadrature_taps(
    coefficients: np.ndarray,
    n_intervals: int,
    rule: str = "exact",
    degree: int = DEFAULT_INTERPOLATION_DEGREE,
) -> np.ndarray:
    """FIR taps that integrate polynomial kernels over ``σ ∈ [0, 1]`` sampled at ``σ_j = j / L``.

    Parameters
    ----------
    coefficients : ndarray, shape (..., D + 1)
        Kernel polynomials, ascending powers of ``σ``.
    n_intervals : int
        ``L``, the number of sample intervals in the window (``L + 1`` samples).
    rule : {"exact", "simpson", "trapezoid"}
        ``"exact"`` integrates the kernel exactly against a piecewise polynomial interpolant of the
        samples: on each interval ``[σ_j, σ_{j+1}]`` the Lagrange polynomial of ``degree``
        through the ``degree + 1`` nearest samples (shifted inwards at the window edges); the
        product with the kernel is integrated by Gauss–Legendre with enough nodes to be exact.
        ``"simpson"`` is the composite Simpson rule (the paper's eq. 21; ``L`` even),
        ``"trapezoid"`` the composite trapezoid rule.
    degree : int
        Degree of the local interpolant of the ``"exact"`` rule (error ``O(L^-(degree+1))``).

    Returns
    -------
    ndarray, shape (..., L + 1)
        ``∫_0^1 K(σ) γ(σ) dσ ≈ taps @ γ(σ_0..σ_L)``.

    Examples
    --------
    >>> taps = quadrature_taps(np.array([0.0, 0.0, 1.0]), 10)   # K = σ², γ = σ³ -> 1/6
    >>> round(float(taps @ np.linspace(0, 1, 11) ** 3), 12)
    0.166666666667
    """
    coeffs = np.asarray(coefficients, dtype=float)
    L = int(n_intervals)
    h = 1.0 / L
    nodes = np.arange(L + 1) * h
    if rule in ("simpson", "trapezoid"):
        if rule == "simpson":
            if L % 2:
                raise InputError(
                    f"integration='simpson' needs an even number of sample intervals L = T/Ts; got "
                    f"L = {L}. Change the window by one sample or use integration='exact'."
                )
            w = np.full(L + 1, 2.0)
            w[1::2] = 4.0
            w[0] = w[-1] = 1.0
            w *= h / 3.0
        else:
            w = np.full(L + 1, h)
            w[0] = w[-1] = h / 2.0
        return np.polynomial.polynomial.polyval(nodes, np.moveaxis(coeffs, -1, 0)) * w
    if rule != "exact":
        raise InputError(f"integration must be one of {INTEGRATION_RULES}; got {rule!r}.")
    d = int(degree)
    if L < d:
        raise SamplingError(
            f"the 'exact' rule with a degree-{d} interpolant needs a window of at least {d} sample "
            f"intervals; got L = {L}. Lengthen the window."
        )
    kdeg = coeffs.shape[-1] - 1
    n_gauss = (kdeg + d + 2) // 2  # exact for polynomials of degree <= 2 n_gauss - 1 >= kdeg + d
    gx, gw = np.polynomial.legendre.leggauss(n_gauss)
    j = np.arange(L)
    start = np.clip(j - (d - 1) // 2, 0, L - d)  # stencil start of interval j
    xi = j[:, None] + 0.5 * (gx[None, :] + 1.0)  # (L, G) Gauss nodes in sample units
    loc = xi - start[:, None]  # local coordinate, stencil nodes at 0..d
    r = np.arange(d + 1)
    # Lagrange basis ℓ_r(loc) = Π_{q≠r} (loc − q)/(r − q), shape (L, G, d+1)
    diff = loc[:, :, None, None] - r[None, None, None, :]  # (L, G, 1, d+1) -> (loc - q)
    diff = np.broadcast_to(diff, (L, n_gauss, d + 1, d + 1)).copy()
    diff[:, :, r, r] = 1.0
    denom = r[:, None] - r[None, :]
    denom = np.where(denom == 0, 1, denom).astype(float)
    lag = np.prod(diff / denom[None, None, :, :], axis=-1)
    kvals = np.polynomial.polynomial.polyval(xi * h, np.moveaxis(coeffs, -1, 0))  # (..., L, G)
    contrib = np.einsum("...jg,g,jgr->...jr", kvals, 0.5 * h * gw, lag)  # (..., L, d+1)
    idx = start[:, None] + r[None, :]  # (L, d+1)
    lead = coeffs.shape[:-1]
    taps = np.zeros((L + 1, *lead))
    np.add.at(taps, idx, np.moveaxis(contrib, (-2, -1), (0, 1)))
    return np.moveaxis(taps, 0, -1)


@functools.lru_cache(maxsize=256)
def _taps_for(order, nus, n_derivatives, L, rule, degree):
    coeffs, scale = _kernel_coefficients(order, nus, n_derivatives)
    taps = quadrature_taps(coeffs, L, rule, degree) * scale[:, None, None]
    taps.setflags(write=False)
    return taps  # (n_eq, order+1, L+1)


# ----------------------------------------------------------------------------------------------
# The plan: everything fixed before the data arrive
# ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Plan:
    order: int
    input_order: int
    n_derivatives: int
    nus: tuple[int, ...]
    names: tuple[str, ...]  # unknown coefficient names, in column order
    columns: tuple[tuple[str, int], ...]  # ("a"|"b", i) per unknown
    known_a: tuple[float, ...]  # a_0..a_n (a_n = 1), zeros at unknown positions
    known_b: tuple[float, ...]
    known: tuple[tuple[str, float], ...]  # known coefficient name -> value (a_n = 1 excluded)
    dt: float
    L: int
    rule: str
    degree: int
    block: int
    block_stride: int
    guard: float
    guard_window: int
    expanding: bool
    min_intervals: int
    y_index: tuple[int, ...]  # which y kernels are needed
    u_index: tuple[int, ...]

    @property
    def window(self) -> float:
        return self.L * self.dt

    @property
    def p(self) -> int:
        return len(self.columns)

    @property
    def span(self) -> int:
        """Samples of history one estimate needs besides its own: L + (K − 1) stride."""
        return self.L + (self.block - 1) * self.block_stride

    def taps(self, L: int) -> np.ndarray:
        return _taps_for(self.order, self.nus, self.n_derivatives, L, self.rule, self.degree)


def min_window_intervals(
    integration: str = "exact", interpolation_degree: int = DEFAULT_INTERPOLATION_DEGREE
) -> int:
    """The fewest sample intervals L = T / T_s a window may span.

    The "exact" rule interpolates each window with a polynomial of ``interpolation_degree`` and
    needs that many intervals; every rule needs at least 4. Shorter windows raise SamplingError.

    Examples
    --------
    >>> min_window_intervals(), min_window_intervals("simpson")
    (7, 4)
    """
    return max(int(interpolation_degree) if integration == "exact" else 2, 4)


def _make_plan(
    model,
    dt: float,
    *,
    window,
    mu,
    integration,
    block,
    block_stride,
    extra_derivatives,
    n_equations,
    unknown,
    known,
    guard,
    guard_window,
    expanding,
    interpolation_degree,
) -> _Plan:
    n = int(model.order)
    m = int(model.input_order)
    if not (0 <= m < n):
        raise InputError(
            f"the model needs 0 <= input_order < order; got order {n}, input_order {m}."
        )
    check_known_finite(known)
    unknown, values = model.split_coefficients(unknown, known)
    known_a = [0.0 if name in unknown else values[name] for name in model.a_names] + [1.0]
    known_b = [0.0 if name in unknown else values[name] for name in model.b_names]
    columns = tuple(
        ("a", list(model.a_names).index(u))
        if u in model.a_names
        else ("b", list(model.b_names).index(u))
        for u in unknown
    )
    offset = offset_name(model)
    if offset is not None:
        # an output offset o (y_m = y + o) is one more unknown, δ' = a_0 T^n o: see
        # `_offset_column` for why it enters linearly
        columns = columns + (("o", 0),)
        unknown = tuple(unknown) + (offset,)
    p = len(columns)
    mu = n + 1 if mu is None else int(mu)
    if mu < n + 1:
        raise InputError(
            f"mu must be >= order + 1 = {n + 1} (smaller powers of 1/s leave derivatives of y "
            f"in the equations); got mu = {mu}."
        )
    if mu + (p if n_equations is None else int(n_equations)) - 1 > MAX_MU:
        raise InputError(
            f"mu must be at most {MAX_MU} (with n_equations, the largest power of 1/s "
            f"mu + n_equations - 1 <= {MAX_MU}); got mu = {mu}. Beyond it the polynomial kernels "
            "lose every significant digit to cancellation and the estimate is rounding noise; "
            "use mu between order + 1 and about 10 (smoother kernels: lengthen the window or "
            "raise extra_derivatives)."
        )
    extra = int(extra_derivatives)
    if extra < 0:
        raise InputError(f"extra_derivatives must be >= 0; got {extra_derivatives!r}.")
    n_eq = p if n_equations is None else int(n_equations)
    if n_eq < p:
        raise InputError(f"n_equations must be >= the number of unknowns {p}; got {n_equations!r}.")
    if integration not in INTEGRATION_RULES:
        raise InputError(f"integration must be one of {INTEGRATION_RULES}; got {integration!r}.")
    block = int(block)
    block_stride = int(block_stride)
    if block < 1 or block_stride < 1:
        raise InputError(
            f"block and block_stride must be >= 1; got block={block}, block_stride={block_stride}."
        )
    window = check_positive(window, "window")
    L = int(round(window / dt))
    degree = int(interpolation_degree)
    if degree < 1:
        raise InputError(f"interpolation_degree must be >= 1; got {interpolation_degree!r}.")
    min_intervals = min_window_intervals(integration, degree)
    if L < min_intervals:
        raise SamplingError(
            f"window = {window:g} s is {L} sample interval(s) at dt = {dt:g} s; the kernels need "
            f"at least {min_intervals} (window >= {min_intervals * dt:g} s). Lengthen the window."
        )
    if integration == "simpson" and L % 2:
        raise InputError(
            f"integration='simpson' needs an even number of sample intervals L = window/dt; got "
            f"L = {L} (window {window:g} s, dt {dt:g} s). Change the window by one sample or use "
            "integration='exact'."
        )
    guard = float(guard or 0.0)
    if not (0.0 <= guard < 1.0):
        raise InputError(f"guard must lie in [0, 1) (0 disables it); got {guard!r}.")
    gw = 2 * L + 1 if guard_window is None else int(guard_window)
    if gw < 1:
        raise InputError(f"guard_window must be >= 1 window; got {guard_window!r}.")
    y_index = tuple(i for i in range(n + 1) if known_a[i] != 0.0 or ("a", i) in columns)
    u_index = tuple(i for i in range(m + 1) if known_b[i] != 0.0 or ("b", i) in columns)
    return _Plan(
        order=n,
        input_order=m,
        n_derivatives=n + extra,
        nus=tuple(range(mu, mu + n_eq)),
        names=unknown,
        columns=columns,
        known_a=tuple(known_a),
        known_b=tuple(known_b),
        known=tuple((k, values[k]) for k in model.coefficient_names if k not in unknown),
        dt=dt,
        L=L,
        rule=integration,
        degree=degree,
        block=block,
        block_stride=block_stride,
        guard=guard,
        guard_window=gw,
        expanding=bool(expanding),
        min_intervals=min_intervals,
        y_index=y_index,
        u_index=u_index,
    )


# ----------------------------------------------------------------------------------------------
# Numerical core
# ----------------------------------------------------------------------------------------------
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


def offset_name(model) -> str | None:
    """The name of the model's output offset to estimate, or None.

    A model declares it as ``output_offset`` (``[ode] output_offset = "offset"`` in a model file);
    it is estimated when the model marks it unknown (``offset_unknown``, default True when the
    attribute is missing).
    """
    name = getattr(model, "output_offset", None)
    if not name:
        return None
    return name if getattr(model, "offset_unknown", True) else None


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


def _unscale(plan: _Plan) -> np.ndarray:
    """Factors from the dimensionless unknowns to SI: a_i = α_i / T^(n−i), b_i = β_i / T^(n−i)."""
    T = plan.window
    return np.array([T ** -(plan.order - i) for _, i in plan.columns])  # ("o", 0): δ = δ'/T^n


# ----------------------------------------------------------------------------------------------
# Settings
# ----------------------------------------------------------------------------------------------
FINAL_RULES = ("median", "lstsq", "bias-compensated")

#: Largest ``mu`` (smallest power ``ν`` of ``1/s``; with ``n_equations`` the largest power used)
#: the kernel construction supports. The kernels are polynomials of degree about ``ν + N + n`` in
#: the monomial basis; their coefficients grow like binomial coefficients and cancel in the
#: quadrature. Measured on the noise-free paper MSD (2 s at 1 kHz, T = 0.05 s / 0.2 s), the relative
#: error of ω0 is 1e-14 at ν = 3, 1e-10 at 10, 8e-8 / 7e-10 at 20, 2e-5 / 4e-7 at 25, 3e-3 / 1e-4
#: at 30, 0.19 / 9e-3 at 35 and 4.2 / NaN at 40 (the issue's ``--mu 40``: ω0 = 64.7 for 11.55).
#: `MAX_MU` = 20 keeps the arithmetic's share of the error below 1e-7; larger values are refused.
MAX_MU = 20

#: Largest condition number of the pooled (dimensionless, unit-diagonal) normal matrix for which
#: the final estimate is reported as a success: beyond it, relative rounding errors of 1e-16 in the
#: window integrals move the estimate by more than 1e-4 relative.
MAX_CONDITION = 1e12

#: The default (``final="lstsq"``) withholds its standard errors (``stderr`` None with the reason)
#: where its estimate lies more than this many of them from the bias-compensated one
#: (`_withhold_if_biased`). Not RLS's 0.5 (``MAX_BIAS_TO_STDERR``, a bias estimated on the same
#: data): this shift also holds the two estimates' sampling disagreement, about 0.7 se where there
#: is no bias (60 dB). Measured (benchmarks/bench_coverage.py): at 0.5 the default withholds
#: 59-68 % of the 60 dB fits and the rest over-cover (θ2 97.6 / 98.4 %, 200 trials); at 1.0 it
#: withholds 13 % (paper's MSD) / 29 % (ζ = 0.5) there and covers 94.3 / 96.6 % and
#: 95.1 / 95.4 % (θ1 / θ2, 400 trials), and withholds every 30 dB fit.
MAX_SHIFT_TO_STDERR = 1.0


@dataclass(frozen=True)
class AlgebraicSettings:
    """Every setting of the algebraic estimator, in one place.

    `AlgebraicEstimator`, `algebraic_estimates` and `StreamingAlgebraicEstimator` take these
    settings by name; this dataclass holds their defaults and documents them once.

    Parameters
    ----------
    window : float [s]
        Window length ``T`` (rounded to ``L = round(T / dt)`` sample intervals).
    mu : int, optional
        Smallest power ``ν`` of ``1/s`` (default and minimum ``order + 1``, at most `MAX_MU`).
        Larger ``mu`` gives smoother kernels (more low-pass) at the price of a flatter, less
        sensitive system.
    integration : {"exact", "simpson", "trapezoid"}
        Quadrature of the window integrals (see `quadrature_taps`); "simpson" is the paper's eq. 21.
    block : int
        Least squares over ``block`` windows ending at ``t0, t0 − s·dt, …`` (``s = block_stride``).
    block_stride : int
        Spacing of the block's windows in samples.
    extra_derivatives : int
        ``d/ds`` applied beyond the ``order`` needed to annihilate the initial conditions
        (smoother kernels that vanish faster at both window ends). With an output offset in the
        model, one more is applied automatically (it annihilates the constant).
    n_equations : int, optional
        Equations per window (``ν = mu … mu + n_equations − 1``); default the number of unknowns,
        more gives least squares within each window.
    unknown : sequence of str, optional
        Coefficients to estimate (default ``model.unknown`` less the names in ``known``); the
        others are known.
    known : dict, optional
        Values of known coefficients overriding ``model.parameters`` (finite numbers).
    guard : float
        A window is invalid when its determinant level is below ``guard`` times the median level
        of the trailing ``guard_window`` windows (0 disables the guard).
    guard_window : int, optional
        Windows in the running median of the guard (default ``2 L + 1``).
    expanding : bool
        Before the first full window, estimate on the growing window ``[0, t0]`` (from
        ``max(interpolation_degree, 4)`` samples on). Each length has its own taps: a start-up
        cost of order ``L²``, meant for windows of up to a few hundred samples.
    interpolation_degree : int
        Degree of the local interpolant of the "exact" rule.
    final_fraction : float in (0, 1]
        The final estimate uses the valid full windows in the trailing ``final_fraction`` of the
        record (1: the whole record).
    final : {"lstsq", "median", "bias-compensated"}
        "lstsq" (default): least squares on all their equations pooled, after dropping windows
        whose own estimate lies beyond 5 robust standard deviations of the median (6-14x more
        accurate than the median on a stationary noisy record, and half PySINDy's ω0 error or
        better at 25/50/80 dB, see docs/algebraic.md); "median": the median of those windows'
        estimates (robust to a parameter change inside the record); "bias-compensated": pooled
        least squares over *every* full window (no guard, no screen: selecting windows by their
        noisy level or estimate biases θ2 by ~1 % at 30 dB) with the errors-in-variables bias of
        the output noise removed (`_bias_compensated`); its standard errors reach nominal
        coverage at 30 and 60 dB (benchmarks/bench_coverage.py). The default's standard errors
        are withheld (``stderr`` None, ``stderr_reason`` with the numbers) where its estimate
        lies more than `MAX_SHIFT_TO_STDERR` of them from the bias-compensated one: at 30 dB on
        the paper's MSD (θ2 biased by ~6 of them) always, at 60 dB in a minority of records.
        The default stays "lstsq": on stationary records "bias-compensated" is more accurate
        (ω0 RMS error over 5 seeds at 25 dB: 8e-4 against 4.5e-3 at Z = 10), but every window
        enters it, and on the paper's disturbed record (ω2 = 500 ω0, aliased; 80 dB, Z = 10)
        its ω0 error is 3.0 % against the screened default's 0.69 %.

    Examples
    --------
    >>> s = AlgebraicSettings(window=0.1)
    >>> s.window, s.final, s.replace(final="median").final
    (0.1, 'lstsq', 'median')
    """

    window: float = 0.05
    mu: int | None = None
    integration: str = "exact"
    block: int = 1
    block_stride: int = 1
    extra_derivatives: int = 0
    n_equations: int | None = None
    unknown: Sequence[str] | None = None
    known: Mapping[str, float] | None = None
    guard: float = DEFAULT_GUARD
    guard_window: int | None = None
    expanding: bool = False
    interpolation_degree: int = DEFAULT_INTERPOLATION_DEGREE
    final_fraction: float = 1.0
    final: str = "lstsq"

    #: Settings that only shape the final estimate (not the per-window estimates).
    FINAL_ONLY = ("final_fraction", "final")

    @classmethod
    def names(cls) -> tuple[str, ...]:
        """The setting names, in order."""
        return tuple(f.name for f in fields(cls))

    @classmethod
    def from_kwargs(cls, where: str, allowed: Sequence[str] | None = None, **kwargs):
        """Build from keywords, refusing unknown names with the list of allowed ones."""
        allowed = cls.names() if allowed is None else tuple(allowed)
        bad = sorted(set(kwargs) - set(allowed))
        if bad:
            raise InputError(f"unknown setting(s) {bad} for {where}; allowed: {sorted(allowed)}.")
        return cls(**kwargs)

    def replace(self, **changes) -> AlgebraicSettings:
        """A copy with some settings changed."""
        return dataclasses.replace(self, **changes)

    def plan_settings(self) -> dict[str, Any]:
        """The settings that shape the per-window systems (all but `FINAL_ONLY`)."""
        return {k: getattr(self, k) for k in self.names() if k not in self.FINAL_ONLY}

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready name -> value."""
        out = {k: getattr(self, k) for k in self.names()}
        out["unknown"] = None if self.unknown is None else list(self.unknown)
        out["known"] = None if self.known is None else dict(self.known)
        return out


# ----------------------------------------------------------------------------------------------
# Result
# ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class AlgebraicResult(LinearODEResultMixin, ResultMixin):
    """Estimates of the algebraic estimator at every sample time.

    Attributes
    ----------
    t : ndarray, shape (n_samples,) [s]
        Times ``t0`` of the estimates (window ends; each estimate uses samples up to ``t0`` only).
    estimates : ndarray, shape (n_samples, n_unknown)
        Per-window estimates in SI units; NaN where no window exists yet (also ``history``).
    names : tuple of str
        Names of the estimated coefficients (columns of ``estimates``).
    valid : ndarray of bool, shape (n_samples,)
        Windows that exist, solved, and passed the determinant guard.
    level : ndarray, shape (n_samples,)
        Determinant level of each window's system (``|det|``; see `AlgebraicEstimator`).
    parameters : dict
        The fitted coefficients: the final estimate from the valid full windows in the trailing
        ``final_fraction`` of the record; by default (``final="lstsq"``) least squares over their
        pooled equations, after dropping the windows whose own estimate lies beyond 5 robust
        standard deviations (1.4826 · MAD) of the median; with ``final="median"`` the median of
        their estimates.
    success, message, valid_fraction
        Whether a trustworthy final estimate exists; what to change otherwise; fraction of
        existing windows that are valid.
    known : dict
        Coefficients held at known values.
    window : float [s], mu, integration, block
        Settings used (``window`` is the rounded ``L · dt``).
    derived : dict
        For the MSD ``natural_frequency`` [rad/s] and ``damping_ratio`` (and ``mass``,
        ``damping``, ``stiffness`` when ``b0 = 1/m`` is known or fitted); for a model whose
        coefficients are expressions of physical parameters (``a = ["k/m", "c/m"]``), those
        parameters where the coefficients determine them (see ``physical``).
    stderr : dict or None
        Standard errors of the fitted coefficients (see `AlgebraicEstimator`); None with
        ``stderr_reason`` when they cannot be given honestly.
    stderr_reason : str or None
    derived_stderr : dict or None
        Standard errors of ``derived`` by the delta method from ``final_covariance``; None
        whenever ``stderr`` is None.
    final_covariance : ndarray (len(names), len(names)) or None
        Covariance of the final estimate (SI, ordered like ``names``; its diagonal is
        ``stderr``²); None whenever ``stderr`` is None.
    physical : dict or None
        For a model in physical terms, `PhysicalParameters.to_dict` of the final estimate:
        ``values``, ``stderr``, ``identifiable``, ``unidentifiable``, ``combinations`` and
        ``message`` (which, when physical parameters are not identifiable, also ends
        ``message``); None for other models.
    units : dict
        name -> unit of ``parameters`` and ``derived``.
    settings : dict
        Every `AlgebraicSettings` value used, and ``dt`` [s].
    model : LinearODEModel
        The model fitted (not written by ``to_dict``; ``model_name`` is).
    fit_percent : float
        Output-error fit ``100 (1 − ‖y − ŷ‖ / ‖y − ȳ‖)`` of the identified model on the fitted
        record (NaN when not computed).
    """

    t: np.ndarray
    estimates: np.ndarray
    names: tuple[str, ...]
    valid: np.ndarray
    level: np.ndarray
    parameters: dict[str, float]
    success: bool
    message: str
    valid_fraction: float
    known: dict[str, float] = field(default_factory=dict)
    window: float = float("nan")
    mu: int = 0
    integration: str = "exact"
    block: int = 1
    derived: dict[str, float] = field(default_factory=dict)
    stderr: dict[str, float] | None = None
    stderr_reason: str | None = None
    derived_stderr: dict[str, float] | None = None
    final_covariance: np.ndarray | None = None
    physical: dict | None = None
    units: dict[str, str] = field(default_factory=dict)
    settings: dict[str, Any] = field(default_factory=dict)
    model_name: str = ""
    fit_percent: float = float("nan")
    model: Any = field(default=None, repr=False, compare=False)

    method = "algebraic"
    _history_fields = ("t", "estimates", "valid", "level")
    _private_fields = ("model",)

    def series(self, name: str) -> np.ndarray:
        """Per-time estimate of one coefficient (or, for the MSD, ``natural_frequency`` /
        ``damping_ratio``); a known coefficient gives a constant array."""
        if name in self.names:
            return self.estimates[:, self.names.index(name)].copy()
        if name in self.known:
            return np.full(self.t.size, self.known[name])
        if name in ("natural_frequency", "damping_ratio") and {"theta1", "theta2"} <= (
            set(self.names) | set(self.known)
        ):
            omega0, zeta = natural_frequency_damping(self.series("theta1"), self.series("theta2"))
            return omega0 if name == "natural_frequency" else zeta
        raise InputError(f"no series {name!r}; available: {list(self.names) + list(self.known)}.")

    def plot(
        self,
        names: Sequence[str] | None = None,
        truth: Mapping[str, float] | None = None,
        ax=None,
    ):
        """Estimates against time with the invalid windows shaded; returns the Figure.

        Parameters
        ----------
        names : sequence of str, optional
            Series to draw (default: ω0 and ζ for the MSD, else the fitted names).
        truth : mapping, optional
            True values drawn as dashed lines.
        ax : matplotlib Axes, optional
            Draw the first series into this axes instead of a new figure.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from ..report.algebraic import plot_algebraic

        if ax is None:
            return plot_algebraic(self, names=names, truth=truth)
        return plot_algebraic(self, names=names, truth=truth, ax=ax)


def _make_result(
    plan: _Plan,
    t,
    theta,
    valid,
    level,
    final_fraction: float,
    final_rule: str,
    equations=None,
    *,
    model=None,
    settings: AlgebraicSettings | None = None,
    signals=None,
) -> AlgebraicResult:
    names = plan.names
    full = np.zeros(t.size, dtype=bool)
    full[plan.span :] = True
    exists = np.isfinite(level)
    valid_fraction = float(valid[exists].mean()) if exists.any() else 0.0
    tail = t >= t[-1] - final_fraction * (t[-1] - t[0])
    use = valid & full & tail
    if final_rule == "bias-compensated" and use.any():
        # every full window enters: selecting windows by their noisy determinant (the guard) or
        # by their own estimate (the screen) biases the pooled estimate at low SNR; the pooled
        # least squares weighs a flat window by its small information anyway
        use = full & tail & np.isfinite(level) & np.isfinite(theta).all(axis=1)
    stderr: dict[str, float] | None = None
    stderr_reason: str | None = "no valid window"
    cov_final: np.ndarray | None = None
    condition = float("nan")
    # every full window with a finite estimate: the windows of the bias-compensated reference
    every = full & tail & np.isfinite(level) & np.isfinite(theta).all(axis=1)
    if use.any():
        if final_rule == "median":
            final = np.median(theta[use], axis=0)
            stderr_reason = (
                "final='median' has no standard error model; use final='lstsq' for standard errors"
            )
        else:
            # Screen first: a window whose own estimate lies beyond 5 robust standard deviations
            # (1.4826 MAD) of the median is an outlier (e.g. it straddles a jump of the input,
            # where the local interpolant of the exact rule breaks); pooling would let it bias
            # the result, the median would not.
            med = np.median(theta[use], axis=0)
            spread = 1.4826 * np.median(np.abs(theta[use] - med), axis=0)
            bound = (np.inf if final_rule == "bias-compensated" else 5.0) * spread + 1e-12 * np.abs(
                med
            )
            close = np.all(np.abs(theta - med) <= bound, axis=1, where=use[:, None])
            use = use & close
            # pooled least squares over every equation of the used windows (dimensionless
            # unknowns α, then back to SI): Σ AᵀA α = Σ Aᵀ r
            A, rhs = equations
            A = A[:, :, -t.size :][:, :, use]
            rhs = rhs[:, -t.size :][:, use]
            G = np.einsum("epw,eqw->pq", A, A)
            h = np.einsum("epw,ew->p", A, rhs)
            alpha = np.linalg.lstsq(G, h, rcond=None)[0]
            if final_rule == "bias-compensated":
                alpha, G = _bias_compensated(plan, A, rhs, G, h, alpha)
            final = _offset_to_value(plan, alpha * _unscale(plan))
            condition = _equilibrated_condition(G)
            stderr, stderr_reason, cov_final = _pooled_stderr(
                plan, A, rhs, alpha, np.flatnonzero(use), G
            )
            if stderr is not None and ("o", 0) in plan.columns:
                # se(o) ≈ se(δ)/|a_0| (the relative error of a_0 is far smaller)
                name = plan.names[plan.columns.index(("o", 0))]
                a0 = abs(
                    final[plan.columns.index(("a", 0))]
                    if ("a", 0) in plan.columns
                    else plan.known_a[0]
                )
                stderr[name] = float(stderr[name] / a0) if a0 > 0 else float("nan")
                k = plan.columns.index(("o", 0))  # the same scaling of its row and column
                cov_final[k, :] /= a0 if a0 > 0 else np.nan
                cov_final[:, k] /= a0 if a0 > 0 else np.nan
            if stderr is not None and final_rule == "lstsq":
                stderr, stderr_reason = _withhold_if_biased(
                    plan, equations, t, every, final, stderr
                )
        success = True
        message = ""
        if valid_fraction < 0.5:
            message = (
                f"only {valid_fraction:.0%} of the windows passed the determinant guard; lengthen "
                "the window, raise block, or excite the system more richly."
            )
    else:
        final = np.full(len(names), np.nan)
        success = False
        message = (
            "no valid full window: the determinant of every window system is small or zero. "
            "Check that the input excites the system, lengthen the window, raise block, or relax "
            "the guard."
        )
    params = {k: float(v) for k, v in zip(names, final, strict=True)}
    if success and not np.all(np.isfinite(final)):
        success = False
        message = "the pooled least-squares system is singular; use final='median'."
    if success and np.isfinite(condition) and condition > MAX_CONDITION:
        success = False
        message = (
            f"the pooled window system is ill-conditioned (condition number {condition:.1e} > "
            f"{MAX_CONDITION:.0e}), so rounding decides the estimate: lower mu, lengthen the "
            "window, or excite the system more richly."
        )
    known = dict(plan.known)
    model = as_linear_ode_model(model if model is not None else "msd")
    derived, _, derived_units, physical = derived_with_stderr(model, {**known, **params}, names)
    if success and not all(np.isfinite(v) for v in derived.values()):
        success = False
        message = (
            "a derived quantity is not finite (for the MSD: θ2 ≤ 0 gives no natural frequency); "
            "check the excitation and the sign conventions of u and x."
        )
    fit = float("nan")
    if success and signals is not None:
        fit = _training_fit(model, {**known, **params}, signals, tail)
        if np.isfinite(fit) and fit < MIN_FIT_PERCENT:
            success = False
            message = (
                f"the identified model explains almost nothing of the output (fit {fit:.1f} % "
                f"< {MIN_FIT_PERCENT:g} %, 100·(1 − ‖y − ŷ‖/‖y − ȳ‖) on the fitted record): the "
                "data look like noise, or the input does not drive the output. Check the channels "
                "and the excitation."
            )
    if not success:
        stderr, stderr_reason = None, stderr_reason or "no trustworthy estimate"
    if stderr is None:
        cov_final = None  # withheld with the standard errors (stderr_reason)
    derived, derived_stderr, derived_units, physical = derived_with_stderr(
        model, {**known, **params}, names, cov_final
    )
    if success and physical_statement(physical):
        message = f"{message} {physical_statement(physical)}".strip()
    units = {**coefficient_units(model, names), **derived_units}
    return AlgebraicResult(
        t=t,
        estimates=theta,
        names=names,
        valid=valid,
        level=level,
        parameters=ParameterDict(params, derived),
        success=success,
        message=message,
        valid_fraction=valid_fraction,
        known=known,
        window=plan.window,
        mu=plan.nus[0],
        integration=plan.rule,
        block=plan.block,
        derived=derived,
        stderr=stderr,
        stderr_reason=None if stderr is not None else stderr_reason,
        derived_stderr=derived_stderr,
        final_covariance=cov_final,
        physical=physical,
        units=units,
        settings={**(settings or AlgebraicSettings()).as_dict(), "dt": plan.dt},
        model_name=model.name,
        fit_percent=fit,
        model=model,
    )


#: Below this output-error fit [%] on the fitted record the model "explains nothing": pure noise
#: gives about 0 %, an output with white noise at 0 dB SNR 29 %, at 10 dB 68 %.
MIN_FIT_PERCENT = 10.0


def _training_fit(model, values, signals, tail) -> float:
    """Output-error fit [%] of the model on the part of the record the final estimate used."""
    from ._linear import simulate_prediction

    t, u, y = signals
    sel = np.flatnonzero(tail)
    if sel.size < 2 * model.order + 2:
        return float("nan")
    t, u, y = t[sel], u[sel], y[sel]
    y_hat, _ = simulate_prediction(model, values, t, u, y)
    if not np.all(np.isfinite(y_hat)):
        return float("nan")
    spread = float(np.linalg.norm(y - y.mean()))
    if spread == 0.0:
        return float("nan")
    return 100.0 * (1.0 - float(np.linalg.norm(y - y_hat)) / spread)


def _equilibrated_condition(G: np.ndarray) -> float:
    """Condition number of the unit-diagonal scaling of the symmetric matrix ``G``."""
    d = np.sqrt(np.abs(np.diag(G)))
    if not np.all(d > 0) or not np.all(np.isfinite(G)):
        return float("inf")
    w = np.linalg.eigvalsh(G / d[:, None] / d[None, :])
    return float(w[-1] / w[0]) if w[0] > 0 else float("inf")


def _noise_kernels(plan: _Plan, alpha):
    """Taps (n_eq, order+1, L+1), the weights γ_i of the y-kernels in the residual, and κ_e."""
    n = plan.order
    taps = plan.taps(plan.L)
    col = {c: k for k, c in enumerate(plan.columns)}
    gamma = np.array(
        [
            alpha[col[("a", i)]] if ("a", i) in col else plan.known_a[i] * plan.window ** (n - i)
            for i in range(n + 1)
        ]
    )
    return taps, gamma, np.einsum("i,eij->ej", gamma, taps)


#: Iterations of the bias-compensated least squares (converges in 3-5 at 20-60 dB).
BIAS_COMPENSATION_ITERATIONS = 20


def _bias_compensated(plan: _Plan, A, rhs, G, h, alpha):
    """Bias-compensated pooled least squares (``final="bias-compensated"``).

    White output noise ``ε`` (variance σ²) enters both ``A`` (the y-kernels of the unknown
    ``a_i``) and ``r`` (the known ones, ``a_n = 1`` included), so ``E[G] = G₀ + W σ² Σ_e M_e`` and
    ``E[h] = h₀ + W σ² Σ_e d_e`` with ``W`` windows, ``M_e[c, c'] = τ_{e,c}·τ_{e,c'}`` and
    ``d_e[c] = −Σ_{known i} γ_i τ_{e,c}·τ_{e,i}`` (``τ_{e,i}`` the taps of kernel ``(ν_e, i)``;
    input columns carry no noise). The errors-in-variables bias of ``G⁻¹ h`` is removed by solving
    ``(G − W σ² M) α = h − W σ² d``, with σ² re-estimated from the residual of the compensated
    fit, ``E[(r − A α)²] = σ² ‖κ_e‖²`` (Zheng's bias-eliminated least squares; Söderström 2007,
    *Errors-in-variables methods in system identification*, sec. 4). Returns (α, G − W σ² M).
    """
    taps, _, _ = _noise_kernels(plan, alpha)
    n = plan.order
    W = A.shape[2]
    y_cols = [(c, i) for c, (kind, i) in enumerate(plan.columns) if kind == "a"]
    known_y = [i for i in range(n + 1) if ("a", i) not in plan.columns]
    M = np.zeros((plan.p, plan.p))
    d_per = np.zeros((plan.p, n + 1))  # Σ_e τ_{e,c}·τ_{e,i}
    for c, i in y_cols:
        for c2, i2 in y_cols:
            M[c, c2] = float(np.einsum("ej,ej->", taps[:, i, :], taps[:, i2, :]))
        for k in known_y:
            d_per[c, k] = float(np.einsum("ej,ej->", taps[:, i, :], taps[:, k, :]))
    a = alpha
    Gc = G
    for _ in range(BIAS_COMPENSATION_ITERATIONS):
        _, gamma, kappa = _noise_kernels(plan, a)
        resid = rhs - np.einsum("epw,p->ew", A, a)
        sigma2 = float((resid**2).mean() / (kappa**2).sum(axis=1).mean())
        d = -(d_per[:, known_y] @ gamma[known_y])
        Gc = G - W * sigma2 * M
        a_new = np.linalg.solve(Gc, h - W * sigma2 * d)
        if np.allclose(a_new, a, rtol=1e-12, atol=0):
            a = a_new
            break
        a = a_new
    return a, Gc


#: Plain text (a result's ``stderr_reason`` is data, not an error: no argument marks).
_USE_COMPENSATED = "final='bias-compensated'"


def _withhold_if_biased(plan: _Plan, equations, t, every, final, stderr):
    """The default's (``final="lstsq"``) standard errors, or (None, reason) where its estimate is
    farther than `MAX_SHIFT_TO_STDERR` of them from the bias-compensated estimate.

    The reference is ``final="bias-compensated"`` over every full window (``every``): consistent,
    with nominal coverage at 30 and 60 dB (benchmarks/bench_coverage.py). The default differs from
    it by the errors-in-variables bias of the output noise inside ``A`` (θ2 of the paper's MSD:
    +1 %, about 6 standard errors, at 30 dB) and by the selection of its 5-MAD screen, which the
    covariance (a fixed set of windows) does not model: the screen drops 13 % of the windows at
    30 dB and 1.7-2.5 % at 60 dB, which alone leaves sd(error)/se ≈ 1.1 (coverage 91 %) for the
    ζ = 0.5 MSD at 60 dB; it also keeps a window that straddles an input jump out of the estimate,
    which the reference then feels. The check is a difference of two estimates from the same
    record, so it costs one more pooled solve.
    """
    A, rhs = equations
    A = A[:, :, -t.size :][:, :, every]
    rhs = rhs[:, -t.size :][:, every]
    G = np.einsum("epw,eqw->pq", A, A)
    h = np.einsum("epw,ew->p", A, rhs)
    try:
        alpha = np.linalg.lstsq(G, h, rcond=None)[0]
        alpha, _ = _bias_compensated(plan, A, rhs, G, h, alpha)
    except np.linalg.LinAlgError:
        alpha = np.full(plan.p, np.nan)
    reference = _offset_to_value(plan, alpha * _unscale(plan))
    if not np.all(np.isfinite(reference)):
        return None, (
            "the bias of the estimate could not be checked (the bias-compensated reference "
            f"is singular); use {_USE_COMPENSATED} for standard errors."
        )
    shift = np.asarray(final, dtype=float) - reference
    shifted = [
        f"{nm} (shift {d:.3g}, se {stderr[nm]:.3g})"
        for nm, d, v in zip(plan.names, shift, final, strict=True)
        if abs(d) > MAX_SHIFT_TO_STDERR * stderr[nm] and abs(d) > 1e-9 * abs(v)
    ]
    if not shifted:
        return stderr, None
    return None, (
        "the estimate lies more than "
        f"{MAX_SHIFT_TO_STDERR:g} standard error(s) from the bias-compensated one (errors in the "
        "variables from the output noise, or windows dropped by the screen): "
        + ", ".join(shifted)
        + f"; a 95 % interval would not cover. Use {_USE_COMPENSATED} for an estimate "
        "without that bias and with honest standard errors."
    )


def _quadratic_term(plan: _Plan, kappa, used) -> np.ndarray:
    """The second-order part of the pooled estimate's covariance, per σ⁴ (p, p).

    The noise inside ``A`` (the y-columns ``c``: ``N_{e,w,c} = τ_{e,c} · ε`` over window ``w``)
    meets the residual's noise ``κ_e · ε`` in the quadratic forms ``Q_c = Σ_{e,w} N_{e,w,c}
    (κ_e · ε)_w = εᵀ B_c ε``. For Gaussian noise ``Cov(Q_c, Q_c') = σ⁴ [tr(B_c B_c'ᵀ) +
    tr(B_c B_c')]``. The first trace is already in ``σ² C Cᵀ`` (``C`` is built from the noisy
    ``A``); this is the second, ``Σ_{e,e'} Σ_d n(d) X^{ee'}_{c'}(d) X^{e'e}_c(−d)`` with the
    kernel cross-correlations ``X^{ee'}_c(d) = Σ_i κ_e[i] τ_{e',c}[i + d]`` and ``n(d)`` the number
    of pairs of used windows ``d`` samples apart. It is negative where the kernels are odd
    against each other: without it the θ1 intervals of the ζ = 0.5 MSD at 30 dB (where the
    quadratic part is a large share) over-cover (99 %).
    """
    taps = plan.taps(plan.L)
    L = plan.L
    y_cols = [(c, i) for c, (kind, i) in enumerate(plan.columns) if kind == "a"]
    T = np.zeros((plan.p, plan.p))
    if not y_cols:
        return T
    span = int(used[-1] - used[0]) + 1
    ind = np.zeros(span)
    ind[used - used[0]] = 1.0
    full = signal.correlate(ind, ind, mode="full", method="fft" if span > 512 else "direct")
    mid = span - 1
    n_d = np.zeros(2 * L + 1)  # n(d), d = -L..L
    lo, hi = max(0, mid - L), min(full.size, mid + L + 1)
    n_d[lo - (mid - L) : hi - (mid - L)] = np.round(full[lo:hi])
    n_eq = kappa.shape[0]
    # X[e, e', c][d + L] = Σ_i κ_e[i] τ_{e',c}[i + d]
    X = {
        (e, e2, c): np.correlate(taps[e2, i], kappa[e], mode="full")
        for e in range(n_eq)
        for e2 in range(n_eq)
        for c, i in y_cols
    }
    for c, _ in y_cols:
        for c2, _ in y_cols:
            T[c, c2] = sum(
                float(np.dot(n_d, X[(e, e2, c2)] * X[(e2, e, c)][::-1]))
                for e in range(n_eq)
                for e2 in range(n_eq)
            )
    return 0.5 * (T + T.T)


def _pooled_stderr(plan: _Plan, A, rhs, alpha, used, G=None):
    """Standard errors of the pooled least-squares estimate under white noise on the output.

    The pooled estimate solves ``G α = h``, ``G = Σ_w A_wᵀ A_w``, ``h = Σ_w A_wᵀ r_w``, over the
    used windows ``w``. At the true ``α`` the residual of equation ``e`` of the window ending at
    sample ``k`` is exactly the output noise filtered by that equation's effective kernel,
    ``r − A α = −Σ_j κ_e[j] ε_{k−L+j}`` with ``κ_e = Σ_i γ_i taps_{e,i}`` (``γ_i = α_i`` for an
    unknown ``a_i``, ``a_i T^(n−i)`` for a known one, ``γ_n = 1``); the signal part cancels because
    the samples satisfy the ODE. So, to first order,

        α̂ − α = G⁻¹ Σ_t c_t ε_t,    c_t = −Σ_e Σ_k A_e(k) κ_e[t − k + L]   (a convolution)

    and ``Cov(α̂) = σ² G⁻¹ (Σ_t c_t c_tᵀ) G⁻¹``: the overlap of the windows (which share ``L`` of
    their ``L + 1`` samples) is accounted for exactly, instead of treating the windows as
    independent. ``σ²`` comes from the residuals, ``E[(r − A α̂)²] = σ² ‖κ_e‖²``. Noise that is
    not white, and the second-order bias from noise inside ``A`` (errors in the variables, which
    biases θ2 at low SNR), are not included: see docs/algebraic.md for the measured coverage.

    ``A`` (n_eq, p, n_used), ``rhs`` (n_eq, n_used), ``alpha`` (p,) dimensionless, ``used`` the
    sample index of each used window's end. Returns (stderr dict in SI units, None, covariance
    (p, p) in SI units) or (None, reason, None).
    """
    n_eq = A.shape[0]
    _, _, kappa = _noise_kernels(plan, alpha)  # effective kernel of each equation
    resid = rhs - np.einsum("epw,p->ew", A, alpha)
    dof = resid.size - plan.p
    k2 = (kappa**2).sum(axis=1)  # ‖κ_e‖²
    if dof <= 0 or not np.all(k2 > 0):
        return None, "too few window equations for a residual variance", None
    sigma2 = float((resid**2).sum() / (A.shape[2] * k2.sum()) * resid.size / dof)
    span = int(used[-1] - used[0]) + 1
    dense = np.zeros((n_eq, plan.p, span))
    dense[:, :, used - used[0]] = A
    C = np.zeros((plan.p, span + plan.L))
    for e in range(n_eq):
        for q in range(plan.p):
            C[q] -= (
                signal.oaconvolve(dense[e, q], kappa[e])
                if span > 256
                else np.convolve(dense[e, q], kappa[e])
            )
    if G is None:
        G = np.einsum("epw,eqw->pq", A, A)
    meat = sigma2 * (C @ C.T) + sigma2**2 * _quadratic_term(plan, kappa, used)
    left = np.linalg.solve(G, meat)
    cov = np.linalg.solve(G, left.T).T  # G⁻¹ meat G⁻¹
    var = np.clip(np.diag(0.5 * (cov + cov.T)), 0.0, None)
    se = np.sqrt(var) * np.abs(_unscale(plan))
    if not np.all(np.isfinite(se)):
        return None, "the pooled window system is singular", None
    scale = _unscale(plan)
    cov_si = 0.5 * (cov + cov.T) * np.outer(scale, scale)
    return {nm: float(v) for nm, v in zip(plan.names, se, strict=True)}, None, cov_si


# ----------------------------------------------------------------------------------------------
# Public entry points
# ----------------------------------------------------------------------------------------------
def _settings_plan(model, dt, settings: AlgebraicSettings):
    return _make_plan(as_linear_ode_model(model), dt, **settings.plan_settings())


def _check_signals(model, plan: _Plan, u, y) -> None:
    """Refuse records that cannot determine the unknowns (before any window is computed)."""
    n = u.size
    if plan.L > n - 1:
        raise SamplingError(
            f"window = {plan.window:g} s ({plan.L} intervals) is longer than the record "
            f"({n} samples, {(n - 1) * plan.dt:g} s). Shorten the window or record longer."
        )
    u_zero = not np.any(u)
    if u_zero and not np.any(y):
        raise EstimationError(
            "no excitation: the input u and the output y are identically zero (zero input and "
            "zero initial state), so every window integral vanishes. Record a response to a "
            "non-zero input."
        )
    if u_zero and any(kind == "b" for kind, _ in plan.columns):
        raise EstimationError(
            f"the input u is identically zero, so the input coefficient(s) "
            f"{[nm for nm, (k, _) in zip(plan.names, plan.columns, strict=True) if k == 'b']} "
            "cannot be estimated; give them as known or excite the system."
        )
    check_distinct_signals(u, y)


def algebraic_estimates(
    u,
    y,
    dt: float,
    model="msd",
    *,
    t_start: float = 0.0,
    settings: AlgebraicSettings | None = None,
    **kwargs,
) -> AlgebraicResult:
    """Algebraic sliding-window estimates of a linear ODE's coefficients at every sample.

    Parameters
    ----------
    u, y : array_like, shape (n_samples,)
        Input and output sampled every ``dt`` (for the built-in MSD ``u = F/m`` [m/s²], ``y = x``
        [m]).
    dt : float [s]
        Sample period.
    model : "msd", path to a TOML model file, or LinearODEModel
        The linear ODE ``Σ a_i y^(i) = Σ b_i u^(i)`` (``a_n = 1``).
    t_start : float [s]
        Time of the first sample (only labels the result's ``t``).
    settings : AlgebraicSettings, optional
        All settings at once (default `AlgebraicSettings()`).
    **kwargs
        Any `AlgebraicSettings` field by name (``window=0.2``, ``mu=4``, …), overriding
        ``settings``.

    Returns
    -------
    AlgebraicResult

    Raises
    ------
    SamplingError
        The window is longer than the record or shorter than the kernels need.
    InputError
        Unknown coefficient names, Simpson with an odd number of intervals, bad settings.
    EstimationError
        No excitation (``u ≡ 0`` and ``y ≡ 0``), ``u ≡ 0`` with an input coefficient unknown, or
        an input proportional to the output.
    IdentifiabilityError
        A coefficient whose window integrals carry no information (e.g. a constant input).

    Notes
    -----
    Oueslati et al. (2011), section 4, derived for any order (see the module docstring and
    ``docs/algebraic.md`` for the corrections to eq. 17-20).

    Examples
    --------
    ÿ + 2ẏ + 5y = u with u = sin(7t), y(0) = ẏ(0) = 0 (closed form from scipy's ``lsim``):

    >>> from scipy import signal
    >>> from physid.models import msd_model
    >>> msd = msd_model()  # ẍ + θ1 ẋ + θ2 x = u, θ1 and θ2 unknown
    >>> t = np.arange(0, 2, 1e-3); u = np.sin(7 * t)
    >>> y = signal.lsim(([1.0], [1.0, 2.0, 5.0]), u, t, interp=True)[1]
    >>> res = algebraic_estimates(u, y, 1e-3, msd, window=0.2)
    >>> round(res.parameters["theta1"], 3), round(res.parameters["theta2"], 3)
    (2.0, 5.0)
    """
    base = settings if settings is not None else AlgebraicSettings()
    bad = sorted(set(kwargs) - set(AlgebraicSettings.names()))
    if bad:
        raise InputError(
            f"unknown setting(s) {bad} for algebraic_estimates; allowed: "
            f"{sorted(AlgebraicSettings.names())}."
        )
    s = base.replace(**kwargs) if kwargs else base
    dt = check_positive(dt, "dt")
    final_fraction = float(s.final_fraction)
    if not (0.0 < final_fraction <= 1.0):
        raise InputError(f"final_fraction must lie in (0, 1]; got {s.final_fraction!r}.")
    if s.final not in FINAL_RULES:
        raise InputError(f"final must be one of {FINAL_RULES}; got {s.final!r}.")
    u, y = check_signal_pair(u, y)
    model = as_linear_ode_model(model)
    y = y - model.known_output_offset()  # a held offset (identify = false) is removed (a copy)
    plan = _settings_plan(model, dt, s)
    _check_signals(model, plan, u, y)
    n = u.size
    theta, valid, level, _, equations = _run(plan, u, y, 0, n, np.empty(0))
    _check_window_excitation(plan, equations, valid, model)
    t = t_start + dt * np.arange(n)
    return _make_result(
        plan,
        t,
        theta,
        valid,
        level,
        final_fraction,
        s.final,
        equations,
        model=model,
        settings=s,
        signals=(t, u, y),
    )


def _check_window_excitation(plan: _Plan, equations, valid, model) -> None:
    """Refuse a record whose window equations cannot determine every unknown.

    The rows of every valid full window's system are one regression ``A α = r`` (dimensionless
    unknowns); the recursive estimator's unit-free tests apply unchanged: a zero column, a column
    whose share ``‖A_i‖·|α_i| / ‖r‖`` is below 1e-6 (e.g. the ẋ kernel on a constant record), and
    linearly dependent columns. A constant input that has settled gives θ1 ≈ 1e-14 "with success"
    otherwise.
    """
    from .recursive import _check_excitation

    A, rhs = equations
    n = valid.size
    use = valid.copy()
    use[: plan.span] = False
    if not use.any():
        return
    X = np.moveaxis(A[:, :, -n:][:, :, use], 1, -1).reshape(-1, plan.p)
    Y = rhs[:, -n:][:, use].reshape(-1)
    nominal = []
    for (kind, i), name in zip(plan.columns, plan.names, strict=True):
        try:
            v = float(model.parameters[name]) if kind != "o" else np.nan  # δ' is not o
        except (KeyError, TypeError, ValueError):
            v = np.nan
        nominal.append(v * plan.window ** (plan.order - i))  # α_i = a_i T^(n−i)
    ok = np.isfinite(X).all(axis=1) & np.isfinite(Y)
    if ok.sum() >= plan.p:
        _check_excitation(X[ok], plan.names, Y[ok], np.array(nominal))


class AlgebraicEstimator(EstimatorMixin):
    """Algebraic (Fliess / Sira-Ramírez) sliding-window estimator, scikit-learn style.

    Parameters
    ----------
    model : "msd", path to a TOML model file, or LinearODEModel
        The linear ODE ``Σ a_i y^(i) = Σ b_i u^(i)`` (``a_n = 1``).
    window : float [s]
        Window length ``T`` (rounded to ``L = round(T / dt)`` sample intervals).
    mu : int, optional
        Smallest power ``ν`` of ``1/s`` (default and minimum ``order + 1``, at most `MAX_MU`).
    integration : {"exact", "simpson", "trapezoid"}
        Quadrature of the window integrals; "simpson" is the paper's eq. 21.
    block : int
        Least squares over ``block`` windows.
    block_stride : int
        Spacing of the block's windows in samples.
    extra_derivatives : int
        ``d/ds`` applied beyond the ``order`` needed to annihilate the initial conditions.
    n_equations : int, optional
        Equations per window (default the number of unknowns).
    unknown : sequence of str, optional
        Coefficients to estimate (default ``model.unknown`` less the names in ``known``).
    known : dict, optional
        Values of known coefficients overriding ``model.parameters``.
    guard : float
        Determinant guard threshold relative to the running median (0 disables it).
    guard_window : int, optional
        Windows in the running median of the guard (default ``2 L + 1``).
    expanding : bool
        Estimate on the growing window ``[0, t0]`` before the first full window.
    interpolation_degree : int
        Degree of the local interpolant of the "exact" rule.
    final_fraction : float in (0, 1]
        The final estimate uses the valid full windows in this trailing fraction of the record.
    final : {"lstsq", "median", "bias-compensated"}
        Pooled least squares over the valid windows (default), their median, or bias-compensated
        pooled least squares over every full window (see `AlgebraicSettings`).

    Attributes
    ----------
    result_ : AlgebraicResult
        Set by `fit` / `fit_arrays`.

    Notes
    -----
    Every setting is described in full in `AlgebraicSettings`. Standard errors (``result_.stderr``)
    propagate white output noise through the window kernels exactly, overlap of the windows
    and the second-order noise × noise term included (`_pooled_stderr`); the default
    (``final="lstsq"``) withholds them where its estimate is biased at their scale
    (`_withhold_if_biased`), ``final="median"`` has none (``stderr_reason`` says so in both
    cases). Measured coverage: benchmarks/bench_coverage.py.

    Examples
    --------
    Noise-free ẍ + 2 ẋ + 100 x = sin(10 t), 1 s at 1 kHz (ω0 = 10 rad/s, ζ = 0.1):

    >>> from scipy import signal
    >>> from physid import Recording
    >>> t = np.arange(1000) * 1e-3
    >>> u = np.sin(10 * t)
    >>> x = signal.lsim(([1.0], [1.0, 2.0, 100.0]), u, t)[1]
    >>> est = AlgebraicEstimator("msd", window=0.05).fit(Recording(t, np.c_[u, x], ["u", "x"]))
    >>> d = est.result_.derived
    >>> round(d["natural_frequency"], 4), round(d["damping_ratio"], 4)
    (10.0, 0.1)
    """

    def __init__(
        self,
        model="msd",
        *,
        window: float = 0.05,
        mu: int | None = None,
        integration: str = "exact",
        block: int = 1,
        block_stride: int = 1,
        extra_derivatives: int = 0,
        n_equations: int | None = None,
        unknown: Sequence[str] | None = None,
        known: Mapping[str, float] | None = None,
        guard: float = DEFAULT_GUARD,
        guard_window: int | None = None,
        expanding: bool = False,
        interpolation_degree: int = DEFAULT_INTERPOLATION_DEGREE,
        final_fraction: float = 1.0,
        final: str = "lstsq",
    ):
        self.model = model
        self.window = window
        self.mu = mu
        self.integration = integration
        self.block = block
        self.block_stride = block_stride
        self.extra_derivatives = extra_derivatives
        self.n_equations = n_equations
        self.unknown = unknown
        self.known = known
        self.guard = guard
        self.guard_window = guard_window
        self.expanding = expanding
        self.interpolation_degree = interpolation_degree
        self.final_fraction = final_fraction
        self.final = final

    @property
    def settings(self) -> AlgebraicSettings:
        """The current settings as an `AlgebraicSettings`."""
        return AlgebraicSettings(**{k: getattr(self, k) for k in AlgebraicSettings.names()})

    def fit(self, recording) -> AlgebraicEstimator:
        """Estimate from a uniformly sampled `Recording`.

        Parameters
        ----------
        recording : Recording
            Channels: the model's input and output (the MSD: ``u`` and ``x`` or ``y``).

        Returns
        -------
        AlgebraicEstimator
            ``self``, with ``result_``.
        """
        names = getattr(recording, "names", None)
        if names is None:
            raise InputError(
                f"recording must be a physid Recording; got {type(recording).__name__}. "
                "Use fit_arrays(t, u=u, x=y) for plain arrays."
            )
        model = as_linear_ode_model(self.model)
        in_name, out = model.recording_channels(names)
        model.check_units(recording)  # a force [N] for the normalised msd is an error
        check_distinct_channels(in_name, out)
        dt = recording.dt
        self.result_ = algebraic_estimates(
            recording[in_name],
            recording[out],
            dt,
            model,
            t_start=float(recording.t[0]),
            settings=self.settings,
        )
        return self

    def fit_arrays(self, *args, **channels) -> AlgebraicEstimator:
        """Fit plain arrays: ``fit_arrays(t, u=u, x=y)`` (see `EstimatorMixin.fit_arrays`).

        Parameters
        ----------
        *args
            ``t`` (sample times [s]); the old form ``fit_arrays(u, y, dt[, t_start])`` still
            works and warns (DeprecationWarning).
        **channels
            The model's input and output channels by name.

        Returns
        -------
        AlgebraicEstimator
            ``self``, with ``result_``.
        """
        if len(args) in (3, 4) and not channels:
            warnings.warn(
                "fit_arrays(u, y, dt) is deprecated; use fit_arrays(t, u=u, x=y) (the one "
                "plain-array form of every estimator).",
                DeprecationWarning,
                stacklevel=2,
            )
            u, y, dt = args[:3]
            t_start = args[3] if len(args) == 4 else 0.0
            self.result_ = algebraic_estimates(
                u, y, dt, self.model, t_start=t_start, settings=self.settings
            )
            return self
        if len(args) != 1:
            raise InputError(
                "fit_arrays takes the sample times and the channels by name: "
                "fit_arrays(t, u=u, x=y)."
            )
        return super().fit_arrays(args[0], **channels)


@dataclass(frozen=True)
class StreamingUpdate:
    """Estimates for the samples of one chunk: ``t`` [s], ``estimates`` (n_new, n_unknown) in SI
    units, ``valid`` (n_new,), ``level`` (n_new,) and the coefficient ``names``."""

    t: np.ndarray
    estimates: np.ndarray
    valid: np.ndarray
    level: np.ndarray
    names: tuple[str, ...]


class StreamingAlgebraicEstimator:
    """The algebraic estimator fed chunk by chunk, with constant memory.

    It keeps the last ``L + (block − 1) block_stride`` samples and the last ``guard_window − 1``
    determinant levels; the estimates for each chunk equal the batch estimates
    (`algebraic_estimates`) of the same samples to rounding (≤ 1e-10).

    Parameters
    ----------
    model : "msd", path to a TOML model file, or LinearODEModel
        The linear ODE to identify.
    dt : float [s]
        Sample period of the stream.
    t_start : float [s]
        Time of the first sample.
    **settings
        Any `AlgebraicSettings` field except ``final_fraction`` and ``final`` (a stream has no
        final estimate).

    Examples
    --------
    The record of `AlgebraicEstimator`'s example fed in chunks of 100 samples gives the same
    per-window estimates as the batch estimator:

    >>> from scipy import signal
    >>> t = np.arange(1000) * 1e-3
    >>> u = np.sin(10 * t)
    >>> x = signal.lsim(([1.0], [1.0, 2.0, 100.0]), u, t)[1]
    >>> stream = StreamingAlgebraicEstimator("msd", dt=1e-3, window=0.05)
    >>> updates = [stream.update(u[i:i + 100], x[i:i + 100]) for i in range(0, 1000, 100)]
    >>> streamed = np.concatenate([upd.estimates for upd in updates])
    >>> batch = algebraic_estimates(u, x, 1e-3, "msd", window=0.05).estimates
    >>> bool(np.allclose(streamed, batch, rtol=1e-10, atol=0, equal_nan=True))
    True
    >>> np.round(updates[-1].estimates[-1], 3).tolist()   # θ1, θ2 at t = 0.999 s
    [2.0, 100.0]
    """

    def __init__(self, model="msd", *, dt: float, t_start: float = 0.0, **settings):
        self.dt = check_positive(dt, "dt")
        allowed = [n for n in AlgebraicSettings.names() if n not in AlgebraicSettings.FINAL_ONLY]
        s = AlgebraicSettings.from_kwargs("StreamingAlgebraicEstimator", allowed, **settings)
        model = as_linear_ode_model(model)
        self._plan = _settings_plan(model, self.dt, s)
        self._offset = model.known_output_offset()  # a held offset is removed from each chunk
        self.t_start = float(t_start)
        self.reset()

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the estimated coefficients (columns of the estimates)."""
        return self._plan.names

    def reset(self) -> None:
        """Forget the stream (start again at ``t_start``)."""
        self._u = np.empty(0)
        self._y = np.empty(0)
        self._n_seen = 0
        self._history = np.empty(0)

    def update(self, u, y) -> StreamingUpdate:
        """Feed the next samples and return their estimates.

        Parameters
        ----------
        u, y : array_like, shape (n_new,)
            Input and output samples.

        Returns
        -------
        StreamingUpdate
            The chunk's estimates.
        """
        u, y = check_signal_pair(u, y)
        y = y - self._offset
        plan = self._plan
        u_all = np.concatenate([self._u, u])
        y_all = np.concatenate([self._y, y])
        first = self._n_seen - self._u.size
        n_new = u.size
        t = self.t_start + self.dt * np.arange(self._n_seen, self._n_seen + n_new)
        if n_new == 0:
            p = plan.p
            return StreamingUpdate(t, np.empty((0, p)), np.empty(0, bool), np.empty(0), plan.names)
        theta, valid, level, self._history, _ = _run(
            plan, u_all, y_all, first, n_new, self._history
        )
        keep = plan.span
        self._u = u_all[-keep:].copy()
        self._y = y_all[-keep:].copy()
        self._n_seen += n_new
        return StreamingUpdate(t, theta, valid, level, plan.names)
