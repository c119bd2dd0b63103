"""The mass–spring–damper of Oueslati et al.: its nominal values and the conversions between
(m, c, k), (θ1, θ2, b0) and (ω0, ζ). The model itself is `physid.models.linear_ode.msd_model`."""

from __future__ import annotations

import numpy as np

from .._validate import check_positive

__all__ = [
    "msd_from_physical",
    "natural_frequency_damping",
    "theta_from_natural",
    "physical_from_theta",
    "MSD_MASS",
    "MSD_DAMPING",
    "MSD_STIFFNESS",
    "MSD_NATURAL_FREQUENCY",
]

#: Oueslati et al., section 4: load mass m = 3 kg, damping c = 0.05 N·s/m, spring k = 400 N/m.
MSD_MASS = 3.0
MSD_DAMPING = 0.05
MSD_STIFFNESS = 400.0
#: Its undamped natural frequency ω0 = √(k/m) [rad/s] (≈ 11.547).
MSD_NATURAL_FREQUENCY = float(np.sqrt(MSD_STIFFNESS / MSD_MASS))


def msd_from_physical(mass, damping, stiffness) -> dict:
    """(m [kg], c [N·s/m], k [N/m]) → {"theta1": c/m [1/s], "theta2": k/m [1/s²], "b0": 1/m [1/kg]}.

    b0 = 1/m is the gain from force u = F; with the normalised input u = F/m use b0 = 1.

    Parameters
    ----------
    mass : float [kg]
        m > 0.
    damping : float [N·s/m]
        c >= 0.
    stiffness : float [N/m]
        k > 0.

    Returns
    -------
    dict
        ``theta1`` [1/s], ``theta2`` [1/s²], ``b0`` [1/kg].

    Examples
    --------
    >>> msd_from_physical(3.0, 0.05, 400.0)["theta2"]   # doctest: +ELLIPSIS
    133.33...
    """
    m = check_positive(mass, "mass")
    c = check_positive(damping, "damping", allow_zero=True)
    k = check_positive(stiffness, "stiffness")
    return {"theta1": c / m, "theta2": k / m, "b0": 1.0 / m}


def natural_frequency_damping(theta1, theta2):
    """(θ1, θ2) → (ω0 = √θ2 [rad/s], ζ = θ1 / (2√θ2)); vectorised, NaN where θ2 ≤ 0.

    Parameters
    ----------
    theta1 : float or array_like [1/s]
        θ1 = c/m.
    theta2 : float or array_like [1/s²]
        θ2 = k/m.

    Returns
    -------
    (omega0, zeta) : tuple of float or ndarray
        Natural frequency [rad/s] and damping ratio, shaped like the inputs.
    """
    t1 = np.asarray(theta1, dtype=float)
    t2 = np.asarray(theta2, dtype=float)
    ok = t2 > 0
    omega0 = np.where(ok, np.sqrt(np.where(ok, t2, 1.0)), np.nan)
    zeta = np.where(ok, t1 / (2.0 * np.where(ok, omega0, 1.0)), np.nan)
    if omega0.ndim == 0:
        return float(omega0), float(zeta)
    return omega0, zeta


def theta_from_natural(omega0, zeta):
    """(ω0 [rad/s], ζ) → (θ1 = 2ζω0 [1/s], θ2 = ω0² [1/s²]); vectorised.

    Parameters
    ----------
    omega0 : float or array_like [rad/s]
        Natural frequency.
    zeta : float or array_like
        Damping ratio.

    Returns
    -------
    (theta1, theta2) : tuple of float or ndarray
        θ1 [1/s] and θ2 [1/s²], shaped like the inputs.
    """
    w = np.asarray(omega0, dtype=float)
    z = np.asarray(zeta, dtype=float)
    t1, t2 = 2.0 * z * w, w * w
    if t1.ndim == 0:
        return float(t1), float(t2)
    return t1, t2


def physical_from_theta(theta1, theta2, mass) -> dict:
    """(θ1, θ2, m) → {"mass": m, "damping": c = θ1 m [N·s/m], "stiffness": k = θ2 m [N/m]}.

    Parameters
    ----------
    theta1 : float [1/s]
        θ1 = c/m.
    theta2 : float [1/s²]
        θ2 = k/m.
    mass : float [kg]
        m > 0.

    Returns
    -------
    dict
        ``mass`` [kg], ``damping`` [N·s/m], ``stiffness`` [N/m].
    """
    m = check_positive(mass, "mass")
    return {"mass": m, "damping": float(theta1) * m, "stiffness": float(theta2) * m}
