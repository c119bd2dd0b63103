"""TOML chains with rigid-body keys → `physid.models.rigid.RigidChain`.

A ``kind = "chain"`` file is a *rigid-body chain* as soon as one joint uses a key that the
point-mass (symbolic) chains do not have: ``type``, ``mdh``, ``axis``, ``com``, ``inertia``, a
standard parameter (``m``, ``mcx`` … ``ZZ``), ``armature``, an asymmetric friction term,
``torque_offset`` or ``limits``. Then every value is a number, or an expression of the
``[parameters]`` evaluated at their nominal values, and the model's parameters are the standard
parameters of each link plus its drive terms (docs/model-files.md).

Frames: with ``dh = {a, alpha, d, offset}`` (standard DH, T = Rz(q + offset) Tz(d) Tx(a) Rx(α);
prismatic: Rz(offset) Tz(d + q) Tx(a) Rx(α)) the link's inertial values are in DH frame k, at the
end of the link; with ``mdh = {alpha, a, d, theta}`` (Craig, T = Rx(α) Tx(a) Rz(θ + q) Tz(d);
prismatic: d + q) and with ``transform`` (a constant 4 × 4 placement of the joint frame in the
previous link frame; the joint moves about/along ``axis``, default z) they are in the joint frame.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..errors import ModelFileError
from . import inertial
from .rigid import DRIVE_NAMES, RigidChain, link_to_joint_map
from .urdf import DRIVE_KEYS, PHYSICAL_KEYS, STANDARD_KEYS, joint_drive, joint_inertial

__all__ = ["is_rigid_chain", "parse_rigid_chain"]

RIGID_ONLY_KEYS = (
    {"type", "mdh", "axis", "com", "inertia", "limits"}
    | set(STANDARD_KEYS)
    | (set(DRIVE_KEYS) - {"rotor_inertia", "viscous", "coulomb"})
)
_JOINT_KEYS = (
    {"name", "type", "dh", "mdh", "transform", "axis", "limits"}
    | set(STANDARD_KEYS)
    | set(PHYSICAL_KEYS)
    | set(DRIVE_KEYS)
)
_TOP = {
    "recording",  # the channel map, read by spec.read_recording_map (docs/your-data.md)
    "name",
    "kind",
    "description",
    "gravity",
    "kinetic_energy",
    "parameters",
    "joints",
    "strict",
    "transmission",  # motors and their coupling (physid.models.transmission)
}


def is_rigid_chain(data: dict) -> bool:
    """Whether a parsed chain file uses rigid-body keys (see the module docstring).

    Parameters
    ----------
    data : dict
        Parsed TOML.

    Returns
    -------
    bool
    """
    joints = data.get("joints")
    if not isinstance(joints, list):
        return False
    return any(isinstance(j, dict) and RIGID_ONLY_KEYS & set(j) for j in joints)


def _rot(axis: str, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    if axis == "x":
        return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _T(R=None, p=None) -> np.ndarray:
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    if p is not None:
        T[:3, 3] = p
    return T


def _evaluator(params, source):
    values = {p.name: p.value for p in params}

    def evaluate(value, where, key):
        if isinstance(value, bool):
            raise ModelFileError(
                f"{where}: {key} must be a number or an expression; got {value!r}."
            )
        if isinstance(value, (int, float)):
            v = float(value)
        elif isinstance(value, str) and value.strip():
            try:
                v = float(value)
            except ValueError:
                v = _expression_value(value, values, f"{where} {key}")
        else:
            raise ModelFileError(
                f"{where}: {key} must be a number or an expression; got {value!r}."
            )
        if not math.isfinite(v):
            raise ModelFileError(f"{where}: {key} = {value!r} is not finite at the nominal values.")
        return v

    return evaluate


def _expression_value(text, values, where) -> float:
    from ..errors import PhysidError
    from ..expressions import evaluate_expression  # the safe numeric evaluator (no eval)

    try:
        out = evaluate_expression(text, {**values, "pi": math.pi}, source=where)
    except PhysidError as exc:
        raise ModelFileError(f"{where}: {exc}") from None
    arr = np.asarray(out, dtype=float)
    if arr.ndim != 0:
        raise ModelFileError(f"{where}: {text!r} must be a single number.")
    return float(arr)


def parse_rigid_chain(data: dict, text: str, source: str, name: str, params, *, strict=False):
    """Parse a rigid-body TOML chain (already read) into a `RigidChain`.

    Parameters
    ----------
    data : dict
        Parsed TOML.
    text : str
        The TOML text (for line numbers).
    source : str
    name : str
    params : tuple of ParameterSpec
        The file's ``[parameters]`` (used to evaluate expressions).
    strict : bool
        Refuse physically doubtful inertias instead of warning.

    Returns
    -------
    RigidChain

    Raises
    ------
    ModelFileError
    """
    from ._locate import _where

    extra = set(data) - _TOP
    if extra:
        raise ModelFileError(
            f"{_where(source, text, 'top level', sorted(extra)[0])}: unknown key(s) "
            f"{sorted(extra)} for a rigid-body chain; allowed: {sorted(_TOP)}."
        )
    strict = bool(data.get("strict", strict))
    held = [p.name for p in params if not getattr(p, "identify", True)]
    evaluate = _evaluator(params, source)
    joints = data.get("joints")
    gravity = _rigid_gravity(data, joints, text, source, evaluate)
    n = len(joints)
    types, names, rots, trans, axes, std, A = [], [], [], [], [], [], []
    drive_rows = []
    limits = {
        "position": np.full((n, 2), np.nan),
        "velocity": np.full(n, np.nan),
        "effort": np.full(n, np.nan),
        "acceleration": np.full(n, np.nan),
    }
    post_prev = np.eye(4)
    for k, jt in enumerate(joints):
        where = _where(source, text, f"joints[{k + 1}]", "type", table="joints", index=k)
        kind = _joint_kind(jt, where)
        pre, post, axis = _joint_frames(jt, k, kind, where, evaluate)
        norm = float(np.linalg.norm(axis))
        if norm < 1e-12:
            raise ModelFileError(
                f"{where}: axis has zero length; give a direction, e.g. axis = [0, 0, 1]."
            )
        placement = post_prev @ pre
        types.append(kind)
        names.append(str(jt.get("name", f"joint{k + 1}")))
        rots.append(placement[:3, :3])
        trans.append(placement[:3, 3])
        axes.append(axis / norm)
        A.append(link_to_joint_map(post[:3, :3], post[:3, 3]))
        post_prev = post

        def ev(value, key, _w=where):
            return evaluate(value, _w, key)

        p = joint_inertial(jt, where, strict, ev, default=None)
        if p is None:
            raise ModelFileError(
                f"{where}: joint {k + 1} moves no link: give mass (with com and inertia) or the "
                "standard parameters m, mcx, …, ZZ."
            )
        std.append(p)
        drive_rows.append(joint_drive(jt, where, ev))
        _joint_limits(jt, k, where, ev, limits)
    present = [dn for dn in DRIVE_NAMES if any(dn in row for row in drive_rows)]
    drive = {dn: np.array([row.get(dn, 0.0) for row in drive_rows]) for dn in present}
    chain = RigidChain(
        name=name,
        joint_names=tuple(names),
        joint_types=tuple(types),
        rotation=np.array(rots),
        translation=np.array(trans),
        axis=np.array(axes),
        standard=np.array(std),
        link_to_joint=np.array(A),
        drive=drive,
        gravity=gravity,
        limits=limits,
        source=source,
        description=str(data.get("description", "")),
        identify=(),
    )
    from .transmission import attach_transmission

    chain = attach_transmission(chain, data.get("transmission"), source)
    if held:  # identify = false: model.unknown is every other model parameter
        chain = _hold(chain, held, text, source)
    return chain


def _rigid_gravity(data: dict, joints, text: str, source: str, evaluate) -> np.ndarray:
    """The gravity vector [m/s²] of a rigid-body chain, after refusing the paper's kinetic energy."""
    from ._locate import _where

    if data.get("kinetic_energy", "exact") != "exact":
        kinds = [j.get("type", "revolute") for j in joints if isinstance(j, dict)]
        what = "a prismatic joint" if "prismatic" in kinds else "rigid-body keys"
        raise ModelFileError(
            f"{_where(source, text, 'kinetic_energy', 'kinetic_energy')}: kinetic_energy = "
            f"{data['kinetic_energy']!r} (the paper's formula for point masses on revolute "
            f"joints) cannot be used with {what}; remove kinetic_energy (exact is the default)."
        )
    g = data.get("gravity", [0.0, 0.0, -9.81])
    if not isinstance(g, list) or len(g) != 3:
        raise ModelFileError(
            f"{_where(source, text, 'gravity', 'gravity')}: gravity must be [gx, gy, gz] in m/s²."
        )
    return np.array([evaluate(v, source, "gravity") for v in g])


def _joint_kind(jt, where: str) -> str:
    """The joint's type (``"revolute"`` or ``"prismatic"``), its keys checked."""
    if not isinstance(jt, dict):
        raise ModelFileError(f"{where}: each [[joints]] entry must be a table.")
    bad = set(jt) - _JOINT_KEYS
    if bad:
        raise ModelFileError(
            f"{where}: unknown key(s) {sorted(bad)} in a rigid-body joint; allowed: "
            f"{sorted(_JOINT_KEYS)}."
        )
    kind = jt.get("type", "revolute")
    if kind in ("planar", "floating", "fixed", "spherical"):
        raise ModelFileError(
            f"{where}: joint type {kind!r} is not supported; use 'revolute' or 'prismatic' "
            "(fold a fixed joint into the neighbouring link's inertia)."
        )
    if kind not in ("revolute", "prismatic"):
        raise ModelFileError(f"{where}: type must be 'revolute' or 'prismatic'; got {kind!r}.")
    return kind


def _joint_frames(jt: dict, k: int, kind: str, where: str, evaluate) -> tuple:
    """``(pre, post, axis)``: the joint frame is ``pre`` after the previous link's ``post``, and
    the link's inertial frame is ``post`` after the joint; ``axis`` (unnormalised) in the joint
    frame."""
    forms = [f for f in ("dh", "mdh", "transform") if f in jt]
    if len(forms) != 1:
        raise ModelFileError(
            f"{where}: give exactly one of dh = {{a, alpha, d, offset}}, mdh = {{alpha, a, d, "
            f"theta}} or transform = [[4×4]] for joint {k + 1}; got "
            f"{forms or 'none'}."
        )
    form = forms[0]
    if form == "transform":
        return _transform_frames(jt, k, where, evaluate)
    if "axis" in jt:
        raise ModelFileError(
            f"{where}: axis is only for transform joints; a {form} joint moves about/along z."
        )
    raw = jt[form]
    if not isinstance(raw, dict):
        raise ModelFileError(f"{where}: {form} must be a table, e.g. {{a = 0.3, alpha = 0}}.")
    allowed = {"a", "alpha", "d", "offset", "theta"}
    badk = set(raw) - allowed
    if badk or ("offset" in raw and "theta" in raw):
        raise ModelFileError(
            f"{where}: {form} keys are a, alpha, d and offset (or theta, the same constant "
            f"angle); got {sorted(raw)}."
        )
    a = evaluate(raw.get("a", 0.0), where, f"{form}.a")
    alpha = evaluate(raw.get("alpha", 0.0), where, f"{form}.alpha")
    d = evaluate(raw.get("d", 0.0), where, f"{form}.d")
    th = evaluate(raw.get("theta", raw.get("offset", 0.0)), where, f"{form}.theta")
    Rz, Rx = _T(_rot("z", th)), _T(_rot("x", alpha))
    Tz, Tx = _T(p=[0, 0, d]), _T(p=[a, 0, 0])
    if form == "dh":
        if kind == "revolute":
            pre, post = np.eye(4), Rz @ Tz @ Tx @ Rx
        else:
            pre, post = Rz @ Tz, Tx @ Rx
    else:
        pre, post = Rx @ Tx @ Rz @ Tz, np.eye(4)
    return pre, post, np.array([0.0, 0.0, 1.0])


def _transform_frames(jt: dict, k: int, where: str, evaluate) -> tuple:
    """`_joint_frames` of a joint placed by a constant ``transform`` (moving about ``axis``)."""
    axis = np.array([0.0, 0.0, 1.0])
    raw = jt["transform"]
    if not (
        isinstance(raw, list)
        and len(raw) == 4
        and all(isinstance(r, list) and len(r) == 4 for r in raw)
    ):
        raise ModelFileError(f"{where}: transform must be 4 rows of 4 numbers.")
    try:
        T = np.array([[evaluate(v, where, "transform") for v in row] for row in raw])
    except ModelFileError as exc:
        if f"q{k + 1}" in str(raw):
            raise ModelFileError(
                f"{where}: in a rigid-body chain the transform is the constant placement "
                f"of the joint frame (no q{k + 1}); the joint moves about/along axis = "
                "[x, y, z] (default z)."
            ) from None
        raise exc
    R = T[:3, :3]
    if (
        not np.allclose(T[3], [0, 0, 0, 1])
        or not np.allclose(R @ R.T, np.eye(3), atol=1e-8)
        or np.linalg.det(R) < 0
    ):
        raise ModelFileError(
            f"{where}: transform is not a rigid homogeneous transform (orthonormal "
            "rotation with det +1, bottom row [0, 0, 0, 1])."
        )
    if "axis" in jt:
        ax = jt["axis"]
        if not isinstance(ax, list) or len(ax) != 3:
            raise ModelFileError(f"{where}: axis must be [x, y, z]; got {ax!r}.")
        axis = np.array([evaluate(v, where, "axis") for v in ax])
    return T, np.eye(4), axis


def _joint_limits(jt: dict, k: int, where: str, ev, limits: dict) -> None:
    """Write joint ``k``'s ``limits`` table into ``limits`` (NaN where not given)."""
    lim = jt.get("limits", {})
    if not isinstance(lim, dict) or set(lim) - {
        "lower",
        "upper",
        "velocity",
        "effort",
        "acceleration",
    }:
        raise ModelFileError(
            f"{where}: limits must be a table with lower, upper, velocity, effort, "
            f"acceleration; got {lim!r}."
        )
    for j, key in enumerate(("lower", "upper")):
        if key in lim:
            limits["position"][k, j] = ev(lim[key], f"limits.{key}")
    for key in ("velocity", "effort", "acceleration"):
        if key in lim:
            limits[key][k] = ev(lim[key], f"limits.{key}")


def _hold(chain: RigidChain, held: list, text: str, source: str) -> RigidChain:
    """``chain`` with every model parameter identified except the ``held`` ones."""
    from ._locate import _where

    names = chain.parameter_names()
    stray = [h for h in held if h not in names]
    if stray:
        raise ModelFileError(
            f"{_where(source, text, 'parameters', stray[0])}: identify = false on {stray}, "
            "which are not parameters of the rigid-body model (its parameters are the "
            "standard ones of each link, m1, mcx1, …, ZZ1, and the drive terms, Ia1, Fv1, "
            "…); only a [parameters] entry named like one of them can be held. Remove "
            "identify = false there."
        )
    return dataclasses.replace(chain, identify=tuple(n for n in names if n not in held))


_ = inertial  # re-exported conversions are documented next to the format
