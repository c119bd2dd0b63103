"""The regression ``Y = X θ`` of a linear ODE model, built from pre-filtered samples."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..._validate import check_signal_pair
from ...errors import EstimationError, InputError
from ...filters.state_variable import state_variable_filter, svf_transient_samples
from ...models.linear_ode import LinearODEModel, as_linear_ode_model
from .._regression import offset_name
from .prefilter import _prefilter_settings


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
        from ...filters import design_filter_bank

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
    unknown, values = spec.split_coefficients(unknown, known)
    offset = offset_name(spec)
    return (tuple(unknown) + (offset,) if offset else tuple(unknown)), values


def _offset_to_value(spec, names, theta):
    """Estimates with the offset column δ = a_0 o turned into o (a copy; theta (..., p))."""
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
