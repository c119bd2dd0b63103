"""TOML model files → model specifications → models, with errors that name the line and the fix.

The format is documented in ``docs/model-files.md``. Two kinds of model:

* ``kind = "chain"``: a serial manipulator, one ``[[joints]]`` table per revolute joint, each with
  ``dh = {a, alpha, d, offset}`` or ``transform = [[...4×4...]]``, a point ``mass`` and optional
  ``rotor_inertia``, ``viscous``, ``coulomb``; ``gravity = [gx, gy, gz]`` and
  ``kinetic_energy = "exact" | "paper"``.
* ``kind = "linear_ode"``: Σ a_i y^(i) = Σ b_i u^(i), with ``[ode] a = [...]`` (a_0 … a_{n−1};
  a_n = 1) and ``b = [...]`` (b_0 … b_m), each entry a parameter name.

Expressions are strings (or plain numbers) in the parameter names, the joint variable ``q<k>`` of
their own joint, ``pi`` and the usual functions (sin, cos, tan, sqrt, exp, log, ...).

The specification objects (`ChainSpec`, `LinearODESpec`) are plain frozen dataclasses: hashing
the derivation-relevant part (`ChainSpec.derivation_content`) keys the on-disk cache, and a warm
load never needs sympy.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import ModelFileError, PhysidError
from ._locate import _line_of, _parameter_line, _parameter_where, _where  # noqa: F401

__all__ = [
    "ParameterSpec",
    "JointSpec",
    "ChainSpec",
    "LinearODESpec",
    "read_model_file",
    "read_recording_map",
    "parse_model_text",
    "dh_transform",
    "RESERVED_NAMES",
]

#: Function and constant names an expression may use.
FUNCTION_NAMES = (
    "sin",
    "cos",
    "tan",
    "asin",
    "acos",
    "atan",
    "atan2",
    "sinh",
    "cosh",
    "tanh",
    "sqrt",
    "exp",
    "log",
    "Abs",
    "sign",
    "pi",
)
#: Names a parameter may not take (functions, joint variables and their derivatives).
RESERVED_NAMES = frozenset(FUNCTION_NAMES) | {"t", "E", "I", "S", "N", "Q", "O", "g"}
_RESERVED_PATTERN = re.compile(r"^(q|qd|qdd|tau|r)\d+$")
_NAME_PATTERN = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")

KINDS = ("chain", "linear_ode")


def _tomllib():
    try:
        import tomllib  # Python ≥ 3.11
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        try:
            import tomli as tomllib
        except ModuleNotFoundError:
            raise ModelFileError(
                "reading TOML model files needs Python ≥ 3.11 (tomllib) or the 'tomli' package on "
                "Python 3.10; install it with `pip install tomli`."
            ) from None
    return tomllib


# ---------------------------------------------------------------------------------------------
# specification objects
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ParameterSpec:
    """One model parameter: nominal ``value`` in SI ``unit``; ``identify`` marks it unknown.

    Attributes
    ----------
    name : str
        The symbol used in expressions.
    value : float
        Nominal value [unit].
    unit : str
        SI unit text.
    identify : bool
        Estimated by default.
    description : str
        Free text.
    where : str
        Where the model file defines it (for messages).
    """

    name: str
    value: float
    unit: str = ""
    identify: bool = True
    description: str = ""
    where: str = ""


@dataclass(frozen=True)
class JointSpec:
    """One revolute joint and the link it moves.

    Exactly one of ``dh`` (tuple of (key, expression) for ``a, alpha, d, offset``) and
    ``transform`` (4 × 4 tuple of expression strings) is set. ``mass`` sits at the origin of the
    link frame; ``rotor_inertia`` J adds ½ J q̇²; ``viscous``·q̇ + ``coulomb``·sign(q̇) is friction.
    ``where`` locates the joint's dh/transform key in the model file; ``locations`` holds
    ``(key, "file, line N (...)")`` pairs for the other keys, so that an error in ``mass`` names
    the line of ``mass`` (see `location`).

    Attributes
    ----------
    mass : str
        Expression of the point mass [kg].
    dh : tuple or None
        ``(key, expression)`` pairs of the Denavit-Hartenberg parameters.
    transform : tuple or None
        4 × 4 expression strings of the link transform.
    rotor_inertia, viscous, coulomb : str
        Expressions of J [kg·m²], the viscous [N·m·s/rad] and Coulomb [N·m] friction.
    name : str
        Joint name.
    where : str
        Where the joint is defined in the model file.
    locations : tuple
        ``(key, location)`` pairs of its other keys.
    """

    mass: str
    dh: tuple | None = None
    transform: tuple | None = None
    rotor_inertia: str = "0"
    viscous: str = "0"
    coulomb: str = "0"
    name: str = ""
    where: str = ""
    locations: tuple = field(default=(), compare=False)

    def location(self, key: str) -> str:
        """Where ``key`` (``"mass"``, ``"viscous"``, ...) is written; `where` if not recorded."""
        return dict(self.locations).get(key, self.where)

    def content(self) -> dict:
        """The expressions the derivation depends on (keys of the on-disk cache)."""
        return {
            "mass": self.mass,
            "dh": self.dh,
            "transform": self.transform,
            "rotor_inertia": self.rotor_inertia,
            "viscous": self.viscous,
            "coulomb": self.coulomb,
        }


@dataclass(frozen=True)
class ChainSpec:
    """A serial chain model: parameters, joints, gravity [m/s²] and kinetic-energy mode.

    Attributes
    ----------
    name : str
        Model name.
    parameters : tuple of ParameterSpec
        The parameters, in file order.
    joints : tuple of JointSpec
        The joints from the base outwards.
    gravity : tuple of float [m/s²]
        Gravity in the base frame.
    kinetic : {"exact", "paper"}
        Kinetic-energy mode.
    description : str
        Free text.
    source : str
        The file (or ``<built-in>``).
    text : str
        The file's text (for messages that quote a line).
    """

    name: str
    parameters: tuple
    joints: tuple
    gravity: tuple = (0.0, 0.0, -9.81)
    kinetic: str = "exact"
    description: str = ""
    source: str = "<built-in>"
    text: str = field(default="", repr=False, compare=False)

    @property
    def parameter_names(self) -> tuple:
        """Names of the parameters θ, in the order of the parameter vector."""
        return tuple(p.name for p in self.parameters)

    def derivation_content(self) -> dict:
        """What the symbolic derivation depends on (not values, units or descriptions)."""
        return {
            "kind": "chain",
            "parameters": list(self.parameter_names),
            "joints": [j.content() for j in self.joints],
            "gravity": [float(g) for g in self.gravity],
            "kinetic": self.kinetic,
        }


@dataclass(frozen=True)
class LinearODESpec:
    """A linear ODE Σ a_i y^(i) = Σ b_i u^(i) with a_n = 1; ``a``/``b`` hold parameter names.

    Attributes
    ----------
    name : str
        Model name.
    parameters : tuple of ParameterSpec
        The coefficients' parameters.
    a : tuple of str
        Names of a_0 … a_(n−1).
    b : tuple of str
        Names of b_0 … b_m.
    input_name, output_name : str
        Recording channels of u and y.
    description : str
        Free text.
    source : str
        The file (or ``<built-in>``).
    """

    name: str
    parameters: tuple
    a: tuple
    b: tuple
    input_name: str = "u"
    output_name: str = "x"
    description: str = ""
    source: str = "<built-in>"
    #: coefficient name -> expression over parameters, for coefficients written as expressions
    expressions: tuple = ()
    output_offset: str | None = None
    input_unit: str = ""
    output_unit: str = ""
    #: the [recording] table: channel -> file variable or expression (see docs/your-data.md)
    recording: tuple = ()


# ---------------------------------------------------------------------------------------------
# locating things in the TOML text (for error messages)
# ---------------------------------------------------------------------------------------------


# ---------------------------------------------------------------------------------------------
# reading TOML
# ---------------------------------------------------------------------------------------------


def read_model_file(path, *, strict: bool = False):
    """Read a TOML model file (or a URDF) into a specification (no sympy needed).

    Parameters
    ----------
    path : str or os.PathLike
        The ``.toml`` file (format: ``docs/model-files.md``), a URDF sidecar TOML
        (``extends = "robot.urdf"``) or a ``.urdf`` file.
    strict : bool
        Rigid-body models: refuse physically doubtful inertias instead of warning.

    Returns
    -------
    ChainSpec or LinearODESpec
        With ``source`` = the path, used in error messages.

    Raises
    ------
    ModelFileError
        The file is missing or unreadable, or its content is invalid (see `parse_model_text`).
    """
    path = Path(path)
    if path.suffix.lower() == ".urdf":
        from .urdf import read_urdf

        return read_urdf(path, strict=strict)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ModelFileError(
            f"model file {str(path)!r} does not exist; give the path of a .toml model file or a "
            f"built-in name ('manipulator', 'msd')."
        ) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"cannot read model file {str(path)!r}: {exc}.") from None
    if text.lstrip().startswith(("<?xml", "<robot")):
        from .urdf import parse_urdf

        return parse_urdf(text, str(path), strict=strict)
    return parse_model_text(text, source=str(path), strict=strict)


def _expr_text(value, where: str) -> str:
    if isinstance(value, bool):
        raise ModelFileError(f"{where}: expected a number or an expression string; got {value!r}.")
    if isinstance(value, (int, float)):
        return repr(float(value)) if isinstance(value, float) else str(value)
    if isinstance(value, str) and value.strip():
        return value.strip()
    raise ModelFileError(
        f'{where}: expected a number or an expression string such as "m1*l1**2/12"; got {value!r}.'
    )


def parse_model_text(text: str, source: str = "<string>", *, strict: bool = False):
    """Parse the TOML text of a model file into a specification.

    Only the structure is checked here (keys, tables, parameter values, 4×4 shape of
    transforms); expressions are parsed with sympy when the model is built
    (`model_from_spec`), and those errors too name the line of the offending key.

    Parameters
    ----------
    text : str
        TOML text in the format of ``docs/model-files.md``.
    source : str
        Name used in error messages (a file path, or ``"<string>"``).
    strict : bool
        Rigid-body chains: refuse physically doubtful inertias instead of warning.

    Returns
    -------
    ChainSpec or LinearODESpec or RigidChain
        ``kind = "chain"`` (the default) or ``kind = "linear_ode"``; rigid-body chains and
        URDF sidecars (``extends = "robot.urdf"``) give a `physid.models.rigid.RigidChain`.

    Raises
    ------
    ModelFileError
        Invalid TOML, unknown keys, a parameter with no or a non-finite value, a transform that
        is not 4×4, ... — each with ``source, line N (what)`` and the fix.

    Examples
    --------
    >>> spec = parse_model_text('''
    ... name = "pendulum"
    ... gravity = [0, -9.81, 0]
    ... [parameters]
    ... m1 = { value = 2.0, unit = "kg" }
    ... l1 = { value = 0.5, unit = "m" }
    ... [[joints]]
    ... dh = { a = "l1" }
    ... mass = "m1"
    ... ''')
    >>> spec.name, spec.parameter_names, spec.joints[0].dh
    ('pendulum', ('m1', 'l1'), (('a', 'l1'), ('alpha', '0'), ('d', '0'), ('offset', '0')))
    """
    tomllib = _tomllib()
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelFileError(
            f"{source}: not valid TOML: {exc}. Check quoting (expressions are strings: "
            f'a = "l2"), brackets and that every key is `name = value`.'
        ) from None
    if "extends" in data:
        from .urdf import read_sidecar

        return read_sidecar(data, source, strict=strict)
    kind = data.get("kind", "chain")
    if kind not in KINDS:
        raise ModelFileError(
            f"{_where(source, text, 'kind', 'kind')}: kind must be one of {KINDS}; got {kind!r}."
        )
    name = data.get("name")
    if not isinstance(name, str) or not name.strip():
        raise ModelFileError(f'{source}: the model needs a name, e.g. name = "my_arm" at the top.')
    params = _parse_parameters(data, text, source)
    if kind == "chain":
        from .rigid_spec import is_rigid_chain, parse_rigid_chain

        if is_rigid_chain(data):
            return parse_rigid_chain(data, text, source, name, params, strict=strict)
        return _parse_chain(data, text, source, name, params)
    return _parse_linear_ode(data, text, source, name, params)


def _parse_parameters(data: dict, text: str, source: str) -> tuple:
    table = data.get("parameters", {})
    if not isinstance(table, dict):
        raise ModelFileError(f"{source}: [parameters] must be a table of name = {{ value = ... }}.")
    params = []
    for pname, entry in table.items():
        where = _parameter_where(source, text, pname)
        if not _NAME_PATTERN.match(pname):
            raise ModelFileError(
                f"{where}: parameter name {pname!r} must start with a letter and hold only "
                "letters, "
                f"digits and '_'."
            )
        if pname in RESERVED_NAMES or _RESERVED_PATTERN.match(pname):
            raise ModelFileError(
                f"{where}: parameter name {pname!r} is reserved (function names, joint variables "
                f"q1, qd1, qdd1, tau1, r1, ...); rename it, e.g. {pname + '_'!r}."
            )
        if isinstance(entry, (int, float)) and not isinstance(entry, bool):
            entry = {"value": entry}
        if not isinstance(entry, dict):
            raise ModelFileError(
                f'{where}: write the parameter as {pname} = {{ value = 1.0, unit = "kg" }}; '
                f"got {entry!r}."
            )
        unknown = set(entry) - {"value", "unit", "identify", "description"}
        if unknown:
            raise ModelFileError(
                f"{where}: unknown key(s) {sorted(unknown)} for a parameter; allowed: value, unit, "
                f"identify, description."
            )
        if "value" not in entry:
            raise ModelFileError(
                f"{where}: parameter {pname!r} has no value; add value = <nominal value in SI "
                "units>."
            )
        value = entry["value"]
        if (
            isinstance(value, bool)
            or not isinstance(value, (int, float))
            or not math.isfinite(value)
        ):
            raise ModelFileError(
                f"{_parameter_where(source, text, pname, 'value')}: the value of {pname!r} must be "
                f"a finite number (nominal value in SI units); got {value!r}."
            )
        identify = entry.get("identify", True)
        if not isinstance(identify, bool):
            raise ModelFileError(
                f"{_parameter_where(source, text, pname, 'identify')}: identify must be true or "
                f"false; got {identify!r}."
            )
        params.append(
            ParameterSpec(
                name=pname,
                value=float(value),
                unit=str(entry.get("unit", "")),
                identify=identify,
                description=str(entry.get("description", "")),
                where=where,
            )
        )
    return tuple(params)


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
    joints_raw = data.get("joints")
    if not isinstance(joints_raw, list) or not joints_raw:
        raise ModelFileError(
            f"{source}: a chain model needs at least one [[joints]] table with dh = {{...}} or "
            f"transform = [[...]] and a mass."
        )
    joints = []
    for k, jt in enumerate(joints_raw):
        label = f"joints[{k + 1}]"

        def where(key, _k=k, _label=label):
            return _where(source, text, f"{_label}.{key}", key, table="joints", index=_k)

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
            raw = jt["dh"]
            if not isinstance(raw, dict):
                raise ModelFileError(
                    f"{where('dh')}: dh must be a table {{a = 0, alpha = 0, d = 0, offset = 0}}."
                )
            bad = set(raw) - set(_DH_KEYS)
            if bad:
                raise ModelFileError(
                    f"{where('dh')}: unknown DH key(s) {sorted(bad)}; allowed: a, alpha, d, offset "
                    f"(the joint angle itself is q{k + 1})."
                )
            dh = tuple((key, _expr_text(raw.get(key, 0), where("dh"))) for key in _DH_KEYS)
        else:
            raw = jt["transform"]
            shape_ok = (
                isinstance(raw, list)
                and len(raw) == 4
                and all(isinstance(r, list) and len(r) == 4 for r in raw)
            )
            if not shape_ok:
                shape = (
                    f"{len(raw)} rows of lengths "
                    f"{[len(r) if isinstance(r, list) else 1 for r in raw]}"
                    if isinstance(raw, list)
                    else type(raw).__name__
                )
                raise ModelFileError(
                    f"{where('transform')}: transform must be a 4×4 homogeneous matrix "
                    f"(4 rows of 4 entries); got {shape}."
                )
            transform = tuple(tuple(_expr_text(v, where("transform")) for v in row) for row in raw)
        key0 = "dh" if has_dh else "transform"
        if "mass" not in jt:
            raise ModelFileError(
                f"{_where(source, text, label, key0, table='joints', index=k)}: joint {k + 1} "
                f'has no mass; add mass = "m{k + 1}" (a parameter name, expression or number).'
            )
        locations = tuple(
            (key, where(key))
            for key in ("mass", "rotor_inertia", "viscous", "coulomb")
            if key in jt
        )
        joints.append(
            JointSpec(
                mass=_expr_text(jt["mass"], where("mass")),
                dh=dh,
                transform=transform,
                rotor_inertia=_expr_text(jt.get("rotor_inertia", 0), where("rotor_inertia")),
                viscous=_expr_text(jt.get("viscous", 0), where("viscous")),
                coulomb=_expr_text(jt.get("coulomb", 0), where("coulomb")),
                name=str(jt.get("name", f"joint{k + 1}")),
                where=_where(
                    source, text, label, "dh" if has_dh else "transform", table="joints", index=k
                ),
                locations=locations,
            )
        )
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


def _parse_linear_ode(data, text, source, name, params) -> LinearODESpec:
    allowed_top = {"name", "kind", "description", "parameters", "ode", "recording"}
    extra = set(data) - allowed_top
    if extra:
        raise ModelFileError(
            f"{_where(source, text, 'top level', sorted(extra)[0])}: unknown key(s) "
            f"{sorted(extra)} "
            f"for a linear_ode model; allowed: {sorted(allowed_top)}."
        )
    ode = data.get("ode")
    if not isinstance(ode, dict):
        raise ModelFileError(
            f"{source}: a linear_ode model needs an [ode] table with a = [a_0, ..., a_(n-1)] and "
            f"b = [b_0, ..., b_m] (parameter names; a_n = 1)."
        )
    names = {p.name for p in params}
    allowed_ode = {"a", "b", "input", "output", "output_offset", "input_unit", "output_unit"}
    extra = set(ode) - allowed_ode
    if extra:
        raise ModelFileError(
            f"{_where(source, text, 'ode', sorted(extra)[0], table='ode')}: unknown key(s) "
            f"{sorted(extra)} in [ode]; allowed: {sorted(allowed_ode)}."
        )
    out: dict = {}
    expressions: dict = {}
    for key in ("a", "b"):
        where = _where(source, text, f"ode.{key}", key, table="ode")
        seq = ode.get(key)
        if (
            not isinstance(seq, list)
            or not seq
            or not all(
                isinstance(s, str) or (isinstance(s, (int, float)) and not isinstance(s, bool))
                for s in seq
            )
        ):
            example = '["theta2", "theta1"] or ["k/m", "c/m"]' if key == "a" else '["1/m"]'
            raise ModelFileError(
                f"{where}: {key} must be a non-empty list of parameter names or expressions of "
                f"them, e.g. {example}; got {seq!r}."
            )
        coefs = []
        for i, entry in enumerate(seq):
            entry_text = repr(float(entry)) if not isinstance(entry, str) else entry.strip()
            if entry_text in names:
                coefs.append(entry_text)
                continue
            from ..expressions import FUNCTION_NAMES, expression_names

            try:
                used, called = expression_names(entry_text, source=f"{where}[{i}]")
            except PhysidError as exc:
                raise ModelFileError(str(exc)) from None
            bad_calls = [f for f in called if f not in FUNCTION_NAMES]
            if bad_calls:
                raise ModelFileError(
                    f"{where}: unknown function(s) {bad_calls} in ode.{key} (entry {i}: "
                    f"{entry_text!r}); allowed: {', '.join(FUNCTION_NAMES)}."
                )
            unknown_names = [u for u in used if u not in names and u != "pi"]
            if unknown_names:
                shown = repr(unknown_names[0]) if len(unknown_names) == 1 else unknown_names
                raise ModelFileError(
                    f"{where}: unknown symbol "
                    f"{shown} in "
                    f"ode.{key} (entry {i}: {entry_text!r}); declare each under [parameters] "
                    f"({unknown_names[0]} = {{ value = ..., identify = true }}). Known: "
                    f"{sorted(names)}."
                )
            coef = f"{key}{i}"
            while coef in names or coef in expressions:
                coef += "_"
            expressions[coef] = entry_text
            coefs.append(coef)
        out[key] = tuple(coefs)
    if len(out["b"]) > len(out["a"]):
        raise ModelFileError(
            f"{_where(source, text, 'ode.b', 'b', table='ode')}: the input order m = "
            f"{len(out['b']) - 1} "
            f"must be below the output order n = {len(out['a'])} (a strictly proper model); drop "
            f"entries from b or add entries to a."
        )
    offset = ode.get("output_offset")
    if offset is not None and (not isinstance(offset, str) or offset not in names):
        raise ModelFileError(
            f"{_where(source, text, 'ode.output_offset', 'output_offset', table='ode')}: "
            f'output_offset must name a declared parameter (e.g. output_offset = "offset" '
            f'with offset = {{ value = 0.0, unit = "m" }} under [parameters]); got {offset!r}.'
        )
    if offset is not None and offset in set(out["a"] + out["b"]):
        raise ModelFileError(
            f"{_where(source, text, 'ode.output_offset', 'output_offset', table='ode')}: "
            f"output_offset {offset!r} is also a coefficient; declare a separate parameter."
        )
    units = {}
    for key in ("input_unit", "output_unit"):
        value = ode.get(key, "")
        if not isinstance(value, str):
            raise ModelFileError(f'{source}: ode.{key} must be a unit string such as "N".')
        if value:
            from ..units import parse_unit

            try:
                parse_unit(value)
            except PhysidError as exc:
                where = _where(source, text, f"ode.{key}", key, table="ode")
                raise ModelFileError(f"{where}: {exc}") from None
        units[key] = value
    return LinearODESpec(
        name=name,
        parameters=params,
        a=out["a"],
        b=out["b"],
        input_name=str(ode.get("input", "u")),
        output_name=str(ode.get("output", "x")),
        description=str(data.get("description", "")),
        source=source,
        expressions=tuple(expressions.items()),
        output_offset=offset,
        input_unit=units["input_unit"],
        output_unit=units["output_unit"],
        recording=tuple(_parse_recording(data, text, source).items()),
    )


def _parse_recording(data: dict, text: str, source: str) -> dict:
    """The ``[recording]`` table: channel = "file variable or expression" (a channel map)."""
    table = data.get("recording", {})
    if not isinstance(table, dict):
        raise ModelFileError(
            f'{source}: [recording] must be a table of channel = "source", e.g. t = "time", '
            'q1 = "qm", tau1 = "gtau*vir".'
        )
    out = {}
    for key, value in table.items():
        if not isinstance(value, str) or not value.strip():
            where = _where(source, text, f"recording.{key}", key, table="recording")
            raise ModelFileError(
                f"{where}: recording.{key} must be a string naming a variable of the file or an "
                f'expression over them, e.g. {key} = "gtau*vir"; got {value!r}.'
            )
        out[str(key)] = value.strip()
    return out


def read_recording_map(path) -> dict:
    """The ``[recording]`` channel map of a model file (empty if it has none).

    Parameters
    ----------
    path : str or Path
        A ``.toml`` model file (chain or linear ODE).

    Returns
    -------
    dict
        channel → source text, for `physid.load_recording(path, channels=...)`.

    Raises
    ------
    ModelFileError
        The file cannot be read, is not TOML, or the table is malformed.
    """
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ModelFileError(f"cannot read model file {str(path)!r}: {exc}.") from None
    tomllib = _tomllib()
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ModelFileError(f"{path}: not valid TOML: {exc}.") from None
    return _parse_recording(data, text, str(path))


# ---------------------------------------------------------------------------------------------
# symbolic side (sympy only imported here and in the derivation)
# ---------------------------------------------------------------------------------------------


def dh_transform(a, alpha, d, theta):
    """Standard (distal) Denavit–Hartenberg transform T = Rz(θ) Tz(d) Tx(a) Rx(α).

    ::

        ⎡cos θ  −sin θ cos α   sin θ sin α   a cos θ⎤
        ⎢sin θ   cos θ cos α  −cos θ sin α   a sin θ⎥
        ⎢  0        sin α         cos α         d   ⎥
        ⎣  0          0             0           1   ⎦

    With a = 0, α = π/2 this is the paper's T1 and with a = l_k, α = 0 its T2..T4 (Cedro &
    Janecki, section 2), for θ = φ_k.

    Parameters
    ----------
    a : number or sympy expression [m]
        Link length (translation along the new x axis).
    alpha : number or sympy expression [rad]
        Link twist (rotation about the new x axis).
    d : number or sympy expression [m]
        Link offset (translation along the old z axis).
    theta : number or sympy expression [rad]
        Joint angle (rotation about the old z axis), q_k + offset.

    Returns
    -------
    sympy.Matrix, shape (4, 4)
        The homogeneous transform from the link frame to the previous one.

    Examples
    --------
    >>> import sympy as sp
    >>> q, l = sp.symbols("q l")
    >>> dh_transform(l, 0, 0, q)[:2, 3].T
    Matrix([[l*cos(q), l*sin(q)]])
    """
    import sympy as sp

    ct, st = sp.cos(theta), sp.sin(theta)
    ca, sa = sp.cos(alpha), sp.sin(alpha)
    return sp.Matrix(
        [
            [ct, -st * ca, st * sa, a * ct],
            [st, ct * ca, -ct * sa, a * st],
            [0, sa, ca, d],
            [0, 0, 0, 1],
        ]
    )


def parse_expression(
    text: str,
    symbols: dict,
    where: str,
    *,
    allowed_hint: str = "",
    unit: str = "",
    variable_hint: str = "",
):
    """Parse one expression string with only ``symbols`` and the standard functions allowed.

    The parsing is `physid.expressions.parse_expression` (a whitelist over Python's syntax tree;
    nothing is evaluated); this wrapper words its errors for model files.

    Parameters
    ----------
    text : str
        The expression, in Python syntax (``"m1*l1**2/12"``, ``"cos(q1)"``).
    symbols : dict of str to sympy.Symbol
        The names the expression may use.
    where : str
        Location for error messages (``"arm.toml, line 7 (joints[1].mass)"``).
    allowed_hint : str
        Appended to the unknown-symbol message (e.g. the declared parameters).
    unit : str
        SI unit of the key (``"kg"`` for a mass), suggested in the "declare it under
        [parameters]" fix when the unknown symbol is the whole expression; empty: none.
    variable_hint : str
        Message used when an unknown symbol is a reserved name (another joint's ``q<k>``,
        ``qd<k>``, ``qdd<k>``, ...), which cannot be declared as a parameter.

    Returns
    -------
    sympy.Expr
        A finite real expression in ``symbols``.

    Raises
    ------
    ModelFileError
        The text does not parse, uses a forbidden construct (strings, attributes, ...), an
        unknown symbol or function, is too large, or is not finite and real.

    Examples
    --------
    >>> import sympy as sp
    >>> m, l = sp.symbols("m l")
    >>> parse_expression("m1*l1**2/12", {"m1": m, "l1": l}, "demo")
    l**2*m/12
    """
    from ..errors import ExpressionError
    from ..expressions import _clip, _clip_names
    from ..expressions import parse_expression as _parse

    try:
        return _real_parts(_parse(text, symbols, source=where))
    except ExpressionError as exc:
        shown = _clip(text)
        if exc.reason == "unknown_function":
            raise ModelFileError(
                f"{where}: unknown function(s) {_clip_names(exc.names)} in {shown}; allowed "
                f"functions: {', '.join(n for n in FUNCTION_NAMES if n != 'pi')}."
            ) from None
        if exc.reason != "unknown_name":
            raise ModelFileError(str(exc)) from None
        unknown = list(exc.names)
    reserved = [u for u in unknown if u in RESERVED_NAMES or _RESERVED_PATTERN.match(u)]
    if reserved:
        fix = variable_hint or (
            "these are reserved names (joint variables q<k>, qd<k>, qdd<k>, tau<k>, functions), "
            "not parameters"
        )
        raise ModelFileError(
            f"{where}: symbol(s) {_clip_names(reserved)} may not appear in {shown}: {fix}."
        )
    # the key's unit fits the symbol only when the symbol is the whole expression
    unit_text = f', unit = "{unit}"' if unit and text.strip() == unknown[0] else ""
    hint = allowed_hint if len(allowed_hint) <= 300 else allowed_hint[:280] + " ..."
    raise ModelFileError(
        f"{where}: unknown symbol(s) {_clip_names(unknown)} in {shown}; declare each under "
        f"[parameters] (e.g. {unknown[0][:40]} = {{ value = 1.0{unit_text} }}){hint}."
    )


def _real_parts(expr):
    """``expr`` with ``re(x)`` → ``x``, ``im(x)`` → 0 and ``conjugate(x)`` → ``x``: every name of a
    model file is real, but sympy's symbols carry no assumptions, so it writes ``abs(exp(m1))`` as
    ``exp(re(m1))``, which the code printers of the derivation cannot print (issue 16 fuzz)."""
    import sympy as sp

    if not expr.has(sp.re, sp.im, sp.conjugate):
        return expr
    return (
        expr.replace(sp.re, lambda x: x)
        .replace(sp.im, lambda x: 0)
        .replace(sp.conjugate, lambda x: x)
    )


def check_transform(
    T, q_sym, theta_syms, theta_values, where: str, *, joint: int, rng=None
) -> None:
    """Raise `ModelFileError` unless T is a rigid homogeneous transform at random q.

    Checks: bottom row (0, 0, 0, 1) and R Rᵀ = I, det R = +1 for the rotation part, numerically at
    five random joint angles with the parameters at their nominal values.
    """
    import numpy as np
    import sympy as sp

    rng = np.random.default_rng(12345) if rng is None else rng
    f = sp.lambdify([q_sym, *theta_syms], T, modules="numpy")
    for qv in rng.uniform(-np.pi, np.pi, size=5):
        try:
            Tn = np.array(f(qv, *theta_values), dtype=float)
        except (TypeError, ValueError, ZeroDivisionError) as exc:
            raise ModelFileError(
                f"{where}: cannot evaluate the transform numerically ({exc})."
            ) from None
        if not np.all(np.isfinite(Tn)):
            raise ModelFileError(
                f"{where}: the transform is not finite at q{joint} = {qv:.3f} rad."
            )
        if not np.allclose(Tn[3], [0, 0, 0, 1], atol=1e-9):
            raise ModelFileError(
                f"{where}: the bottom row of the transform of joint {joint} must be [0, 0, 0, 1]; "
                f"got {np.round(Tn[3], 6).tolist()} at q{joint} = {qv:.3f} rad."
            )
        R = Tn[:3, :3]
        with np.errstate(all="ignore"):  # entries near 1e308 overflow in R Rᵀ: not a rotation
            err = float(np.abs(R @ R.T - np.eye(3)).max())
            det = float(np.linalg.det(R)) if np.isfinite(err) else float("nan")
        if not err <= 1e-8 or not det > 0:
            raise ModelFileError(
                f"{where}: the rotation part (upper-left 3×3) of the transform of joint {joint} is "
                f"not orthonormal with det +1 (max |R Rᵀ − I| = {err:.3g}, det = "
                f"{det:.4g} at q{joint} = {qv:.3f} rad, nominal parameters). Check "
                f"signs and sin/cos placement; a rotation about z is [[cos(q), -sin(q), 0], "
                f"[sin(q), cos(q), 0], [0, 0, 1]]."
            )


def check_nominal_values(spec: ChainSpec) -> None:
    """Refuse a chain whose constant expressions are not finite and real at the nominal values.

    Evaluates every DH entry, mass, rotor inertia and friction coefficient numerically
    (`physid.expressions.evaluate_expression`, no sympy, so a warm-cache load checks too) with
    the parameters at their nominal values: ``mass = "m1/(l1 - 0.5)"`` with l1 = 0.5 or
    ``rotor_inertia = "sqrt(-m1)"`` is an error naming its line, not a model full of NaN.
    Transforms (functions of q) are checked by `check_transform` during the derivation.

    Parameters
    ----------
    spec : ChainSpec

    Raises
    ------
    ModelFileError
        An expression that does not parse, uses an unknown name, or has no finite real value.
    """
    import numpy as np

    from ..errors import ExpressionError
    from ..expressions import _clip, evaluate_expression

    values = {p.name: p.value for p in spec.parameters}
    shown = ", ".join(f"{k}={v:.6g}" for k, v in list(values.items())[:12])
    for k, joint in enumerate(spec.joints):
        jt_where = joint.where or f"{spec.source} (joints[{k + 1}])"
        items = [(f"{jt_where} dh.{key}", txt) for key, txt in (joint.dh or ())]
        items += [
            (joint.location(attr) if attr in dict(joint.locations) else f"{jt_where} {attr}", txt)
            for attr, txt in (
                ("mass", joint.mass),
                ("rotor_inertia", joint.rotor_inertia),
                ("viscous", joint.viscous),
                ("coulomb", joint.coulomb),
            )
        ]
        for where, txt in items:
            try:
                value = evaluate_expression(txt, values, source=where)
            except ExpressionError:
                continue  # unknown names etc.: parse_expression words these with the model's hints
            if value.ndim != 0 or not np.isfinite(value):
                raise ModelFileError(
                    f"{where}: the expression {_clip(txt)} has no finite real value at the nominal "
                    f"parameter values ({shown}): got {float(value) if value.ndim == 0 else value}. "
                    "Check divisions by a parameter that is zero and square roots or logarithms of "
                    "negative values; give the parameters nominal values where the model is valid."
                )


def symbolic_chain(spec: ChainSpec):
    """Parse and validate a chain spec; return the sympy pieces for the derivation.

    Parameters
    ----------
    spec : ChainSpec

    Returns
    -------
    dict
        ``q, qd, qdd, theta`` (tuples of internal symbols ``_q0``, ``_th0``, ...),
        ``transforms`` (list of 4×4 sympy matrices), ``axis_static``, ``masses``,
        ``rotor_inertias``, ``viscous``, ``coulomb`` (lists of sympy expressions, one per joint).

    Raises
    ------
    ModelFileError
        An expression does not parse or uses an unknown symbol (the message names the line of
        its key), or a transform is not a rigid homogeneous transform.
    """
    import sympy as sp

    n = len(spec.joints)
    # plain symbols (no assumptions): assumption queries dominate sympy's time on big trees
    q = tuple(sp.Symbol(f"_q{i}") for i in range(n))
    qd = tuple(sp.Symbol(f"_qd{i}") for i in range(n))
    qdd = tuple(sp.Symbol(f"_qdd{i}") for i in range(n))
    theta = tuple(sp.Symbol(f"_th{i}") for i in range(len(spec.parameters)))
    param_syms = {p.name: s for p, s in zip(spec.parameters, theta, strict=False)}
    values = [p.value for p in spec.parameters]
    out = {
        "q": q,
        "qd": qd,
        "qdd": qdd,
        "theta": theta,
        "transforms": [],
        "axis_static": [],
        "masses": [],
        "rotor_inertias": [],
        "viscous": [],
        "coulomb": [],
    }
    declared = ", ".join(param_syms) or "none"
    for k, joint in enumerate(spec.joints):
        jt_where = joint.where or f"{spec.source} (joints[{k + 1}])"
        with_q = dict(param_syms)
        with_q[f"q{k + 1}"] = q[k]
        hint_q = f"; the transform may use the joint variable q{k + 1} and: {declared}"
        hint = f"; declared parameters: {declared}"
        only_own = (
            f"only q{k + 1} of this joint may appear in its transform (joint variables are "
            "reserved names, not parameters)"
        )
        no_variables = (
            f"joint variables may not appear here; the angle q{k + 1} enters through the DH "
            "rotation about z (use offset for a constant angle)"
        )
        if joint.dh is not None:
            dh = {
                key: parse_expression(
                    txt,
                    param_syms,
                    f"{jt_where} dh.{key}",
                    allowed_hint=hint,
                    unit=_DH_UNITS[key],
                    variable_hint=no_variables,
                )
                for key, txt in joint.dh
            }
            T = dh_transform(dh["a"], dh["alpha"], dh["d"], q[k] + dh["offset"])
            static = dh_transform(dh["a"], dh["alpha"], dh["d"], dh["offset"])  # T = Rz(q) S
        else:
            rows = [
                [
                    parse_expression(
                        txt,
                        with_q,
                        f"{jt_where} transform[{r}][{c}]",
                        allowed_hint=hint_q,
                        unit="m" if c == 3 and r < 3 else "",  # translation column; rotation: 1
                        variable_hint=only_own,
                    )
                    for c, txt in enumerate(row)
                ]
                for r, row in enumerate(joint.transform)
            ]
            T = sp.Matrix(rows)
            check_transform(T, q[k], theta, values, jt_where, joint=k + 1)
            static = None
        out["transforms"].append(T)
        out["axis_static"].append(static)
        for key, attr in (
            ("masses", "mass"),
            ("rotor_inertias", "rotor_inertia"),
            ("viscous", "viscous"),
            ("coulomb", "coulomb"),
        ):
            out[key].append(
                parse_expression(
                    getattr(joint, attr),
                    param_syms,
                    dict(joint.locations).get(attr, f"{jt_where} {attr}"),
                    allowed_hint=hint,
                    unit=_ATTRIBUTE_UNITS[attr],
                    variable_hint=(
                        f"the {attr} of a joint is a constant; joint variables (q<k>, qd<k>, "
                        "qdd<k>) may not appear in it"
                    ),
                )
            )
    return out
