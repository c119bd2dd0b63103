"""The specification objects of model files, and the rules for the names they use.

`ParameterSpec`, `JointSpec`, `ChainSpec` and `LinearODESpec` are plain frozen dataclasses: hashing
the derivation-relevant part (`ChainSpec.derivation_content`) keys the on-disk cache, and a warm
load never needs sympy. `FUNCTION_NAMES` and `RESERVED_NAMES` say which names an expression may
call and which a parameter may not take.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

__all__ = [
    "ParameterSpec",
    "JointSpec",
    "ChainSpec",
    "LinearODESpec",
    "FUNCTION_NAMES",
    "RESERVED_NAMES",
    "KINDS",
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

KINDS = ("chain", "linear_ode", "structure")


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
