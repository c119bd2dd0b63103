"""User-written arithmetic, parsed by a whitelist — never evaluated as Python.

Every expression physid reads from a user (model files, URDF attributes, channel maps such as
``tau1=gtau*vir``, command-line assignments) goes through this package. The text is parsed with
Python's own grammar (`ast.parse` in ``eval`` mode, which only builds a syntax tree and runs
nothing), and the tree is walked by a whitelist that knows exactly these constructs:

* numbers (integers and decimals, ``1.5e-3``), the constant ``pi``;
* declared names (the ``symbols`` / ``variables`` the caller passes);
* ``+ - * / **`` (``^`` is read as ``**``, as sympy's ``convert_xor`` reads it), unary ``-``
  and ``+``, parentheses;
* calls of the listed functions by bare name with positional arguments (``sin(q1)``).

Everything else — attributes, subscripts, strings, keywords, lambdas, comprehensions,
comparisons, boolean operators, ``if`` expressions, starred arguments, complex numbers — is
refused with an `ExpressionError` that names the construct and says what to write instead. The
sympy expression (or the numpy value) is built node by node by this package; ``eval``,
``sympify`` and ``parse_expr`` are never applied to user text.

Size is bounded before any work is done, so that hostile text fails at once instead of hanging:
at most `MAX_LENGTH` characters, `MAX_NODES` syntax-tree nodes, `MAX_DEPTH` levels of nesting
(a long sum ``a + b + c + ...`` counts as one level), integer literals of at most
`MAX_INTEGER_DIGITS` digits, constant exponents of magnitude at most `MAX_EXPONENT`, and exact
numbers (integers, fractions) of at most `MAX_RESULT_DIGITS` digits (``9**9**9**9`` is refused
at its second power). Messages quote at most `MESSAGE_CLIP` characters of the text.

Layout: every check that decides whether a text is allowed (the limits, the whitelist of
nodes, the declared names, the bounds on powers) is in one module, `physid.expressions._check`,
the security boundary of the package; `physid.expressions._build` walks a checked tree node by
node; `physid.expressions._sympy` (`parse_expression`, `check_real_at`) and
`physid.expressions._numpy` (`evaluate_expression`) are the two back ends that build values.
"""

from ._check import (  # noqa: F401 - the private names are used by physid.models.spec
    CONSTANT_NAMES,
    FUNCTION_NAMES,
    MAX_DEPTH,
    MAX_EXPONENT,
    MAX_INTEGER_DIGITS,
    MAX_LENGTH,
    MAX_NODES,
    MAX_RESULT_DIGITS,
    MESSAGE_CLIP,
    _check_node,
    _check_tree,
    _clip,
    _clip_names,
    _dotted,
    _fail,
    _names_in,
    _syntax_tree,
    _unknown_check,
    expression_names,
)
from ._numpy import evaluate_expression
from ._sympy import check_real_at, parse_expression

__all__ = [
    "parse_expression",
    "evaluate_expression",
    "expression_names",
    "check_real_at",
    "FUNCTION_NAMES",
    "CONSTANT_NAMES",
    "MAX_LENGTH",
    "MAX_NODES",
    "MAX_DEPTH",
    "MAX_EXPONENT",
    "MAX_INTEGER_DIGITS",
    "MAX_RESULT_DIGITS",
]
