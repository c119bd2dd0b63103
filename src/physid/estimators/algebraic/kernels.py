"""The algebraic estimator's polynomial kernels and the FIR taps that integrate them.

`algebraic_kernels` derives the kernels ``K_{ν,i}(σ)`` with sympy (once, cached);
`quadrature_taps` turns polynomial kernels into FIR taps over the ``L + 1`` samples of a window.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from ...errors import InputError, SamplingError

#: Integration rules for the window integrals.
INTEGRATION_RULES = ("exact", "simpson", "trapezoid")


#: Default degree of the local Lagrange interpolant used by the "exact" rule.
DEFAULT_INTERPOLATION_DEGREE = 7


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
