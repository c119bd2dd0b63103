"""Row selection: which equations of a Coulomb joint to drop near rest (IDIM and input-error).

While a joint with Coulomb friction is stuck, the friction torque holding it lies anywhere in
[−Fc, Fc] but the regressor writes Fc·sign(0) = 0, and the filters smear every stick/slip switch
over their length; those equations are wrong, not noisy, and both inverse-model estimators drop
them (see ``stick_threshold`` of `physid.estimators.idim.idim_rows`).
"""

from __future__ import annotations

import numpy as np

__all__: list[str] = []

STICK_THRESHOLD = 0.05  # fraction of the joint's rms filtered speed


def coulomb_joints(model) -> np.ndarray:
    """Bool per joint: whether the model has a Coulomb term ``Fc{j}`` there."""
    names = set(getattr(model, "parameter_names", ()))
    return np.array([f"Fc{j + 1}" in names for j in range(int(model.n_joints))])


def stuck_samples(qd, coulomb, threshold: float, reach: int) -> np.ndarray:
    """Samples × joints where a Coulomb joint is at or near rest, widened by ``reach`` samples.

    ``qd`` (n, n_joints) are the filtered speeds; a sample is near rest when |q̇_j| is below
    ``threshold`` · rms(q̇_j). The mask is dilated by ``reach`` (the parallel filter's half
    length) on both sides, since a decimated row mixes that many neighbours. Vectorised: a
    moving maximum by cumulative sums.
    """
    qd = np.asarray(qd, dtype=float)
    rms = np.sqrt(np.mean(qd**2, axis=0))
    near = (np.abs(qd) < threshold * np.where(rms > 0, rms, 1.0)) & coulomb[None, :]
    if reach <= 0:
        return near
    c = np.concatenate([np.zeros((1, near.shape[1])), np.cumsum(near, axis=0)])
    n = near.shape[0]
    lo = np.clip(np.arange(n) - reach, 0, n)
    hi = np.clip(np.arange(n) + reach + 1, 0, n)
    return (c[hi] - c[lo]) > 0


def drop_equations(W, tau, stuck) -> tuple[np.ndarray, np.ndarray]:
    """Zero, in place, the equations marked ``stuck``: no information, no weight.

    ``W`` (n, n_joints, p) and ``tau`` (n, n_joints) are the rows of a regression
    ``τ = W β``; ``stuck`` (n, n_joints) of bool. A zeroed equation adds nothing to the normal
    equations, so the least-squares solution is that of the equations kept. Returns ``(W, tau)``.
    """
    W[stuck] = 0.0
    tau[stuck] = 0.0
    return W, tau
