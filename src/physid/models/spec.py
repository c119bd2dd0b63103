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

from pathlib import Path

from ..errors import ModelFileError
from ._locate import _line_of, _parameter_line, _parameter_where, _where  # noqa: F401
from .chain_symbolic import (  # noqa: F401
    _real_parts,
    check_nominal_values,
    check_transform,
    dh_transform,
    parse_expression,
    symbolic_chain,
)
from .spec_chain import _ATTRIBUTE_UNITS, _DH_KEYS, _DH_UNITS, _JOINT_KEYS, _parse_chain  # noqa: F401
from .spec_common import (  # noqa: F401
    _expr_text,
    _parse_parameters,
    _parse_recording,
    _tomllib,
    read_recording_map,
)
from .spec_linear_ode import _parse_linear_ode
from .spec_types import (  # noqa: F401
    _NAME_PATTERN,
    _RESERVED_PATTERN,
    FUNCTION_NAMES,
    KINDS,
    RESERVED_NAMES,
    ChainSpec,
    JointSpec,
    LinearODESpec,
    ParameterSpec,
)

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

        if "strict" in data and not isinstance(data["strict"], bool):
            raise ModelFileError(
                f"{_where(source, text, 'strict', 'strict')}: strict must be a TOML boolean, "
                f"true or false without quotes; got {data['strict']!r}."
            )

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
    if kind == "structure":
        from .spec_structure import _parse_structure

        return _parse_structure(data, text, source, name, params)
    return _parse_linear_ode(data, text, source, name, params)
