"""What the algebraic and recursive estimators both need: the name of a model's output offset to
estimate, and the test that a regression's rows determine every unknown."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..errors import IdentifiabilityError, arg

#: Smallest equilibrated eigenvalue of the whole record's Σ x xᵀ for every unknown to count as
#: excited (reciprocal condition number 1e-8: below it, relative errors of 1e-8 in the rows, e.g. a
#: filter transient remnant, already move θ̂ by O(1)).
MIN_EXCITATION = 1e-8


#: Smallest share ‖X_i‖·|θ_i| / ‖Y‖ of the regression that a column must explain (see
#: `check_excitation`); below it the column is transient residue or rounding, not excitation.
MIN_RELATIVE_CONTRIBUTION = 1e-6


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


def check_excitation(
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
    moments = None
    if Y is not None:
        Y = np.asarray(Y, dtype=float)
        moments = (X.T @ Y, float(Y @ Y), lambda: np.linalg.lstsq(X, Y, rcond=None)[0])
    check_excitation_moments(X.T @ X, X.shape[0], names, moments, nominal)


def check_excitation_moments(S, n_rows: int, names: Sequence[str], moments=None, nominal=None):
    """`check_excitation` from the accumulated moments of the rows (a record read in blocks).

    Parameters
    ----------
    S : ndarray (p, p)
        Σ x xᵀ over the rows.
    n_rows : int
        Number of rows (for the column RMS in the message).
    names : sequence of str
        One name per column.
    moments : (ndarray (p,), float, callable) or None
        ``(Σ x Y, Σ Y², least-squares θ)``: the last a callable returning the least-squares
        estimate, used where the nominal value is 0 or undefined. None skips test 2.
    nominal : ndarray (p,), optional
        The model's nominal values of the unknowns.

    Raises
    ------
    IdentifiabilityError
        As `check_excitation`.
    """
    S = np.asarray(S, dtype=float)
    diag = np.diag(S)
    scale_ref = max(float(diag.max()), np.finfo(float).tiny)
    dead = [names[i] for i in range(len(names)) if diag[i] <= 1e-24 * scale_ref or diag[i] == 0]
    if dead:
        raise IdentifiabilityError(
            f"the regressor column of {dead} is zero over the whole record (no excitation), so "
            f"{dead} cannot be estimated. Excite the system (non-zero, varying input) or fix "
            f"them with {arg('known', '{NAME: VALUE}', cli='NAME=VALUE')}."
        )
    if moments is not None:
        _, yy, least_squares = moments
        y_norm = float(np.sqrt(yy))
        col_norm = np.sqrt(diag)
        theta = (
            np.abs(np.asarray(nominal, dtype=float))
            if nominal is not None
            else np.full(len(names), np.nan)
        )
        missing = ~np.isfinite(theta) | (theta == 0)
        if missing.any():
            theta_ls = least_squares()
            theta = np.where(missing, np.abs(theta_ls), theta)
        if y_norm > 0:
            share = col_norm * theta / y_norm
            weak = [i for i in range(len(names)) if share[i] < MIN_RELATIVE_CONTRIBUTION]
            if weak:
                detail = ", ".join(
                    f"{names[i]} (‖X‖·|θ|/‖Y‖ = {share[i]:.1e}, column RMS "
                    f"{col_norm[i] / np.sqrt(n_rows):.2e})"
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
            f"{list(names)} with {arg('known', '{NAME: VALUE}', cli='NAME=VALUE')}."
        )
