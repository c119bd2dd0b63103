"""Units of recording channels: one explicit table, one rule for every file format.

A unit string (from a CSV header ``pos [deg]``, an HDF5/MAT ``unit`` attribute, a channel map
``tau1=35.15*vir [N]`` or a model file) is parsed into a scale to SI and a dimension over
(length, mass, time, current, angle). Values are multiplied by the scale at load time, so every
channel physid computes with is in SI; the unit kept on the recording is the SI unit (the
original string is kept when it already is SI, scale 1, e.g. ``"N*m"`` or ``"Hz"``).

Why a table and not pint: physid reads mechanical signals. The units those carry are few (lengths,
angles, times, forces, torques, their rates, volts and amperes of drives), a table of them is
deterministic and versioned with the code, costs no dependency, and refuses what it does not
know (``degC``, ``counts``) instead of guessing. Angle is kept as its own dimension (SI treats
the radian as 1) so that ``deg`` → ``rad`` is a conversion and a length is never read as an angle.

Grammar: factors joined by ``*``, ``·``, ``.`` or a space, one ``/`` after which every factor is in
the denominator (``N·s/m``, ``m/s^2``, ``1/s``, ``kg·m^2``), powers as ``^2``, ``**2``, ``2`` right
after a letter (``s2``, ``m2``) or ``²``/``³``; optional parentheses around the denominator.
Prefixes n, µ/u, m, c, k, M, G apply to m, g, s, N, V, A, Pa, W, J, Hz and rad; ``Nm`` (with its
prefixed forms ``mNm``, ``kNm``, ``Nmm``) is the newton-metre, not a nanometre.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from .errors import InputError

__all__ = [
    "Unit",
    "parse_unit",
    "to_si",
    "same_dimension",
    "dimension_name",
    "expected_dimensions",
    "KNOWN_UNITS",
]

# dimension exponents over (m, kg, s, A, rad)
_L, _M, _T, _I, _ANG = (
    (1, 0, 0, 0, 0),
    (0, 1, 0, 0, 0),
    (0, 0, 1, 0, 0),
    (0, 0, 0, 1, 0),
    (0, 0, 0, 0, 1),
)
_ONE = (0, 0, 0, 0, 0)


def _mul(a, b, k=1):
    return tuple(x + k * y for x, y in zip(a, b, strict=True))


_N = (1, 1, -2, 0, 0)
_V = (2, 1, -3, -1, 0)

#: base units that take SI prefixes: symbol -> (scale to SI, dimension)
_PREFIXABLE = {
    "m": (1.0, _L),
    "g": (1e-3, _M),
    "s": (1.0, _T),
    "N": (1.0, _N),
    "V": (1.0, _V),
    "A": (1.0, _I),
    "Pa": (1.0, (-1, 1, -2, 0, 0)),
    "W": (1.0, (2, 1, -3, 0, 0)),
    "J": (1.0, (2, 1, -2, 0, 0)),
    "Hz": (1.0, (0, 0, -1, 0, 0)),
    "rad": (1.0, _ANG),
    "Nm": (1.0, (2, 1, -2, 0, 0)),
}
_PREFIXES = {"n": 1e-9, "µ": 1e-6, "μ": 1e-6, "u": 1e-6, "m": 1e-3, "c": 1e-2, "k": 1e3, "M": 1e6}
_PREFIXES["G"] = 1e9

#: units without prefixes: symbol -> (scale to SI, dimension)
_PLAIN = {
    "deg": (math.pi / 180.0, _ANG),
    "degree": (math.pi / 180.0, _ANG),
    "degrees": (math.pi / 180.0, _ANG),
    "°": (math.pi / 180.0, _ANG),
    "rev": (2.0 * math.pi, _ANG),
    "turn": (2.0 * math.pi, _ANG),
    "rpm": (2.0 * math.pi / 60.0, (0, 0, -1, 0, 1)),
    "min": (60.0, _T),
    "h": (3600.0, _T),
    "sec": (1.0, _T),
    "in": (0.0254, _L),
    "ft": (0.3048, _L),
    "lbf": (4.4482216152605, _N),
    "Nmm": (1e-3, (2, 1, -2, 0, 0)),
    "1": (1.0, _ONE),
    "-": (1.0, _ONE),
    "%": (0.01, _ONE),
}

#: canonical SI spelling of common dimensions (the unit written after a conversion)
_CANONICAL = {
    _ONE: "",
    _L: "m",
    _M: "kg",
    _T: "s",
    _I: "A",
    _ANG: "rad",
    _N: "N",
    (2, 1, -2, 0, 0): "N·m",
    (1, 0, -1, 0, 0): "m/s",
    (1, 0, -2, 0, 0): "m/s^2",
    (0, 0, -1, 0, 1): "rad/s",
    (0, 0, -2, 0, 1): "rad/s^2",
    (0, 0, -1, 0, 0): "1/s",
    (0, 0, -2, 0, 0): "1/s^2",
    _V: "V",
    (-1, 1, -2, 0, 0): "Pa",
    (2, 1, -3, 0, 0): "W",
    (0, 1, -1, 0, 0): "N·s/m",
    (0, 1, -2, 0, 0): "N/m",
    (1, 1, -1, 0, 0): "N·s",
    (2, 1, -2, 0, -1): "N·m/rad",
    (2, 1, -1, 0, -1): "N·m·s/rad",
    (2, 1, 0, 0, 0): "kg·m^2",
    (2, 1, 0, 0, -2): "kg·m^2/rad^2",
    (1, 1, -2, -1, 0): "N/A",
    (2, 1, -2, -1, 0): "N·m/A",
}

#: words for error messages
_WORDS = {
    _ONE: "dimensionless",
    _L: "a length",
    _M: "a mass",
    _T: "a time",
    _I: "a current",
    _ANG: "an angle",
    _N: "a force",
    (2, 1, -2, 0, 0): "a torque",
    (1, 0, -1, 0, 0): "a velocity",
    (1, 0, -2, 0, 0): "an acceleration",
    (0, 0, -1, 0, 1): "an angular velocity",
    (0, 0, -2, 0, 1): "an angular acceleration",
    (0, 0, -1, 0, 0): "a frequency",
    _V: "a voltage",
}

KNOWN_UNITS = tuple(sorted(set(_PREFIXABLE) | set(_PLAIN) - {"1", "-"}))

_TOKEN = re.compile(r"([A-Za-zµμ°%]+|1|-)(?:\^(-?\d+)|\*\*(-?\d+)|([²³])|(\d+))?$")


@dataclass(frozen=True)
class Unit:
    """A parsed unit: ``value_si = value * scale``; ``dimension`` over (m, kg, s, A, rad).

    Attributes
    ----------
    text : str
        The unit as written.
    scale : float
        Factor to SI.
    dimension : tuple of int, length 5
        Exponents of m, kg, s, A, rad.
    si : str
        The SI unit the values are in after multiplying by ``scale`` (``text`` itself when
        ``scale == 1``).
    """

    text: str
    scale: float
    dimension: tuple
    si: str

    @property
    def words(self) -> str:
        """The dimension in words ("a length", "a torque"), or its SI unit."""
        return dimension_name(self.dimension)


def _canonical(dim) -> str:
    if dim in _CANONICAL:
        return _CANONICAL[dim]
    top = [(s, e) for s, e in zip(("m", "kg", "s", "A", "rad"), dim, strict=True) if e > 0]
    bottom = [(s, -e) for s, e in zip(("m", "kg", "s", "A", "rad"), dim, strict=True) if e < 0]

    def join(parts):
        return "·".join(s if e == 1 else f"{s}^{e}" for s, e in parts)

    num = join(top) or "1"
    return f"{num}/{join(bottom)}" if bottom else num


def dimension_name(dim) -> str:
    """Words for a dimension tuple (``"a torque"``), else ``"a quantity in <SI unit>"``."""
    dim = tuple(dim)
    return _WORDS.get(dim, f"a quantity in {_canonical(dim)}")


def _symbol(sym: str, whole: str) -> tuple[float, tuple]:
    if sym in _PLAIN:
        return _PLAIN[sym]
    if sym in _PREFIXABLE:
        return _PREFIXABLE[sym]
    for p, f in _PREFIXES.items():
        if sym.startswith(p) and sym[len(p) :] in _PREFIXABLE:
            base = sym[len(p) :]
            if p == "c" and base != "m":
                continue
            scale, dim = _PREFIXABLE[base]
            return f * scale, dim
    raise InputError(
        f"unknown unit {whole!r} (the factor {sym!r} is not in physid's table); known units: "
        f"{', '.join(KNOWN_UNITS)} with the prefixes n, u, m, c, k, M, G (e.g. mm, kN, mN·m, ms). "
        "Convert the values to SI, or scale them by their gain to SI."
    )


def parse_unit(text: str) -> Unit:
    """Parse a unit string.

    Parameters
    ----------
    text : str
        E.g. ``"deg"``, ``"mm/s"``, ``"kN"``, ``"N·m"``, ``"rpm"``, ``"m/s^2"``, ``""`` (none).

    Returns
    -------
    Unit

    Raises
    ------
    InputError
        A factor that is not in the table, or a malformed string (the message lists the table).

    Examples
    --------
    >>> u = parse_unit("deg/s")
    >>> round(u.scale, 12), u.si
    (0.01745329252, 'rad/s')
    >>> parse_unit("N*m").si, parse_unit("kN").scale
    ('N*m', 1000.0)
    """
    if not isinstance(text, str):
        raise InputError(f"a unit must be a string; got {text!r} of type {type(text).__name__}.")
    raw = text
    text = text.strip()
    if not text:
        return Unit("", 1.0, _ONE, "")
    if len(text) > 64:
        raise InputError(f"unit {raw[:40]!r}... is too long (over 64 characters).")
    if text.count("/") > 1:
        raise InputError(
            f"unit {raw!r} has more than one '/'; write every denominator factor after one '/', "
            "e.g. N·s/m or kg/(m·s)."
        )
    num, _, den = text.partition("/")
    den = den.strip()
    if den.startswith("(") and den.endswith(")"):
        den = den[1:-1]
    scale, dim = 1.0, _ONE
    for part, sign in ((num, 1), (den, -1)):
        if sign == -1 and not text.count("/"):
            break
        factors = [f for f in re.split(r"[*·. ]+", part.replace("**", "^")) if f]
        if not factors:
            raise InputError(f"unit {raw!r} is malformed (an empty factor around '/').")
        for factor in factors:
            match = _TOKEN.match(factor)
            if not match:
                raise InputError(
                    f"unit {raw!r} is malformed at {factor!r}; write units such as mm, deg/s, "
                    "N·m, m/s^2, kN."
                )
            sym = match.group(1)
            power = match.group(2) or match.group(3) or match.group(5)
            power = int(power) if power else {"²": 2, "³": 3}.get(match.group(4) or "", 1)
            if abs(power) > 4:
                raise InputError(f"unit {raw!r}: the power {power} is outside -4..4.")
            f, d = _symbol(sym, raw)
            scale *= f ** (sign * power)
            dim = _mul(dim, d, sign * power)
    si = text if scale == 1.0 else _canonical(dim)
    return Unit(text, scale, dim, si)


def to_si(values, unit: str | Unit) -> tuple[np.ndarray, str]:
    """Convert values in ``unit`` to SI.

    Parameters
    ----------
    values : array_like [unit]
    unit : str or Unit

    Returns
    -------
    values : ndarray [SI]
        ``values * scale`` (the input itself, as float, when the scale is 1: bit for bit).
    si : str
        The SI unit.

    Examples
    --------
    >>> v, u = to_si([1.0, 2.0], "mm")
    >>> v.tolist(), u
    ([0.001, 0.002], 'm')
    """
    u = unit if isinstance(unit, Unit) else parse_unit(unit)
    arr = np.asarray(values, dtype=float)
    if u.scale == 1.0:
        return arr, u.si
    return arr * u.scale, u.si


def same_dimension(a: str | Unit, b: str | Unit) -> bool:
    """True when the two units measure the same kind of quantity (``"mm"`` and ``"m"``)."""
    ua = a if isinstance(a, Unit) else parse_unit(a)
    ub = b if isinstance(b, Unit) else parse_unit(b)
    return ua.dimension == ub.dimension


_CHANNEL_KINDS = (
    (re.compile(r"^(q|r)\d+$"), ((_ANG, "rad"), (_L, "m"))),
    (re.compile(r"^qd\d+$"), (((0, 0, -1, 0, 1), "rad/s"), ((1, 0, -1, 0, 0), "m/s"))),
    (re.compile(r"^qdd\d+$"), (((0, 0, -2, 0, 1), "rad/s^2"), ((1, 0, -2, 0, 0), "m/s^2"))),
    (re.compile(r"^tau\d+$"), (((2, 1, -2, 0, 0), "N·m"), (_N, "N"))),
)


def expected_dimensions(name: str) -> tuple[tuple[tuple, str], ...] | None:
    """The dimensions a channel of physid's naming convention may have, or None if any.

    ``q1``/``r1``: an angle [rad] or a length [m] (prismatic joint); ``qd1``: their rates;
    ``tau1``: a torque [N·m] or a force [N]. ``t`` is a time. Other names are not checked here
    (a linear ODE model checks its own input and output, `LinearODEModel.check_units`).

    Examples
    --------
    >>> [u for _, u in expected_dimensions("tau2")]
    ['N·m', 'N']
    >>> expected_dimensions("vir") is None
    True
    """
    if name == "t":
        return ((_T, "s"),)
    for pattern, kinds in _CHANNEL_KINDS:
        if pattern.match(name):
            return kinds
    return None
