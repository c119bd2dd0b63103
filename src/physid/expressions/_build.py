"""The tree walker shared by both back ends: a checked syntax tree to a value, node by node."""

from __future__ import annotations

import ast

from ._check import _ADDITIVE, _MULTIPLICATIVE, _dotted, _fail


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


def _literal_text(node: ast.Constant, code: str) -> str:
    """The literal as written (so 0.4 becomes Float('0.4'), as sympy's auto_number did)."""
    segment = ast.get_source_segment(code, node)
    return (segment or repr(node.value)).replace("_", "")
