"""Independent implementations of the same chain, for cross-checks and benchmarks (optional peers).

`pinocchio_model` builds the pinocchio model (extra ``peers``: ``pip install pin``) of a DH chain
described by a `ChainModel`: revolute-Z joints whose placements come from the DH transforms,
point masses as ``pin.Inertia(m, lever, 0)`` at the link-frame origins, the rotor inertias as
``model.armature`` and the model's gravity vector as ``model.gravity.linear``.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError

__all__ = ["pinocchio_model"]


def _evaluate(text: str, values: dict) -> float:
    import sympy as sp

    from .spec import parse_expression

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
