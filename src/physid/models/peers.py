"""Independent implementations of the same chain, for cross-checks and benchmarks (optional peers).

`to_pinocchio` builds a `PinocchioPeer` from any chain model — a rigid-body model (URDF, sidecar,
rigid TOML) from its placements, axes and link inertias, or a DH point-mass chain (the paper's
arm) as below — carrying every term: armature as ``model.armature`` and the friction and offset
terms (viscous, Coulomb, asymmetric, offset) added by the peer's `rnea` and removed before `aba`,
so that ``peer.rnea(q, v, a)`` equals physid's ``inverse_dynamics`` term for term.

`pinocchio_model` builds the pinocchio model (extra ``peers``: ``pip install pin``) of a DH chain
described by a `ChainModel`: revolute-Z joints whose placements come from the DH transforms,
point masses as ``pin.Inertia(m, lever, 0)`` at the link-frame origins, the rotor inertias as
``model.armature`` and the model's gravity vector as ``model.gravity.linear``.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["pinocchio_model", "to_pinocchio", "PinocchioPeer"]


def _evaluate(text: str, values: dict) -> float:
    import sympy as sp

    from .chain_symbolic import parse_expression

    syms = {k: sp.Symbol(k) for k in values}
    expr = parse_expression(text, syms, "pinocchio_model")
    return float(expr.subs({syms[k]: v for k, v in values.items()}))


def pinocchio_model(model, params=None):
    """Pinocchio model (and data) of a DH `ChainModel` at the given parameters.

    Standard DH: frame_k = frame_{k−1} · Rz(q_k) · S_k, S_k = Rz(offset) Tz(d) Tx(a) Rx(α). In
    pinocchio, joint k rotates about the z axis of its placement, the placement of joint k in
    joint k−1's frame is S_{k−1} (identity for k = 1), and link k's point mass sits at the origin
    of S_k, i.e. at lever S_k[:3, 3] in joint k's frame.

    Returns
    -------
    (pinocchio.Model, pinocchio.Data)
    """
    import pinocchio as pin

    spec = model.spec
    if any(j.dh is None for j in spec.joints):
        raise InputError(
            "pinocchio_model needs a chain given by DH parameters (dh = {...}) for every joint."
        )
    values = dict(zip(model.parameter_names, model.parameter_vector(params).tolist(), strict=False))
    pm = pin.Model()
    parent = 0
    placement = pin.SE3.Identity()
    armature = []
    for k, joint in enumerate(spec.joints):
        dh = {key: _evaluate(txt, values) for key, txt in joint.dh}
        ca, sa = np.cos(dh["alpha"]), np.sin(dh["alpha"])
        co, so = np.cos(dh["offset"]), np.sin(dh["offset"])
        Rz = np.array([[co, -so, 0], [so, co, 0], [0, 0, 1]])
        Rx = np.array([[1, 0, 0], [0, ca, -sa], [0, sa, ca]])
        S = pin.SE3(Rz @ Rx, Rz @ np.array([dh["a"], 0.0, dh["d"]]))  # Rz(off) Tz(d) Tx(a) Rx(α)
        jid = pm.addJoint(parent, pin.JointModelRZ(), placement, f"joint{k + 1}")
        mass = _evaluate(joint.mass, values)
        pm.appendBodyToJoint(
            jid, pin.Inertia(mass, S.translation.copy(), np.zeros((3, 3))), pin.SE3.Identity()
        )
        armature.append(_evaluate(joint.rotor_inertia, values))
        parent, placement = jid, S
    pm.armature = np.array(armature)
    pm.gravity.linear = np.array(model.gravity, dtype=float)
    return pm, pm.createData()


class PinocchioPeer:
    """A pinocchio model of a physid chain plus the drive terms pinocchio's algorithms lack.

    Attributes
    ----------
    model, data : pinocchio.Model, pinocchio.Data
    friction : dict prefix -> ndarray (n,)
        Fv, Fc, Fvp, Fvn, Fcp, Fcn, OF values (armature is in ``model.armature``).
    """

    def __init__(self, pmodel, friction: dict, coulomb_smoothing: float = 0.0):
        self.coulomb_smoothing = float(coulomb_smoothing)
        self.model = pmodel
        self.data = pmodel.createData()
        self.friction = {k: np.asarray(v, dtype=float) for k, v in friction.items()}

    def drive_torque(self, qd) -> np.ndarray:
        """Friction and offset torques (no armature) at joint velocities ``qd`` (n,).

        Parameters
        ----------
        qd : array_like (n,)

        Returns
        -------
        ndarray (n,)
        """
        v = np.asarray(qd, dtype=float)
        f = self.friction
        out = np.zeros_like(v)
        eps = self.coulomb_smoothing
        if eps > 0:
            th = np.tanh(v / eps)
            pos, neg, sgn = 0.5 * (1 + th), 0.5 * (1 - th), th
        else:
            pos, neg, sgn = (v > 0), (v < 0), np.sign(v)
        if "Fv" in f:
            out += f["Fv"] * v
        if "Fc" in f:
            out += f["Fc"] * sgn
        if "Fvp" in f:
            out += f["Fvp"] * np.where(v > 0, v, 0.0)
        if "Fvn" in f:
            out += f["Fvn"] * np.where(v < 0, v, 0.0)
        if "Fcp" in f:
            out += f["Fcp"] * pos
        if "Fcn" in f:
            out -= f["Fcn"] * neg
        if "OF" in f:
            out += f["OF"]
        return out

    def rnea(self, q, qd, qdd) -> np.ndarray:
        """τ of one state, drive terms included (pinocchio.rnea + friction + offset)."""
        import pinocchio as pin

        return pin.rnea(self.model, self.data, q, qd, qdd) + self.drive_torque(qd)

    def crba(self, q) -> np.ndarray:
        """M(q) of one state (full symmetric matrix, armature included)."""
        import pinocchio as pin

        M = pin.crba(self.model, self.data, q)
        return np.triu(M) + np.triu(M, 1).T

    def aba(self, q, qd, tau) -> np.ndarray:
        """q̈ of one state under torques ``tau`` (friction and offset removed first)."""
        import pinocchio as pin

        return pin.aba(self.model, self.data, q, qd, np.asarray(tau) - self.drive_torque(qd))


def to_pinocchio(model, params=None, *, coulomb_smoothing: float = 0.0) -> PinocchioPeer:
    """The pinocchio peer of a physid chain model, every term carried.

    Parameters
    ----------
    model : RigidBodyModel or ChainModel
        A rigid-body model, or a DH point-mass chain.
    params : dict or array_like, optional
        Parameters (nominal by default).
    coulomb_smoothing : float [rad/s]
        0: exact sign(q̇); > 0: tanh(q̇ / v_s) as physid's simulation uses.

    Returns
    -------
    PinocchioPeer
    """
    import pinocchio as pin

    from .inertial import to_pinocchio_order

    if not hasattr(model, "chain"):
        pm, _ = pinocchio_model(model, params)
        values = dict(
            zip(model.parameter_names, model.parameter_vector(params).tolist(), strict=False)
        )
        spec = model.spec
        friction = {
            "Fv": [_evaluate(j.viscous, values) for j in spec.joints],
            "Fc": [_evaluate(j.coulomb, values) for j in spec.joints],
        }
        return PinocchioPeer(pm, friction, coulomb_smoothing)
    chain = model.chain
    if chain.mimic:
        raise InputError(
            f"to_pinocchio: model {model.name!r} has mimic joints; build the peer with "
            "pinocchio.buildModelFromUrdf(path, mimic=True) instead."
        )
    if chain.motor_names:
        raise InputError(
            f"to_pinocchio: model {model.name!r} has motor-side terms {list(chain.motor_names)} "
            "acting through a coupling matrix; pinocchio's armature is per joint and cannot "
            "hold them. Compare without the [transmission] motor terms."
        )
    inertia, drive = chain.split(model.parameter_vector(params))
    pm = pin.Model()
    for i in range(chain.n_joints):
        parent = chain.parents[i] + 1  # pinocchio's joint ids: 0 the universe, then ours in order
        a = chain.axis[i]
        if chain.joint_types[i] == "revolute":
            jm = pin.JointModelRevoluteUnaligned(float(a[0]), float(a[1]), float(a[2]))
        else:
            jm = pin.JointModelPrismaticUnaligned(float(a[0]), float(a[1]), float(a[2]))
        placement = pin.SE3(np.array(chain.rotation[i]), np.array(chain.translation[i]))
        jid = pm.addJoint(parent, jm, placement, chain.joint_names[i])
        pm.appendBodyToJoint(
            jid,
            pin.Inertia.FromDynamicParameters(to_pinocchio_order(inertia[i])),
            pin.SE3.Identity(),
        )
    names = chain.drive_names
    pm.armature = (
        np.array(drive[:, names.index("Ia")]) if "Ia" in names else np.zeros(chain.n_joints)
    )
    pm.gravity.linear = np.array(chain.gravity, dtype=float)
    friction = {k: drive[:, c] for c, k in enumerate(names) if k != "Ia"}
    return PinocchioPeer(pm, friction, coulomb_smoothing)
