"""The whitelist checker of user-written arithmetic: the security boundary of `physid.expressions`.

Every check that decides whether a text is allowed lives in this module, on purpose, so that the
boundary can be read in one place: the size limits (`MAX_LENGTH`, `MAX_NODES`, `MAX_DEPTH`,
`MAX_INTEGER_DIGITS`, `MAX_EXPONENT`, `MAX_RESULT_DIGITS`), the parse of the text into a syntax
tree (`ast.parse` in ``eval`` mode, which runs nothing), the node-by-node whitelist
(`_check_tree`, `_check_node`), the names a tree uses and the refusal of undeclared ones
(`_unknown_check`), the arity of calls (`_check_arity`) and the bounds on powers the back ends
apply while they build (`_check_exact_power`, `_check_numeric_power`). The back ends
(`physid.expressions._sympy`, `physid.expressions._numpy`) only build values from a tree that
passed these checks, with the shared walker of `physid.expressions._build`.
"""

from __future__ import annotations

import ast
import math
from collections.abc import Iterable
from typing import Any

from ..errors import ExpressionError

#: Longest expression text accepted [characters]. The longest expression in physid's own model
#: files is under 40 characters; a generated one for a 7-joint arm stays far below this.
MAX_LENGTH = 10_000
#: Most syntax-tree nodes accepted (a term like ``m1*l1**2`` is about 7 nodes).
MAX_NODES = 5_000
#: Deepest nesting accepted. Chains of one operator family (``a + b - c``, ``a*b/c``) count as
#: one level, so long sums and products are not limited by this, only by `MAX_NODES`.
MAX_DEPTH = 60
#: Largest |exponent| of a power whose exponent is a number (``m1**99999999999`` is refused).
MAX_EXPONENT = 100
#: Most digits of an integer literal.
MAX_INTEGER_DIGITS = 50
#: Most digits of an exact number (integer or fraction) built from the literals by ``**``.
MAX_RESULT_DIGITS = 1_000
#: Characters of the user's text quoted in a message (the rest is elided, with its length).
MESSAGE_CLIP = 120

#: Functions an expression may call, with their number of positional arguments.
FUNCTION_NAMES = {
    "sin": 1,
    "cos": 1,
    "tan": 1,
    "asin": 1,
    "acos": 1,
    "atan": 1,
    "atan2": 2,
    "sinh": 1,
    "cosh": 1,
    "tanh": 1,
    "sqrt": 1,
    "exp": 1,
    "log": 1,
    "Abs": 1,
    "abs": 1,
    "sign": 1,
}
#: Named constants an expression may use.
CONSTANT_NAMES = ("pi",)

_EXAMPLE = 'write arithmetic in Python syntax, e.g. "m1*l1**2/12" or "cos(q1)"'

# what each forbidden node is, in words, and what to write instead
_FORBIDDEN = {
    ast.Attribute: ("an attribute access (a.b)", "use a declared name"),
    ast.Subscript: ("a subscript (a[i])", "use a declared name"),
    ast.Compare: ("a comparison", "expressions are arithmetic only"),
    ast.BoolOp: ("a boolean operator (and/or)", "expressions are arithmetic only"),
    ast.IfExp: ("a conditional (x if c else y)", "expressions are arithmetic only"),
    ast.Lambda: ("a lambda", "expressions are arithmetic only"),
    ast.ListComp: ("a comprehension", "expressions are arithmetic only"),
    ast.SetComp: ("a comprehension", "expressions are arithmetic only"),
    ast.DictComp: ("a comprehension", "expressions are arithmetic only"),
    ast.GeneratorExp: ("a generator expression", "expressions are arithmetic only"),
    ast.List: ("a list", "expressions are a single number"),
    ast.Tuple: ("a tuple (a comma)", "expressions are a single number; drop the comma"),
    ast.Set: ("a set", "expressions are a single number"),
    ast.Dict: ("a dict", "expressions are a single number"),
    ast.Starred: ("a starred argument (*a)", "pass arguments one by one"),
    ast.JoinedStr: ("an f-string", "write the expression without quotes"),
    ast.NamedExpr: ("an assignment expression (:=)", "expressions are arithmetic only"),
    ast.Await: ("await", "expressions are arithmetic only"),
    ast.Yield: ("yield", "expressions are arithmetic only"),
    ast.YieldFrom: ("yield", "expressions are arithmetic only"),
    ast.Slice: ("a slice", "expressions are arithmetic only"),
}
_BINOP_WORDS = {
    ast.FloorDiv: ("floor division (//)", "use / for division"),
    ast.Mod: ("the % operator", "expressions use + - * / ** only"),
    ast.MatMult: ("matrix multiplication (@)", "use * for a product"),
    ast.LShift: ("a shift (<<)", "expressions use + - * / ** only"),
    ast.RShift: ("a shift (>>)", "expressions use + - * / ** only"),
    ast.BitOr: ("the | operator", "expressions use + - * / ** only"),
    ast.BitAnd: ("the & operator", "expressions use + - * / ** only"),
    ast.BitXor: ("the ^ operator", "write ** for a power"),
}
_ADDITIVE = (ast.Add, ast.Sub)
_MULTIPLICATIVE = (ast.Mult, ast.Div)


def _clip(text: str, limit: int = MESSAGE_CLIP) -> str:
    """``repr`` of ``text``, elided in the middle beyond ``limit`` characters."""
    if len(text) <= limit:
        return repr(text)
    head, tail = text[: limit * 2 // 3], text[-(limit // 4) :]
    return repr(f"{head} … {tail}") + f" ({len(text)} characters)"


def _clip_names(names: Iterable[str], limit: int = 10) -> str:
    """``['a', 'b', ...]`` with at most ``limit`` names (and how many more)."""
    names = [n if len(n) <= 40 else n[:37] + "..." for n in names]
    if len(names) <= limit:
        return repr(names)
    return repr(names[:limit])[:-1] + f", ... and {len(names) - limit} more]"


def _fail(
    reason: str, detail: str, text: str, source: str, *, names=(), fix: str = "", after: str = ""
):
    """The ExpressionError "SOURCE: DETAIL in the expression 'TEXT'AFTER; FIX." (text clipped).

    With ``after``, the form is "SOURCE: DETAIL the expression 'TEXT' AFTER; FIX." instead.
    """
    prefix = f"{source}: " if source else ""
    tail = f"; {fix}" if fix else ""
    middle = (
        f"{detail} the expression {_clip(text)} {after}"
        if after
        else (f"{detail} in the expression {_clip(text)}")
    )
    return ExpressionError(
        f"{prefix}{middle}{tail}.",
        reason=reason,
        names=tuple(names),
        text=text,
        source=source,
    )


# ---------------------------------------------------------------------------------------------
# parsing and checking the syntax tree (shared by the symbolic and the numeric builder)
# ---------------------------------------------------------------------------------------------


def _syntax_tree(text: Any, source: str, dotted=None) -> ast.expr:
    """Parse ``text`` into the body of an ``ast.Expression``, checking size and constructs.

    ``dotted``: None (attribute access is refused) or a set: then a chain ``a.b.c`` on a bare
    name is one name, looked up like any other (numeric mode: MATLAB struct fields).
    """
    if not isinstance(text, str):
        raise ExpressionError(
            f"{source + ': ' if source else ''}an expression must be a string such as "
            f'"m1*l1**2/12"; got {type(text).__name__} {_clip(repr(text), 60)}.',
            reason="type",
            text=str(text)[:MESSAGE_CLIP],
            source=source,
        )
    if len(text) > MAX_LENGTH:
        raise _fail(
            "too_large",
            f"{len(text)} characters exceed the limit of {MAX_LENGTH}",
            text,
            source,
            fix="split the model into named parameters, or simplify the expression",
        )
    if not text.strip():
        raise _fail("syntax", "nothing to parse", text, source, fix=_EXAMPLE)
    if "\x00" in text:
        raise _fail("syntax", "a NUL character", text, source, fix=_EXAMPLE)
    # ^ means a power, as sympy's convert_xor made it (token-level, so precedence is **'s)
    code = text.strip().replace("^", "**")
    try:
        tree = ast.parse(code, mode="eval")
    except SyntaxError as exc:
        msg = exc.msg if getattr(exc, "msg", None) else str(exc)
        raise _fail(
            "syntax",
            "cannot parse",
            text,
            source,
            fix=_EXAMPLE,
            after=f"({type(exc).__name__}: {msg[:100]})",
        ) from None
    except (RecursionError, MemoryError, ValueError, OverflowError) as exc:
        raise _fail(
            "too_large",
            f"cannot parse ({type(exc).__name__}: the syntax tree too deep for Python's parser)",
            text,
            source,
            fix="Python parses chains of up to about 2000 terms: split the expression into named "
            "parameters, or group terms in parentheses",
        ) from None
    _check_tree(tree.body, text, source, dotted)
    return tree.body


def _children_depth(node: ast.AST, depth: int):
    """Children of ``node`` with their nesting depth (chains of one operator family: same)."""
    for child in ast.iter_child_nodes(node):
        same_chain = (
            isinstance(node, ast.BinOp)
            and isinstance(child, ast.BinOp)
            and child is node.left
            and (
                (isinstance(node.op, _ADDITIVE) and isinstance(child.op, _ADDITIVE))
                or (isinstance(node.op, _MULTIPLICATIVE) and isinstance(child.op, _MULTIPLICATIVE))
            )
        )
        yield child, depth if same_chain else depth + 1


def _check_tree(root: ast.expr, text: str, source: str, dotted=None) -> None:
    """Whitelist check over the whole tree, iteratively (no recursion on hostile depth)."""
    stack = [(root, 1)]
    count = 0
    while stack:
        node, depth = stack.pop()
        count += 1
        if count > MAX_NODES:
            raise _fail(
                "too_large",
                f"more than {MAX_NODES} terms and operators",
                text,
                source,
                fix="split the model into named parameters, or simplify the expression",
            )
        if depth > MAX_DEPTH:
            raise _fail(
                "too_large",
                f"nesting deeper than {MAX_DEPTH} levels",
                text,
                source,
                fix="remove redundant parentheses or unary signs",
            )
        if isinstance(node, ast.Attribute) and dotted is not None and _dotted(node):
            continue  # a dotted name (a struct field): a leaf, looked up by its spelling
        _check_node(node, text, source)
        if isinstance(node, ast.Call):
            children = [(a, depth + 1) for a in node.args]  # func is a checked bare Name
        else:
            children = list(_children_depth(node, depth))
        for child, d in children:
            if isinstance(child, (ast.operator, ast.unaryop, ast.expr_context)):
                continue
            stack.append((child, d))


def _check_constant(node: ast.Constant, text: str, source: str) -> None:
    value = node.value
    if isinstance(value, bool) or value is None or value is Ellipsis:
        raise _fail(
            "forbidden",
            f"the constant {value!r} is not a number",
            text,
            source,
            fix=_EXAMPLE,
        )
    if isinstance(value, (str, bytes)):
        raise _fail(
            "forbidden",
            "a string literal (quotes) is not allowed",
            text,
            source,
            fix="write the expression itself, without quotes inside it",
        )
    if isinstance(value, complex):
        raise _fail(
            "forbidden",
            f"the complex number {value!r} is not allowed",
            text,
            source,
            fix="expressions are real",
        )
    if isinstance(value, int) and len(str(abs(value))) > MAX_INTEGER_DIGITS:
        raise _fail(
            "too_large",
            f"an integer literal with more than {MAX_INTEGER_DIGITS} digits",
            text,
            source,
            fix="write it as a decimal with an exponent, e.g. 1.5e60",
        )
    if isinstance(value, float) and not math.isfinite(value):
        raise _fail(
            "too_large",
            "a number beyond the range of double precision (about 1.8e308)",
            text,
            source,
            fix="use SI units that keep values in range",
        )


def _check_name(node: ast.Name, text: str, source: str) -> None:
    """Nothing to check: the builder resolves the name against the declared names."""


def _check_binop(node: ast.BinOp, text: str, source: str) -> None:
    if type(node.op) in _BINOP_WORDS:
        what, fix = _BINOP_WORDS[type(node.op)]
        raise _fail("forbidden", f"{what} is not allowed", text, source, fix=fix)


def _check_unaryop(node: ast.UnaryOp, text: str, source: str) -> None:
    if not isinstance(node.op, (ast.USub, ast.UAdd)):
        word = "not" if isinstance(node.op, ast.Not) else "~"
        raise _fail(
            "forbidden",
            f"the operator {word!r} is not allowed",
            text,
            source,
            fix="expressions use + - * / ** only",
        )


def _check_call(node: ast.Call, text: str, source: str) -> None:
    if not isinstance(node.func, ast.Name):
        raise _fail(
            "forbidden",
            "only functions called by their bare name (sin(x)) are allowed, not "
            f"{type(node.func).__name__.lower()} calls",
            text,
            source,
            fix=f"allowed functions: {', '.join(FUNCTION_NAMES)}",
        )
    if node.keywords:
        raise _fail(
            "forbidden",
            f"keyword arguments in the call of {node.func.id!r} are not allowed",
            text,
            source,
            fix="pass the arguments by position",
        )


#: The allowed node kinds and the check of each, in the order they are tried.
_NODE_CHECKS = (
    (ast.Constant, _check_constant),
    (ast.Name, _check_name),
    (ast.BinOp, _check_binop),
    (ast.UnaryOp, _check_unaryop),
    (ast.Call, _check_call),
)


def _check_node(node: ast.AST, text: str, source: str) -> None:
    """Refuse ``node`` unless it is an allowed kind that passes its check in `_NODE_CHECKS`."""
    for kind, check in _NODE_CHECKS:
        if isinstance(node, kind):
            check(node, text, source)
            return
    for kind, (what, fix) in _FORBIDDEN.items():
        if isinstance(node, kind):
            raise _fail("forbidden", f"{what} is not allowed", text, source, fix=fix)
    raise _fail(
        "forbidden",
        f"the construct {type(node).__name__} is not allowed",
        text,
        source,
        fix=_EXAMPLE,
    )


def _names_in(root: ast.expr, dotted=frozenset()) -> tuple[set, set]:
    """(names used as values, names called as functions) in a checked tree."""
    values, calls = set(), set()
    stack = [root]
    while stack:
        node = stack.pop()
        if isinstance(node, ast.Attribute):  # only allowed dotted names get here
            values.add(_dotted(node))
            continue
        if isinstance(node, ast.Name):
            values.add(node.id)
            continue
        if isinstance(node, ast.Call):
            calls.add(node.func.id)
            stack.extend(node.args)
            continue
        stack.extend(c for c in ast.iter_child_nodes(node) if isinstance(c, ast.expr))
    return values, calls


def expression_names(text: str, *, source: str = "") -> tuple[tuple[str, ...], tuple[str, ...]]:
    """The names an expression uses, without building it.

    Parameters
    ----------
    text : str
        The expression.
    source : str
        Where the text comes from, for error messages.

    Returns
    -------
    names : tuple of str
        Names used as values (sorted), constants such as ``pi`` included.
    functions : tuple of str
        Names called as functions (sorted).

    Raises
    ------
    ExpressionError
        The text does not parse, is too large, or uses a forbidden construct.

    Examples
    --------
    >>> expression_names("gtau*vir + sin(q1)")
    (('gtau', 'q1', 'vir'), ('sin',))
    """
    root = _syntax_tree(text, source)
    values, calls = _names_in(root)
    return tuple(sorted(values)), tuple(sorted(calls))


def _unknown_check(root, known_values, known_functions, text, source, dotted=frozenset()):
    values, calls = _names_in(root, dotted)
    bad_calls = sorted(calls - set(known_functions))
    if bad_calls:
        called_values = [c for c in bad_calls if c in known_values]
        if called_values:
            raise _fail(
                "not_callable",
                f"{_clip_names(called_values)} called like a function",
                text,
                source,
                names=called_values,
                fix="a declared name is a value; write * for a product, e.g. m1*(l1 + l2)",
            )
        raise _fail(
            "unknown_function",
            f"unknown function(s) {_clip_names(bad_calls)}",
            text,
            source,
            names=bad_calls,
            fix=f"allowed functions: {', '.join(known_functions) or 'none'}",
        )
    bad_values = sorted(values - set(known_values))
    if bad_values:
        functions_as_values = [v for v in bad_values if v in known_functions]
        if functions_as_values:
            raise _fail(
                "forbidden",
                f"the function(s) {_clip_names(functions_as_values)} used without arguments",
                text,
                source,
                names=functions_as_values,
                fix="call it with its argument, e.g. sin(q1)",
            )
        shown = _clip_names(bad_values)
        known = _clip_names(sorted(known_values), 12)
        raise _fail(
            "unknown_name",
            f"unknown name(s) {shown}",
            text,
            source,
            names=bad_values,
            fix=f"the names that may appear are {known}",
        )


def _digits(x) -> float:
    """Decimal digits of an exact sympy number (integer or rational)."""
    import sympy as sp

    if isinstance(x, sp.Integer):
        return len(str(abs(int(x)))) if abs(int(x)) < 10**60 else abs(int(x)).bit_length() * 0.302
    if isinstance(x, sp.Rational):
        return _digits(sp.Integer(x.p)) + _digits(sp.Integer(x.q))
    return 0.0


def _is_constant(node: ast.AST) -> bool:
    """True when the subtree holds no names other than ``pi``."""
    return not any(isinstance(n, ast.Name) and n.id not in CONSTANT_NAMES for n in ast.walk(node))


def _check_arity(name, args, arity, text, source):
    if arity is not None and len(args) != arity:
        raise _fail(
            "arguments",
            f"{name}() takes {arity} argument{'s' if arity != 1 else ''}, got {len(args)}",
            text,
            source,
            fix=f"call it as {name}({', '.join('xyz'[:arity])})",
        )


def _dotted(node) -> str | None:
    """``a.b.c`` for a chain of attribute accesses on a bare name, else None."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if not isinstance(node, ast.Name):
        return None
    parts.append(node.id)
    return ".".join(reversed(parts))


def _check_exact_power(base, exponent, text: str, source: str) -> None:
    """Refuse a sympy power whose numeric exponent or exact result is beyond the limits."""
    import sympy as sp

    if exponent.is_number:
        try:
            e = float(exponent)
        except (TypeError, ValueError, OverflowError):
            e = math.inf
        if not math.isfinite(e) or abs(e) > MAX_EXPONENT:
            raise _fail(
                "too_large",
                f"the exponent {_clip(str(exponent), 40)} exceeds the limit of ±{MAX_EXPONENT}",
                text,
                source,
                fix="physical models need small powers; check the expression",
            )
        if isinstance(base, sp.Rational) and isinstance(exponent, sp.Rational):
            size = abs(e) * max(_digits(base), 1.0)
            if size > MAX_RESULT_DIGITS:
                raise _fail(
                    "too_large",
                    f"an exact number of about {size:.0f} digits (limit {MAX_RESULT_DIGITS})",
                    text,
                    source,
                    fix="write large numbers as decimals, e.g. 1.5e60",
                )


def _check_numeric_power(exponent, node: ast.BinOp, text: str, source: str) -> None:
    """Refuse a numpy power whose constant exponent is beyond `MAX_EXPONENT`."""
    import numpy as np

    if np.ndim(exponent) == 0 and _is_constant(node.right):
        e = float(exponent)
        if math.isfinite(e) and abs(e) > MAX_EXPONENT:
            raise _fail(
                "too_large",
                f"the exponent {e:g} exceeds the limit of ±{MAX_EXPONENT}",
                text,
                source,
                fix="check the expression",
            )
