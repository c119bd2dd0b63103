"""The symbolic back end: user text to a sympy expression, by the whitelist of `._check`."""

from __future__ import annotations

import math
from collections.abc import Mapping

from ..errors import ExpressionError
from ._build import _Builder, _literal_text
from ._check import (
    _EXAMPLE,
    FUNCTION_NAMES,
    _check_arity,
    _check_exact_power,
    _clip,
    _clip_names,
    _fail,
    _syntax_tree,
    _unknown_check,
)


def _sympy_functions():
    import sympy as sp

    return {
        "sin": sp.sin,
        "cos": sp.cos,
        "tan": sp.tan,
        "asin": sp.asin,
        "acos": sp.acos,
        "atan": sp.atan,
        "atan2": sp.atan2,
        "sinh": sp.sinh,
        "cosh": sp.cosh,
        "tanh": sp.tanh,
        "sqrt": sp.sqrt,
        "exp": sp.exp,
        "log": sp.log,
        "Abs": sp.Abs,
        "abs": sp.Abs,
        "sign": sp.sign,
    }


def _resolve_functions(functions, table: dict) -> dict:
    """The callable table: the default ``table``, a subset of it by name, or a mapping."""
    if functions is None:
        return table
    if isinstance(functions, Mapping):
        return dict(functions)
    names = list(functions)
    bad = [n for n in names if n not in table]
    if bad:
        raise ExpressionError(
            f"functions= names unknown function(s) {_clip_names(bad)}; choose from "
            f"{', '.join(table)} or pass a mapping name -> callable.",
            reason="argument",
            names=tuple(bad),
        )
    return {n: table[n] for n in names}


def _resolve_symbols(symbols) -> dict:
    import sympy as sp

    if isinstance(symbols, Mapping):
        out = {}
        for name, sym in symbols.items():
            out[str(name)] = sym if isinstance(sym, sp.Basic) else sp.Symbol(str(name))
        return out
    if isinstance(symbols, str):
        raise ExpressionError(
            f"symbols= must be a mapping name -> sympy.Symbol or an iterable of names; got the "
            f"string {_clip(symbols, 40)} (wrap one name in a list: [{symbols!r}]).",
            reason="argument",
        )
    return {str(n): sp.Symbol(str(n)) for n in symbols}


def parse_expression(
    text: str,
    symbols,
    *,
    functions=None,
    source: str = "",
):
    """Parse user text into a sympy expression with a whitelist walker (no Python evaluation).

    Parameters
    ----------
    text : str
        Arithmetic in Python syntax: numbers, the declared names, ``pi``, ``+ - * / **`` (``^``
        is read as ``**``), unary minus, parentheses and calls of the allowed functions
        (``"m1*l1**2/12"``, ``"cos(q1 + pi/2)"``).
    symbols : mapping of str to sympy.Symbol, or iterable of str
        The names the text may use; a plain name ``n`` becomes ``sympy.Symbol(n)``.
    functions : None, iterable of str, or mapping of str to callable
        Allowed functions: None → `FUNCTION_NAMES` (sin, cos, tan, asin, acos, atan, atan2,
        sinh, cosh, tanh, sqrt, exp, log, Abs/abs, sign); names → that subset; a mapping →
        exactly those callables (each receives sympy arguments).
    source : str
        Where the text comes from (``"arm.toml, line 7 (joints[1].mass)"``); prefixes messages.

    Returns
    -------
    sympy.Expr
        Built node by node with sympy's own operators, so numbers come out as sympy's parser
        made them: integer literals as ``Integer``, decimal literals as ``Float`` of the text
        as written, ``2/3`` as ``Rational(2, 3)``.

    Raises
    ------
    ExpressionError
        With ``reason`` one of ``"syntax"``, ``"forbidden"``, ``"too_large"``,
        ``"unknown_name"``, ``"unknown_function"``, ``"not_callable"``, ``"arguments"``,
        ``"not_finite"``, ``"invalid"``, ``"type"``; ``names`` holds the offending names.

    Examples
    --------
    >>> import sympy as sp
    >>> m, l = sp.symbols("m l")
    >>> parse_expression("m1*l1**2/12", {"m1": m, "l1": l})
    l**2*m/12
    >>> parse_expression("__import__('os')", ["x"])
    Traceback (most recent call last):
        ...
    physid.errors.ExpressionError: a string literal (quotes) is not allowed in the expression "__import__('os')"; write the expression itself, without quotes inside it.
    """
    import sympy as sp

    root = _syntax_tree(text, source)
    table = _resolve_symbols(symbols)
    funcs = _resolve_functions(functions, _sympy_functions())
    constants = {"pi": sp.pi}
    known_values = {**constants, **table}
    _unknown_check(root, known_values, funcs, text, source)
    code = text.strip().replace("^", "**")

    def number(node):
        if isinstance(node.value, int):
            return sp.Integer(node.value)
        return sp.Float(_literal_text(node, code))

    def name(n):
        return known_values[n]

    def call(fname, args):
        _check_arity(
            fname, args, FUNCTION_NAMES.get(fname) if functions is None else None, text, source
        )
        return funcs[fname](*args)

    def power(base, exponent, node):
        _check_exact_power(base, exponent, text, source)
        return base**exponent

    builder = _Builder(text, source, number, name, call, power)
    try:
        expr = builder.build(root)
    except ExpressionError:
        raise
    except (TypeError, ValueError, ZeroDivisionError, OverflowError, ArithmeticError) as exc:
        raise _fail(
            "invalid",
            f"sympy cannot build it ({type(exc).__name__}: {str(exc)[:100]})",
            text,
            source,
            fix=_EXAMPLE,
        ) from None
    except RecursionError:
        raise _fail(
            "too_large", "too deeply nested to build", text, source, fix="simplify it"
        ) from None
    if not isinstance(expr, sp.Basic):  # pragma: no cover - every leaf is a sympy object
        expr = sp.Float(expr)
    if (
        expr.has(sp.I)
        or expr.has(sp.zoo)
        or expr.has(sp.nan)
        or expr.has(sp.oo)
        or expr.has(-sp.oo)
    ):
        raise _fail(
            "not_finite",
            "not a finite real value (it contains a division by zero, an infinity or an "
            f"imaginary part: {_clip(str(expr), 60)})",
            text,
            source,
            fix="check divisions and square roots",
        )
    return expr


def check_real_at(expr, values: Mapping, *, text: str = "", source: str = "") -> float:
    """Value of a parsed expression at numeric values; refuse one that is not finite and real.

    Parameters
    ----------
    expr : sympy.Expr
        From `parse_expression`.
    values : mapping of sympy.Symbol to float
        Values for every free symbol (e.g. a model's nominal parameter values, SI units).
    text : str
        The expression as the user wrote it (for the message).
    source : str
        Where it was written (for the message).

    Returns
    -------
    float
        The value.

    Raises
    ------
    ExpressionError
        ``reason="not_finite"`` when the value is a division by zero, infinite, NaN or complex
        (``sqrt(-m1)`` with m1 = 2).

    Examples
    --------
    >>> import sympy as sp
    >>> m = sp.Symbol("m")
    >>> check_real_at(parse_expression("sqrt(m)", {"m": m}), {m: 4.0})
    2.0
    """
    import sympy as sp

    subs = {k: sp.Float(float(v)) for k, v in values.items()}
    try:
        value = complex(sp.N(expr.xreplace(subs)))
    except (TypeError, ValueError, ZeroDivisionError, OverflowError) as exc:
        value_text = f"cannot be evaluated ({type(exc).__name__})"
        value = None
    else:
        value_text = f"{value.real:.6g}" if value.imag == 0 else f"{value:.6g}"
    if value is None or not math.isfinite(value.real) or value.imag != 0:
        shown = ", ".join(
            f"{k}={float(v):.6g}" for k, v in list(values.items())[:8] if k in expr.free_symbols
        )
        at = f" at {shown}" if shown else ""
        raise _fail(
            "not_finite",
            f"the value{at} is not a finite real number ({value_text})",
            text or str(expr),
            source,
            fix="check divisions by parameters that are zero and roots of negative values",
        )
    return value.real
