"""Recursive least squares ("Kalman-Bucy" parameter estimator) with a forgetting factor.

Section 3 of Oueslati et al. (2011), *On algebraic approach for MSD parametric estimation*, for any
linear ODE model ``Σ_{i=0}^{n} a_i y^(i) = Σ_{j=0}^{m} b_j u^(j)`` with ``a_n = 1``.

Regression (paper eq. 2)
    Every coefficient to estimate gets one column of ``X``; the known ones move to ``Y``::

        Σ_{i<n, unknown} a_i y^(i) − Σ_{j, unknown} b_j u^(j)
              = −y^(n) − Σ_{i<n, known} a_i y^(i) + Σ_{j, known} b_j u^(j)            (Y = X θ)

    For the MSD (ẍ + θ1 ẋ + θ2 x = b0 u, b0 = 1 known) this is ``X = [ẋ_e, x_e]``, ``Y = u − ẍ_e``.
    *Erratum:* the paper's eq. 2 prints ``Y = u − (ẋ)_e`` (the velocity) where the acceleration
    belongs; with the velocity the regression is not the model (1).

State-variable filter (SVF)
    The derivatives come from one linear filter applied to *both* ``y`` and ``u``: if ``y`` and
    ``u`` satisfy the ODE then so do ``F y`` and ``F u`` for any linear time-invariant ``F``, so the
    filter adds no bias (only a decaying start-up term, which is discarded). The default ``F`` is a
    causal analog Butterworth low-pass of order ``n + 1`` realised in controllable canonical form,
    whose states *are* the filtered signal and its derivatives ``w, ẇ, …, w^(n)``; it is discretised
    exactly for a piecewise-linear (first-order-hold) input (`physid.filters.state_variable`;
    re-exported here). Optionally the project's non-causal differential FIR filters
    (`physid.filters.design_filter`) are used instead (order ≤ 2, batch).

Recursion (paper eq. 3) and its initialisation (eq. 4)
    ``K = P x (R + xᵀ P x)⁻¹``, ``θ ← θ + K (y − xᵀ θ)``, ``P ← λ⁻¹ (P − K xᵀ P)``, started from
    the ordinary least-squares solution on the first rows, ``P_M = (X_Mᵀ X_M / R)⁻¹``. Written in
    information form (``S = (λ P)⁻¹`` after each update) this is, exactly::

        θ_k = S_k⁻¹ b_k,  S_k = Σ_{i≤M} λ^{k−M−1} x_i x_iᵀ / R + Σ_{M<i≤k} λ^{k−i} x_i x_iᵀ / R
                          b_k = (same weights) Σ x_i y_i / R,                        (k > M)

    i.e. the OLS rows ``0..M`` enter with the weight of sample ``M + 1`` (eq. 4's ``P_M`` is the
    covariance *before* the division by λ). *Erratum:* the paper's eq. 5 prints the exponent
    ``α(i) = k − max{i − m, k}``, which is identically 0 for ``i ≤ k`` (no forgetting at all); the
    exponent implied by eq. 3 is ``k − i``.

Two implementations that agree to rounding (tests: ≤ 1e-9):

* `weighted_ls_path` — vectorised: the running weighted sums ``S_k``, ``b_k`` are one
  ``scipy.signal.lfilter`` call each along the sample axis, then one batched solve. No loop.
* `StreamingRLS` / `rls_update` — the true recursion, one row or a chunk at a time, with the
  covariance update in Joseph form (symmetric, positive semi-definite by construction) instead of
  the printed ``λ⁻¹ (P − K x P)``, which loses symmetry and, with λ < 1 and a regressor that stops
  being excited, grows as ``λ^{-k}`` until it overflows ("covariance wind-up"). The streaming form
  also caps ``trace(P)`` (by forgetting less in that step) so that it stays bounded.

A record read in blocks (`physid.signals.io.open_blocks`) is fitted in constant memory by
`fit_blocks`, with the in-memory fit's final estimate, standard errors and verdict.

References
----------
Oueslati M., Thiery S., Gibaru O., Béarée R., Moraru G. (2011), section 3, eqs. 2–7.
Ljung L., Söderström T. (1983), *Theory and practice of recursive identification*, ch. 2.
"""

from ...filters.state_variable import (
    StreamingStateVariableFilter,
    state_variable_filter,
    svf_transient_samples,
)

# Re-exported so that the names importable from this path before it became a package still are.
from .._regression import MIN_EXCITATION as MIN_EXCITATION
from .._regression import MIN_RELATIVE_CONTRIBUTION as MIN_RELATIVE_CONTRIBUTION
from .._regression import check_excitation as _check_excitation  # noqa: F401 (its former name)
from .batch import MIN_EQUILIBRATED_EIGENVALUE as MIN_EQUILIBRATED_EIGENVALUE
from .batch import _first_invertible_row as _first_invertible_row
from .batch import weighted_ls_path
from .estimator import RecursiveLeastSquares
from .estimator import _nominal_of as _nominal_of
from .online import StreamingRecursiveEstimator, StreamingRecursiveUpdate
from .prefilter import _model_frequency as _model_frequency
from .prefilter import default_prefilter_cutoff
from .regression import LinearRegression, build_regression
from .result import MIN_FIT_PERCENT as MIN_FIT_PERCENT
from .result import RecursiveResult
from .streamed import fit_blocks
from .streaming import DEFAULT_COVARIANCE_LIMIT_FACTOR as DEFAULT_COVARIANCE_LIMIT_FACTOR
from .streaming import StreamingRLS, rls_update
from .uncertainty import MAX_BIAS_TO_STDERR as MAX_BIAS_TO_STDERR

__all__ = [
    "RecursiveLeastSquares",
    "RecursiveResult",
    "fit_blocks",
    "StreamingRLS",
    "rls_update",
    "weighted_ls_path",
    "state_variable_filter",
    "StreamingStateVariableFilter",
    "StreamingRecursiveEstimator",
    "StreamingRecursiveUpdate",
    "svf_transient_samples",
    "default_prefilter_cutoff",
    "LinearRegression",
    "build_regression",
]
