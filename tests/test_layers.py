"""The stage order of docs/architecture.md, enforced.

`make test` runs ``lint-imports`` (the contracts in pyproject.toml); this file runs the same
contracts under plain pytest and checks what import-linter cannot: that each upward import it
is told to ignore stays lazy, inside a function (a result's ``plot()``), and that no two modules
import each other through any path (function-level imports and a package's ``__init__``
included).
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


def _strongly_connected(graph):
    """Tarjan's strongly connected components of ``graph`` (module -> imported modules)."""
    index, low, stack, on_stack, components = {}, {}, [], set(), []

    def visit(start):
        # iterative depth-first search: (node, iterator over its successors)
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        work = [(start, iter(sorted(graph[start])))]
        while work:
            node, successors = work[-1]
            for nxt in successors:
                if nxt not in index:
                    index[nxt] = low[nxt] = len(index)
                    stack.append(nxt)
                    on_stack.add(nxt)
                    work.append((nxt, iter(sorted(graph[nxt]))))
                    break
                if nxt in on_stack:
                    low[node] = min(low[node], index[nxt])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = set()
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.add(member)
                        if member == node:
                            break
                    components.append(component)

    for module in sorted(graph):
        if module not in index:
            visit(module)
    return components


def test_no_import_cycle_between_modules():
    # Every import counts: function-level ones and a package's __init__ (a submodule importing
    # its own package while the package imports it back is a cycle). The lazy plot() imports of
    # report are the layers contract's sanctioned exceptions and are left out here too.
    import grimp

    built = grimp.build_graph("physid", cache_dir=None)
    sanctioned = {tuple(line.split(" -> ")) for line in _pyproject_ignore_imports()}
    graph = {
        module: {
            imported
            for imported in built.find_modules_directly_imported_by(module)
            if (module, imported) not in sanctioned
        }
        for module in built.modules
    }
    cycles = [sorted(c) for c in _strongly_connected(graph) if len(c) > 1]
    assert cycles == [], f"import cycles between modules of physid: {cycles}"


def test_cycle_check_finds_a_planted_cycle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert [sorted(c) for c in _strongly_connected(graph) if len(c) > 1] == [["a", "b", "c"]]


def _pyproject_ignore_imports():
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10
        import tomli as tomllib
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    lines = []
    for contract in config["tool"]["importlinter"]["contracts"]:
        lines.extend(contract.get("ignore_imports", []))
    return lines
