"""Model-based feed-forward in the closed loop: PD plus gravity (and friction) compensation.

Industrial controllers add the model's gravity torque (and often its friction) to the PD law:
``τ = Kp (r − q) − Kd q̇ + g(q) [+ τ_f(q̇)]``. When the compensation uses the plant's own
parameters, the loop ``M q̈ + C q̇ + g + τ_f = τ`` becomes ``M q̈ + C q̇ [+ τ_f] = Kp (r − q) −
Kd q̇``: the plant without gravity (and friction) under the pure PD law. `compensated_plant`
builds that plant, so that every back end of `physid.simulate.simulate_closed_loop` (compiled,
generated, event-driven Coulomb) simulates the loop; `feedforward_torque` gives the compensation
to add to the recorded torque.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..errors import InputError

__all__ = ["FEEDFORWARD", "compensated_plant", "feedforward_torque"]

#: Controllers: name -> the law, as written in the recording's metadata.
FEEDFORWARD = {
    "none": "tau = Kp (r - q) - Kd qd",
    "gravity": "tau = Kp (r - q) - Kd qd + g(q)",
    "gravity+friction": "tau = Kp (r - q) - Kd qd + g(q) + tau_friction(qd)",
}
_FRICTION = ("Fv", "Fc", "Fvp", "Fvn", "Fcp", "Fcn")  # and the transmission's motor friction


def _check(model, kind: str) -> None:
    if not isinstance(kind, str) or kind not in FEEDFORWARD:
        raise InputError(f"feedforward must be one of {sorted(FEEDFORWARD)}; got {kind!r}.")
    if kind != "none" and not hasattr(model, "chain"):
        raise InputError(
            f"feedforward={kind!r} needs a rigid-body model (a URDF, sidecar or rigid TOML "
            f"chain); model {getattr(model, 'name', '?')!r} is not one. Use feedforward='none'."
        )


def _without_friction(model, theta) -> np.ndarray:
    """θ with every friction term (joint and motor side) zeroed."""
    out = np.array(theta, dtype=float)
    tr = model.chain.transmission
    motor = {t[2] for t in tr.terms if t[1] != "inertia"} if tr is not None else set()
    for i, name in enumerate(model.parameter_names):
        if name in motor or name.rstrip("0123456789") in _FRICTION:
            out[i] = 0.0
    return out


def compensated_plant(model, theta, kind: str):
    """The plant that the PD law sees under the feed-forward ``kind``.

    Parameters
    ----------
    model : RigidBodyModel (or any model with ``kind = "none"``)
    theta : array_like (n_parameters,)
        The plant's (and the compensation's) parameters.
    kind : {"none", "gravity", "gravity+friction"}

    Returns
    -------
    (model, ndarray)
        The model without gravity (for ``"gravity"``…) and the parameters without friction
        (for ``"gravity+friction"``); the inputs for ``"none"``.
    """
    _check(model, kind)
    if kind == "none":
        return model, theta
    from ..models.rigid_model import RigidBodyModel

    chain = dataclasses.replace(model.chain, gravity=np.zeros(3))
    plant = RigidBodyModel(chain, check=False, cache=False)
    if kind == "gravity+friction":
        theta = _without_friction(model, theta)
    return plant, theta


def feedforward_torque(model, theta, kind: str, q, qd) -> np.ndarray:
    """The compensation ``g(q) [+ τ_f(q̇)]`` (n_samples, n_joints) [N·m | N]; zeros for "none".

    Parameters
    ----------
    model : RigidBodyModel
    theta : array_like (n_parameters,)
    kind : {"none", "gravity", "gravity+friction"}
    q, qd : ndarray (n_samples, n_joints)

    Returns
    -------
    ndarray (n_samples, n_joints)
    """
    _check(model, kind)
    if kind == "none":
        return np.zeros_like(q)
    out = model.gravity_forces(q, theta)
    if kind == "gravity+friction":  # τ_f = h(θ) − h(θ without friction), at q̈ = 0
        zero = np.zeros_like(q)
        out = (
            out
            + model.inverse_dynamics(q, qd, zero, theta)
            - model.inverse_dynamics(q, qd, zero, _without_friction(model, theta))
        )
    return out
