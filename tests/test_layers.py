"""The stage order of docs/architecture.md, enforced.

`make test` runs ``lint-imports`` (the contracts in pyproject.toml); this file runs the same
contracts under plain pytest and checks what import-linter cannot: that each upward import it
is told to ignore stays lazy, inside a function (a result's ``plot()``).
"""

from __future__ import annotations

import ast
from pathlib import Path

from importlinter.cli import lint_imports

import physid

SRC = Path(physid.__file__).resolve().parent
ROOT = SRC.parents[1]
#: Stages that may import physid.report at module level (report itself, and the command line).
MAY_IMPORT_REPORT = {"report", "cli", "experiments"}


def _report_imports(path: Path):
    """(line, inside a function?) for each import of physid.report in a module."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    package = ".".join(path.relative_to(SRC.parent).with_suffix("").parts[:-1])

    def target(node):
        if isinstance(node, ast.Import):
            return [a.name for a in node.names]
        base = package.split(".")
        if node.level:
            base = base[: len(base) - node.level + 1]
            name = ".".join([*base, node.module] if node.module else base)
        else:
            name = node.module or ""
        return [name] + [f"{name}.{a.name}" for a in node.names]

    def walk(node, in_function):
        for child in ast.iter_child_nodes(node):
            lazy = in_function or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef))
            if isinstance(child, (ast.Import, ast.ImportFrom)) and any(
                t == "physid.report" or t.startswith("physid.report.") for t in target(child)
            ):
                yield child.lineno, in_function
            yield from walk(child, lazy)

    yield from walk(tree, False)


def test_upward_imports_of_report_are_lazy():
    eager = []
    n_lazy = 0
    for path in sorted(SRC.rglob("*.py")):
        stage = path.relative_to(SRC).parts[0]
        if stage in MAY_IMPORT_REPORT:
            continue
        for line, lazy in _report_imports(path):
            n_lazy += lazy
            if not lazy:
                eager.append(f"{path.relative_to(SRC)}:{line}")
    assert not eager, f"module-level imports of physid.report outside report/cli: {eager}"
    assert n_lazy >= 5  # the plot() methods of results and recordings


def test_import_layer_contracts_hold():
    assert lint_imports(config_filename=str(ROOT / "pyproject.toml"), no_cache=True) == 0
