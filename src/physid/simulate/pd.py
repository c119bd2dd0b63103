"""The PD control law of the closed loop, ``τ = Kp (r(t) − q) − Kd q̇`` per joint, fused with a model.

Cedro & Janecki, section 4: ``Mzr_k = Kp_k (M_k(t) − φ_k) − Kd_k φ̇_k``. The controller belongs to
the simulation, not to the model: `pd_rhs` builds the closed-loop right-hand side
``f(t, y) -> ẏ = [q̇, M⁻¹(τ − h)]`` of any chain model from what the model offers:

* symbolic chains (`physid.models.chain.ChainModel`): the PD law is written as generated lines
  and fused into the model's generated scalar dynamics through `ChainModel.scalar_factory` (one
  Python function per call: the PD law, the bias forces and an unrolled Cholesky solve, with no
  numpy temporaries);
* rigid-body chains (`physid.models.rigid_model.RigidBodyModel`): the PD law in numpy around the
  model's one-state forward dynamics `make_rhs` (the C kernel when it is built);
* any other model with ``make_rhs(params)``: the PD law per joint around it.
"""

from __future__ import annotations

import numpy as np

from .._validate import as_1d, per_joint
from ..errors import ShapeError

__all__ = ["pd_rhs"]


def _pd_lines(n: int) -> dict:
    """The generated PD law for `ChainModel.scalar_factory`: gains bound once, τ per call."""
    q = ", ".join(f"_q{i}" for i in range(n))
    qd = ", ".join(f"_qd{i}" for i in range(n))
    return dict(
        outer_args="TH, KP, KD",
        outer_extra=[
            f"{', '.join(f'KP{i}' for i in range(n))}, = KP",
            f"{', '.join(f'KD{i}' for i in range(n))}, = KD",
        ],
        inner_args="Y, R",
        prologue=[
            f"{q}, {qd}, = Y",
            f"{', '.join(f'R{i}' for i in range(n))}, = R",
            *[
                f"T{i} = KP{i}*(R{i} - _q{i}) - KD{i}*_qd{i}" for i in range(n)
            ],  # τ = Kp(r−q) − Kd q̇
        ],
        ret=f"return [{', '.join(f'_qd{i}' for i in range(n))}, "
        f"{', '.join(f'X{i}' for i in range(n))}]",
    )


def _symbolic_pd_rhs(model, params, kp_l, kd_l, reference):
    nj = model.n_joints
    factory = model.scalar_factory("pd", **_pd_lines(nj))
    core = factory(model.parameter_vector(params).tolist(), kp_l, kd_l)
    if callable(reference):
        ref = reference

        def pd_rhs(t, y):
            r = ref(t)
            return core(
                y.tolist() if hasattr(y, "tolist") else y,
                r.tolist() if hasattr(r, "tolist") else r,
            )
    else:
        r_const = as_1d(reference, "reference").tolist()
        if len(r_const) != nj:
            raise ShapeError(f"reference must hold {nj} angles; got {len(r_const)}.")

        def pd_rhs(t, y):
            return core(y.tolist() if hasattr(y, "tolist") else y, r_const)

    return pd_rhs


def _numpy_pd_rhs(model, params, kp_a, kd_a, reference, coulomb_smoothing):
    accel = model.make_rhs(params, coulomb_smoothing=coulomb_smoothing)
    n = model.n_joints
    if callable(reference):
        ref = reference
    else:
        r_const = np.asarray(reference, dtype=float)

        def ref(t):
            return r_const

    def pd_rhs(t, y):
        y = np.asarray(y, dtype=float)
        q, qd = y[:n], y[n:]
        tau = kp_a * (np.asarray(ref(t), dtype=float) - q) - kd_a * qd  # τ = Kp (r − q) − Kd q̇
        return np.concatenate([qd, accel(q, qd, tau)])

    return pd_rhs


def _generic_pd_rhs(model, params, kp_a, kd_a, reference):
    accel = model.make_rhs(params)
    n = int(model.n_joints)
    kp_l, kd_l = kp_a.tolist(), kd_a.tolist()

    def rhs(t, y):
        q = y[:n]
        qd = y[n:]
        r = reference(t)
        tau = [kp_l[j] * (r[j] - q[j]) - kd_l[j] * qd[j] for j in range(n)]
        return np.concatenate((qd, accel(q, qd, tau)))

    return rhs


def pd_rhs(model, params=None, *, kp, kd, reference, coulomb_smoothing: float = 0.0):
    """Closed-loop right-hand side ``f(t, y) -> ẏ`` of `model` under the PD law (generated code).

    τ_k = Kp_k (r_k(t) − q_k) − Kd_k q̇_k, then ẏ = [q̇, M⁻¹(τ − h)], y = [q, q̇].

    Parameters
    ----------
    model : ChainModel or RigidBodyModel
        The chain; any model with ``n_joints`` and ``make_rhs(params)`` works.
    params : dict or array_like, optional
        Model parameters (nominal values overridden), as in ``model.parameter_vector``.
    kp, kd : float, array_like (n_joints,) or mapping
        Proportional [N·m/rad] and derivative [N·m·s/rad] gains (`physid._validate.per_joint`).
    reference : callable or array_like (n_joints,)
        r(t) [rad]: a function of time returning n_joints values, or a constant set-point.
    coulomb_smoothing : float [rad/s]
        Rigid-body models: tanh(q̇ / coulomb_smoothing) in the Coulomb terms (0: exact sign).
        Symbolic chains ignore it.

    Returns
    -------
    callable
        ``f(t, y)`` returning ẏ [rad/s, rad/s²] (2 n_joints values; a list for symbolic chains,
        an array otherwise), for ``scipy.integrate.solve_ivp(f, ...)``.

    Examples
    --------
    At rest on the reference the PD torque is zero, so only gravity accelerates the arm:

    >>> import physid
    >>> arm = physid.load_model("manipulator")
    >>> f = pd_rhs(arm, kp=100.0, kd=10.0, reference=[0.0, 0.0, 0.0, 0.0])
    >>> qdd = arm.forward_dynamics(np.zeros((1, 4)), np.zeros((1, 4)), np.zeros((1, 4)))[0]
    >>> bool(np.allclose(f(0.0, np.zeros(8))[4:], qdd, rtol=1e-12, atol=1e-12))
    True
    """
    n = int(model.n_joints)
    kp_a = per_joint(kp, "kp", n)
    kd_a = per_joint(kd, "kd", n)
    if hasattr(model, "chain"):  # rigid-body chain (a ChainModel subclass without generated code)
        return _numpy_pd_rhs(model, params, kp_a, kd_a, reference, coulomb_smoothing)
    if hasattr(model, "scalar_factory"):
        return _symbolic_pd_rhs(model, params, kp_a.tolist(), kd_a.tolist(), reference)
    return _generic_pd_rhs(model, params, kp_a, kd_a, reference)
