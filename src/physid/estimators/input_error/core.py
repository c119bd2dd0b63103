"""Input-error: warning classes, settings' constants, the quality factor and linear least squares.

Part of `physid.estimators.input_error` (see its docstring for the method).
"""

from __future__ import annotations

import numpy as np

#: Relative rms residual (per joint, rms(τ̂ - τ^f) / rms(τ^f)) above which the estimator warns
#: after the fit. On the paper's noise-free experiments, fits with all errors below 0.1 % leave
#: 1e-6..1.1e-4; fits biased by 0.5 % or more leave 1.4e-3 or more (docs/input-error.md).
RESIDUAL_WARN = 1e-3

#: With noise="compensate", the share of the residual's energy that the noise on q must explain
#: (`.solve.noise_fraction`) for the intervals of a fit above `RESIDUAL_WARN` to be given:
#: measured 1.06-1.56 on the noisy 2-link URDF arm (exact torques), 0.016 on the encoder-quantised
#: linear axis with stiction (intervals 8-60 standard errors from the truth).
NOISE_SHARE = 0.5


class FilterWarning(UserWarning):
    """The filter's pass band does not cover the signals' spectrum: expect biased estimates."""


class BoundWarning(UserWarning):
    """The fit ended with parameters on (or within ``BOUND_RTOL`` of) their bounds.

    Not a filter problem (`FilterWarning`) and not an identifiability problem (the data do
    determine the direction; the unconstrained optimum lies outside the physical region): the
    usual cause is a model that does not match the system, e.g. ``kinetic="paper"`` fitted to
    data of the exact kinetic energy. The estimate is then a boundary point, not a minimum of J;
    its standard error is reported as NaN and ``success`` is False.
    """


#: M when a numeric cut-off is given without a half-width (the paper's).
DEFAULT_HALF_WIDTH = 100
#: Smallest record `cutoff="auto"` works on: filters of at least this half-width must fit.
MIN_AUTO_HALF_WIDTH = 10

#: A parameter within ``BOUND_RTOL * max(|initial value|, 1)`` of a finite bound (or flagged by
#: least_squares' ``active_mask``) counts as ended on that bound.
BOUND_RTOL = 1e-3


def linear_least_squares(regressor, tau) -> tuple[np.ndarray, np.ndarray]:
    """Least squares in the linear parameters β of ``τ = Y β``, and a small factor of Y.

    Parameters
    ----------
    regressor : array_like, shape (n_rows, n_beta)
        Y (rows: samples × joints). May be rank-deficient (the base-parameter relations).
    tau : array_like, shape (n_rows,)

    Returns
    -------
    beta_hat : ndarray, shape (n_beta,)
        The minimum-norm least-squares solution.
    r : ndarray, shape (rank, n_beta)
        A factor with ``|Y (β - β̂)|² = |r (β - β̂)|²`` for every β, so that
        ``|Y β - τ|² = |r (β - β̂)|² + |Y β̂ - τ|²``: a problem of ``rank`` rows with the same
        minimiser as the full one.

    Notes
    -----
    Column-scaled Gram matrix ``G = D YᵀY D = V Λ Vᵀ``; ``r = Λ^½ Vᵀ D⁻¹`` over the eigenvalues
    above ``1e-12 λ_max``. Squaring the (column-scaled) condition number costs digits, but this is
    used for starting values and grids (accuracy ~1e-8 is plenty; the main fit polishes on the
    residual form) and avoids a QR of the tall regressor.
    """
    y = np.asarray(regressor, dtype=float)
    tau = np.asarray(tau, dtype=float)
    norms = np.linalg.norm(y, axis=0)
    d = np.where(norms > 0, 1.0 / np.where(norms > 0, norms, 1.0), 0.0)
    lam, vec = np.linalg.eigh((y.T @ y) * np.outer(d, d))
    keep = lam > 1e-12 * lam.max()
    rhs = d * (y.T @ tau)
    beta_hat = d * (vec[:, keep] @ ((vec[:, keep].T @ rhs) / lam[keep]))
    r = (np.sqrt(lam[keep])[:, None] * vec[:, keep].T) / np.where(d > 0, d, 1.0)
    return beta_hat, r


def _gram_least_squares(gram, rhs) -> tuple[np.ndarray, np.ndarray]:
    """`linear_least_squares` from the normal equations ``G β = h`` (G symmetric, maybe not PSD).

    Column scaling ``D = diag(G)^-½``; ``D G D = V Λ Vᵀ``; eigenvalues below ``1e-12 λ_max``
    (and negative ones, which a compensated G can have along unexcited directions) are dropped.
    """
    g = 0.5 * (np.asarray(gram, dtype=float) + np.asarray(gram, dtype=float).T)
    diag = np.sqrt(np.clip(np.diag(g), 0.0, None))
    d = np.where(diag > 0, 1.0 / np.where(diag > 0, diag, 1.0), 0.0)
    lam, vec = np.linalg.eigh(g * np.outer(d, d))
    keep = lam > 1e-12 * lam.max()
    beta_hat = d * (vec[:, keep] @ ((vec[:, keep].T @ (d * rhs)) / lam[keep]))
    r = (np.sqrt(lam[keep])[:, None] * vec[:, keep].T) / np.where(d > 0, d, 1.0)
    return beta_hat, r


def quality_factor(residuals) -> float:
    """The paper's J: sum over joints of the mean squared residual (eq. 5, discrete form).

    Parameters
    ----------
    residuals : array_like, shape (n_valid, n_joints) [N·m]

    Returns
    -------
    float [N²·m²]

    Notes
    -----
    The paper divides each joint's sum by ``Length[tp] - 2M`` although its ``Filtr`` returns
    ``Length[tp] - 2M - 1`` samples; we divide by the number of samples actually summed.
    """
    e = np.asarray(residuals, dtype=float)
    return float(np.mean(e**2, axis=0).sum())


#: Ways `InputErrorEstimator` computes standard errors (``uncertainty=``).
STDERR_METHODS = ("hac", "iid")
#: What `InputErrorEstimator` does about the noise on q (``noise=``).
NOISE_METHODS = ("auto", "ignore", "compensate")
