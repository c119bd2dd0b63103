"""The numeric back end: user text to a numpy value over named arrays, by the whitelist of `._check`."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..errors import ExpressionError
from ._build import _Builder
from ._check import (
    FUNCTION_NAMES,
    _check_arity,
    _check_numeric_power,
    _fail,
    _syntax_tree,
    _unknown_check,
)


def _numpy_functions():
    import numpy as np

    return {
        "sin": np.sin,
        "cos": np.cos,
        "tan": np.tan,
        "asin": np.arcsin,
        "acos": np.arccos,
        "atan": np.arctan,
        "atan2": np.arctan2,
        "sinh": np.sinh,
        "cosh": np.cosh,
        "tanh": np.tanh,
        "sqrt": np.sqrt,
        "exp": np.exp,
        "log": np.log,
        "Abs": np.abs,
        "abs": np.abs,
        "sign": np.sign,
    }


def evaluate_expression(text: str, variables: Mapping[str, Any], *, source: str = ""):
    """Evaluate arithmetic over named arrays with numpy, by the same whitelist (no Python eval).

    Used for channel maps such as ``tau1 = gtau*vir`` (a drive gain times a voltage). The
    grammar is `parse_expression`'s, plus dotted names (``data.pos``) when a key of that exact
    spelling is in ``variables`` (a MATLAB struct field); nothing is looked up by attribute.

    Parameters
    ----------
    text : str
        The expression, e.g. ``"gtau*vir"`` or ``"35.15*vir - 0.2"``.
    variables : mapping of str to float or numpy.ndarray
        The values of the names (scalars and arrays broadcast by numpy's rules).
    source : str
        Where the text comes from; prefixes messages.

    Returns
    -------
    numpy.ndarray of float
        The value, with the broadcast shape of the variables used (0-d for a constant).
        Invalid operations (``log(-1)``, ``1/0``) give NaN or ±inf without warnings; the
        caller checks finiteness where it matters. Peak memory: a few temporaries of the
        output's size.

    Raises
    ------
    ExpressionError
        As `parse_expression` (unknown names, forbidden constructs, size limits).

    Examples
    --------
    >>> import numpy as np
    >>> evaluate_expression("gtau*vir", {"gtau": 2.0, "vir": np.array([1.0, 2.0])})
    array([2., 4.])
    """
    import numpy as np

    if isinstance(variables, Mapping):
        table = {str(k): v for k, v in variables.items()}
    else:
        raise ExpressionError(
            f"variables= must be a mapping name -> number or array; got {type(variables).__name__}.",
            reason="argument",
        )
    dotted = frozenset(k for k in table if "." in k)
    root = _syntax_tree(text, source, dotted)
    values = {"pi": np.pi, **table}
    funcs = _numpy_functions()
    _unknown_check(root, values, funcs, text, source, dotted)

    def number(node):
        return np.float64(node.value)

    def name(n):
        v = values[n]
        return np.asarray(v, dtype=float) if not np.isscalar(v) else np.float64(v)

    def call(fname, args):
        _check_arity(fname, args, FUNCTION_NAMES[fname], text, source)
        return funcs[fname](*args)

    def power(base, exponent, node):
        _check_numeric_power(exponent, node, text, source)
        return np.power(base, exponent)

    builder = _Builder(text, source, number, name, call, power)
    try:
        with np.errstate(all="ignore"):
            out = builder.build(root)
            return np.asarray(out, dtype=float)
    except ExpressionError:
        raise
    except (TypeError, ValueError) as exc:
        raise _fail(
            "invalid",
            f"cannot evaluate it ({type(exc).__name__}: {str(exc)[:100]})",
            text,
            source,
            fix="check that the arrays have compatible shapes and numeric types",
        ) from None
