"""User-written arithmetic, parsed by a whitelist — never evaluated as Python.

Every expression physid reads from a user (model files, URDF attributes, channel maps such as
``tau1=gtau*vir``, command-line assignments) goes through this module. The text is parsed with
Python's own grammar (`ast.parse` in ``eval`` mode, which only builds a syntax tree and runs
nothing), and the tree is walked by a whitelist that knows exactly these constructs:

* numbers (integers and decimals, ``1.5e-3``), the constant ``pi``;
* declared names (the ``symbols`` / ``variables`` the caller passes);
* ``+ - * / **`` (``^`` is read as ``**``, as in the earlier sympy-based parser), unary ``-``
  and ``+``, parentheses;
* calls of the listed functions by bare name with positional arguments (``sin(q1)``).

Everything else — attributes, subscripts, strings, keywords, lambdas, comprehensions,
comparisons, boolean operators, ``if`` expressions, starred arguments, complex numbers — is
refused with an `ExpressionError` that names the construct and says what to write instead. The
sympy expression (or the numpy value) is built node by node by this module; ``eval``,
``sympify`` and ``parse_expr`` are never applied to user text.

Size is bounded before any work is done, so that hostile text fails at once instead of hanging:
at most `MAX_LENGTH` characters, `MAX_NODES` syntax-tree nodes, `MAX_DEPTH` levels of nesting
(a long sum ``a + b + c + ...`` counts as one level), integer literals of at most
`MAX_INTEGER_DIGITS` digits, constant exponents of magnitude at most `MAX_EXPONENT`, and exact
numbers (integers, fractions) of at most `MAX_RESULT_DIGITS` digits (``9**9**9**9`` is refused
at its second power). Messages quote at most `MESSAGE_CLIP` characters of the text.
"""

from __future__ import annotations

import ast
import math
from collections.abc import Iterable, Mapping
from typing import Any

from .errors import ExpressionError

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


def _check_node(node: ast.AST, text: str, source: str) -> None:
    if isinstance(node, ast.Constant):
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
        return
    if isinstance(node, ast.Name):
        return  # resolved by the builder against the declared names
    if isinstance(node, ast.BinOp):
        if type(node.op) in _BINOP_WORDS:
            what, fix = _BINOP_WORDS[type(node.op)]
            raise _fail("forbidden", f"{what} is not allowed", text, source, fix=fix)
        return
    if isinstance(node, ast.UnaryOp):
        if not isinstance(node.op, (ast.USub, ast.UAdd)):
            word = "not" if isinstance(node.op, ast.Not) else "~"
            raise _fail(
                "forbidden",
                f"the operator {word!r} is not allowed",
                text,
                source,
                fix="expressions use + - * / ** only",
            )
        return
    if isinstance(node, ast.Call):
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


# ---------------------------------------------------------------------------------------------
# symbolic: text → sympy
# ---------------------------------------------------------------------------------------------


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


class _Builder:
    """Builds a value from a checked tree; ``ops`` gives numbers, names, operators, calls."""

    def __init__(self, text, source, number, name, call, power):
        self.text, self.source = text, source
        self.number, self.name, self.call, self.power = number, name, call, power

    def build(self, node):
        if isinstance(node, ast.BinOp) and not isinstance(node.op, ast.Pow):
            # walk the left spine of a chain iteratively: a + b + ... + z is not deep recursion
            chain = []
            family = _ADDITIVE if isinstance(node.op, _ADDITIVE) else _MULTIPLICATIVE
            while (
                isinstance(node, ast.BinOp)
                and not isinstance(node.op, ast.Pow)
                and isinstance(node.op, family)
            ):
                chain.append((node.op, node.right))
                node = node.left
            acc = self.build(node)
            for op, right in reversed(chain):
                rhs = self.build(right)
                if isinstance(op, ast.Add):
                    acc = acc + rhs
                elif isinstance(op, ast.Sub):
                    acc = acc - rhs
                elif isinstance(op, ast.Mult):
                    acc = acc * rhs
                else:
                    acc = acc / rhs
            return acc
        if isinstance(node, ast.BinOp):  # Pow
            return self.power(self.build(node.left), self.build(node.right), node)
        if isinstance(node, ast.UnaryOp):
            operand = self.build(node.operand)
            return -operand if isinstance(node.op, ast.USub) else +operand
        if isinstance(node, ast.Constant):
            return self.number(node)
        if isinstance(node, ast.Name):
            return self.name(node.id)
        if isinstance(node, ast.Attribute):  # a declared dotted name (checked)
            return self.name(_dotted(node))
        if isinstance(node, ast.Call):
            return self.call(node.func.id, [self.build(a) for a in node.args])
        raise _fail(  # pragma: no cover - _check_tree refused it already
            "forbidden", f"the construct {type(node).__name__}", self.text, self.source
        )


def _is_constant(node: ast.AST) -> bool:
    """True when the subtree holds no names other than ``pi``."""
    return not any(isinstance(n, ast.Name) and n.id not in CONSTANT_NAMES for n in ast.walk(node))


def _literal_text(node: ast.Constant, code: str) -> str:
    """The literal as written (so 0.4 becomes Float('0.4'), as sympy's auto_number did)."""
    segment = ast.get_source_segment(code, node)
    return (segment or repr(node.value)).replace("_", "")


def _check_arity(name, args, arity, text, source):
    if arity is not None and len(args) != arity:
        raise _fail(
            "arguments",
            f"{name}() takes {arity} argument{'s' if arity != 1 else ''}, got {len(args)}",
            text,
            source,
            fix=f"call it as {name}({', '.join('xyz'[:arity])})",
        )


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


# ---------------------------------------------------------------------------------------------
# numeric: text → numpy
# ---------------------------------------------------------------------------------------------


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
