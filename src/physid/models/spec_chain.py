"""The TOML tables of a chain model file (``kind = "chain"``): the top level and the joints."""

from __future__ import annotations

from ..errors import ModelFileError
from ._locate import _where
from .spec_common import _expr_text
from .spec_types import ChainSpec, JointSpec

_JOINT_KEYS = {"name", "dh", "transform", "mass", "rotor_inertia", "viscous", "coulomb"}
_DH_KEYS = ("a", "alpha", "d", "offset")
#: SI units suggested when an unknown symbol should be declared as a parameter.
_DH_UNITS = {"a": "m", "alpha": "rad", "d": "m", "offset": "rad"}
_ATTRIBUTE_UNITS = {
    "mass": "kg",
    "rotor_inertia": "kg*m^2",
    "viscous": "N*m*s/rad",
    "coulomb": "N*m",
}


def _parse_chain(data, text, source, name, params) -> ChainSpec:
    """The chain tables of a parsed TOML file as a `ChainSpec` (structure only; no sympy)."""
    gravity, kinetic = _chain_top_level(data, text, source)
    joints_raw = data.get("joints")
    if not isinstance(joints_raw, list) or not joints_raw:
        raise ModelFileError(
            f"{source}: a chain model needs at least one [[joints]] table with dh = {{...}} or "
            f"transform = [[...]] and a mass."
        )
    joints = [_parse_joint(k, jt, text, source) for k, jt in enumerate(joints_raw)]
    return ChainSpec(
        name=name,
        parameters=params,
        joints=tuple(joints),
        gravity=tuple(float(g) for g in gravity),
        kinetic=kinetic,
        description=str(data.get("description", "")),
        source=source,
        text=text,
    )


def _chain_top_level(data, text, source) -> tuple:
    """The top-level keys of a chain file checked; its ``gravity`` and ``kinetic_energy``."""
    allowed_top = {
        "name",
        "kind",
        "description",
        "gravity",
        "kinetic_energy",
        "parameters",
        "joints",
        "recording",  # the channel map, read by read_recording_map (docs/your-data.md)
    }
    extra = set(data) - allowed_top
    if extra:
        raise ModelFileError(
            f"{_where(source, text, 'top level', sorted(extra)[0])}: unknown key(s) "
            f"{sorted(extra)} "
            f"for a chain model; allowed: {sorted(allowed_top)}."
        )
    gravity = data.get("gravity", [0.0, 0.0, -9.81])
    where_g = _where(source, text, "gravity", "gravity")
    if (
        not isinstance(gravity, list)
        or len(gravity) != 3
        or not all(isinstance(g, (int, float)) and not isinstance(g, bool) for g in gravity)
    ):
        raise ModelFileError(
            f"{where_g}: gravity must be three numbers [gx, gy, gz] in m/s² (base frame); got "
            f"{gravity!r}."
        )
    kinetic = data.get("kinetic_energy", "exact")
    if kinetic not in ("exact", "paper"):
        raise ModelFileError(
            f"{_where(source, text, 'kinetic_energy', 'kinetic_energy')}: kinetic_energy must be "
            f'"exact" or "paper"; got {kinetic!r}.'
        )
    return gravity, kinetic


def _parse_joint(k: int, jt, text: str, source: str) -> JointSpec:
    """The ``k``-th ``[[joints]]`` table (from 0) as a `JointSpec`."""
    label = f"joints[{k + 1}]"

    def where(key):
        return _where(source, text, f"{label}.{key}", key, table="joints", index=k)

    unknown = set(jt) - _JOINT_KEYS
    if unknown:
        raise ModelFileError(
            f"{where(sorted(unknown)[0])}: unknown key(s) {sorted(unknown)} in a joint; "
            "allowed: "
            f"{sorted(_JOINT_KEYS)}."
        )
    has_dh, has_tf = "dh" in jt, "transform" in jt
    if has_dh == has_tf:
        raise ModelFileError(
            f"{_where(source, text, label, 'mass', table='joints', index=k)}: give exactly one "
            f"of dh = {{a = ..., alpha = ..., d = ..., offset = ...}} or transform = "
            "[[4×4]] for "
            f"joint {k + 1}; got {'both' if has_dh else 'neither'}."
        )
    dh = transform = None
    if has_dh:
        dh = _joint_dh(jt["dh"], k, where("dh"))
    else:
        transform = _joint_transform(jt["transform"], where("transform"))
    key0 = "dh" if has_dh else "transform"
    if "mass" not in jt:
        raise ModelFileError(
            f"{_where(source, text, label, key0, table='joints', index=k)}: joint {k + 1} "
            f'has no mass; add mass = "m{k + 1}" (a parameter name, expression or number).'
        )
    locations = tuple(
        (key, where(key)) for key in ("mass", "rotor_inertia", "viscous", "coulomb") if key in jt
    )
    return JointSpec(
        mass=_expr_text(jt["mass"], where("mass")),
        dh=dh,
        transform=transform,
        rotor_inertia=_expr_text(jt.get("rotor_inertia", 0), where("rotor_inertia")),
        viscous=_expr_text(jt.get("viscous", 0), where("viscous")),
        coulomb=_expr_text(jt.get("coulomb", 0), where("coulomb")),
        name=str(jt.get("name", f"joint{k + 1}")),
        where=_where(source, text, label, key0, table="joints", index=k),
        locations=locations,
    )


def _joint_dh(raw, k: int, where: str) -> tuple:
    """The ``dh`` table of joint ``k`` (from 0) as ``(key, expression)`` pairs."""
    if not isinstance(raw, dict):
        raise ModelFileError(
            f"{where}: dh must be a table {{a = 0, alpha = 0, d = 0, offset = 0}}."
        )
    bad = set(raw) - set(_DH_KEYS)
    if bad:
        raise ModelFileError(
            f"{where}: unknown DH key(s) {sorted(bad)}; allowed: a, alpha, d, offset "
            f"(the joint angle itself is q{k + 1})."
        )
    return tuple((key, _expr_text(raw.get(key, 0), where)) for key in _DH_KEYS)


def _joint_transform(raw, where: str) -> tuple:
    """The ``transform`` of a joint as 4 × 4 expression strings."""
    shape_ok = (
        isinstance(raw, list)
        and len(raw) == 4
        and all(isinstance(r, list) and len(r) == 4 for r in raw)
    )
    if not shape_ok:
        shape = (
            f"{len(raw)} rows of lengths {[len(r) if isinstance(r, list) else 1 for r in raw]}"
            if isinstance(raw, list)
            else type(raw).__name__
        )
        raise ModelFileError(
            f"{where}: transform must be a 4×4 homogeneous matrix "
            f"(4 rows of 4 entries); got {shape}."
        )
    return tuple(tuple(_expr_text(v, where) for v in row) for row in raw)
