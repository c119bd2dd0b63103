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

A record read in blocks (`physid.signals.io.open_blocks`) is fitted in constant memory by
`fit_blocks` (``final="bias-compensated"``, the rule whose pooled sums stream).
"""

# Re-exported so that the names importable from this path before it became a package still are.
from .._regression import offset_name as offset_name
from .estimator import AlgebraicEstimator, algebraic_estimates
from .kernels import DEFAULT_INTERPOLATION_DEGREE as DEFAULT_INTERPOLATION_DEGREE
from .kernels import INTEGRATION_RULES, algebraic_kernels, quadrature_taps
from .kernels import _kernel_coefficients as _kernel_coefficients
from .plan import DEFAULT_GUARD as DEFAULT_GUARD
from .plan import FINAL_RULES as FINAL_RULES
from .plan import MAX_MU, AlgebraicSettings, min_window_intervals
from .result import MAX_CONDITION as MAX_CONDITION
from .result import MIN_FIT_PERCENT as MIN_FIT_PERCENT
from .result import AlgebraicResult
from .solve import _trailing_median as _trailing_median
from .streamed import fit_blocks
from .streaming import StreamingAlgebraicEstimator
from .streaming import StreamingUpdate as StreamingUpdate
from .uncertainty import BIAS_COMPENSATION_ITERATIONS as BIAS_COMPENSATION_ITERATIONS
from .uncertainty import MAX_SHIFT_TO_STDERR as MAX_SHIFT_TO_STDERR
from .windows import DIRECT_CONVOLUTION_MAX_TAPS as DIRECT_CONVOLUTION_MAX_TAPS

__all__ = [
    "AlgebraicEstimator",
    "AlgebraicResult",
    "AlgebraicSettings",
    "StreamingAlgebraicEstimator",
    "fit_blocks",
    "algebraic_estimates",
    "algebraic_kernels",
    "quadrature_taps",
    "INTEGRATION_RULES",
    "min_window_intervals",
    "MAX_MU",
]
