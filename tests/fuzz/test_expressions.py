"""Fuzz the expression parser: any text parses to a sympy expression in the declared names, or
raises `ExpressionError` — never another exception, never a hang, never code execution.

``make fuzz`` runs these at 20 000 examples each (profile ``fuzz`` in tests/conftest.py).
"""

from __future__ import annotations

import numpy as np
import sympy as sp
from hypothesis import given
from hypothesis import strategies as st

from physid.errors import ExpressionError
from physid.expressions import FUNCTION_NAMES, evaluate_expression, parse_expression

NAMES = ("m1", "l1", "q1", "data.pos")
SYMBOLS = {n: sp.Symbol(n) for n in NAMES[:3]}
VALUES = {"m1": 2.0, "l1": np.array([0.5, -1.0, 0.0]), "q1": 0.3, "data.pos": np.ones(3)}

# leaves: declared and undeclared names, numbers of every shape, and hostile atoms
_leaves = st.one_of(
    st.sampled_from([*NAMES, "pi", "zz", "E", "I", "__import__", "os", "True", "None"]),
    st.integers(min_value=-(10**70), max_value=10**70).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.sampled_from(["1e400", "1e-400", "0x1f", "1_000", "2j", "0.5e", ".5", "5.", "1e3"]),
    st.sampled_from(["'x'", '"1+1"', "b'x'", "f'{m1}'", "...", "[]", "{}", "()"]),
)
_unary = st.sampled_from(["-", "+", "not ", "~", ""])
_binary = st.sampled_from(
    ["+", "-", "*", "/", "**", "^", "//", "%", "@", "<", "==", " and ", " or ", "&", "|", ","]
)
_funcs = st.sampled_from([*FUNCTION_NAMES, "foo", "eval", "exec", "getattr", "lambda: "])


def _extend(children):
    return st.one_of(
        st.tuples(_unary, children).map(lambda t: f"{t[0]}{t[1]}"),
        st.tuples(children, _binary, children).map(lambda t: f"{t[0]}{t[1]}{t[2]}"),
        st.tuples(children).map(lambda t: f"({t[0]})"),
        st.tuples(_funcs, st.lists(children, max_size=3)).map(
            lambda t: f"{t[0]}({', '.join(t[1])})"
        ),
        st.tuples(
            children, st.sampled_from([".real", ".__class__", "[0]", "(1)", " if 1 else 0"])
        ).map(lambda t: f"{t[0]}{t[1]}"),
        st.tuples(children, st.sampled_from(["**99999999999", "**9**9**9", "**(10**9)"])).map(
            lambda t: f"{t[0]}{t[1]}"
        ),
    )


GRAMMAR = st.recursive(_leaves, _extend, max_leaves=40)
TEXT = st.one_of(
    GRAMMAR, st.text(max_size=200), st.text(alphabet="m1l+-*/()^.,'\" sqrt", max_size=80)
)


@given(TEXT)
def test_parse_expression_returns_an_expression_or_refuses(text):
    try:
        expr = parse_expression(text, SYMBOLS)
    except ExpressionError as exc:
        assert len(str(exc)) < 1500
        return
    assert isinstance(expr, sp.Basic)
    assert expr.free_symbols <= set(SYMBOLS.values())
    assert not expr.has(sp.zoo, sp.nan, sp.oo, -sp.oo, sp.I)


@given(TEXT)
def test_evaluate_expression_returns_floats_or_refuses(text):
    try:
        value = evaluate_expression(text, VALUES)
    except ExpressionError as exc:
        assert len(str(exc)) < 1500
        return
    assert isinstance(value, np.ndarray) and value.dtype == float
    assert value.shape in ((), (3,))
