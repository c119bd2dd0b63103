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

References
----------
Oueslati M., Thiery S., Gibaru O., Béarée R., Moraru G. (2011), section 3, eqs. 2–7.
Ljung L., Söderström T. (1983), *Theory and practice of recursive identification*, ch. 2.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import signal

from .._validate import (
    as_1d,
    as_2d,
    check_finite,
    check_in_range,
    check_int,
    check_positive,
    check_signal_pair,
)
from ..errors import EstimationError, IdentifiabilityError, InputError, ShapeError, arg
from ..filters.state_variable import (
    StreamingStateVariableFilter,
    state_variable_filter,
    svf_transient_samples,
)
from ..models.linear_ode import (
    LinearODEModel,
    as_linear_ode_model,
    natural_frequency_damping,
)
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
    "RecursiveLeastSquares",
    "RecursiveResult",
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

#: Smallest eigenvalue of the unit-diagonal (equilibrated) information matrix that counts as
#: invertible. The equilibrated matrix has eigenvalues in (0, p], so this is a reciprocal condition
#: number threshold that does not depend on the units of the regressors.
MIN_EQUILIBRATED_EIGENVALUE = 1e-10
#: Smallest equilibrated eigenvalue of the whole record's Σ x xᵀ for every unknown to count as
#: excited (reciprocal condition number 1e-8: below it, relative errors of 1e-8 in the rows, e.g. a
#: filter transient remnant, already move θ̂ by O(1)).
MIN_EXCITATION = 1e-8
#: Smallest share ‖X_i‖·|θ_i| / ‖Y‖ of the regression that a column must explain (see
#: `_check_excitation`); below it the column is transient residue or rounding, not excitation.
MIN_RELATIVE_CONTRIBUTION = 1e-6
#: An estimated errors-in-variables bias above this many standard errors withholds the interval
#: (``stderr`` None with the reason): at 0.5 the coverage of a nominal 95 % interval is still
#: ≥ 92 % (|z| ≤ 1.96 with the centre shifted by 0.5 σ).
MAX_BIAS_TO_STDERR = 0.5
#: Default cap of trace(P) in the streaming form, relative to trace(P) at initialisation.
DEFAULT_COVARIANCE_LIMIT_FACTOR = 1e8


# =============================================================================== the model
# =============================================================================== the pre-filter
def default_prefilter_cutoff(dt: float, characteristic_frequency: float | None = None) -> float:
    """Default SVF cut-off [Hz]: ``min(10 f_model, f_s / 10)``, or ``f_s / 20`` without a model.

    ``f_model`` [Hz] is the largest ``|root| / 2π`` of the model's nominal characteristic polynomial
    (for the MSD: ω0 / 2π). Ten times the model's frequency passes its dynamics and a sinusoidal
    input up to Z ≈ 10 with little attenuation; ``f_s / 10`` keeps ``ω_c·dt ≤ 0.63`` so the
    discretised filter stays well conditioned. The SVF adds no bias whatever the cut-off; it only
    trades noise suppression against excitation.

    Parameters
    ----------
    dt : float [s]
        Sample period (f_s = 1 / dt).
    characteristic_frequency : float, optional [Hz]
        ``f_model``; None, non-finite or ≤ 0 means unknown.

    Returns
    -------
    float [Hz]
        The cut-off.

    Examples
    --------
    The paper's MSD (ω0 = √(400/3) rad/s, f_model = 1.838 Hz) at 1 kHz, and no model:

    >>> round(default_prefilter_cutoff(1e-3, np.sqrt(400 / 3) / (2 * np.pi)), 2)
    18.38
    >>> default_prefilter_cutoff(1e-3)
    50.0
    """
    fs = 1.0 / dt
    if (
        characteristic_frequency is None
        or not np.isfinite(characteristic_frequency)
        or (characteristic_frequency <= 0)
    ):
        return fs / 20.0
    return float(min(10.0 * characteristic_frequency, fs / 10.0))


def _model_frequency(spec: LinearODEModel) -> float | None:
    try:
        a = [float(spec.parameters[name]) for name in spec.a_names]
    except (KeyError, TypeError, ValueError):
        return None
    roots = np.roots(np.r_[1.0, a[::-1]])  # s^n + a_{n-1} s^{n-1} + ... + a_0
    if roots.size == 0:
        return None
    return float(np.max(np.abs(roots)) / (2 * np.pi))


# =============================================================================== regression
@dataclass(frozen=True)
class LinearRegression:
    """Rows ``Y = X θ`` built from a recording (after the pre-filter transient).

    Attributes
    ----------
    X : ndarray, shape (n_rows, p)
    Y : ndarray, shape (n_rows,)
    names : tuple of str, length p — the unknown coefficient of each column.
    sample_index : ndarray of int, shape (n_rows,) — the recording sample each row belongs to.
    discarded : int — samples dropped at the start (filter transient).
    cutoff : float [Hz] — pre-filter cut-off used.
    """

    X: np.ndarray
    Y: np.ndarray
    names: tuple[str, ...]
    sample_index: np.ndarray
    discarded: int
    cutoff: float


def _prefilter_settings(spec, dt, prefilter_cutoff, prefilter_order, discard):
    """The pre-filter's settings, shared by `build_regression` and the streaming estimator so that
    both filter alike: (highest derivative order, cut-off [Hz], Butterworth order, samples to
    discard or None for the filter's own transient)."""
    check_int(discard, "transient_samples", minimum=0, allow_none=True)
    highest = max(spec.order, spec.input_order)
    cutoff = (
        default_prefilter_cutoff(dt, _model_frequency(spec))
        if prefilter_cutoff is None
        else check_positive(prefilter_cutoff, "prefilter_cutoff")
    )
    order = highest + 1 if prefilter_order is None else int(prefilter_order)
    return highest, cutoff, order, (None if discard is None else int(discard))


def build_regression(
    spec_or_model,
    y,
    u,
    dt: float,
    *,
    unknown: Sequence[str] | None = None,
    known: Mapping[str, float] | None = None,
    prefilter: str = "butterworth",
    prefilter_cutoff: float | None = None,
    prefilter_order: int | None = None,
    discard: int | None = None,
) -> LinearRegression:
    """Build the regression ``Y = X θ`` of a linear ODE model from sampled ``y`` and ``u``.

    Parameters
    ----------
    spec_or_model : LinearODEModel or "msd"
    y, u : array_like, shape (n_samples,)
        Output and input samples [SI units of the model's output and input].
    dt : float [s]
        Uniform sample period of ``y`` and ``u``.
    unknown : sequence of str, optional
        Coefficients to estimate (default: the model's ``unknown`` less the names in ``known``).
    known : mapping, optional
        Values of the other coefficients (default: the model's nominal ``parameters``).
    prefilter : {"butterworth", "differential"}
    prefilter_cutoff : float, optional [Hz]
        Default `default_prefilter_cutoff`.
    prefilter_order : int, optional
        Butterworth order (default model order + 1).
    discard : int, optional
        Samples to drop at the start (default `svf_transient_samples`; the differential filters
        drop their half-width at each end instead).

    Returns
    -------
    LinearRegression
        ``X`` (n_rows, p) [unit of the output / sⁱ for a_i columns, of the input / sʲ for b_j
        columns], ``Y`` (n_rows,) [unit of y / sⁿ], ``names`` (the unknown of each column),
        ``sample_index`` (the sample each row belongs to), ``discarded`` [samples] and ``cutoff``
        [Hz].

    Examples
    --------
    For the MSD, ``X = [ẋ_f, x_f]`` and ``Y = u_f − ẍ_f``, so θ = (θ1, θ2) solves it exactly on
    noise-free data:

    >>> from scipy import signal
    >>> t = np.arange(3000) * 1e-3
    >>> u = np.sin(10 * t)
    >>> x = signal.lsim(([1.0], [1.0, 2.0, 100.0]), u, t)[1]
    >>> reg = build_regression("msd", x, u, 1e-3)
    >>> reg.names, reg.discarded
    (('theta1', 'theta2'), 240)
    >>> np.round(np.linalg.lstsq(reg.X, reg.Y, rcond=None)[0], 4).tolist()
    [2.0, 100.0]
    """
    spec = as_linear_ode_model(spec_or_model)
    u, y = check_signal_pair(u, y)
    y = y - spec.known_output_offset()  # a held offset (identify = false) is removed (a copy)
    unknown, values = _split_with_offset(spec, unknown, known)
    highest, cutoff, order, discard = _prefilter_settings(
        spec, dt, prefilter_cutoff, prefilter_order, discard
    )
    if prefilter == "butterworth":
        derivs = state_variable_filter(np.column_stack([y, u]), dt, cutoff, highest, order)
        skip = svf_transient_samples(cutoff, dt, order) if discard is None else discard
        rows = np.arange(skip, y.size)
        yd, ud = derivs[skip:, 0, :], derivs[skip:, 1, :]
    elif prefilter == "differential":
        if highest > 2:
            raise InputError(
                f"prefilter='differential' provides derivatives up to order 2; this model needs "
                f"order {highest}. Use prefilter='butterworth'."
            )
        from ..filters import design_filter_bank

        omega = 2 * np.pi * cutoff * dt  # [rad/sample]
        half = max(highest + 1, int(round(4 * np.pi / omega)))  # ≈ 2 main-lobe widths of the kernel
        sig = np.column_stack([y, u])
        # consistent bank: F_k = s^k F0 in the pass band, so the pre-filter adds no bias
        bank = design_filter_bank(half, omega, dt, design="consistent")
        parts = [f.apply(sig) for f in bank[: highest + 1]]  # output j belongs to sample j + half
        skip = half if discard is None else max(discard, half)
        rows = np.arange(skip, y.size - half)
        yd = np.stack([p[skip - half : skip - half + rows.size, 0] for p in parts], axis=-1)
        ud = np.stack([p[skip - half : skip - half + rows.size, 1] for p in parts], axis=-1)
    else:
        raise InputError(f"prefilter must be 'butterworth' or 'differential'; got {prefilter!r}.")
    if rows.size == 0:
        raise EstimationError(
            f"the record has {y.size} samples but the pre-filter discards {skip}; record longer or "
            "raise prefilter_cutoff."
        )

    X, Y = _regression_rows(spec, unknown, values, yd, ud)
    return LinearRegression(X, Y, unknown, rows, int(rows[0]), float(cutoff))


def _split_with_offset(spec, unknown, known):
    """`split_coefficients`, plus the model's output offset (if it has one to estimate) last."""
    from .algebraic import offset_name

    unknown, values = spec.split_coefficients(unknown, known)
    offset = offset_name(spec)
    return (tuple(unknown) + (offset,) if offset else tuple(unknown)), values


def _offset_to_value(spec, names, theta):
    """Estimates with the offset column δ = a_0 o turned into o (a copy; theta (..., p))."""
    from .algebraic import offset_name

    offset = offset_name(spec)
    theta = np.array(theta, dtype=float, copy=True)
    if not offset or offset not in names:
        return theta
    a0_name = spec.a_names[0]
    a0 = theta[..., names.index(a0_name)] if a0_name in names else None
    if a0 is None:
        a0 = float(spec.parameters[a0_name])
    with np.errstate(divide="ignore", invalid="ignore"):
        theta[..., names.index(offset)] = theta[..., names.index(offset)] / a0
    return theta


def _regression_rows(spec: LinearODEModel, unknown, values, yd, ud):
    """(X, Y) from the filtered derivatives ``yd`` (rows, n + 1…) and ``ud`` (rows, m + 1…).

    An output offset ``o`` (measured ``y_m = y + o``) adds ``a_0 o`` to the equation in ``y_m``;
    the SVF passes the constant with unit gain to its state ``w`` and nothing to the derivatives
    (after the start-up transient that is discarded), so it is one more column, ``−1``, with the
    unknown ``δ = a_0 o`` (converted to ``o`` by the estimator).
    """
    n = spec.order
    # Σ_unknown a_i y^(i) − Σ_unknown b_j u^(j) = −y^(n) − Σ_known a_i y^(i) + Σ_known b_j u^(j)
    Y = -yd[:, n].copy()
    cols = {}
    for i, name in enumerate(spec.a_names):
        if name in unknown:
            cols[name] = yd[:, i]
        else:
            Y -= values[name] * yd[:, i]
    for j, name in enumerate(spec.b_names):
        if name in unknown:
            cols[name] = -ud[:, j]
        else:
            Y += values[name] * ud[:, j]
    for name in unknown:
        if name not in cols:  # the output offset: Σ a_i y_m^(i) − δ = … (δ = a_0 o)
            cols[name] = -np.ones(Y.size)
    X = np.column_stack([cols[name] for name in unknown]) if unknown else np.empty((Y.size, 0))
    return X, Y


# =============================================================================== batch form
def _equilibrated_solve(S: np.ndarray, rhs: np.ndarray):
    """Solve ``S θ = rhs`` for a stack of symmetric matrices (..., p, p); see `_packed_solve`."""
    p = S.shape[-1]
    iu = np.triu_indices(p)
    return _packed_solve(S[..., iu[0], iu[1]], rhs, p)


#: Rows per block in `weighted_ls_path` and `_packed_solve`: the temporaries of a block (64 kB)
#: stay in cache and in the allocator's free lists instead of fresh page-faulted memory per op.
_SOLVE_BLOCK = 8192


def _packed_solve(S_packed: np.ndarray, rhs: np.ndarray, p: int, diagonal_only: bool = False):
    """`_packed_solve_block` over blocks of `_SOLVE_BLOCK` matrices (any leading shape)."""
    lead = S_packed.shape[:-1]
    flat_S = S_packed.reshape(-1, S_packed.shape[-1])
    flat_rhs = rhs.reshape(-1, p)
    count = flat_S.shape[0]
    theta = np.empty((count, p))
    inv = np.empty((count, p) if diagonal_only else (count, p, p))
    ok = np.empty(count, dtype=bool)
    for start in range(0, count, _SOLVE_BLOCK):
        block = slice(start, start + _SOLVE_BLOCK)
        theta[block], inv[block], ok[block] = _packed_solve_block(
            flat_S[block], flat_rhs[block], p, diagonal_only
        )
    return theta.reshape(lead + (p,)), inv.reshape(lead + inv.shape[1:]), ok.reshape(lead)


def _packed_solve_block(S_packed: np.ndarray, rhs: np.ndarray, p: int, diagonal_only: bool):
    """Solve ``S θ = rhs`` for a stack of symmetric matrices with Jacobi scaling and LDLᵀ.

    ``S_packed`` (..., p(p+1)/2) holds the upper triangle row by row (``np.triu_indices(p)``).
    ``S = D^{1/2} Ŝ D^{1/2}`` with ``Ŝ`` unit-diagonal, so the test of invertibility and the solve
    do not depend on the scale of the sums (which grow like k for λ = 1 and shrink like λ^k without
    excitation) or on the units of the columns. ``Ŝ = L Δ Lᵀ`` is factorised elementwise over the
    stack (Python loops run over the p matrix indices only, each line a vectorised operation on all
    samples: much faster than numpy's batched LAPACK calls on 2×2 matrices). A matrix counts as
    invertible when every pivot ``Δ_j > MIN_EQUILIBRATED_EIGENVALUE`` (pivots of a unit-diagonal
    matrix lie between its smallest eigenvalue and 1).

    Returns (θ (..., p), S⁻¹ (..., p, p) or its diagonal (..., p), ok (...)), NaN where not ok;
    ``S⁻¹ = D^{-1/2} L⁻ᵀ Δ⁻¹ L⁻¹ D^{-1/2}``.
    """
    iu = np.triu_indices(p)
    packed_first = np.ascontiguousarray(np.moveaxis(S_packed, -1, 0))  # contiguous entries
    rhs_first = np.ascontiguousarray(np.moveaxis(rhs, -1, 0))
    entry = {(int(a), int(b)): packed_first[c] for c, (a, b) in enumerate(zip(*iu, strict=True))}
    diag = [entry[i, i] for i in range(p)]
    ok = np.ones(S_packed.shape[:-1], dtype=bool)
    for d in diag:
        ok &= (d > 0) & np.isfinite(d)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        sc = [1.0 / np.sqrt(d) for d in diag]  # D^{-1/2}
        L = [[None] * p for _ in range(p)]
        piv = []
        for j in range(p):  # Δ_j = Ŝ_jj − Σ_k L_jk² Δ_k ;  L_ij = (Ŝ_ij − Σ_k L_ik L_jk Δ_k) / Δ_j
            dj = 1.0 - sum(L[j][k] ** 2 * piv[k] for k in range(j))  # Ŝ_jj = 1
            piv.append(dj)
            ok &= dj > MIN_EQUILIBRATED_EIGENVALUE
            for i in range(j + 1, p):
                s_ij = entry[j, i] * sc[i] * sc[j]
                L[i][j] = (s_ij - sum(L[i][k] * L[j][k] * piv[k] for k in range(j))) / dj
        z = []
        for i in range(p):  # L z = D^{-1/2} rhs
            z.append(rhs_first[i] * sc[i] - sum(L[i][k] * z[k] for k in range(i)))
        th = [None] * p
        for i in reversed(range(p)):  # Δ Lᵀ θ̂ = z, θ = D^{-1/2} θ̂
            th[i] = z[i] / piv[i] - sum(L[k][i] * th[k] for k in range(i + 1, p))
        Li = [[None] * p for _ in range(p)]  # L⁻¹ (unit lower triangular)
        for jj in range(p):
            for i in range(jj + 1, p):
                Li[i][jj] = -(L[i][jj] + sum(L[i][k] * Li[k][jj] for k in range(jj + 1, i)))
        shape = S_packed.shape[:-1] + ((p,) if diagonal_only else (p, p))
        inv = np.empty(shape)
        for i in range(p):
            for jj in (i,) if diagonal_only else range(i, p):
                # (Ŝ⁻¹)_ij = Σ_{k ≥ j} (L⁻¹)_ki (L⁻¹)_kj / Δ_k
                val = sum(
                    (1.0 if k == i else Li[k][i]) * (1.0 if k == jj else Li[k][jj]) / piv[k]
                    for k in range(jj, p)
                )
                val = val * sc[i] * sc[jj]
                if diagonal_only:
                    inv[..., i] = val
                else:
                    inv[..., i, jj] = val
                    inv[..., jj, i] = val
        theta = np.stack([th[i] * sc[i] for i in range(p)], axis=-1)
    theta[~ok] = np.nan
    inv[~ok] = np.nan
    return theta, inv, ok


def _first_invertible_row(X: np.ndarray, weight: float, init_samples: int) -> int | None:
    """Index M of the last OLS row: the first M ≥ init_samples − 1 with Σ_{i≤M} x xᵀ invertible.

    Searched block by block (running sums carried over), so a record that is excited early costs
    one block, not a pass over all rows.
    """
    start = init_samples - 1
    n, p = X.shape
    if start >= n:
        return None
    iu = np.triu_indices(p)
    carry = (X[:start, iu[0]] * X[:start, iu[1]]).sum(axis=0) / weight
    for begin in range(start, n, _SOLVE_BLOCK):
        block = X[begin : begin + _SOLVE_BLOCK]
        sums = carry + np.cumsum(block[:, iu[0]] * block[:, iu[1]], axis=0) / weight
        _, _, ok = _packed_solve_block(sums, np.zeros((sums.shape[0], p)), p, True)
        hits = np.flatnonzero(ok)
        if hits.size:
            return int(begin + hits[0])
        carry = sums[-1]
    return None


def weighted_ls_path(
    X,
    Y,
    *,
    forgetting: float = 1.0,
    weight: float = 1.0,
    init_end: int,
    covariance: str = "full",
):
    """Estimates of the RLS recursion (eqs. 3–4) at every row, computed without a loop.

    Parameters
    ----------
    X : array_like, shape (..., n_rows, p)
        Regressor rows (leading axes, e.g. Monte-Carlo trials, are batched).
    Y : array_like, shape (..., n_rows)
    forgetting : float in (0, 1]
        λ.
    weight : float > 0
        R, the (constant) noise variance assumed for each row.
    init_end : int
        M: rows ``0..M`` form the OLS initialisation (eq. 4).
    covariance : {"full", "diagonal"}
        Return ``P_k`` as (..., n_rows, p, p) or only its diagonal (..., n_rows, p).

    Returns
    -------
    theta : ndarray, shape (..., n_rows, p)
        θ̂_k, NaN for rows before M and where the weighted information is singular.
    P : ndarray
        The recursion's ``P_k`` (eq. 3): ``S_M⁻¹`` at row M and ``(λ S_k)⁻¹`` after it, with ``S_k``
        the weighted information matrix (module docstring).
    ok : ndarray of bool, shape (..., n_rows)

    Notes
    -----
    ``S_k = λ S_{k−1} + x_k x_kᵀ / R`` is a first-order IIR filter along the rows:
    ``lfilter([1], [1, −λ])`` on the (n, p, p) outer products, started at row M + 1 from the OLS
    information of rows 0..M (which the recursion weighs like row M + 1). With λ < 1 the sums stay
    bounded (≤ max‖x‖² / (1 − λ)); with λ = 1 they grow like k, and the Jacobi-scaled solve keeps
    the conditioning independent of that growth. Without excitation the sums decay like λ^k; rows
    whose information has underflowed or become singular are NaN (the streaming form holds its
    estimate).
    """
    X = np.asarray(X, dtype=float)
    Y = np.asarray(Y, dtype=float)
    lam = _check_forgetting(forgetting)
    r = check_positive(weight, "weight")
    n_rows, p = X.shape[-2], X.shape[-1]
    M = int(init_end)
    if not 0 <= M < n_rows:
        raise InputError(f"init_end must index a row in [0, {n_rows - 1}]; got {M}.")
    if covariance not in ("full", "diagonal"):
        raise InputError(f"covariance must be 'full' or 'diagonal'; got {covariance!r}.")
    iu = np.triu_indices(p)
    lead = X.shape[:-2]
    theta = np.empty(X.shape)
    P = np.empty(lead + ((n_rows, p, p) if covariance == "full" else (n_rows, p)))
    ok = np.zeros(lead + (n_rows,), dtype=bool)
    head = (slice(None),) * len(lead)  # index the row axis explicitly (P may be (..., n, p, p))
    theta[head + (slice(0, M),)] = np.nan
    P[head + (slice(0, M),)] = np.nan
    # Rows 0..M enter as one block: feed S_M / λ at row M, then x_k x_kᵀ / R. The filter output is
    # S_k for k > M (S_{M+1} = S_M + G_{M+1}: no λ on the OLS block, as eq. 3 started from eq. 4
    # does) and S_M / λ at M, so eq. 3's P is (λ · output)⁻¹ on every row and θ̂ = output⁻¹ ·
    # (the same filter on x y / R). Rows go in blocks (lfilter's state carried across), so every
    # temporary stays small and cache-resident; each block is fully vectorised.
    zi_S = np.zeros(lead + (1, iu[0].size))
    zi_b = np.zeros(lead + (1, p))
    for start in range(M, n_rows, _SOLVE_BLOCK):
        rows = slice(start, min(start + _SOLVE_BLOCK, n_rows))
        Xb, Yb = X[..., rows, :], Y[..., rows]
        G = Xb[..., :, iu[0]] * Xb[..., :, iu[1]] / r  # upper triangle of x xᵀ / R
        g = Xb * Yb[..., None] / r  # x y / R
        if start == M:
            X0, Y0 = X[..., : M + 1, :], Y[..., : M + 1]
            G[..., 0, :] = (X0[..., iu[0]] * X0[..., iu[1]]).sum(axis=-2) / (r * lam)
            g[..., 0, :] = (X0 * Y0[..., None]).sum(axis=-2) / (r * lam)
        S, zi_S = signal.lfilter([1.0], [1.0, -lam], G, axis=-2, zi=zi_S)  # S_k = λ S_{k−1} + G_k
        b, zi_b = signal.lfilter([1.0], [1.0, -lam], g, axis=-2, zi=zi_b)  # b_k = λ b_{k−1} + g_k
        th, S_inv, ok_b = _packed_solve_block(
            S.reshape(-1, iu[0].size), b.reshape(-1, p), p, covariance == "diagonal"
        )
        theta[head + (rows,)] = th.reshape(b.shape)
        P[head + (rows,)] = (S_inv / lam).reshape(b.shape[:-1] + S_inv.shape[1:])  # (λ S_k)⁻¹
        ok[head + (rows,)] = ok_b.reshape(b.shape[:-1])
    return theta, P, ok


# =============================================================================== streaming form
def rls_update(
    theta,
    P,
    x,
    y,
    forgetting: float = 1.0,
    weight: float = 1.0,
    *,
    covariance_limit: float = math.inf,
):
    """One step of the recursion (eq. 3) with a Joseph-form covariance update; pure function.

    Parameters
    ----------
    theta : array_like, shape (p,)
        θ̂_k.
    P : array_like, shape (p, p)
        P_k, symmetric positive definite.
    x : array_like, shape (p,)
        Regressor row x_{k+1}.
    y : float
        Observation y_{k+1}.
    forgetting : float in (0, 1]
        λ.
    weight : float > 0
        R.
    covariance_limit : float, default inf
        Cap on trace(P_{k+1}): when ``trace(P⁺) / λ`` would exceed it, the step forgets less,
        ``λ_eff = max(λ, trace(P⁺) / limit)`` (anti-wind-up for directions without excitation).

    Returns
    -------
    (theta, P) : new arrays; the inputs are not modified.

    Examples
    --------
    With P = I, R = 1 and x = (1, 0), the gain is 1/2 and P₁₁ halves:

    >>> th, P = rls_update(np.zeros(2), np.eye(2), np.array([1.0, 0.0]), 2.0)
    >>> th.tolist(), P.tolist()
    ([1.0, 0.0], [[0.5, 0.0], [0.0, 1.0]])
    """
    theta = np.asarray(theta, dtype=float)
    P = np.asarray(P, dtype=float)
    x = np.asarray(x, dtype=float)
    v = P @ x  # P_k x
    s = weight + x @ v  # R + xᵀ P_k x  (> 0)
    K = v / s  # K = P_k x (R + xᵀ P_k x)⁻¹
    theta_new = theta + K * (y - x @ theta)  # θ + K α,  α = y − xᵀ θ
    # Joseph form: P⁺ = (I − K xᵀ) P (I − K xᵀ)ᵀ + K R Kᵀ, expanded as P − K vᵀ − v Kᵀ + s K Kᵀ.
    # It equals the printed P − K xᵀ P for the optimal K but is symmetric term by term and PSD for
    # any K (errors in K enter at second order), where the printed form loses symmetry.
    Kv = np.outer(K, v)
    P_plus = P - Kv - Kv.T + s * np.outer(K, K)
    P_plus = 0.5 * (P_plus + P_plus.T)
    lam_eff = max(forgetting, np.trace(P_plus) / covariance_limit)
    return theta_new, P_plus / min(lam_eff, 1.0)


def _rls_rows_2(theta, P, X_rows, Y_rows, lam, r, limit, out_theta, out_P):
    """`_rls_rows` unrolled for p = 2 (the MSD): about 1 µs per row instead of 13."""
    t0, t1 = theta
    (a, b), (_, d) = P  # P = [[a, b], [b, d]]
    store_theta = out_theta.append
    store_P = out_P.append
    for (x0, x1), y in zip(X_rows, Y_rows, strict=True):
        v0 = a * x0 + b * x1  # v = P x
        v1 = b * x0 + d * x1
        s = r + x0 * v0 + x1 * v1  # s = R + xᵀ P x
        K0 = v0 / s  # K = P x / s
        K1 = v1 / s
        alpha = y - x0 * t0 - x1 * t1  # α = y − xᵀ θ
        t0 += K0 * alpha  # θ ← θ + K α
        t1 += K1 * alpha
        a = a - 2.0 * K0 * v0 + s * K0 * K0  # Joseph: P − K vᵀ − v Kᵀ + s K Kᵀ
        b = b - K0 * v1 - v0 * K1 + s * K0 * K1
        d = d - 2.0 * K1 * v1 + s * K1 * K1
        trace = a + d  # P ← P⁺ / λ_eff,  λ_eff = max(λ, trace(P⁺) / limit) ≤ 1
        lam_eff = lam if trace <= lam * limit else min(trace / limit, 1.0)
        if lam_eff < 1.0:
            a /= lam_eff
            b /= lam_eff
            d /= lam_eff
        store_theta((t0, t1))
        store_P((a, b, b, d))
    return [t0, t1], [[a, b], [b, d]]


def _rls_rows(theta, P, X_rows, Y_rows, lam, r, limit, out_theta, out_P):
    """The recursion over a block of rows in Python floats (p is small; numpy per row is slow).

    Same equations as `rls_update` (Joseph form, trace cap); writes θ and P after each row.
    """
    p = len(theta)
    if p == 2:
        return _rls_rows_2(theta, P, X_rows, Y_rows, lam, r, limit, out_theta, out_P)
    rng = range(p)
    for x, y in zip(X_rows, Y_rows, strict=True):
        v = [sum(P[i][j] * x[j] for j in rng) for i in rng]  # v = P x
        s = r + sum(x[i] * v[i] for i in rng)  # s = R + xᵀ P x
        K = [vi / s for vi in v]  # K = P x / s
        alpha = y - sum(x[i] * theta[i] for i in rng)  # α = y − xᵀ θ
        theta = [theta[i] + K[i] * alpha for i in rng]  # θ ← θ + K α
        # Joseph form P⁺ = P − K vᵀ − v Kᵀ + s K Kᵀ, filled upper triangle → exactly symmetric.
        Pn = [[0.0] * p for _ in rng]
        trace = 0.0
        for i in rng:
            Ki, vi, Pi = K[i], v[i], P[i]
            for j in range(i, p):
                val = Pi[j] - Ki * v[j] - vi * K[j] + s * Ki * K[j]
                Pn[i][j] = val
                Pn[j][i] = val
            trace += Pn[i][i]
        lam_eff = min(max(lam, trace / limit), 1.0)  # forget less when trace(P) passes the cap
        if lam_eff < 1.0:
            inv = 1.0 / lam_eff
            Pn = [[val * inv for val in row] for row in Pn]
        P = Pn
        out_theta.append(theta)
        out_P.append([val for row in P for val in row])
    return theta, P


class StreamingRLS:
    """The RLS recursion (eq. 3) fed one row or a chunk of rows at a time.

    Parameters
    ----------
    n_parameters : int
        p, the number of unknowns.
    forgetting : float in (0, 1], default 1
        λ.
    weight : float > 0, default 1
        R.
    init_samples : int, optional
        Rows for the OLS initialisation (eq. 4); default 10 p. If those rows do not determine θ
        (singular ``Σ x xᵀ``), rows are added until they do — the same rule as the batch form.
    covariance_limit : float, optional
        Cap on trace(P); default 1e8 × trace(P) at initialisation. It is inactive whenever the
        regressors keep some excitation, and then the streaming and batch forms agree.

    Attributes
    ----------
    theta : ndarray (p,) — current θ̂ (NaN before initialisation).
    covariance : ndarray (p, p) — current P.
    n_rows : int — rows received.
    init_end : int or None — index M of the last OLS row.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> X = rng.normal(size=(50, 2)); Y = X @ [2.0, -1.0]
    >>> est = StreamingRLS(2, init_samples=5)
    >>> th = est.update(X[:20], Y[:20]); th = est.update(X[20:], Y[20:])
    >>> np.allclose(est.theta, [2.0, -1.0])
    True
    """

    def __init__(
        self,
        n_parameters: int,
        *,
        forgetting: float = 1.0,
        weight: float = 1.0,
        init_samples: int | None = None,
        covariance_limit: float | None = None,
    ):
        self.n_parameters = int(n_parameters)
        if self.n_parameters < 1:
            raise InputError(f"n_parameters must be >= 1; got {n_parameters!r}.")
        self.forgetting = _check_forgetting(forgetting)
        self.weight = check_positive(weight, "weight")
        p = self.n_parameters
        self.init_samples = _check_init_samples(init_samples, p)
        self._limit_setting = covariance_limit
        if covariance_limit is not None:
            check_positive(covariance_limit, "covariance_limit")
        self._limit = math.inf
        # running sums of the OLS start (eq. 4) until it happens: Σ x xᵀ / R (upper triangle),
        # Σ x y / R and the number of rows
        self._sum_S = np.zeros(self.n_parameters * (self.n_parameters + 1) // 2)
        self._sum_B = np.zeros(self.n_parameters)
        self._n_accumulated = 0
        self._theta: list[float] | None = None
        self._P: list[list[float]] | None = None
        self.n_rows = 0
        self.init_end: int | None = None

    @property
    def covariance_limit(self) -> float:
        """The trace(P) cap in force (inf before initialisation)."""
        return self._limit

    @property
    def theta(self) -> np.ndarray:
        """θ̂ after the last row, shape (p,) (NaN before initialisation)."""
        if self._theta is None:
            return np.full(self.n_parameters, np.nan)
        return np.array(self._theta)

    @property
    def covariance(self) -> np.ndarray:
        """P after the last row, shape (p, p) (eq. 3's P; NaN before initialisation)."""
        if self._P is None:
            return np.full((self.n_parameters, self.n_parameters), np.nan)
        return np.array(self._P)

    @property
    def initialized(self) -> bool:
        """Whether the OLS start (eq. 4) has happened."""
        return self._theta is not None

    def update(self, x, y, *, return_covariance: bool = False):
        """Feed one row (x shape (p,), y scalar) or a chunk (x (n, p), y (n,)).

        Returns
        -------
        ndarray, shape (n, p)
            θ̂ after each row (NaN before initialisation); with ``return_covariance`` also the
            (n, p, p) P after each row.
        """
        p = self.n_parameters
        X = as_2d(x, "x") if np.ndim(x) != 1 else as_1d(x, "x")[None, :]
        Y = as_1d(y, "y")
        if X.shape[1] != p or X.shape[0] != Y.size:
            raise ShapeError(
                f"x must have shape (n, {p}) and y shape (n,); got x {X.shape} and y {Y.shape}."
            )
        check_finite(X, "x")
        check_finite(Y[:, None], "y")
        n = X.shape[0]
        out_theta = np.full((n, p), np.nan)
        out_P = np.full((n, p, p), np.nan)
        start = 0
        if self._theta is None:
            start = self._try_initialise(X, Y, out_theta, out_P)
        if self._theta is not None and start < n:
            th_rows: list = []
            P_rows: list = []
            self._theta, self._P = _rls_rows(
                self._theta,
                self._P,
                X[start:].tolist(),
                Y[start:].tolist(),
                self.forgetting,
                self.weight,
                self._limit,
                th_rows,
                P_rows,
            )
            out_theta[start:] = np.array(th_rows)
            out_P[start:] = np.array(P_rows).reshape(-1, p, p)
        self.n_rows += n
        return (out_theta, out_P) if return_covariance else out_theta

    def _try_initialise(self, X, Y, out_theta, out_P) -> int:
        """Accumulate rows until the OLS of eq. 4 is defined; return the first row left to recurse.

        Only the running sums ``S = Σ x xᵀ / R`` (upper triangle) and ``B = Σ x y / R`` are kept
        (O(p²) memory), and a chunk's candidate starts are tested together: the cumulative sums of
        the chunk's rows give ``S`` at every row, one vectorised equilibrated solve tests them
        all (O(p³) per row, independent of how many rows came before — the old form re-solved the
        whole buffer at every row, O(n²) on input that never excites the system).
        """
        p = self.n_parameters
        iu = np.triu_indices(p)
        G = X[:, iu[0]] * X[:, iu[1]] / self.weight  # (n, p(p+1)/2) rows of Σ x xᵀ / R
        g = X * Y[:, None] / self.weight
        S_rows = self._sum_S + np.cumsum(G, axis=0)
        B_rows = self._sum_B + np.cumsum(g, axis=0)
        count = self._n_accumulated + np.arange(1, X.shape[0] + 1)
        candidates = np.flatnonzero(count >= self.init_samples)
        if candidates.size:
            theta, S_inv, ok = _packed_solve(S_rows[candidates], B_rows[candidates], p)
            hits = np.flatnonzero(ok)
            if hits.size:
                j = int(hits[0])
                k = int(candidates[j])
                th, Si = theta[j], S_inv[j]
                self._theta = th.tolist()  # θ_M = P_M B_M            (eq. 4)
                self._P = (0.5 * (Si + Si.T)).tolist()  # P_M = (X_Mᵀ R⁻¹ X_M)⁻¹
                trace0 = float(np.trace(Si))
                self._limit = (
                    DEFAULT_COVARIANCE_LIMIT_FACTOR * trace0
                    if self._limit_setting is None
                    else float(self._limit_setting)
                )
                self.init_end = self.n_rows + k
                out_theta[k] = th
                out_P[k] = self._P
                self._sum_S = np.zeros(iu[0].size)
                self._sum_B = np.zeros(p)
                self._n_accumulated = 0
                return k + 1
        self._sum_S = S_rows[-1].copy()
        self._sum_B = B_rows[-1].copy()
        self._n_accumulated = int(count[-1])
        return X.shape[0]


def _check_forgetting(forgetting) -> float:
    """λ as a float in (0, 1], else `InputError` saying how to choose it."""
    try:
        return check_in_range(forgetting, "forgetting", 0.0, 1.0, low_open=True)
    except InputError:
        raise InputError(
            f"{arg('forgetting')} must lie in (0, 1] (λ); got {forgetting!r}. Use 0.95–1: "
            "1 keeps all data (constant parameters), λ < 1 forgets with a memory of about "
            "1 / (1 − λ) samples (0.998: 500 samples) to track changing parameters."
        ) from None


def _check_init_samples(init_samples, p: int) -> int:
    if init_samples is None:
        return 10 * p
    return check_int(
        init_samples,
        "init_samples",
        minimum=p,
        fix=f"It must be >= the number of unknowns ({p}) so the OLS start (eq. 4) is defined.",
    )


# =============================================================================== estimator
@dataclass(frozen=True, eq=False)
class RecursiveResult(LinearODEResultMixin, ResultMixin):
    """Result of `RecursiveLeastSquares.fit`.

    Attributes
    ----------
    t : ndarray (n_samples,) [s] — the recording's time.
    estimates : ndarray (n_samples, p) — θ̂ at every sample (NaN before initialisation).
    covariance : ndarray (n_samples, p, p) or (n_samples, p) — eq. 3's P at every sample (in units
        of R; multiply by the noise variance / R for a covariance), or its diagonal.
    names : tuple of str — the unknown of each column.
    parameters : dict — final estimates of the fitted coefficients.
    derived : dict — for the MSD ``natural_frequency`` [rad/s] and ``damping_ratio`` (and m, c,
        k with a force input: ``mass``, ``damping``, ``stiffness``); for a model whose
        coefficients are expressions of physical parameters (``a = ["k/m", "c/m"]``), those
        parameters where the coefficients determine them (see ``physical``).
    derived_stderr : dict or None — standard errors of ``derived`` by the delta method from
        ``final_covariance``; None whenever ``stderr`` is None.
    final_covariance : ndarray (p, p) or None — covariance of the final θ̂ (SI, ordered like
        ``names``, diagonal ``stderr``²; not ``covariance``, which is P at every sample); None
        whenever ``stderr`` is None.
    physical : dict or None — for a model in physical terms, `PhysicalParameters.to_dict` of the
        final estimate (values, stderr, identifiable, unidentifiable, combinations, message; the
        message also ends ``message`` when physical parameters are not identifiable).
    stderr : dict or None — standard errors of the final θ̂: white noise on the measured output
        propagated exactly through the state-variable filter (`_output_noise_covariance`;
        Newey–West HAC for the differential pre-filter); ``metadata["stderr_method"]`` names it
        and ``metadata["stderr_white_rows"]`` keeps the white-row formula. None with
        ``stderr_reason`` where they cannot be given.
    natural_frequency, damping_ratio : ndarray (n_samples,) or None — MSD only.
    valid_fraction : float — share of samples with a defined estimate.
    forgetting, weight, prefilter_cutoff [Hz], discarded (samples), init_end (sample index).
    """

    t: np.ndarray
    estimates: np.ndarray
    covariance: np.ndarray
    names: tuple[str, ...]
    parameters: dict[str, float]
    stderr: dict[str, float]
    natural_frequency: np.ndarray | None
    damping_ratio: np.ndarray | None
    valid_fraction: float
    forgetting: float
    weight: float
    prefilter: str
    prefilter_cutoff: float
    discarded: int
    init_end: int
    success: bool
    message: str
    metadata: dict[str, Any] = field(default_factory=dict)
    derived: dict[str, float] = field(default_factory=dict)
    stderr_reason: str | None = None
    derived_stderr: dict[str, float] | None = None
    final_covariance: np.ndarray | None = None
    physical: dict | None = None
    units: dict[str, str] = field(default_factory=dict)
    known: dict[str, float] = field(default_factory=dict)
    settings: dict[str, Any] = field(default_factory=dict)
    model_name: str = ""
    fit_percent: float = float("nan")
    model: Any = field(default=None, repr=False, compare=False)

    method = "rls"
    _history_fields = ("t", "estimates", "covariance", "natural_frequency", "damping_ratio")
    _private_fields = ("model",)

    @property
    def valid(self) -> np.ndarray:
        """Samples with a defined estimate, shape (n_samples,) (as the algebraic result's)."""
        return np.all(np.isfinite(self.estimates), axis=1)

    def series(self, name: str) -> np.ndarray:
        """Per-sample estimate of one unknown, or (MSD) ``natural_frequency``/``damping_ratio``."""
        if name in self.names:
            return self.estimates[:, self.names.index(name)].copy()
        if name == "natural_frequency" and self.natural_frequency is not None:
            return self.natural_frequency.copy()
        if name == "damping_ratio" and self.damping_ratio is not None:
            return self.damping_ratio.copy()
        raise InputError(
            f"no per-sample series {name!r}; available: {list(self.names)}"
            + ("" if self.natural_frequency is None else " and natural_frequency, damping_ratio")
            + "."
        )

    def plot(self, truth: Mapping[str, float] | None = None, ax=None):
        """θ̂ (and ω0 for the MSD) against time; see `physid.report.recursive`.

        Parameters
        ----------
        truth : mapping, optional
            True values drawn as dashed lines.
        ax : matplotlib Axes, optional
            Draw the last panel (ω0 for the MSD) there.

        Returns
        -------
        matplotlib.figure.Figure
        """
        from ..report.recursive import plot_recursive

        return plot_recursive(self, truth=truth, ax=ax)


#: Below this output-error fit [%] on the fitted record the model "explains nothing" (pure noise
#: gives about 0 %, white output noise at 0 dB SNR 29 %, at 10 dB 68 %).
MIN_FIT_PERCENT = 10.0


def _training_fit(spec, values, recording, in_name, out_name) -> float:
    """Output-error fit [%] of the identified model on the fitted record (NaN if not defined)."""
    from ._linear import simulate_prediction

    y = np.asarray(recording[out_name], dtype=float)
    y_hat, _ = simulate_prediction(spec, values, recording.t, recording[in_name], y)
    spread = float(np.linalg.norm(y - y.mean()))
    if not np.all(np.isfinite(y_hat)) or spread == 0.0:
        return float("nan")
    return 100.0 * (1.0 - float(np.linalg.norm(y - y_hat)) / spread)


def _jsonable_settings(params: Mapping[str, Any]) -> dict[str, Any]:
    out = {}
    for k, v in params.items():
        if k == "model":
            v = getattr(v, "name", v) if not isinstance(v, str) else v
        elif isinstance(v, (tuple, list)):
            v = list(v)
        elif isinstance(v, Mapping):
            v = dict(v)
        out[k] = v
    return out


class RecursiveLeastSquares(EstimatorMixin):
    """Recursive least squares with forgetting for linear ODE models (paper section 3).

    Parameters
    ----------
    model : "msd" or LinearODEModel
    forgetting : float in (0, 1], default 1
        λ; 1 weighs all rows equally.
    weight : float > 0, default 1
        R, the noise variance assumed per row (scales P, not θ̂).
    prefilter : {"butterworth", "differential"}
        Causal Butterworth state-variable filter (default) or the project's non-causal FIR
        differential filters (order ≤ 2, batch only).
    prefilter_cutoff : float, optional [Hz]
        Default `default_prefilter_cutoff` (10× the model's nominal frequency, ≤ f_s/10).
    init_samples : int, optional
        Rows of the OLS start (eq. 4), default 10 p.
    unknown : sequence of str, optional
        Coefficients to estimate (default the model's ``unknown`` less the names in ``known``;
        MSD: theta1, theta2).
    known : mapping, optional
        Values of the other coefficients (default nominal; MSD: b0 = 1).
    prefilter_order : int, optional
        Butterworth order, ≥ n + 1 (default n + 1).
    covariance : {"full", "diagonal"}
        Store P per sample as (n, p, p) (8 p² bytes per sample: 32 MB for 1e6 samples and p = 2)
        or only its diagonal.
    transient_samples : int, optional
        Samples dropped at the start before the first row. Default: the SVF start-up rule
        (`svf_transient_samples`, 240 samples at 18.4 Hz and 1 kHz). Pass 0 when the record starts
        at rest (u, y and their derivatives zero), where the filter's zero state is already right.
    bias_compensation : bool, default False
        Remove the errors-in-variables bias that white noise on the measured output causes
        (`_bias_compensated_ls`) from the *final* estimate (the per-sample history is unchanged).
        Without it, where that bias exceeds half a standard error (e.g. the paper's MSD at 30 dB)
        the result gives no standard errors and says why.

    Examples
    --------
    >>> from scipy import signal
    >>> from physid import Recording
    >>> t = np.arange(4000) * 1e-3
    >>> u = np.sin(10 * t)
    >>> x = signal.lsim(([1.0], [1.0, 2.0, 100.0]), u, t)[1]
    >>> est = RecursiveLeastSquares("msd").fit(Recording(t, np.c_[u, x], ["u", "x"]))
    >>> round(est.result_.derived["natural_frequency"], 2)
    10.0
    """

    def __init__(
        self,
        model="msd",
        *,
        forgetting: float = 1.0,
        weight: float = 1.0,
        prefilter: str = "butterworth",
        prefilter_cutoff: float | None = None,
        init_samples: int | None = None,
        unknown: Sequence[str] | None = None,
        known: Mapping[str, float] | None = None,
        prefilter_order: int | None = None,
        covariance: str = "full",
        transient_samples: int | None = None,
        bias_compensation: bool = False,
    ):
        self.model = model
        self.forgetting = forgetting
        self.weight = weight
        self.prefilter = prefilter
        self.prefilter_cutoff = prefilter_cutoff
        self.init_samples = init_samples
        self.unknown = unknown
        self.known = known
        self.prefilter_order = prefilter_order
        self.covariance = covariance
        self.transient_samples = transient_samples
        self.bias_compensation = bias_compensation

    def fit(self, recording) -> RecursiveLeastSquares:
        """Estimate the unknowns at every sample of ``recording``.

        The channels are the model's ``input_name`` and ``output_name`` (the MSD: ``u`` and ``x``;
        an output ``x`` or ``y`` is accepted as a fallback, as by the algebraic estimator).
        """
        lam = _check_forgetting(self.forgetting)
        r = check_positive(self.weight, "weight")
        if self.covariance not in ("full", "diagonal"):
            raise InputError(f"covariance must be 'full' or 'diagonal'; got {self.covariance!r}.")
        spec = as_linear_ode_model(self.model)
        names = getattr(recording, "names", None)
        if names is None:
            raise InputError(f"fit expects a Recording; got {type(recording).__name__}.")
        in_name, out_name = spec.recording_channels(names)
        spec.check_units(recording)  # a force [N] for the normalised msd is an error
        check_distinct_channels(in_name, out_name)
        check_known_finite(self.known)
        check_distinct_signals(recording[in_name], recording[out_name])
        dt = recording.dt
        reg = build_regression(
            spec,
            recording[out_name],
            recording[in_name],
            dt,
            unknown=self.unknown,
            known=self.known,
            prefilter=self.prefilter,
            prefilter_cutoff=self.prefilter_cutoff,
            prefilter_order=self.prefilter_order,
            discard=self.transient_samples,
        )
        p = len(reg.names)
        init = _check_init_samples(self.init_samples, p)
        n_rows = reg.X.shape[0]
        if n_rows < max(init, p):
            raise EstimationError(
                f"the regression has {n_rows} rows after the {reg.discarded}-sample pre-filter "
                f"transient but needs at least {max(init, p)} ({arg('init_samples')}, >= {p} "
                f"unknowns). Use a longer record, fewer {arg('init_samples')} (>= {p}) or a higher "
                f"{arg('prefilter_cutoff')} [Hz] (a shorter transient)."
            )
        _check_excitation(reg.X, reg.names, reg.Y, _nominal_of(spec, reg.names))
        M = _first_invertible_row(reg.X, r, init)
        if M is None:  # pragma: no cover - _check_excitation catches this first
            raise IdentifiabilityError("the regressors never determine all unknowns.")
        theta_rows, P_rows, ok_rows = weighted_ls_path(
            reg.X, reg.Y, forgetting=lam, weight=r, init_end=M, covariance=self.covariance
        )
        n = recording.n_samples
        estimates = np.full((n, p), np.nan)
        estimates[reg.sample_index] = _offset_to_value(spec, reg.names, theta_rows)
        cov_shape = (n, p, p) if self.covariance == "full" else (n, p)
        cov = np.full(cov_shape, np.nan)
        cov[reg.sample_index] = P_rows
        valid_rows = np.flatnonzero(ok_rows)
        last = valid_rows[-1]
        theta_final = theta_rows[last]
        sigma2, white_cov = _final_covariance(reg.X, reg.Y, theta_final, M, last, lam)
        values_all = dict(spec.parameters)
        values_all.update(self.known or {})
        order = (
            max(spec.order, spec.input_order) + 1
            if self.prefilter_order is None
            else int(self.prefilter_order)
        )
        half = max(max(spec.order, spec.input_order) + 1, int(round(2.0 / (reg.cutoff * dt))))
        bandwidth = _hac_bandwidth(self.prefilter, reg.cutoff, dt, order, half)
        eiv_bias = None
        if self.prefilter == "butterworth":
            values_known = {k: float(v) for k, v in values_all.items()}
            theta_bc, S_bc = _bias_compensated_ls(
                reg, theta_final, spec, values_known, M, last, lam, dt, order
            )
            if self.bias_compensation:
                theta_final = theta_bc
                cov_final = _output_noise_covariance(
                    reg, theta_final, spec, values_known, M, last, lam, dt, order, S=S_bc
                )
                stderr_method = "bias-compensated; white output noise through the SVF"
            else:
                eiv_bias = theta_final - theta_bc  # estimated errors-in-variables bias
                cov_final = _output_noise_covariance(
                    reg, theta_final, spec, values_known, M, last, lam, dt, order
                )
                stderr_method = "white output noise through the state-variable filter"
        else:
            cov_final = _hac_covariance(reg.X, reg.Y, theta_final, M, last, lam, bandwidth)
            stderr_method = f"Newey-West HAC, {bandwidth} lags"
        stderr = {nm: float(np.sqrt(max(cov_final[i, i], 0.0))) for i, nm in enumerate(reg.names)}
        stderr_reason = None
        if eiv_bias is not None:
            # an interval is honest only if the bias is small against its width
            biased = [
                f"{nm} (bias ≈ {eiv_bias[i]:.3g}, se {stderr[nm]:.3g})"
                for i, nm in enumerate(reg.names)
                if abs(eiv_bias[i]) > MAX_BIAS_TO_STDERR * stderr[nm]
            ]
            if biased:
                stderr, stderr_reason = (
                    None,
                    (
                        "the output noise biases the estimate by more than "
                        f"{MAX_BIAS_TO_STDERR:g} standard error(s) (errors in the variables): "
                        + ", ".join(biased)
                        + "; a 95 % interval would not cover. Use bias_compensation=True "
                        "for an unbiased estimate with honest standard errors."
                    ),
                )
        theta_si = _offset_to_value(spec, reg.names, theta_final)
        if stderr is not None and len(theta_si) and not np.array_equal(theta_si, theta_final):
            k = [i for i in range(len(reg.names)) if theta_si[i] != theta_final[i]][0]
            a0 = theta_final[k] / theta_si[k] if theta_si[k] != 0 else np.nan
            stderr[reg.names[k]] = float(stderr[reg.names[k]] / abs(a0))
            cov_final = np.array(cov_final, dtype=float, copy=True)
            cov_final[k, :] /= a0  # δ = a0·o: o's row and column scale by 1/a0 (signed)
            cov_final[:, k] /= a0
        theta_final = theta_si
        fitted = {nm: float(theta_final[i]) for i, nm in enumerate(reg.names)}
        values = dict(spec.parameters)
        values.update(self.known or {})
        omega0 = zeta = None
        if spec.is_msd:
            th1 = (
                estimates[:, reg.names.index("theta1")]
                if "theta1" in reg.names
                else np.where(np.isnan(estimates[:, 0]), np.nan, values["theta1"])
            )
            th2 = (
                estimates[:, reg.names.index("theta2")]
                if "theta2" in reg.names
                else np.where(np.isnan(estimates[:, 0]), np.nan, values["theta2"])
            )
            omega0, zeta = natural_frequency_damping(th1, th2)
        known_values = {k: float(v) for k, v in values.items() if k not in reg.names}
        known_values = {k: v for k, v in known_values.items() if k in spec.coefficient_names}
        derived, _, _, _ = derived_with_stderr(spec, {**known_values, **fitted}, reg.names)
        valid_fraction = float(np.mean(np.all(np.isfinite(estimates), axis=1)))
        finite = all(np.isfinite(v) for v in [*fitted.values(), *derived.values()])
        lost = int(np.count_nonzero(~ok_rows[M:]))
        fit = float("nan")
        if finite:
            fit = _training_fit(spec, {**known_values, **fitted}, recording, in_name, out_name)
        if not finite:
            success, message = (
                False,
                (
                    "the final estimate is not finite (for the MSD: θ2 ≤ 0 gives no natural "
                    "frequency); check the excitation and the sign conventions of u and x."
                ),
            )
        elif np.isfinite(fit) and fit < MIN_FIT_PERCENT:
            success, message = (
                False,
                (
                    f"the identified model explains almost nothing of the output (fit {fit:.1f} % "
                    f"< {MIN_FIT_PERCENT:g} %, 100·(1 − ‖y − ŷ‖/‖y − ȳ‖) on the fitted record): "
                    "the data look like noise, or the input does not drive the output. Check the "
                    "channels and the excitation."
                ),
            )
        elif lost:
            success, message = (
                True,
                (
                    f"{lost} sample(s) after the start had no usable information (λ < 1 without "
                    "excitation); their estimates are NaN. Raise forgetting or keep exciting the "
                    "system."
                ),
            )
        else:
            success, message = True, ""
        if not success:
            stderr, stderr_reason = None, "no trustworthy estimate"
        cov_final = None if stderr is None else np.array(cov_final, dtype=float)
        derived, derived_stderr, derived_units, physical = derived_with_stderr(
            spec, {**known_values, **fitted}, reg.names, cov_final
        )
        if success and physical_statement(physical):
            message = f"{message} {physical_statement(physical)}".strip()
        units = {**coefficient_units(spec, reg.names), **derived_units}
        self.result_ = RecursiveResult(
            t=np.array(recording.t),
            estimates=estimates,
            covariance=cov,
            names=reg.names,
            parameters=ParameterDict(fitted, derived),
            stderr=stderr,
            natural_frequency=omega0,
            damping_ratio=zeta,
            valid_fraction=valid_fraction,
            forgetting=lam,
            weight=r,
            prefilter=self.prefilter,
            prefilter_cutoff=reg.cutoff,
            discarded=reg.discarded,
            init_end=int(reg.sample_index[M]),
            success=success,
            message=message,
            metadata={
                "rows": int(n_rows),
                "residual_variance": sigma2,
                # the white-row sandwich (the stderr before the output-noise model; kept for
                # comparison: it overstates the spread 6-10x on SVF-filtered data)
                "stderr_white_rows": {
                    nm: float(np.sqrt(max(white_cov[i, i], 0.0))) for i, nm in enumerate(reg.names)
                },
                "stderr_method": stderr_method,
            },
            derived=derived,
            stderr_reason=stderr_reason,
            derived_stderr=derived_stderr,
            final_covariance=cov_final,
            physical=physical,
            units=units,
            known=known_values,
            settings={**_jsonable_settings(self.get_params()), "dt": float(dt)},
            model_name=spec.name,
            fit_percent=fit,
            model=spec,
        )
        self.regression_ = reg
        return self

    # parity with the algebraic estimator's result attributes, for the CLI
    @property
    def valid_fraction(self) -> float:
        return self.result_.valid_fraction

    def stream(self, dt: float, *, t_start: float = 0.0) -> StreamingRecursiveEstimator:
        """An online form of `fit` fed raw ``(u, y)`` chunks: see `StreamingRecursiveEstimator`.

        Parameters
        ----------
        dt : float [s]
            Sample period of the stream.
        t_start : float [s], default 0
            Time of the first sample.
        """
        return StreamingRecursiveEstimator(self, dt, t_start=t_start)


@dataclass(frozen=True)
class StreamingRecursiveUpdate:
    """Estimates for the samples of one chunk.

    Attributes
    ----------
    t : ndarray (n_new,) [s]
    estimates : ndarray (n_new, p) — θ̂ after each sample (NaN during the pre-filter transient and
        before the OLS start), in SI units.
    valid : ndarray of bool (n_new,)
    names : tuple of str — the unknown of each column.
    natural_frequency, damping_ratio : ndarray (n_new,) or None — MSD only ([rad/s], 1).
    """

    t: np.ndarray
    estimates: np.ndarray
    valid: np.ndarray
    names: tuple[str, ...]
    natural_frequency: np.ndarray | None = None
    damping_ratio: np.ndarray | None = None


class StreamingRecursiveEstimator:
    """`RecursiveLeastSquares` run online on raw ``(u, y)`` chunks, with constant memory.

    A `StreamingStateVariableFilter` (its state carried across chunks) builds the regression rows
    of each new sample, the rows inside the pre-filter start-up transient are dropped exactly as
    in the batch `RecursiveLeastSquares.fit` (``transient_samples``, default
    `svf_transient_samples`), and the rest feed a `StreamingRLS` (OLS start, then eq. 3 in Joseph
    form). For any chunking the estimates equal the batch ``fit`` of the whole record (tests:
    chunks of 1, 7 and 1000 samples, ≤ 1e-9 relative). Memory: the filter state and p × p numbers
    (plus the ``init_samples`` rows of the OLS start until it happens).

    Only the causal ``prefilter="butterworth"`` streams (the differential filters are
    non-causal). The batch form's whole-record excitation check cannot run online: a stream
    without excitation keeps NaN (before the start) or holds its estimate.

    Parameters
    ----------
    estimator : RecursiveLeastSquares
        Settings (model, forgetting, weight, prefilter cut-off and order, init_samples, unknown,
        known, transient_samples).
    dt : float [s]
        Sample period.
    t_start : float [s], default 0

    Examples
    --------
    >>> from scipy import signal
    >>> t = np.arange(3000) * 1e-3
    >>> u = np.sin(10 * t)
    >>> x = signal.lsim(([1.0], [1.0, 2.0, 100.0]), u, t)[1]
    >>> online = RecursiveLeastSquares("msd").stream(dt=1e-3)
    >>> for i in range(0, t.size, 500):
    ...     upd = online.update(u[i:i + 500], x[i:i + 500])
    >>> round(float(upd.natural_frequency[-1]), 2)
    10.0
    """

    def __init__(self, estimator: RecursiveLeastSquares, dt: float, *, t_start: float = 0.0):
        est = estimator
        self.dt = check_positive(dt, "dt")
        self.t_start = float(t_start)
        if est.prefilter != "butterworth":
            raise InputError(
                f"only prefilter='butterworth' (causal) can stream; got {est.prefilter!r}. The "
                "differential FIR filters need future samples: use fit() on the whole record."
            )
        spec = as_linear_ode_model(est.model)
        self._spec = spec
        self._unknown, self._values = _split_with_offset(spec, est.unknown, est.known)
        highest, cutoff, order, discard = _prefilter_settings(
            spec, self.dt, est.prefilter_cutoff, est.prefilter_order, est.transient_samples
        )
        if discard is None:
            discard = svf_transient_samples(cutoff, self.dt, order)
        self.discarded = discard
        self.prefilter_cutoff = float(cutoff)
        self._highest = highest
        self._svf = StreamingStateVariableFilter(
            self.dt, cutoff, highest, n_channels=2, filter_order=order
        )
        self._rls = StreamingRLS(
            len(self._unknown),
            forgetting=est.forgetting,
            weight=est.weight,
            init_samples=est.init_samples,
        )
        self.n_samples = 0

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the estimated coefficients (columns of the estimates)."""
        return self._unknown

    @property
    def theta(self) -> np.ndarray:
        """θ̂ after the last sample, shape (p,)."""
        return self._rls.theta

    @property
    def covariance(self) -> np.ndarray:
        """eq. 3's P after the last sample, shape (p, p)."""
        return self._rls.covariance

    def update(self, u, y) -> StreamingRecursiveUpdate:
        """Feed the next samples ``u``, ``y`` (shape (n_new,)); return their estimates."""
        u, y = check_signal_pair(u, y)
        y = y - self._spec.known_output_offset()  # as build_regression: a held offset removed
        n_new = u.size
        p = len(self._unknown)
        index = np.arange(self.n_samples, self.n_samples + n_new)
        estimates = np.full((n_new, p), np.nan)
        if n_new:
            derivs = self._svf.update(np.column_stack([y, u]))  # (n_new, 2, highest + 1)
            keep = index >= self.discarded  # rows after the start-up transient (as in fit)
            if keep.any():
                X, Y = _regression_rows(
                    self._spec,
                    self._unknown,
                    self._values,
                    derivs[keep, 0, :],
                    derivs[keep, 1, :],
                )
                estimates[keep] = _offset_to_value(
                    self._spec, self._unknown, self._rls.update(X, Y)
                )
        self.n_samples += n_new
        valid = np.all(np.isfinite(estimates), axis=1)
        omega0 = zeta = None
        if self._spec.is_msd:
            th = {nm: estimates[:, i] for i, nm in enumerate(self._unknown)}
            nan = np.where(valid, 0.0, np.nan)
            th1 = th.get("theta1", self._values["theta1"] + nan)
            th2 = th.get("theta2", self._values["theta2"] + nan)
            omega0, zeta = natural_frequency_damping(np.asarray(th1), np.asarray(th2))
            omega0, zeta = np.atleast_1d(omega0), np.atleast_1d(zeta)
        return StreamingRecursiveUpdate(
            t=self.t_start + self.dt * index,
            estimates=estimates,
            valid=valid,
            names=self._unknown,
            natural_frequency=omega0,
            damping_ratio=zeta,
        )


def _final_covariance(X, Y, theta, M: int, last: int, lam: float):
    """Nominal covariance of θ̂ at row ``last``: the weighted-LS sandwich with white row noise.

    Weights as in the recursion (rows ≤ M: λ^{last−M−1}, later rows λ^{last−i}; 1 at row M). With
    ``S = Σ w x xᵀ``, ``A = Σ w² x xᵀ``: ``Cov = σ̂² S⁻¹ A S⁻¹``, ``σ̂² = Σ w e² / Σ w · n/(n − p)``
    with ``n = (Σ w)² / Σ w²`` the effective number of rows. For λ = 1 this is the textbook
    ``σ̂² (XᵀX)⁻¹`` (R cancels). Noise in the regressors (errors in variables) is not included.
    """
    i = np.arange(last + 1)
    age = np.where(i <= M, max(last - M - 1, 0), last - i).astype(float)
    with np.errstate(under="ignore"):
        w = lam**age
    Xw = X[: last + 1]
    e = Y[: last + 1] - Xw @ theta
    S = (Xw * w[:, None]).T @ Xw
    A = (Xw * (w**2)[:, None]).T @ Xw
    n_eff = w.sum() ** 2 / (w**2).sum()
    p = X.shape[1]
    sigma2 = float((w * e**2).sum() / w.sum() * n_eff / max(n_eff - p, 1.0))
    left = np.linalg.solve(S, A)  # S⁻¹ A
    cov = sigma2 * np.linalg.solve(S, left.T).T  # σ̂² S⁻¹ A S⁻¹ (S, A symmetric)
    return sigma2, 0.5 * (cov + cov.T)


def _hac_covariance(X, Y, theta, M: int, last: int, lam: float, bandwidth: int):
    """Covariance of θ̂ at row ``last`` valid under the pre-filter's coloured residual (HAC).

    The final estimate is the weighted least squares ``θ̂ = S⁻¹ Σ w_i x_i y_i`` (weights as in
    `_final_covariance`), so ``θ̂ − θ = S⁻¹ Σ_i g_i`` with the scores ``g_i = w_i x_i e_i``. The
    state-variable filter colours the noise in ``e_i`` (and in ``x_i``) over its impulse response,
    so neighbouring scores are correlated and the white-row formula is wrong (on the paper's MSD
    it overstates the spread 6-10x: the residual's power lies above the regressors' band). The
    Newey–West estimator (Newey & West 1987) sums the score autocovariances up to ``bandwidth``
    lags with Bartlett weights,

        Ω = Γ₀ + Σ_{k=1}^{K} (1 − k/(K + 1)) (Γ_k + Γ_kᵀ),   Γ_k = Σ_i g_{i+k} g_iᵀ,

    and ``Cov(θ̂) = S⁻¹ Ω S⁻¹``. ``K`` covers the filter's memory (`_hac_bandwidth`). Noise in the
    regressors biases θ̂ at low SNR (errors in variables); that bias is not in the interval (see
    docs/recursive.md for the measured coverage).
    """
    i = np.arange(last + 1)
    age = np.where(i <= M, max(last - M - 1, 0), last - i).astype(float)
    with np.errstate(under="ignore"):
        w = lam**age
    Xw = X[: last + 1]
    e = Y[: last + 1] - Xw @ theta
    g = Xw * (w * e)[:, None]  # (n, p) scores
    S = (Xw * w[:, None]).T @ Xw
    n = g.shape[0]
    K = int(min(max(bandwidth, 1), n - 1))
    omega = g.T @ g
    for k in range(1, K + 1):  # K ≤ a few hundred lags; each lag one (p × n)(n × p) product
        gamma = g[k:].T @ g[:-k]
        omega += (1.0 - k / (K + 1.0)) * (gamma + gamma.T)
    p = X.shape[1]
    omega *= n / max(n - p, 1)
    left = np.linalg.solve(S, omega)
    cov = np.linalg.solve(S, left.T).T  # S⁻¹ Ω S⁻¹
    return 0.5 * (cov + cov.T)


def _svf_impulse(reg, spec, dt: float, order: int) -> np.ndarray:
    """Impulse responses of the SVF states ``w, ẇ, …`` (n_imp, highest + 1), to e^-40."""
    sigma_min = 2 * np.pi * reg.cutoff * np.sin(np.pi / (2 * order))
    n_imp = int(min(math.ceil(40.0 / (sigma_min * dt)), 200_000))
    impulse = np.zeros(n_imp)
    impulse[0] = 1.0
    return state_variable_filter(impulse, dt, reg.cutoff, max(spec.order, spec.input_order), order)


def _bias_compensated_ls(
    reg, theta, spec, values, M: int, last: int, lam: float, dt: float, order: int
):
    """Final θ̂ with the errors-in-variables bias of white output noise removed (BCLS).

    Output noise ``ε`` (variance σ²) reaches the columns of the unknown ``a_j`` through the SVF
    state ``h_j`` and ``Y`` through ``−η``, ``η = h_n + Σ_{known a_i} a_i h_i``; so
    ``E[Σ w x xᵀ] = S₀ + σ² Σw H`` and ``E[Σ w x Y] = b₀ + σ² Σw d`` with ``H_jk = ⟨h_j, h_k⟩`` and
    ``d_j = −⟨h_j, η⟩`` (input columns carry no noise). Solving ``(S − σ² Σw H) θ = b − σ² Σw d``,
    with σ² re-estimated from the residual of the compensated fit, removes the bias (Zheng's
    bias-eliminated least squares; Söderström 2007, sec. 4). Returns (θ, S − σ² Σw H).
    """
    i = np.arange(last + 1)
    age = np.where(i <= M, max(last - M - 1, 0), last - i).astype(float)
    with np.errstate(under="ignore"):
        w = lam**age
    X = reg.X[: last + 1]
    Yv = reg.Y[: last + 1]
    S = (X * w[:, None]).T @ X
    b = (X * w[:, None]).T @ Yv
    h = _svf_impulse(reg, spec, dt, order)
    n_ord = spec.order
    a_names = list(spec.a_names)
    cols = [a_names.index(nm) if nm in a_names else None for nm in reg.names]
    eta = h[:, n_ord].copy()
    for j, name in enumerate(a_names):
        if name not in reg.names:
            eta += values[name] * h[:, j]
    p = len(reg.names)
    H = np.zeros((p, p))
    d = np.zeros(p)
    for q, cq in enumerate(cols):
        if cq is None:
            continue
        d[q] = -float(h[:, cq] @ eta)
        for r, cr in enumerate(cols):
            if cr is not None:
                H[q, r] = float(h[:, cq] @ h[:, cr])
    sw = float(w.sum())
    th = np.asarray(theta, dtype=float)
    Sc = S
    for _ in range(20):
        a = {**values, **dict(zip(reg.names, th, strict=True))}
        kappa = h[:, n_ord].copy()
        for j, name in enumerate(a_names):
            kappa += a[name] * h[:, j]
        e = Yv - X @ th
        sigma2 = float((w * e**2).sum() / (sw * float(kappa @ kappa)))
        Sc = S - sigma2 * sw * H
        new = np.linalg.solve(Sc, b - sigma2 * sw * d)
        done = np.allclose(new, th, rtol=1e-12, atol=0)
        th = new
        if done:
            break
    return th, Sc


def _output_noise_covariance(
    reg, theta, spec, values, M: int, last: int, lam: float, dt: float, order: int, S=None
):
    """Covariance of θ̂ at row ``last`` under white noise on the measured output, through the SVF.

    With output noise ``ε`` (variance σ²), the residual of row ``i`` at the true θ is that noise
    through the pre-filter and the model's polynomial: ``e_i = Σ_k κ[s_i − k] ε_k`` with
    ``κ = h_n + Σ_{j<n} a_j h_j`` (``h_j`` the impulse response of the SVF state ``w^(j)``, ``s_i``
    row i's sample; input columns carry no noise). The weighted least squares error is then, to
    first order, ``S⁻¹ Σ_k c_k ε_k`` with ``c_k = Σ_i w_i x_i κ[s_i − k]`` (one convolution), so

        Cov(θ̂) = σ² S⁻¹ (Σ_k c_k c_kᵀ) S⁻¹,    σ² = Σ w e² / (Σ w · ‖κ‖²).

    This is exact for the coloured residual the SVF makes (a lag-window HAC estimate is not: the
    residual's power sits near the cut-off, the regressors' near the system's frequency, and the
    long-run variance of their product is 30-100x below its lag-0 value, which any lag window
    leaks into). Noise in the regressors also biases θ̂ at low SNR (errors in variables); that
    bias is not in the interval (see docs/recursive.md for the measured coverage).
    """
    from scipy.signal import fftconvolve

    n_ord = spec.order
    i = np.arange(last + 1)
    age = np.where(i <= M, max(last - M - 1, 0), last - i).astype(float)
    with np.errstate(under="ignore"):
        w = lam**age
    X = reg.X[: last + 1]
    e = reg.Y[: last + 1] - X @ theta
    if S is None:
        S = (X * w[:, None]).T @ X
    h = _svf_impulse(reg, spec, dt, order)
    a = {**values, **dict(zip(reg.names, theta, strict=True))}
    kappa = h[:, n_ord].copy()
    for j, name in enumerate(spec.a_names):
        kappa += a[name] * h[:, j]
    k2 = float(kappa @ kappa)
    s_idx = reg.sample_index[: last + 1]
    N = int(s_idx[-1]) + 1
    xw = np.zeros((N, X.shape[1]))
    xw[s_idx] = X * w[:, None]
    # c_k = Σ_s xw[s] κ[s − k]: a convolution of the time-reversed xw with κ
    C = fftconvolve(xw[::-1], kappa[:, None], axes=0)[:N][::-1]
    p = X.shape[1]
    sigma2 = float((w * e**2).sum() / (w.sum() * k2)) * X.shape[0] / max(X.shape[0] - p, 1)
    meat = sigma2 * (C.T @ C) + sigma2**2 * _quadratic_term(
        reg, spec, h, kappa, _dense_weights(s_idx, w, N)
    )
    left = np.linalg.solve(S, meat)
    cov = np.linalg.solve(S, left.T).T
    return 0.5 * (cov + cov.T)


def _dense_weights(s_idx, w, N: int) -> np.ndarray:
    out = np.zeros(N)
    out[s_idx] = w
    return out


def _quadratic_term(reg, spec, h, kappa, u) -> np.ndarray:
    """The second-order (noise × noise) part of the covariance per σ⁴ (p, p).

    The noise in the columns of the unknown ``a_j`` (``h_j`` through the SVF) meets the
    residual's (``−κ``) in ``Q_c = Σ_i w_i N_{i,c} e_i = εᵀ B_c ε``; for Gaussian noise
    ``Cov(Q_c, Q_c') = σ⁴ [tr(B_c B_c'ᵀ) + tr(B_c B_c')]``. The first trace is already in
    ``σ² Cᵀ C`` (``C`` is built from the noisy regressors); this is the second,
    ``Σ_d n(d) X_{c'}(d) X_c(−d)`` with ``X_c(d) = Σ_m κ[m] h_c[m + d]`` and ``n(d)`` the weighted
    number of row pairs ``d`` samples apart. Without it the θ1 intervals of the ζ = 0.5 MSD at
    30 dB over-cover (99 %; benchmarks/bench_coverage.py), as the algebraic estimator's did.
    """
    from scipy.signal import correlate

    a_names = list(spec.a_names)
    cols = [(q, a_names.index(nm)) for q, nm in enumerate(reg.names) if nm in a_names]
    p = len(reg.names)
    T = np.zeros((p, p))
    if not cols:
        return T
    n_imp, N = kappa.size, u.size
    D = min(N, n_imp) - 1
    pairs = correlate(u, u, mode="full", method="fft")[N - 1 - D : N + D]  # n(d), d = -D..D
    X = {
        j: correlate(h[:, j], kappa, mode="full", method="fft")[n_imp - 1 - D : n_imp + D]
        for _, j in cols
    }
    for q, j in cols:
        for r, k in cols:
            T[q, r] = float(np.dot(pairs, X[k] * X[j][::-1]))
    return 0.5 * (T + T.T)


def _hac_bandwidth(prefilter: str, cutoff: float, dt: float, order: int, half_width: int) -> int:
    """Lags of the HAC sum: the pre-filter's memory.

    Butterworth SVF: 8 time constants of its slowest mode, ``8 / (ω_c sin(π / 2N) dt)`` samples
    (its impulse response has decayed to 3e-4 there); differential FIR filters: their length
    ``2 M + 1``.
    """
    if prefilter == "butterworth":
        sigma_min = 2 * np.pi * cutoff * np.sin(np.pi / (2 * order))
        return int(math.ceil(8.0 / (sigma_min * dt)))
    return 2 * int(half_width) + 1


def _nominal_of(spec: LinearODEModel, names: Sequence[str]) -> np.ndarray:
    """Nominal values of the unknowns ``names`` (NaN where the model has none)."""
    out = []
    for name in names:
        try:
            out.append(float(spec.parameters[name]))
        except (KeyError, TypeError, ValueError):
            out.append(np.nan)
    return np.array(out)


def _check_excitation(
    X: np.ndarray,
    names: Sequence[str],
    Y: np.ndarray | None = None,
    nominal: np.ndarray | None = None,
) -> None:
    """Raise `IdentifiabilityError` naming the parameter(s) the rows cannot determine.

    Three tests, all unit-free:

    1. a column that is zero (``‖X_i‖² ≤ 1e-24 max_j ‖X_j‖²``);
    2. a column whose *contribution* to the regression is negligible,
       ``c_i = ‖X_i‖ · |θ_i| / ‖Y‖ < MIN_RELATIVE_CONTRIBUTION`` (1e-6), with ``θ_i`` the model's
       nominal value (the least-squares estimate where the nominal is 0 or undefined). ``c_i`` is
       the share of the left-hand side that the term ``θ_i X_i`` explains: below 1e-6 the column
       is filter-transient residue or rounding (e.g. a settled record u ≡ 1, x ≡ 0.01: the ẋ
       column is 7.8e-8 RMS against x's 1e-2, c = 1e-9) and θ_i would be fitted to that residue,
       not to the system; 1e-6 is the resolution of 20-bit data (120 dB), finer than any sensor;
    3. linearly dependent columns (smallest eigenvalue of the unit-diagonal Σ x xᵀ ≤ 1e-8).
    """
    S = X.T @ X
    diag = np.diag(S)
    scale_ref = max(float(diag.max()), np.finfo(float).tiny)
    dead = [names[i] for i in range(len(names)) if diag[i] <= 1e-24 * scale_ref or diag[i] == 0]
    if dead:
        raise IdentifiabilityError(
            f"the regressor column of {dead} is zero over the whole record (no excitation), so "
            f"{dead} cannot be estimated. Excite the system (non-zero, varying input) or fix "
            "them with known=..."
        )
    if Y is not None:
        y_norm = float(np.linalg.norm(Y))
        col_norm = np.sqrt(diag)
        theta = (
            np.abs(np.asarray(nominal, dtype=float))
            if nominal is not None
            else np.full(len(names), np.nan)
        )
        missing = ~np.isfinite(theta) | (theta == 0)
        if missing.any():
            theta_ls = np.linalg.lstsq(X, Y, rcond=None)[0]
            theta = np.where(missing, np.abs(theta_ls), theta)
        if y_norm > 0:
            share = col_norm * theta / y_norm
            weak = [i for i in range(len(names)) if share[i] < MIN_RELATIVE_CONTRIBUTION]
            if weak:
                detail = ", ".join(
                    f"{names[i]} (‖X‖·|θ|/‖Y‖ = {share[i]:.1e}, column RMS "
                    f"{col_norm[i] / np.sqrt(X.shape[0]):.2e})"
                    for i in weak
                )
                raise IdentifiabilityError(
                    f"no excitation of {detail}: the term explains less than "
                    f"{MIN_RELATIVE_CONTRIBUTION:g} of the regression's left-hand side, so the "
                    "estimate would be fitted to filter transients or rounding (a settled or "
                    "constant record). Excite the system with a varying input (e.g. a sinusoid "
                    "near its natural frequency) or give those parameters with "
                    f"{arg('known', '{NAME: VALUE}', cli='NAME=VALUE')}."
                )
    d = 1.0 / np.sqrt(diag)
    w, V = np.linalg.eigh(S * d[:, None] * d[None, :])
    if w[0] <= MIN_EXCITATION:
        vec = V[:, 0]
        combo = " + ".join(
            f"{vec[i]:+.3g}·{names[i]}" for i in np.argsort(-np.abs(vec)) if abs(vec[i]) > 1e-3
        )
        raise IdentifiabilityError(
            f"the regressors are linearly dependent (rank-deficient Σ x xᵀ, smallest scaled "
            f"eigenvalue {w[0]:.2e}); the direction {combo} is not identifiable from this record. "
            "Use a richer input (e.g. a sinusoid away from the filter's stop band) or fix one of "
            f"{list(names)} with known=..."
        )
